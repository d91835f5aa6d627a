"""Run time against error: every method and quality setting against a converged reference
(``povh3d bench``), written as ``bench.csv``, ``bench.md`` and ``bench.png``.

The reference integrates each pixel's footprint (docs/geometry.md): many
stratified random rays per pixel across the lens aperture and the pixel's
angular width, all in one mesh-camera pass, averaged in linear light.  Its own
noise floor is the PSNR between two references drawn with different seeds.
"""

from __future__ import annotations

import csv
import io
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..engine.auto import reference_quality, to_8bit
from ..engine.methods import METHODS, run_method
from ..engine.quality import QUALITY_LEVELS, Quality, RenderSettings
from ..errors import ConfigError
from ..geometry.lens_array import LensArray
from ..image.io import atomic_path
from ..image.metrics import pareto_front, psnr, ssim
from ..scene.scene import Scene


@dataclass(frozen=True)
class Trial:
    method: str
    quality: Quality
    options: tuple[tuple[str, Any], ...] = ()   # the method's own (single-stage: lenslet, ior)

    @property
    def label(self) -> str:
        extra = "".join(f" {k}={v}" for k, v in self.options)
        return f"{self.method}{extra}: {self.quality.label}"


@dataclass(frozen=True)
class TrialResult:
    trial: Trial
    seconds: float          # wall time of the render, s
    psnr_db: float          # against the reference
    ssim: float
    pareto: bool = False


@dataclass(frozen=True)
class BenchReport:
    results: tuple[TrialResult, ...]
    reference: Quality
    reference_seconds: float
    noise_floor_db: float    # PSNR between two references of different seeds
    panel: tuple[int, int]

    def rows(self) -> list[dict[str, Any]]:
        return [{"method": r.trial.method, "setting": r.trial.label, "seconds": round(r.seconds, 3),
                 "psnr_db": round(r.psnr_db, 2), "ssim": round(r.ssim, 4), "pareto": r.pareto}
                for r in self.results]


def default_trials(lens_array: LensArray, methods: Iterable[str] = ("multi-ortho", "pinhole")) -> list[Trial]:
    """The grid the bench walks for each method: POV-Ray's antialiasing (threshold,
    method, depth, jitter), angular sub-views with and without it, footprint samples
    (for a method that traces them on ``lens_array``), a cut trace depth, and the
    named levels as the method renders them."""
    aa = Quality(antialias=0.1, aa_method=2, aa_depth=3)
    trials: list[Trial] = []
    for entry in methods:
        method, _, lenslet = entry.partition(":")   # single-stage:conic, single-stage:spherical
        if method not in METHODS:
            raise ConfigError(f"unknown method {method!r}; choose from {', '.join(METHODS)}")
        options = (("lenslet", lenslet),) if lenslet else ()
        grid = [Quality(), Quality(antialias=0.3), aa, replace(aa, jitter=True),
                replace(aa, max_trace_level=1)]
        if METHODS[method].takes_samples(lens_array):
            grid += [Quality(subviews=2), Quality(subviews=3), replace(aa, subviews=2), replace(aa, subviews=3),
                     Quality(footprint=16, seed=7), Quality(footprint=64, seed=7), Quality(footprint=128, seed=7)]
            levels = QUALITY_LEVELS.values()
        else:
            levels = [q.point_sampled() for q in QUALITY_LEVELS.values()]
        trials += [Trial(method, q, options) for q in dict.fromkeys([*grid, *levels])]
    return trials


def run_bench(scene: Scene, lens_array: LensArray, trials: list[Trial], *,
              reference_samples: int = 256, settings: RenderSettings | None = None,
              on_trial: Callable[[int, int, str], None] | None = None) -> BenchReport:
    """Render the reference twice and every trial once (uncached), and score each."""
    base = replace(settings or RenderSettings(), use_cache=False)

    def render(method: str, quality: Quality, bit_depth: int = 8, options=()) -> tuple[np.ndarray, float]:
        start = time.perf_counter()
        h3d = run_method(method, scene, lens_array, replace(base, quality=quality, bit_depth=bit_depth),
                         **dict(options)).h3d
        return h3d, time.perf_counter() - start

    steps = len(trials) + 2
    if on_trial:
        on_trial(0, steps, "reference")
    ref_q = reference_quality(reference_samples, seed=1)
    reference16, ref_seconds = render("multi-ortho", ref_q, 16)
    if on_trial:
        on_trial(1, steps, "second reference (noise floor)")
    second16, _ = render("multi-ortho", replace(ref_q, seed=2), 16)
    reference = to_8bit(reference16)
    floor = psnr(to_8bit(second16), reference)

    measured = []
    for n, trial in enumerate(trials):
        if on_trial:
            on_trial(n + 2, steps, trial.label)
        image, seconds = render(trial.method, trial.quality, options=trial.options)
        measured.append((trial, seconds, psnr(image, reference), ssim(image, reference)))
    front = pareto_front(np.array([m[1] for m in measured]), np.array([m[2] for m in measured]))
    results = tuple(TrialResult(t, s, p, q, bool(f)) for (t, s, p, q), f in zip(measured, front))
    return BenchReport(results, ref_q, ref_seconds, floor, (lens_array.panel.width, lens_array.panel.height))


def write_report(report: BenchReport, folder: str | Path) -> dict[str, Path]:
    """``bench.csv``, ``bench.md`` (a table) and ``bench.png`` (time against PSNR,
    the Pareto front joined) into ``folder``, each written atomically."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rows = report.rows()
    paths = {"csv": folder / "bench.csv", "table": folder / "bench.md", "plot": folder / "bench.png"}
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(rows[0]))
    writer.writeheader()
    writer.writerows(rows)
    with atomic_path(paths["csv"]) as tmp:
        tmp.write_text(buffer.getvalue(), encoding="utf-8")
    with atomic_path(paths["table"]) as tmp:
        tmp.write_text(format_table(report) + "\n", encoding="utf-8")
    with atomic_path(paths["plot"]) as tmp:
        _plot(report, tmp)
    return paths


def format_table(report: BenchReport) -> str:
    w, h = report.panel
    lines = [f"Panel {w}x{h}; reference: {report.reference.label} "
             f"({report.reference_seconds:.1f} s); its noise floor {report.noise_floor_db:.2f} dB "
             "(PSNR between two references of different seeds).", "",
             "| setting | wall s | PSNR dB | SSIM | Pareto |", "|---|---|---|---|---|"]
    for r in sorted(report.results, key=lambda r: r.seconds):
        lines.append(f"| {r.trial.label} | {r.seconds:.2f} | {r.psnr_db:.2f} | {r.ssim:.4f} | "
                     f"{'yes' if r.pareto else ''} |")
    return "\n".join(lines)


def _plot(report: BenchReport, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")  # no display: write the file only
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5), dpi=120)
    for method in dict.fromkeys(r.trial.method for r in report.results):
        rs = [r for r in report.results if r.trial.method == method]
        ax.scatter([r.seconds for r in rs], [r.psnr_db for r in rs], label=method, s=24)
    front = sorted((r for r in report.results if r.pareto), key=lambda r: r.seconds)
    ax.plot([r.seconds for r in front], [r.psnr_db for r in front], "k--", lw=1, label="Pareto front")
    for r in front:
        ax.annotate(r.trial.quality.label, (r.seconds, r.psnr_db), fontsize=6, xytext=(4, -8),
                    textcoords="offset points")
    ax.axhline(report.noise_floor_db, color="grey", lw=0.8, ls=":", label="reference noise floor")
    ax.set_xscale("log")
    ax.set_xlabel("wall time, s (log)")
    ax.set_ylabel("PSNR against the footprint reference, dB")
    w, h = report.panel
    ax.set_title(f"povh3d bench: {w}x{h} panel")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, format="png")
    plt.close(fig)

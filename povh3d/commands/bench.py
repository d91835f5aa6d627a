"""Run time against error: methods and quality levels against a converged reference
(``povh3d bench``), written as ``bench.csv``, ``bench.md`` and ``bench.png``.

Every trial is a whole ``povh3d render`` command, timed from interpreter start to exit
(PNG written).  The reference integrates each pixel's footprint (docs/geometry.md):
stratified random rays across the lens aperture and the pixel's angular width, on a
window of the central lenses traced with the full render's rays and the real panel
declared (``renderer.methods.auto.probe_window``).  It is drawn with two seeds: their PSNR is its
stated noise floor, and the trials are scored against their mean with its own noise
taken off (``image.metrics.Reference``), on that window of each trial's image.
"""

from __future__ import annotations

import csv
import io
import tempfile
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..renderer.methods.auto import probe_window, reference_quality, window_offset
from .timing import time_povh3d
from ..renderer.methods.registry import METHODS, run_method
from ..renderer.methods.quality import QUALITY_LEVELS, Quality, RenderSettings, quality_level
from ..errors import ConfigError
from ..geometry.lens_array import LensArray
from ..image.io import atomic_path, read_png
from ..image.metrics import Reference, pareto_front, ssim
from ..scene.scene import Scene

#: Quality levels every method is benched at (names ``--quality`` takes): the named levels and
#: footprint sample counts between ``normal`` and ``high``.
BENCH_LEVELS = ("draft", "normal", "16", "64", "high")
#: Lenses of the central window the reference covers and the trials are scored on: enough
#: pixels for a PSNR, few enough that two converged references take seconds.
BENCH_WINDOW = (8, 6)


@dataclass(frozen=True)
class Trial:
    method: str
    quality: str                                # a ``--quality`` value
    options: tuple[tuple[str, Any], ...] = ()   # the method's own (single-stage: lenslet, ior)

    @property
    def spec(self) -> Quality:
        return quality_level(self.quality)

    @property
    def label(self) -> str:
        extra = "".join(f" {k}={v}" for k, v in self.options)
        return f"{self.method}{extra}: {self.quality} ({self.spec.label})"

    def argv(self) -> list[str]:
        """The trial's own ``povh3d render`` options."""
        return ["--method", self.method, "--quality", self.quality,
                *(arg for k, v in self.options for arg in (f"--{k}", str(v)))]


@dataclass(frozen=True)
class TrialResult:
    trial: Trial
    seconds: float          # wall time of the whole command, s
    psnr_db: float          # against the reference (its own noise taken off)
    ssim: float
    pareto: bool = False


@dataclass(frozen=True)
class BenchReport:
    results: tuple[TrialResult, ...]
    reference: Quality
    reference_seconds: float
    noise_floor_db: float    # PSNR between the reference's two seeds
    panel: tuple[int, int]
    window: tuple[int, int] = (0, 0)   # lenses of the window scored

    def rows(self) -> list[dict[str, Any]]:
        return [{"method": r.trial.method, "setting": r.trial.label, "seconds": round(r.seconds, 3),
                 "psnr_db": round(r.psnr_db, 2), "ssim": round(r.ssim, 4), "pareto": r.pareto}
                for r in self.results]


def default_trials(lens_array: LensArray, methods: Iterable[str] = ("multi-ortho", "pinhole")) -> list[Trial]:
    """``BENCH_LEVELS`` for each method (``single-stage:conic`` picks a lenslet); a method that
    traces no footprint samples on ``lens_array`` renders the sample counts as antialiasing, so
    it is benched at the named levels only."""
    trials: list[Trial] = []
    for entry in methods:
        method, _, lenslet = entry.partition(":")   # single-stage:conic, single-stage:spherical
        if method not in METHODS:
            raise ConfigError(f"unknown method {method!r}; choose from {', '.join(METHODS)}")
        options = (("lenslet", lenslet),) if lenslet else ()
        levels = BENCH_LEVELS if METHODS[method].takes_samples(lens_array) else tuple(QUALITY_LEVELS)
        trials += [Trial(method, q, options) for q in levels]
    return trials


def run_bench(scene: Scene, lens_array: LensArray, trials: list[Trial], *, scene_args: Sequence[str] = (),
              reference_samples: int = 512, settings: RenderSettings | None = None,
              on_trial: Callable[[int, int, str], None] | None = None) -> BenchReport:
    """Render the reference twice (in process, uncached) and time every trial as a whole command.

    ``scene_args``: the scene path and the display options of ``povh3d render`` that give
    ``lens_array`` (the trials' command lines).
    """
    import time

    base = replace(settings or RenderSettings(), use_cache=False)
    window, mask = probe_window(lens_array, BENCH_WINDOW)
    (r0, c0), (h, w) = window_offset(lens_array, window), mask.shape
    steps = len(trials) + 2
    ref_q = reference_quality(reference_samples, seed=1)
    images = []
    start = time.perf_counter()
    for seed in (1, 2):
        if on_trial:
            on_trial(seed - 1, steps, "reference" if seed == 1 else "second reference (noise floor)")
        images.append(run_method("multi-ortho", scene, window, replace(base, quality=replace(ref_q, seed=seed),
                                                                          bit_depth=16), declared=lens_array).h3d)
    ref_seconds = (time.perf_counter() - start) / 2
    first, second = images
    reference = Reference(first, second, mask)
    measured = []
    with tempfile.TemporaryDirectory(prefix="povh3d-bench-") as folder:
        for n, trial in enumerate(trials):
            if on_trial:
                on_trial(n + 2, steps, trial.label)
            out = Path(folder) / f"trial-{n}.png"
            seconds = time_povh3d(["render", *scene_args, *trial.argv(), "--no-cache", "-q", "-o", out])
            image = read_png(out)[r0:r0 + h, c0:c0 + w]
            masked = np.where(mask[..., None], image, 0).astype(image.dtype)
            truth = np.where(mask[..., None], np.rint(images[0] / 257.0), 0).astype(image.dtype)
            measured.append((trial, seconds, reference.psnr(image), ssim(masked, truth)))
    front = pareto_front(np.array([m[1] for m in measured]), np.array([m[2] for m in measured]))
    results = tuple(TrialResult(t, s, p, q, bool(f)) for (t, s, p, q), f in zip(measured, front))
    return BenchReport(results, ref_q, ref_seconds, reference.floor_db,
                       (lens_array.panel.width, lens_array.panel.height), (window.lenses_x, window.lenses_y))


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
    lx, ly = report.window
    lines = [f"Panel {w}x{h}; reference: {report.reference.label} on the central {lx}x{ly} lenses "
             f"({report.reference_seconds:.1f} s per seed); its noise floor {report.noise_floor_db:.2f} dB "
             "(PSNR between two seeds; scores are against their mean, its own noise taken off). "
             "Wall s: the whole povh3d render command, interpreter start to exit.", "",
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
        ax.annotate(r.trial.quality, (r.seconds, r.psnr_db), fontsize=6, xytext=(4, -8),
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

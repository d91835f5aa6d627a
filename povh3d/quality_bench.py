"""Run time against error: every method and quality setting against a converged reference.

The reference integrates each pixel's footprint (CONVENTIONS): many
stratified random rays per pixel across the lens aperture and the pixel's
angular width, all in one mesh-camera pass, averaged in linear light.  Its own
noise floor is the PSNR between two references drawn with different seeds.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .errors import ConfigError
from .geometry import LensArray
from .methods import METHODS, run_method
from .metrics import pareto_front, psnr, ssim
from .render import QUALITY_LEVELS, Quality, RenderSettings
from .scene import Scene


@dataclass(frozen=True)
class Trial:
    method: str
    quality: Quality
    name: str = ""

    @property
    def label(self) -> str:
        return self.name or f"{self.method}: {self.quality.label}"


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


def reference_quality(samples: int = 256, seed: int = 1) -> Quality:
    return Quality(footprint=samples, seed=seed)


def default_trials(methods: Iterable[str] = ("multi-ortho", "pinhole")) -> list[Trial]:
    """The grid the bench walks: each named level, then antialiasing, jitter,
    angular sub-views and trace depth one at a time, for the methods given."""
    trials: list[Trial] = []
    for method in methods:
        if method not in METHODS:
            raise ConfigError(f"unknown method {method!r}; choose from {', '.join(METHODS)}")
        aa = [Quality(), Quality(antialias=0.3), Quality(antialias=0.1, aa_method=2, aa_depth=3),
              Quality(antialias=0.1, aa_method=2, aa_depth=3, jitter=True)]
        trials += [Trial(method, q) for q in aa]
        if method == "multi-ortho":  # the only method that takes footprint samples
            for n in (2, 3, 4):
                trials.append(Trial(method, Quality(subviews=n)))
                trials.append(Trial(method, Quality(antialias=0.1, aa_method=2, aa_depth=3, jitter=True,
                                                    subviews=n)))
            trials += [Trial(method, Quality(footprint=n, seed=7)) for n in (16, 64)]
            trials.append(Trial(method, Quality(antialias=0.1, aa_method=2, aa_depth=3, jitter=True,
                                                subviews=3, max_trace_level=2)))
        trials += [Trial(method, q, f"{method}: --quality {name}") for name, q in QUALITY_LEVELS.items()
                   if method == "multi-ortho" or not (q.subviews > 1 or q.footprint)]
    return list(dict.fromkeys(trials))  # a level equal to a grid point is run once


def run_bench(scene: Scene, lens_array: LensArray, trials: list[Trial], *,
              reference_samples: int = 256, settings: RenderSettings | None = None,
              on_trial: Callable[[int, int, str], None] | None = None) -> BenchReport:
    """Render the reference twice and every trial once (uncached), and score each."""
    base = replace(settings or RenderSettings(), use_cache=False)

    def render(method: str, quality: Quality, bit_depth: int = 8) -> tuple[np.ndarray, float]:
        start = time.perf_counter()
        h3d = run_method(method, scene, lens_array, replace(base, quality=quality, bit_depth=bit_depth)).h3d
        return h3d, time.perf_counter() - start

    steps = len(trials) + 2
    if on_trial:
        on_trial(0, steps, "reference")
    ref_q = reference_quality(reference_samples, seed=1)
    reference16, ref_seconds = render("multi-ortho", ref_q, 16)
    if on_trial:
        on_trial(1, steps, "second reference (noise floor)")
    second16, _ = render("multi-ortho", replace(ref_q, seed=2), 16)
    reference = _to_8bit(reference16)
    floor = psnr(_to_8bit(second16), reference)

    measured = []
    for n, trial in enumerate(trials):
        if on_trial:
            on_trial(n + 2, steps, trial.label)
        image, seconds = render(trial.method, trial.quality)
        measured.append((trial, seconds, psnr(image, reference), ssim(image, reference)))
    front = pareto_front(np.array([m[1] for m in measured]), np.array([m[2] for m in measured]))
    results = tuple(TrialResult(t, s, p, q, bool(f)) for (t, s, p, q), f in zip(measured, front))
    return BenchReport(results, ref_q, ref_seconds, floor, (lens_array.panel.width, lens_array.panel.height))


def _to_8bit(image: np.ndarray) -> np.ndarray:
    return (np.rint(image / 257.0)).astype(np.uint8) if image.dtype == np.uint16 else image


def fastest_meeting(report: BenchReport, min_psnr_db: float) -> TrialResult:
    """The fastest trial whose PSNR reaches ``min_psnr_db``; a ConfigError if none does."""
    good = [r for r in report.results if r.psnr_db >= min_psnr_db]
    if not good:
        best = max(report.results, key=lambda r: r.psnr_db)
        raise ConfigError(f"no quality setting reaches {min_psnr_db:g} dB on this scene (best "
                          f"{best.psnr_db:.1f} dB with {best.trial.label}; the reference's own noise "
                          f"floor is {report.noise_floor_db:.1f} dB); lower --max-error")
    return min(good, key=lambda r: r.seconds)


def probe_array(lens_array: LensArray, max_lenses: tuple[int, int] = (32, 20)) -> LensArray:
    """The central part of ``lens_array``, at most ``max_lenses``, on a panel of its own size:
    what ``--quality auto`` renders to choose a setting.  Lenticular arrays keep 8 panel rows
    per lens row of the limit, since every panel row is its own lens row."""
    lx = min(lens_array.lenses_x, max_lenses[0])
    ly = min(lens_array.lenses_y, max_lenses[1] * (8 if lens_array.grid == "lenticular" else 1))
    p = lens_array.panel
    width = math.ceil(lx * lens_array.pitch_x / p.pitch_x - 1e-9)
    height = ly if lens_array.grid == "lenticular" else math.ceil(ly * lens_array.pitch_y / p.pitch_y - 1e-9)
    return replace(lens_array, lenses_x=lx, lenses_y=ly, panel=replace(p, width=width, height=height))

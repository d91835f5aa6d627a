"""``--quality auto`` on the full image, scored by its own seeds: no probe, no separate reference.

A footprint render of ``N`` samples drawn as two independent seeds ``A`` and ``B`` of ``N/2``
is its own error gauge: each seed is an unbiased estimate of the converged image, so the mean
squared difference of the two is twice each one's error, and their mean (the image written)
has a quarter of it (``image.metrics.Reference``: its ``floor_db`` plus 6.02 dB).  So:

1. one POV-Ray run traces the point-sampled centre (``draft``) and two seeds, sized from a prior
   guess of what the target needs plus as many samples as a second run's start-up costs
   (``first_samples``); the seeds are the reference ``draft`` is scored against (its noise
   taken off) and tell how the error falls with the samples;
2. where ``draft`` misses the target and the seeds' mean too, one more run continues each seed
   (``view_seeds``: a scrambled Sobol' sequence per seed and view, so a seed's samples of all
   runs are one sequence, as good as if drawn in one run) by what the error's fall with ``N``
   says the target needs, and the seeds score the result again; a third run and on, rarely;
3. the image that met the target is the output: nothing is rendered twice.

Every sample is traced once, in as few POV-Ray runs as the target allows, and on the full image,
so the score is the written image's own.  ``auto.resolve_auto`` uses this where the method can
split its footprint samples (``MethodPlan.assemble_groups``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ...errors import ConfigError, param
from ...geometry.footprint import CENTRE, scrambled_sobol
from ...geometry.lens_array import LensArray
from ...image.colour import encode
from ...image.metrics import Reference
from ...scene.scene import Scene
from .registry import MethodResult, run_method
from .quality import Progress, Quality, RenderSettings

#: The samples (both seeds) a target of X dB needs, as a first guess: ``PRIOR_SAMPLES_40`` at 40 dB,
#: times 10 ** (PRIOR_SLOPE (X - 40)): the Sobol' seeds of sample.pov and fine_texture.pov on
#: benchmarks/bench_auto.py's panel reach 40 dB at 52 and 60 samples and gain 3.0-5.1 dB a doubling
#: (the benchmark's third scene, the one auto has not seen, was left out of this fit).  The first run
#: traces ``FIRST_SHARE`` of it and more (``first_samples``); the runs after it add what the measured
#: error says is missing.
PRIOR_SAMPLES_40, PRIOR_SLOPE, FIRST_SHARE = 55.0, 0.085, 0.8
#: A POV-Ray run's start-up (about 0.5 s of wall, most of it idle: POV-Ray 3.7's threads hand messages
#: over at 50 ms waits) costs as much as ``STARTUP_SAMPLES`` footprint samples of a panel of
#: ``STARTUP_PIXELS`` (27 ms of wall a sample on benchmarks/bench_auto.py's 160x120 panel), fewer on a
#: larger one.  The first run adds ``STARTUP_SHARE`` of that many samples over ``FIRST_SHARE`` of the
#: prior, up to ``COVER`` times the prior in all.  What the scenes need spans 0.36 to 1.4 times the
#: prior (the unseen scene the least): covering the top would cost the easy scene more than the
#: start-up it saves the hard one (a whole start-up's worth: 7 of 10 cases in a model of the
#: benchmark's times, half of one: 8; docs/benchmarks.md).
STARTUP_SAMPLES, STARTUP_PIXELS, STARTUP_SHARE, COVER = 18.0, 19_200, 0.5, 1.6
#: Targets up to this also try ``draft`` (the point-sampled centre, in the first run): it reaches
#: 20-25 dB on textured scenes.
DRAFT_UP_TO_DB = 30.0
#: The most footprint samples auto renders (both seeds); past them the target is refused.
MAX_SAMPLES = 1024
#: dB the estimate (one standard error high, ``SeedRuns.error_bound``) must clear above the target:
#: the plain estimate was up to 0.34 dB over the image's score against two seeds of 1024 samples
#: (sample.pov, 64 samples); the bound adds 0.3-0.4 dB on 16 views, less on more.
MARGIN_DB = 0.1
#: How the error falls with the samples per seed N, as N ** -ALPHA, to size the next run: the Sobol'
#: seeds gained 3.0-5.1 dB a doubling (ALPHA 1.0-1.7); the lower end taken, as a run too many
#: costs a start-up.  A further run adds at least ``LEAST_MORE`` of the samples so far.
ALPHA, LEAST_MORE = 1.1, 0.25
MAX_RUNS = 5


@dataclass
class SeedRuns:
    """Each seed's samples summed over the runs (linear light), the samples per seed of each run, and
    the centre (``draft``).  A seed's runs continue one Sobol' sequence (``view_seeds``), so its
    samples of all runs weigh the same: their mean is the seed's image."""

    labels: np.ndarray   # (H, W) view of each pixel (``view_labels``), -1 outside the bank
    sums: list[np.ndarray] = field(default_factory=list)
    counts: list[int] = field(default_factory=list)
    draft: np.ndarray | None = None
    result: MethodResult | None = None

    def add(self, result: MethodResult, per_seed: int) -> None:
        groups = list(result.groups or [])
        if len(groups) == 3:
            self.draft = groups.pop(0)
        self.sums = [per_seed * g + (self.sums[k] if self.sums else 0) for k, g in enumerate(groups[:2])]
        self.counts.append(per_seed)
        self.result = result

    def combined(self) -> tuple[np.ndarray, np.ndarray]:
        n = sum(self.counts)
        return self.sums[0] / n, self.sums[1] / n

    @property
    def per_seed(self) -> int:
        return sum(self.counts)

    @property
    def total(self) -> int:
        return 2 * sum(self.counts)

    def reference(self) -> Reference:
        return Reference(*(encode(x, np.uint16) for x in self.combined()))

    def error_bound(self) -> float:
        """The mean squared error of the seeds' mean (sRGB codes, the whole panel), one standard error
        high: each view has samples of its own, so the views' shares of the seeds' squared difference
        are independent, and their spread says how far the estimate may be off (with few views, far:
        4x4 views at 4 samples a seed were 1.1 dB over the image's score)."""
        a, b = (encode(x, np.uint16).astype(np.float64) / 65535 for x in self.combined())
        squared = np.mean((a - b) ** 2, axis=-1)
        inside = self.labels >= 0
        per_view = np.bincount(self.labels[inside], weights=squared[inside])
        spread = math.sqrt(len(per_view)) * float(np.std(per_view, ddof=1)) if len(per_view) > 1 else 0.0
        return (float(squared.sum()) + spread) / squared.size / 4

    def image(self, dtype: type) -> np.ndarray:
        a, b = self.combined()
        return encode((a + b) / 2, dtype)


def view_seeds(count: int, seed: int, views: tuple[int, int], start: int = 0) -> np.ndarray:
    """``(count, Ny, Nx, 4)``: footprint samples ``start`` to ``start + count`` of a scrambled Sobol'
    sequence of its own per view (seeded by ``seed`` and the view).

    A view bank traces one sample for every lens of a view: with one set for all views a seed's
    error is one pattern over the whole image, so two seeds' difference says little of the error
    of their mean (on the bundled sample their errors correlated by -0.07 to 0.38).  A set per view
    makes the errors of the views independent, and the seeds' difference a measure of the error.
    Scrambled Sobol' points stay unbiased and independent between seeds, stratify the footprint's
    planes as well as its axes (sample.pov: 41.5 dB from 64 samples where two Latin hypercubes per
    view reach 39.9 dB, 48.1 dB from 192 against 44.6 dB), and a later run that continues them
    makes one sequence with the first (independent sets of a quarter each reached 44.4 dB)."""
    ny, nx = views
    return np.stack([scrambled_sobol(count, seed * 1_000_003 + v, start) for v in range(ny * nx)],
                    axis=1).reshape(count, ny, nx, 4)


def quantisation_mse(bit_depth: int) -> float:
    """Mean squared error rounding to the output's codes adds (uniform over one code)."""
    return 1.0 / (12.0 * (2 ** bit_depth - 1) ** 2)


def mean_psnr(runs: SeedRuns, quantisation: float) -> float:
    """PSNR of the two seeds' mean as written (``SeedRuns.error_bound``), plus rounding."""
    return -10 * math.log10(runs.error_bound() + quantisation)


def view_labels(lens_array: LensArray) -> np.ndarray:
    """``(H, W)``: the view of each pixel of the camera bank (a cell's pixel offset), -1 elsewhere."""
    ny, nx = lens_array.require_views()
    rows, cols = lens_array.bank_region
    labels = np.full((lens_array.panel.height, lens_array.panel.width), -1, np.int64)
    labels[rows, cols] = (np.arange(rows.stop - rows.start) % ny)[:, None] * nx + np.arange(cols.stop - cols.start) % nx
    return labels


def with_rounding(psnr_db: float, quantisation: float) -> float:
    return -10 * math.log10(10 ** (-psnr_db / 10) + quantisation) if math.isfinite(psnr_db) else \
        -10 * math.log10(quantisation)


def first_samples(prior: float, lens_array: LensArray) -> float:
    """The footprint samples (both seeds) of auto's first run, for a prior guess of ``prior``."""
    startup = STARTUP_SAMPLES * STARTUP_PIXELS / (lens_array.panel.width * lens_array.panel.height)
    return max(FIRST_SHARE * prior, min(COVER * prior, FIRST_SHARE * prior + STARTUP_SHARE * startup))


def seeded_auto(scene: Scene, lens_array: LensArray, method: str, settings: RenderSettings,
                progress: Progress | None = None, **options: Any):
    """The fastest image that reaches ``settings.max_error_db`` on the full image (see the module),
    as ``(quality, record fields, MethodResult of the image written)``; a one-line refusal where
    ``MAX_SAMPLES`` would not reach it."""
    start = time.perf_counter()
    assert settings.max_error_db is not None  # quality 'auto' (RenderSettings: then and only then)
    target = float(settings.max_error_db)
    need = target + MARGIN_DB
    rounding = quantisation_mse(settings.bit_depth)
    if need >= -10 * math.log10(rounding):
        raise ConfigError(f"{param('max_error_db')} {target:g} dB is above the noise floor of {settings.bit_depth}-bit "
                          f"codes themselves ({-10 * math.log10(rounding):.1f} dB); use {param('max_error_db')} "
                          f"{math.floor(-10 * math.log10(rounding) - 3):g} or less")
    base = replace(settings, quality=Quality(footprint=1), max_error_db=None)
    runs = SeedRuns(view_labels(lens_array))
    tried: list[tuple[str, float]] = []
    views = lens_array.require_views()

    def render(count: int, centre: tuple[np.ndarray, ...] = ()) -> Reference:
        # seeds 1 and 2, continued from where the runs before left them
        groups = [*centre, *(view_seeds(count, seed, views, runs.per_seed) for seed in (1, 2))]
        result = run_method(method, scene, lens_array, base, footprint_groups=groups, **options)
        runs.add(result, count)
        if progress is not None:
            progress(len(runs.counts), len(runs.counts) + 1)
        return runs.reference()

    prior = PRIOR_SAMPLES_40 * 10 ** (PRIOR_SLOPE * (target - 40))
    first = min(max(2, math.ceil(first_samples(prior, lens_array) / 2)), MAX_SAMPLES // 8)
    centre = (np.broadcast_to(CENTRE[:, None, None, :], (1, *views, 4)),) if target <= DRAFT_UP_TO_DB else ()
    reference = render(first, centre)
    chosen = _draft_or_seeds(runs, reference, centre, target, need, rounding, tried)
    allowed = 10 ** (-need / 10) - rounding
    for _ in range(MAX_RUNS):
        if chosen is not None:
            break
        got = mean_psnr(runs, rounding)
        if not tried or tried[-1][0] != f"{runs.total} footprint samples":
            tried.append((f"{runs.total} footprint samples", got))
        if got >= need:
            chosen = (Quality(footprint=runs.total), None)
            break
        # The samples per seed that bring the error of the seeds' mean down to ``allowed``.
        error, n = runs.error_bound(), runs.per_seed
        more = max(math.ceil(n * (error / allowed) ** (1 / ALPHA)) - n, math.ceil(LEAST_MORE * n))
        more += -more % 4 if more > 8 else 0   # shots of a few banks each (``view_bank.bank_groups``)
        if runs.total + 2 * more > MAX_SAMPLES:
            best = with_rounding(-10 * math.log10(error * (runs.total / MAX_SAMPLES) ** ALPHA), rounding)
            raise ConfigError(f"{param('max_error_db')} {target:g} dB is above what {MAX_SAMPLES} footprint samples reach on "
                              f"this scene (about {best:.1f} dB by the noise floor of two seeds of "
                              f"{n}); use {param('max_error_db')} {math.floor(best * 10) / 10:g} or less")
        reference = render(more)
    if chosen is None:
        raise ConfigError(f"{param('quality')} auto did not reach {target:g} dB in {MAX_RUNS} runs; lower {param('max_error_db')} "
                          f"or give {param('quality')} {runs.total}")
    quality, image = chosen
    dtype = np.uint8 if settings.bit_depth == 8 else np.uint16
    h3d = encode(image, dtype) if image is not None else runs.image(dtype)
    assert runs.result is not None  # render ran at least once
    result = replace(runs.result, h3d=h3d, quality=quality, groups=None)
    fields = {"tried": tuple(tried), "seconds": time.perf_counter() - start,
              "reference_samples": runs.counts[0], "reference_floor_db": reference.floor_db,
              "povray_runs": len(runs.counts)}
    return quality, fields, result


def _draft_or_seeds(runs: SeedRuns, reference: Reference, centre: tuple, target: float, need: float,
                    rounding: float, tried: list[tuple[str, float]]) -> tuple[Quality, np.ndarray | None] | None:
    """``draft`` where the seeds score it over ``need`` (and their floor is no more than 3 dB under the
    target: each seed then reaches it itself), else the seeds' mean where it reaches ``need``, else None."""
    if centre:
        assert runs.draft is not None  # the centre's group, run with the seeds (SeedRuns.add)
        draft_db = with_rounding(reference.psnr(encode(runs.draft, np.uint16)), rounding)
        tried.append(("draft", draft_db))
        if draft_db >= need and reference.floor_db >= target - 3:
            return Quality(), runs.draft
    got = mean_psnr(runs, rounding)
    tried.append((f"{runs.total} footprint samples", got))
    return (Quality(footprint=runs.total), None) if got >= need else None

"""``--quality auto`` on the full image, scored by its own seeds: no probe, no separate reference.

A footprint render of ``N`` samples drawn as two independent seeds ``A`` and ``B`` of ``N/2``
is its own error gauge: each seed is an unbiased estimate of the converged image, so the mean
squared difference of the two is twice each one's error, and their mean (the image written)
has a quarter of it (``image.metrics.Reference``: its ``floor_db`` plus 6.02 dB).  So:

1. one POV-Ray run traces the point-sampled centre (``draft``) and two seeds of a few samples;
   the seeds are the reference ``draft`` is scored against (its noise taken off) and tell how
   the error falls with the samples (as ``1/N``);
2. where few samples are asked for, a spare run of more seeds starts beside the first (a second
   POV-Ray process, ``SpareRun``), killed where the first reaches the target, added where not:
   a run's start-up is about 0.5 s, most of it idle;
3. where ``draft`` misses the target and the seeds' mean too, one more run adds the samples the
   ``1/N`` law says the target needs, to each seed, and the seeds score the result again; a
   third run and on, rarely, where the law fell short;
4. the image that met the target is the output: nothing is rendered twice (a killed spare
   run's samples are dropped).

Every sample is traced once, in as few POV-Ray runs as the target allows, and on the full image,
so the score is the written image's own.  ``auto.resolve_auto`` uses this where the method can
split its footprint samples (``MethodPlan.assemble_groups``).
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import ConfigError, RenderInterrupted
from ..geometry.footprint import CENTRE, latin_hypercube
from ..geometry.lens_array import LensArray
from ..image.colour import encode, linear_to_srgb
from ..image.metrics import Reference
from ..scene.scene import Scene
from .methods import MethodResult, run_method
from .quality import Progress, Quality, RenderSettings

#: The samples a target of X dB needs, as a first guess: ``PRIOR_SAMPLES_40`` at 40 dB, times
#: 10 ** (PRIOR_SLOPE (X - 40)) (the three scenes of benchmarks/bench_auto.py needed 0.7 to 1.9 times
#: it, from 8 to 260 samples).  The first run traces ``FIRST_SHARE`` of it (at least two per seed),
#: enough for the easiest scene: the runs after it add what the measured error says is missing.
PRIOR_SAMPLES_40, PRIOR_SLOPE, FIRST_SHARE = 50.0, 0.09, 0.8
#: Where the prior asks for few samples, a second POV-Ray process traces a spare run beside the
#: first, up to ``SPARE_SHARE`` of the prior in all (the hardest scene's 1.9 and some), and is
#: stopped where the first run alone reaches the target.  A POV-Ray run costs about 0.5 s of
#: start-up, mostly idle (POV-Ray 3.7's threads hand messages over at 50 ms waits): as much as
#: 15-20 samples of this benchmark's 160x120 panel, so there a run after the first costs more
#: than the samples; past ``SPARE_UP_TO`` samples the spare run would take half the cores from the
#: first for samples that may not be needed.
SPARE_SHARE, SPARE_UP_TO = 2.2, 48
#: Targets up to this also try ``draft`` (the point-sampled centre, in the first run): it reaches
#: 20-25 dB on textured scenes.
DRAFT_UP_TO_DB = 30.0
#: The most footprint samples auto renders (both seeds); past them the target is refused.
MAX_SAMPLES = 1024
#: dB the estimate must clear above the target: against two seeds of 1024 samples the estimate of the
#: image written was from 0.33 dB over the full image's score to 0.65 dB under it on the three scenes
#: of benchmarks/bench_auto.py (a view's samples make one error pattern over its lenses, so the
#: seeds' difference has few independent parts).
MARGIN_DB = 0.15
#: How the error falls with the count N, as N ** -ALPHA: a little faster than ``1/N`` from a few
#: samples (1.04-1.19 from 2 per seed on the three scenes; the lower end taken: a run too many
#: costs more than a few samples too many on a small image), ``1/N`` from more on.
FEW_SAMPLES, FEW_ALPHA, MANY_ALPHA = 4, 1.05, 1.0
#: Extra samples over the law's count, and the least a further run adds (of those so far): 10 % extra
#: overshot by 0.25-0.4 dB on the three scenes (the error falls a little faster than the law).
LAW_SAFETY, LEAST_MORE = 1.04, 0.25
MAX_RUNS = 5


@dataclass
class SeedRuns:
    """Each run's two seeds (linear light) and samples per seed, and the centre (``draft``).

    The runs are combined weighted by the inverse of each run's own error (its seeds'
    difference): a first run of a few samples would otherwise add its noise to the many
    of the next.  Any fixed weights keep both seeds unbiased and independent.
    """

    seeds: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    counts: list[int] = field(default_factory=list)
    draft: np.ndarray | None = None
    result: MethodResult | None = None

    def add(self, result: MethodResult, per_seed: int) -> None:
        groups = list(result.groups or [])
        if len(groups) == 3:
            self.draft = groups.pop(0)
        self.seeds.append((groups[0], groups[1]))
        self.counts.append(per_seed)
        self.result = result

    def errors(self) -> np.ndarray:
        """Each run's mean squared error of its seeds' mean (sRGB codes): a quarter of their difference."""
        return np.array([max(_coded_mse(a, b) / 4, 1e-30) for a, b in self.seeds])

    def combined(self) -> tuple[np.ndarray, np.ndarray]:
        weights = 1 / self.errors()
        weights /= weights.sum()
        return tuple(sum(w * run[k] for w, run in zip(weights, self.seeds)) for k in (0, 1))

    @property
    def total(self) -> int:
        return 2 * sum(self.counts)

    def reference(self) -> Reference:
        return Reference(*(encode(x, np.uint16) for x in self.combined()))

    def image(self, dtype: type) -> np.ndarray:
        a, b = self.combined()
        return encode((a + b) / 2, dtype)


def _coded_mse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean((linear_to_srgb(a) - linear_to_srgb(b)) ** 2))


def view_seeds(count: int, seed: int, views: tuple[int, int]) -> np.ndarray:
    """``(count, Ny, Nx, 4)``: an independent Latin hypercube of ``count`` footprint samples per view.

    A view bank traces one sample for every lens of a view: with one set for all views a seed's
    error is one pattern over the whole image, so two seeds' difference says little of the error
    of their mean (on the bundled sample their errors correlated by -0.07 to 0.38).  A set per view
    makes the errors of the views independent, and the seeds' difference a measure of the error."""
    ny, nx = views
    return np.stack([latin_hypercube(count, seed * 1_000_003 + v) for v in range(ny * nx)], axis=1).reshape(
        count, ny, nx, 4)


def quantisation_mse(bit_depth: int) -> float:
    """Mean squared error rounding to the output's codes adds (uniform over one code)."""
    return 1.0 / (12.0 * (2 ** bit_depth - 1) ** 2)


def mean_psnr(reference: Reference, quantisation: float) -> float:
    """PSNR of the two seeds' mean as written: a quarter of their squared difference, plus rounding."""
    mse = 10 ** (-reference.floor_db / 10) / 4 + quantisation
    return -10 * math.log10(mse)


def with_rounding(psnr_db: float, quantisation: float) -> float:
    return -10 * math.log10(10 ** (-psnr_db / 10) + quantisation) if math.isfinite(psnr_db) else \
        -10 * math.log10(quantisation)


def seeded_auto(scene: Scene, lens_array: LensArray, method: str, settings: RenderSettings,
                progress: Progress | None = None, **options: Any):
    """The fastest image that reaches ``settings.max_error_db`` on the full image (see the module),
    as ``(quality, record fields, MethodResult of the image written)``; a one-line refusal where
    ``MAX_SAMPLES`` would not reach it."""
    start = time.perf_counter()
    target = float(settings.max_error_db)
    need = target + MARGIN_DB
    rounding = quantisation_mse(settings.bit_depth)
    if need >= -10 * math.log10(rounding):
        raise ConfigError(f"--max-error {target:g} dB is above the noise floor of {settings.bit_depth}-bit "
                          f"codes themselves ({-10 * math.log10(rounding):.1f} dB); use --max-error "
                          f"{math.floor(-10 * math.log10(rounding) - 3):g} or less")
    base = replace(settings, quality=Quality(footprint=1), max_error_db=None)
    runs = SeedRuns()
    tried: list[tuple[str, float]] = []
    seed = 1

    def render(groups: list[np.ndarray]) -> Reference:
        result = run_method(method, scene, lens_array, base, footprint_groups=groups, **options)
        runs.add(result, len(groups[-1]))
        if progress is not None:
            progress(len(runs.counts), len(runs.counts) + 1)
        return runs.reference()

    views = lens_array.require_views()
    prior = PRIOR_SAMPLES_40 * 10 ** (PRIOR_SLOPE * (target - 40))
    first = min(max(2, math.ceil(FIRST_SHARE * prior / 2)), MAX_SAMPLES // 8)
    # (not on a Dask cluster: its runs cannot be stopped from here)
    spare = math.ceil(SPARE_SHARE * prior / 2) - first if (2 * math.ceil(SPARE_SHARE * prior / 2) <= SPARE_UP_TO
                                                          and not settings.scheduler) else 0
    centre = [np.broadcast_to(CENTRE[:, None, None, :], (1, *views, 4))] if target <= DRAFT_UP_TO_DB else []
    beside = SpareRun(method, scene, lens_array, base, options, [view_seeds(spare, seed + 2, views),
                                                                 view_seeds(spare, seed + 3, views)]) if spare > 0 else None
    chosen: tuple[Quality, np.ndarray | None] | None = None
    spare_taken = False
    try:
        reference = render([*centre, view_seeds(first, seed, views), view_seeds(first, seed + 1, views)])
        chosen = _draft_or_seeds(runs, reference, centre, target, need, rounding, tried)
        if beside is not None and chosen is None:
            runs.add(beside.result(), spare)
            spare_taken = True
            if progress is not None:
                progress(len(runs.counts), len(runs.counts) + 1)
            reference = runs.reference()
            chosen = _draft_or_seeds(runs, reference, centre, target, need, rounding, tried)
            seed += 2
    except BaseException:
        if beside is not None:   # its POV-Ray stopped before the error leaves
            beside.stop()
            beside.join(quiet=True)
        raise
    if beside is not None:
        beside.stop()   # a no-op where its seeds were taken; joined once the image is encoded
    allowed = 10 ** (-need / 10) - rounding
    for _ in range(MAX_RUNS):
        if chosen is not None:
            break
        got = mean_psnr(reference, rounding)
        if not tried or tried[-1][0] != f"{runs.total} footprint samples":
            tried.append((f"{runs.total} footprint samples", got))
        if got >= need:
            chosen = (Quality(footprint=runs.total), None)
            break
        # The next run's seeds must bring the combined error (inverse errors add) down to ``allowed``.
        error, last = 10 ** (-reference.floor_db / 10) / 4, runs.errors()[-1]
        wanted = 1 / max(1 / allowed - 1 / error, 1e-30)
        alpha = FEW_ALPHA if runs.counts[-1] <= FEW_SAMPLES else MANY_ALPHA
        more = math.ceil(runs.counts[-1] * (last / wanted) ** (1 / alpha) * LAW_SAFETY)
        more = max(more, math.ceil(LEAST_MORE * runs.total / 2) if len(runs.counts) > 1 else 1)
        more += -more % 4 if more > 8 else 0   # frames of a few banks each (``view_bank.bank_groups``)
        if runs.total + 2 * more > MAX_SAMPLES:
            best = with_rounding(-10 * math.log10(error * runs.total / MAX_SAMPLES), rounding)
            raise ConfigError(f"--max-error {target:g} dB is above what {MAX_SAMPLES} footprint samples reach on "
                              f"this scene (about {best:.1f} dB by the noise floor of two seeds of "
                              f"{runs.counts[-1]}); use --max-error {math.floor(best * 10) / 10:g} or less")
        seed += 2
        reference = render([view_seeds(more, seed, views), view_seeds(more, seed + 1, views)])
    if chosen is None:
        raise ConfigError(f"--quality auto did not reach {target:g} dB in {MAX_RUNS} runs; lower --max-error "
                          f"or give --quality {runs.total}")
    quality, image = chosen
    dtype = np.uint8 if settings.bit_depth == 8 else np.uint16
    h3d = encode(image, dtype) if image is not None else runs.image(dtype)
    result = replace(runs.result, h3d=h3d, quality=quality, groups=None)
    if beside is not None:
        beside.join()
    fields = {"tried": tuple(tried), "seconds": time.perf_counter() - start,
              "reference_samples": runs.counts[0], "reference_floor_db": reference.floor_db,
              "povray_runs": len(runs.counts) + (beside is not None and not spare_taken)}
    return quality, fields, result


def _draft_or_seeds(runs: SeedRuns, reference: Reference, centre: list, target: float, need: float,
                    rounding: float, tried: list[tuple[str, float]]) -> tuple[Quality, np.ndarray | None] | None:
    """``draft`` where the seeds score it over ``need`` (and their floor is no more than 3 dB under the
    target: each seed then reaches it itself), else the seeds' mean where it reaches ``need``, else None."""
    if centre:
        draft_db = with_rounding(reference.psnr(encode(runs.draft, np.uint16)), rounding)
        tried.append(("draft", draft_db))
        if draft_db >= need and reference.floor_db >= target - 3:
            return Quality(), runs.draft
    got = mean_psnr(reference, rounding)
    tried.append((f"{runs.total} footprint samples", got))
    return (Quality(footprint=runs.total), None) if got >= need else None


class SpareRun:
    """A run of footprint seeds in a thread beside the first run (``SPARE_SHARE``): its result where
    the first falls short, else stopped (its POV-Ray process killed)."""

    def __init__(self, method: str, scene: Scene, lens_array: LensArray, settings: RenderSettings,
                 options: dict[str, Any], groups: list[np.ndarray]) -> None:
        self._stopped = threading.Event()
        self._outcome: list[Any] = []
        # One thread: the first run, which decides, keeps the rest of the cores.
        settings = replace(settings, should_stop=self._stopped.is_set, threads=1)

        def trace() -> None:
            try:
                self._outcome.append(run_method(method, scene, lens_array, settings, footprint_groups=groups,
                                                **options))
            except BaseException as exc:   # handed to the caller by ``result``
                self._outcome.append(exc)

        self._thread = threading.Thread(target=trace, name="povh3d-auto-spare", daemon=True)
        self._thread.start()

    def result(self) -> MethodResult:
        self._thread.join()
        outcome = self._outcome[0]
        if isinstance(outcome, BaseException):
            raise outcome
        return outcome

    def stop(self) -> None:
        """Stop the run if it is still going (no wait: ``join``)."""
        self._stopped.set()

    def join(self, quiet: bool = False) -> None:
        """Wait for the thread (its POV-Ray process stopped); an error other than the stop is raised."""
        self._thread.join()
        outcome = self._outcome[0] if self._outcome else None
        if isinstance(outcome, BaseException) and not isinstance(outcome, RenderInterrupted) and not quiet:
            raise outcome

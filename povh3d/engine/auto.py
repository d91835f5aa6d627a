"""``--quality auto --max-error DB``: the cheapest quality setting that reaches a PSNR
target against a converged footprint reference, chosen on a probe of the central
lenses (the ladder and its costs come from ``povh3d bench``, docs/benchmarks.md)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..geometry.lens_array import LensArray
from .methods import METHODS, run_method
from ..image.metrics import psnr
from .quality import AUTO, QUALITY_LEVELS, Progress, Quality, RenderSettings
from ..scene.scene import Scene


def reference_quality(samples: int = 256, seed: int = 1) -> Quality:
    return Quality(footprint=samples, seed=seed)


def to_8bit(image: np.ndarray) -> np.ndarray:
    return (np.rint(image / 257.0)).astype(np.uint8) if image.dtype == np.uint16 else image


# What --quality auto tries, cheapest first (the order the bench measures): it takes
# the first that meets the target on a probe of the central lenses.
AUTO_LADDER: tuple[Quality, ...] = (
    QUALITY_LEVELS["draft"], QUALITY_LEVELS["normal"],
    *(Quality(footprint=n) for n in (8, 16, 32, 64, 128)), QUALITY_LEVELS["high"],
)


@dataclass(frozen=True)
class AutoChoice:
    quality: Quality
    min_psnr_db: float
    tried: tuple[tuple[str, float], ...]   # (setting, PSNR dB) on the probe, in order
    probe_lenses: tuple[int, int]
    seconds: float
    reference_samples: int = 256

    def as_record(self) -> dict[str, Any]:
        return {"max_error_db": self.min_psnr_db, "chosen": self.quality.label,
                "probe_lenses": list(self.probe_lenses), "probe_seconds": round(self.seconds, 3),
                "probe_reference_samples": self.reference_samples,
                "tried": [{"setting": s, "psnr_db": round(p, 2)} for s, p in self.tried]}


def resolve_auto(scene: Scene, lens_array: LensArray, method: str, settings: RenderSettings,
                 progress: Progress | None = None, **options: Any) -> tuple[RenderSettings, AutoChoice | None]:
    """``settings`` with ``--quality auto`` replaced by the cheapest setting of
    ``AUTO_LADDER`` that reaches ``settings.max_error_db`` on a probe of the
    central lenses; unchanged (and None) for any other quality.

    The probe renders a footprint reference of the probe (cached like any render;
    ``probe_reference_samples`` for the target), then the ladder in order until
    one setting meets the target; a ConfigError if none does.  Methods without
    footprint samples stop at antialiasing.  ``progress(done, total)`` counts the
    probe's renders (the reference, then each setting tried).
    """
    if settings.quality != AUTO:
        return settings, None
    start = time.perf_counter()
    target = float(settings.max_error_db)
    probe = probe_array(lens_array)
    base = replace(settings, quality=QUALITY_LEVELS["draft"], max_error_db=None)
    samples = probe_reference_samples(target)
    reference = run_method("multi-ortho", scene, probe,
                           replace(base, quality=reference_quality(samples), bit_depth=16)).h3d
    reference = to_8bit(reference)
    takes_samples = METHODS[method].takes_samples(probe)
    tried: list[tuple[str, float]] = []
    ladder = list(dict.fromkeys(q if takes_samples else q.point_sampled() for q in AUTO_LADDER))
    if progress is not None:
        progress(1, 1 + len(ladder))
    for quality in ladder:
        result = run_method(method, scene, probe, replace(base, quality=quality), **options)
        tried.append((quality.label, psnr(result.h3d, reference)))
        if progress is not None:
            progress(1 + len(tried), 1 + len(ladder))
        if tried[-1][1] >= target:
            choice = AutoChoice(quality, target, tuple(tried), (probe.lenses_x, probe.lenses_y),
                                time.perf_counter() - start, samples)
            return replace(settings, quality=quality, max_error_db=None), choice
    best = max(tried, key=lambda t: t[1])
    raise ConfigError(f"no quality setting reaches {target:g} dB on this scene (best {best[1]:.1f} dB with "
                      f"{best[0]}, on the central {probe.lenses_x}x{probe.lenses_y} lenses); lower --max-error")


def probe_reference_samples(target_db: float) -> int:
    """Footprint samples of the probe's reference: enough that its own error is 10 dB under the target.

    Two references of 256 samples differ by 43.4 dB (bench), so each is about 46.4 dB
    from the converged image, and halving the samples costs 3 dB.  A noisier
    reference only makes a setting look worse (the errors add), so auto stays on
    the safe side: at 10 dB the bias is under 0.5 dB (at 8 dB it tipped a 35.15 dB
    setting under 35 and auto took one five times dearer).
    """
    samples = 32
    while samples < 256 and 46.4 - 3.0 * math.log2(256 / samples) < target_db + 10.0:
        samples *= 2
    return samples


def probe_array(lens_array: LensArray, max_lenses: tuple[int, int] = (16, 12)) -> LensArray:
    """The central part of ``lens_array``, at most ``max_lenses``, on a panel of its own size:
    what ``--quality auto`` renders to choose a setting.  Lenticular arrays keep 8 panel rows
    per lens row of the limit, since every panel row is its own lens row."""
    lx = min(lens_array.lenses_x, max_lenses[0])
    ly = min(lens_array.lenses_y, max_lenses[1] * (8 if lens_array.grid == "lenticular" else 1))
    p = lens_array.panel
    width = math.ceil(lx * lens_array.pitch_x / p.pitch_x - 1e-9)
    height = ly if lens_array.grid == "lenticular" else math.ceil(ly * lens_array.pitch_y / p.pitch_y - 1e-9)
    return replace(lens_array, lenses_x=lx, lenses_y=ly, panel=replace(p, width=width, height=height))



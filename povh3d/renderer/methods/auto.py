"""``--quality auto --max-error DB``: the fastest quality setting that reaches a PSNR
target against a converged footprint reference.

It is chosen on a probe: a window of the real request (the central lenses, traced with
the rays of the full render, the scene told the real panel), scored against a reference
of two seeds whose own noise floor sits above the target (``image.metrics.Reference``).
The ladder and its costs come from ``povh3d bench`` (docs/benchmarks.md).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ...jsontext import JSONValue
from ...errors import ConfigError, param
from ...geometry.lens_array import LensArray
from ...geometry.rays import pixel_rays
from ...image.metrics import Reference
from .auto_seeds import seeded_auto
from .registry import METHODS, GroupsUnsupported, MethodResult, run_method
from .quality import AUTO, QUALITY_LEVELS, Progress, Quality, RenderSettings
from ...scene.scene import Scene


def reference_quality(samples: int = 256, seed: int = 1) -> Quality:
    return Quality(footprint=samples, seed=seed)


def to_8bit(image: np.ndarray) -> np.ndarray:
    return (np.rint(image / 257.0)).astype(np.uint8) if image.dtype == np.uint16 else image


# What --quality auto tries, cheapest first (the order the bench measures): named levels and
# footprint sample counts between ``normal`` and ``high`` and past it, about 1.5x apart in cost.
AUTO_LADDER: tuple[Quality, ...] = (
    QUALITY_LEVELS["draft"], QUALITY_LEVELS["normal"],
    *(Quality(footprint=n) for n in (8, 12, 16, 24, 32, 48, 64, 96, 128, 192)), QUALITY_LEVELS["high"],
    *(Quality(footprint=n) for n in (384, 512)),
)
#: Footprint samples of the probe's reference, doubled from the first until its two seeds
#: agree above the target; past the last the target is refused.
REFERENCE_SAMPLES = (64, 128, 256, 512, 1024, 2048)
#: dB the probe must clear above the target: the window shows the centre, the full image more.
PROBE_MARGIN_DB = 0.1


@dataclass(frozen=True)
class AutoChoice:
    quality: Quality
    min_psnr_db: float
    tried: tuple[tuple[str, float], ...]   # (setting, PSNR dB) on the probe, in the order tried
    probe_lenses: tuple[int, int]
    seconds: float
    reference_samples: int = 256
    reference_floor_db: float = math.inf   # PSNR between the reference's two seeds
    povray_runs: int = 0   # POV-Ray processes started while choosing (``auto_seeds``: a stopped spare run too)
    # The full image already rendered at the choice (``auto_seeds``): written as it is, not rendered again.
    image: MethodResult | None = field(default=None, compare=False, repr=False)

    def as_record(self) -> dict[str, JSONValue]:
        return {"max_error_db": self.min_psnr_db, "chosen": self.quality.label,
                "probe_lenses": list(self.probe_lenses), "probe_seconds": round(self.seconds, 3),
                "probe_reference_samples": self.reference_samples,
                "probe_reference_floor_db": round(self.reference_floor_db, 2),
                "full_image": self.image is not None, "povray_runs": self.povray_runs,
                "tried": [{"setting": s, "psnr_db": round(p, 2)} for s, p in self.tried]}


def resolve_auto(scene: Scene, lens_array: LensArray, method: str, settings: RenderSettings,
                 progress: Progress | None = None, **options: Any) -> tuple[RenderSettings, AutoChoice | None]:
    """``settings`` with ``--quality auto`` replaced by the fastest setting of ``AUTO_LADDER``
    that reaches ``settings.max_error_db`` on the probe; unchanged (and None) for any other quality.

    The probe (``probe_window``) renders the reference (``probe_reference``), then the ladder:
    draft and normal, then a bisection of the sample counts (the error falls as they grow).
    Methods without footprint samples try what they can render.  ``progress(done, total)``
    counts the probe's renders.
    """
    if settings.quality != AUTO:
        return settings, None
    assert settings.max_error_db is not None  # quality 'auto' (RenderSettings: then and only then)
    if full_image_auto(method, lens_array):
        try:
            quality, fields, image = seeded_auto(scene, lens_array, method, settings, progress, **options)
        except GroupsUnsupported:
            pass   # a lens mesh (a clearance under one view-bank step): the probe below
        else:
            choice = AutoChoice(quality, float(settings.max_error_db), probe_lenses=(lens_array.lenses_x,
                                lens_array.lenses_y), image=image, **fields)
            return replace(settings, quality=quality, max_error_db=None), choice
    start = time.perf_counter()
    target = float(settings.max_error_db)
    window, mask = probe_window(lens_array)
    base = replace(settings, quality=QUALITY_LEVELS["draft"], max_error_db=None)
    reference, samples = probe_reference(scene, window, lens_array, mask, base, target)
    takes_samples = METHODS[method].takes_samples(window)
    ladder = list(dict.fromkeys(q if takes_samples else q.point_sampled() for q in AUTO_LADDER))
    scores: dict[int, float] = {}
    tried: list[tuple[str, float]] = []

    def score(i: int) -> float:
        if i not in scores:
            result = run_method(method, scene, window, replace(base, quality=ladder[i]), declared=lens_array,
                                **options)
            scores[i] = reference.psnr(result.h3d)
            tried.append((ladder[i].label, scores[i]))
            if progress is not None:
                progress(1 + len(tried), 1 + len(ladder))
        return scores[i]

    if progress is not None:
        progress(1, 1 + len(ladder))
    need = target + PROBE_MARGIN_DB
    first = next((i for i in range(min(2, len(ladder))) if score(i) >= need), None)
    if first is None and len(ladder) > 2:
        lo, hi = 2, len(ladder) - 1   # the first rung from ``lo`` that meets the target, if ``hi`` does
        if score(hi) >= need:
            while lo < hi:
                mid = (lo + hi) // 2
                lo, hi = (lo, mid) if score(mid) >= need else (mid + 1, hi)
            first = hi
    if first is None:
        best = max(tried, key=lambda t: t[1])
        raise ConfigError(f"no quality setting reaches {target:g} dB on this scene (best {best[1]:.1f} dB with "
                          f"{best[0]}, on the central {window.lenses_x}x{window.lenses_y} lenses); lower {param('max_error_db')}")
    quality = ladder[first]
    choice = AutoChoice(quality, target, tuple(tried), (window.lenses_x, window.lenses_y),
                        time.perf_counter() - start, samples, reference.floor_db)
    return replace(settings, quality=quality, max_error_db=None), choice


#: Panels up to this many pixels are chosen for on the full image (``auto_seeds``, which holds each
#: run's two seeds in linear light: 24 MB an image here); larger ones on the probe window, a small
#: share of them.
FULL_IMAGE_PIXELS = 1_000_000


def full_image_auto(method: str, lens_array: LensArray) -> bool:
    """Whether ``--quality auto`` renders the full image while choosing (``auto_seeds``): a method
    that traces footprint samples in a view bank, on a panel of at most ``FULL_IMAGE_PIXELS``."""
    return (METHODS[method].takes_samples(lens_array)
            and lens_array.panel.width * lens_array.panel.height <= FULL_IMAGE_PIXELS)


def probe_reference(scene: Scene, window: LensArray, declared: LensArray, mask: np.ndarray,
                    settings: RenderSettings, target_db: float) -> tuple[Reference, int]:
    """The probe's converged reference: two seeds of ``REFERENCE_SAMPLES`` footprint samples,
    doubled until they agree above ``target_db``; a one-line refusal naming the floor past the last."""
    for samples in REFERENCE_SAMPLES:
        first, second = (run_method("multi-ortho", scene, window,
                                    replace(settings, quality=reference_quality(samples, seed), bit_depth=16),
                                    declared=declared).h3d for seed in (1, 2))
        reference = Reference(first, second, mask)
        if reference.floor_db >= target_db:
            return reference, samples
    raise ConfigError(f"{param('max_error_db')} {target_db:g} dB is above the converged reference's own noise floor on this "
                      f"scene ({reference.floor_db:.1f} dB between two {samples}-sample references); "
                      f"use {param('max_error_db')} {math.floor(reference.floor_db * 10) / 10:g} or less")


def probe_window(lens_array: LensArray, max_lenses: tuple[int, int] = (16, 12)) -> tuple[LensArray, np.ndarray]:
    """The central lenses of ``lens_array`` on a window of its panel, and the window's pixels
    whose ray is the full render's (``(h, w)`` bool): what ``--quality auto`` renders and scores.

    The window keeps the panel's pixel phase (an even number of pixels off each edge), and of
    the lens counts up to ``max_lenses`` (lenticular: 8 panel rows per lens row of the limit)
    the one whose rays match the full array's on the most pixels: on a lattice whose lens
    count has the other parity, or a hex array's row phase, the lenses land elsewhere.
    """
    la, p = lens_array, lens_array.panel
    full_c, full_d, full_in = pixel_rays(la)
    best = None
    for dx in (0, 1, 2, 3):
        for dy in (0, 1, 2, 3):
            lx = min(la.lenses_x, max_lenses[0]) - dx
            ly = min(la.lenses_y, max_lenses[1] * (8 if la.grid == "lenticular" else 1)) - dy
            if lx < 1 or ly < 1:
                continue
            extra = la.pitch_x / 2 if la.grid == "hex" and ly > 1 else 0.0   # odd rows sit half a pitch over
            width = min(p.width, math.ceil((lx * la.pitch_x + extra) / p.pitch_x - 1e-9))
            height = ly if la.grid == "lenticular" else min(p.height, math.ceil(ly * la.pitch_y / p.pitch_y - 1e-9))
            width += (p.width - width) % 2
            height += (p.height - height) % 2
            try:
                window = replace(la, lenses_x=lx, lenses_y=ly, panel=replace(p, width=width, height=height))
            except ConfigError:
                continue
            r0, c0 = (p.height - height) // 2, (p.width - width) // 2
            c, d, inside = pixel_rays(window)
            fc, fd = full_c[r0:r0 + height, c0:c0 + width], full_d[r0:r0 + height, c0:c0 + width]
            tol = 1e-9 * max(la.pitch_x, la.pitch_y, la.focal)
            same = (inside & full_in[r0:r0 + height, c0:c0 + width]
                    & np.all(np.abs(np.nan_to_num(c) - np.nan_to_num(fc)) <= tol, axis=-1)
                    & np.all(np.abs(np.nan_to_num(d) - np.nan_to_num(fd)) <= tol, axis=-1))
            if best is None or same.sum() > best[2].sum():
                best = (window, (r0, c0), same)
    if best is None or not best[2].any():
        raise ConfigError(f"{param('quality')} auto found no window of this display to probe; choose {param('quality')} "
                          "draft, normal or high")
    return best[0], best[2]


def window_offset(lens_array: LensArray, window: LensArray) -> tuple[int, int]:
    """Row and column of the window's top-left pixel in the full panel (``probe_window``)."""
    return ((lens_array.panel.height - window.panel.height) // 2, (lens_array.panel.width - window.panel.width) // 2)

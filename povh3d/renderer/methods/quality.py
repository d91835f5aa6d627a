"""The quality model: how densely a render samples each pixel's footprint, and
how POV-Ray is run (``RenderSettings``); none of it changes the geometry."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import ConfigError, param
from ...system import thread_limit
from ...geometry.footprint import GRID, angular_grid, latin_hypercube
from ...scene.features import Features, needed_settings


@dataclass(frozen=True)
class Quality:
    """How densely a render samples each pixel's footprint (docs/geometry.md).

    Attributes
    ----------
    antialias : float or None   POV-Ray's ``+A`` threshold; None: one ray per sub-view
    aa_method : {1, 2}          ``+AM``: 1 non-recursive, 2 adaptive recursive
    aa_depth : int              ``+R``: supersampling depth
    jitter : bool               ``+J``: jitter the supersamples
    subviews : int              angular sub-views per axis, averaged in linear light:
                                an orthographic view pixel spans the lens aperture
                                but not the pixel's angular width; these do
    footprint : int             > 0: that many stratified random samples of the whole
                                footprint instead (the converged reference)
    seed : int                  of the footprint samples
    max_trace_level : int or None   overrides the scene's (None: the scene's own)
    """

    antialias: float | None = None
    aa_method: int = 1
    aa_depth: int = 2
    jitter: bool = False
    subviews: int = 1
    footprint: int = 0
    seed: int = 0
    max_trace_level: int | None = None

    def __post_init__(self) -> None:
        if self.antialias is not None and not 0 <= self.antialias <= 3:
            raise ConfigError(f"the antialiasing threshold must be within 0..3, got {self.antialias}")
        if self.aa_method not in (1, 2):
            raise ConfigError(f"the antialiasing method must be 1 or 2, got {self.aa_method}")
        if not 1 <= self.aa_depth <= 9:
            raise ConfigError(f"the antialiasing depth must be within 1..9, got {self.aa_depth}")
        if self.subviews < 1 or not 0 <= self.footprint <= GRID:
            raise ConfigError(f"sub-views must be at least 1 and footprint samples 0 to {GRID}")
        if self.max_trace_level is not None and not 1 <= self.max_trace_level <= 256:
            raise ConfigError(f"max trace level must be within 1..256, got {self.max_trace_level}")

    @property
    def options(self) -> tuple[str, ...]:
        """POV-Ray's command-line switches for this quality."""
        if self.antialias is None:
            return ("-A",)
        # POV-Ray jitters by default, and its jitter depends on where a pixel sits in
        # the image: -J keeps a pixel's value whatever the layout (crop, tiling).
        return (f"+A{self.antialias:g}", f"+AM{self.aa_method}", f"+R{self.aa_depth}",
                "+J" if self.jitter else "-J")

    @property
    def samples_pixel_borders(self) -> bool:
        """Whether POV-Ray may trace rays on a pixel's border, shared with its neighbour:
        adaptive antialiasing (``+AM2``) traces every pixel's corners; jitter moves
        samples up to the border.  ``+AM1`` without jitter stays inside the pixel."""
        return self.antialias is not None and (self.aa_method == 2 or self.jitter)

    def point_sampled(self) -> Quality:
        """This quality for a method that traces one ray per sub-view (no footprint
        samples): sub-views and footprint samples become adaptive antialiasing."""
        if self.subviews == 1 and not self.footprint:
            return self
        aa: dict[str, Any] = {} if self.antialias is not None else {"antialias": 0.05, "aa_method": 2, "aa_depth": 3}
        return replace(self, subviews=1, footprint=0, **aa)

    def footprint_sampled(self) -> Quality:
        """This quality where POV-Ray's antialiasing would cross footprints (a lens mesh:
        corner samples on a lens border belong to the next lens): ``+R`` squared footprint
        samples (9 at ``normal``) instead, each traced through the pixel's own lens."""
        if self.antialias is None:
            return self
        return replace(self, antialias=None, aa_method=1, footprint=max(self.footprint, self.aa_depth ** 2))

    def samples(self) -> np.ndarray:
        """The footprint samples each pixel gets, ``(K, 4)`` (see ``povh3d.footprint``)."""
        if self.footprint:
            return latin_hypercube(self.footprint, self.seed)
        return angular_grid(self.subviews)

    @property
    def label(self) -> str:
        parts = [" ".join(self.options)]
        if self.footprint:
            parts.append(f"{self.footprint} footprint samples")
        elif self.subviews > 1:
            parts.append(f"{self.subviews}x{self.subviews} sub-views")
        if self.max_trace_level is not None:
            parts.append(f"trace level {self.max_trace_level}")
        return ", ".join(parts)


# The named levels, chosen from `povh3d bench` (README, "Run time against error"):
# on a finely textured scene, against a reference that integrates every pixel's
# footprint, point sampling reached 21 dB; POV-Ray's adaptive antialiasing 34 dB
# at about 1.8x the time (it integrates across the lens aperture, which an
# orthographic view pixel spans, not the pixel's angular width); stratified
# footprint samples converge to the reference itself, 256 of them to its noise
# floor.  draft is point-sampled: what methods are compared with when they must
# agree exactly.  A method that cannot trace footprint samples antialiases
# instead (``Quality.point_sampled``).
QUALITY_LEVELS: dict[str, Quality] = {
    "draft": Quality(),
    "normal": Quality(antialias=0.1, aa_method=2, aa_depth=3),
    "high": Quality(footprint=256),
}
AUTO = "auto"  # --quality auto --max-error DB: the fastest setting that meets DB (``methods.auto``)
QUALITY_OPTIONS: dict[str, tuple[str, ...]] = {name: q.options for name, q in QUALITY_LEVELS.items()}



def quality_level(name: str) -> Quality:
    """A named level, or a whole number ``N``: ``N`` footprint samples per pixel (``high`` is 256;
    the counts between ``normal`` and ``high`` are the rungs ``--quality auto`` chooses from)."""
    if name in QUALITY_LEVELS:
        return QUALITY_LEVELS[name]
    if isinstance(name, str) and name.isdigit() and 1 <= int(name) <= GRID:
        return Quality(footprint=int(name))
    raise ConfigError(f"quality must be one of {', '.join(QUALITY_LEVELS)}, auto or a number of footprint samples "
                      f"from 1 to {GRID}, got {name!r}")


Progress = Callable[[float, int], None]  # (done, total) shots; done may be fractional
#: --depth-scale: a compression beyond 1/1000 leaves nothing of the depth; an expansion past 100
#: tilts rays further than any lens can.
DEPTH_SCALE_RANGE = (1e-3, 100.0)


@dataclass(frozen=True)
class RenderSettings:
    """How to run POV-Ray; none of it changes the geometry.

    Attributes
    ----------
    quality : {'draft', 'normal', 'high', 'auto'}, 'N' (footprint samples) or Quality
              ('auto' is resolved before rendering; see ``methods.auto.resolve_auto``)
    jobs : int or None          parallel POV-Ray processes (None: chosen per method)
    threads : int or None       POV-Ray threads per process (None: cores / jobs)
    timeout : float or None     seconds allowed to each POV-Ray run
    use_cache : bool            read and write the image cache
    cache_dir : Path or None    None: ``default_cache_dir()``
    bit_depth : {8, 16}
    front_clearance : float or None    mm in front of the screen where rays start (None: default)
    front_clearance_limit : float or None   mm: the farthest out rays may start whatever the method's
                                default or rounding (a camera placement: short of the scene's camera,
                                so nothing behind it enters the image); None: no limit
    front_clearance_reason : str   why the limit, for the sidecar
    clock : float or None       POV-Ray's ``clock`` for every run (None: POV-Ray's default, 0);
                                set only for scenes that read it (see animation.py)
    sequence : ClockSequence or None   the animation frames from ``clock``'s on, which the engine
                                may render in the same POV-Ray runs (``renderer.shots.clock_runs``)
    scheduler : str or None     Dask scheduler address (``tcp://host:8786``); None: local processes
    max_error_db : float or None   with quality 'auto': the lowest PSNR against the reference to accept
    pose : tuple of 12 floats or None    the placement's pose as a POV-Ray ``matrix`` (display mm -> scene
                                units, ``geometry.pose.DisplayPose.matrix``); None: native
    depth_scale : float             compress depth along the display normal by this factor (1: none); a
                                distortion, traced as every ray's slope times it (``depth_scaled_rays``)
    should_stop : callable or None  polled while local POV-Ray runs; True stops them (``RenderInterrupted``):
                                a caller's way to cancel a render (the command itself sets none)
    shared_lighting : bool      a still's shots share one radiosity solution (``renderer.shots.lighting``);
                                False: each POV-Ray frame computes its own, as a plain render does
    """

    quality: str | Quality = "normal"
    jobs: int | None = None
    threads: int | None = None
    timeout: float | None = None
    use_cache: bool = True
    cache_dir: Path | None = None
    bit_depth: int = 8
    front_clearance: float | None = None
    front_clearance_limit: float | None = None
    front_clearance_reason: str = ""
    clock: float | None = None
    sequence: Any = None
    scheduler: str | None = None
    max_error_db: float | None = None
    pose: tuple[float, ...] | None = None
    depth_scale: float = 1.0
    shared_lighting: bool = True
    should_stop: Callable[[], bool] | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        k = self.depth_scale
        if isinstance(k, bool) or not isinstance(k, (int, float)) or not DEPTH_SCALE_RANGE[0] <= k <= DEPTH_SCALE_RANGE[1]:
            raise ConfigError(f"{param('depth_scale')} must be a number within {DEPTH_SCALE_RANGE[0]:g}..{DEPTH_SCALE_RANGE[1]:g}, "
                              f"got {k!r}")
        if self.pose is not None and len(self.pose) != 12:
            raise ConfigError(f"the pose is a matrix of 12 numbers, got {len(self.pose)}")
        if not isinstance(self.quality, Quality) and self.quality != AUTO:
            quality_level(self.quality)
        if (self.quality == AUTO) != (self.max_error_db is not None):
            raise ConfigError(f"{param('quality')} auto needs {param('max_error_db')} DB (the lowest PSNR to accept), "
                              f"and {param('max_error_db')} needs {param('quality')} auto")
        if self.jobs is not None and self.jobs < 1:
            raise ConfigError(f"{param('jobs')} must be at least 1, got {self.jobs}")
        if self.threads is not None and self.threads < 1:
            raise ConfigError(f"{param('threads')} must be at least 1, got {self.threads}")
        if self.threads is not None and self.threads > (limit := thread_limit(self.scheduler is not None)):
            where = "a cluster's process" if self.scheduler else f"this machine's {limit} cores"
            raise ConfigError(f"{param('threads')} {self.threads} is more than {where} can run (at most {limit}); "
                              f"give fewer or leave {param('threads')} out (the cores / jobs)")
        if self.timeout is not None and not self.timeout > 0:
            raise ConfigError(f"{param('timeout')} must be a positive number of seconds, got {self.timeout}")
        if self.bit_depth not in (8, 16):
            raise ConfigError(f"bit depth must be 8 or 16, got {self.bit_depth}")
        if self.front_clearance is not None and not (np.isfinite(self.front_clearance) and self.front_clearance > 0):
            raise ConfigError(f"{param('front_clearance')} must be a positive number of mm, got {self.front_clearance}")
        clearance_limit = self.front_clearance_limit
        if clearance_limit is not None and not (np.isfinite(clearance_limit) and clearance_limit > 0):
            raise ConfigError(f"the front clearance limit must be a positive number of mm, got {clearance_limit}")

        if self.clock is not None and not np.isfinite(self.clock):
            raise ConfigError(f"the clock must be a finite number, got {self.clock}")

    @property
    def spec(self) -> Quality:
        if self.quality == AUTO:
            raise RuntimeError(f"resolve {param('quality')} auto first (renderer.methods.auto.resolve_auto)")
        return self.quality if isinstance(self.quality, Quality) else quality_level(self.quality)

    @property
    def options(self) -> tuple[str, ...]:
        # +K sets the clock of a still; a run of several shots is a
        # POV-Ray animation, where initial = final clock keeps it constant.
        c = self.clock
        clock = () if c is None else (f"+K{c!r}", f"+KI{c!r}", f"+KF{c!r}")
        return self.spec.options + clock


def _init_taking_frame(init: Any) -> Any:
    """``RenderSettings(frame=...)``, the name of ``pose`` before issue 36 (``frame`` is an
    animation's), still taken with a deprecation."""
    def __init__(self: RenderSettings, *args: Any, frame: tuple[float, ...] | None = None, **kwargs: Any) -> None:
        if frame is not None:
            import warnings

            warnings.warn("RenderSettings(frame=...) is deprecated; its name is pose", DeprecationWarning, stacklevel=2)
            kwargs.setdefault("pose", frame)
        init(self, *args, **kwargs)
    return __init__


setattr(RenderSettings, "__init__", _init_taking_frame(RenderSettings.__init__))


def quality_settings(features: Features, quality: Quality) -> dict[str, Any]:
    """The global settings ``quality`` asks for that act on something this scene uses."""
    requested = {} if quality.max_trace_level is None else {"max_trace_level": str(quality.max_trace_level)}
    return needed_settings(features, requested)

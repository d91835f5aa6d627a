"""The sidecar: what povh3d writes beside every image (``name.json`` beside ``name.png``), typed.

``Sidecar`` holds the keys every sidecar has (``povh3d_version``, ``kind``, ``image_sha256``), the
lens array, and one typed field for each of the render's sub-records (the quality, the timings, the
passes, the display frame, the quilt, the object masks, an animation frame's place, the warnings).
A command's own keys (a refocus's depths, a resample's pitches, a method's set-up) are ``extra``:
JSON values kept as given.  ``to_json`` writes the keys in the order they were given (or read), so a
sidecar read and written again is the same bytes; ``from_json`` checks the type of every key it
knows and refuses a wrong one in one line that names the file and the key
(``jsontext.Record``).  ``image.io.read_sidecar_record`` reads one; ``image.io.write_image_pair``
and ``write_sidecar`` write one.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, KeysView
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

from .._version import __version__
from ..jsontext import JSONObject, JSONValue, Record, to_json_value

if TYPE_CHECKING:
    from ..geometry.lens_array import LensArray

@dataclass(frozen=True, kw_only=True)
class PanelRecord(Record):
    """A panel: its pixels, their pitch and its size (``lens_array.panel``)."""

    size_px: tuple[int, int]
    pixel_pitch_mm: tuple[float, float]
    size_mm: tuple[float, float]
    extra: JSONObject = field(default_factory=dict)
    order: tuple[str, ...] = field(default=(), compare=False)


@dataclass(frozen=True, kw_only=True)
class LensArrayRecord(Record):
    """``LensArray.as_record``: the array the image was rendered through (``Display.from_record``
    rebuilds the ``LensArray`` and checks that its numbers agree)."""

    grid: str
    lenses: tuple[int, int]
    lens_pitch_mm: tuple[float, float]
    focal_mm: float
    panel: PanelRecord
    ppl: tuple[float, float]
    rotation_deg: float | None = None
    lattice_mm: tuple[tuple[float, float], ...] | None = None
    viewing_angle_deg: float | None = None
    resolution_3d: tuple[float, float] | None = None
    pixel_distance_3d_mm: tuple[float, float] | None = None
    ppi_3d: tuple[float, float] | None = None
    views: tuple[int, int] | None = None
    view_size_px: tuple[int, int] | None = None
    h3d_size_px: tuple[int, int] | None = None
    view_angles_deg: JSONObject | None = None
    extra: JSONObject = field(default_factory=dict)
    order: tuple[str, ...] = field(default=(), compare=False)

    @classmethod
    def of(cls, lens_array: LensArray) -> LensArrayRecord:
        return cls.from_json(lens_array.as_record())


@dataclass(frozen=True, kw_only=True)
class QualityRecord(Record):
    """The quality asked for and as rendered (``renderer.render.quality_record``), where the rays start."""

    level: str
    setting: str | None = None
    povray_options: tuple[str, ...] | None = None
    subviews: int | None = None
    footprint_samples: int | None = None
    max_trace_level: int | None = None
    bit_depth: int | None = None
    front_clearance_mm: float | None = None
    front_clearance_reason: str | None = None
    auto: JSONObject | None = None     # ``--quality auto``: what it tried (``renderer.methods.auto``)
    extra: JSONObject = field(default_factory=dict)
    order: tuple[str, ...] = field(default=(), compare=False)


@dataclass(frozen=True, kw_only=True)
class Timings(Record):
    """What the render cost (``renderer.shots.batch.RenderStats.as_record``, the whole request's seconds)."""

    render_seconds: float | None = None
    shots: int | None = None
    shots_from_cache: int | None = None
    povray_jobs: int | None = None
    processes: int | None = None
    threads_per_process: int | None = None
    povray_seconds_total: float | None = None
    wall_seconds: float | None = None
    total_seconds: float | None = None
    output_from_cache: bool | None = None
    extra: JSONObject = field(default_factory=dict)
    order: tuple[str, ...] = field(default=(), compare=False)


@dataclass(frozen=True)
class PassCost(Record):
    """One POV-Ray pass around a render, for the sidecar's ``passes`` list (``renderer.passes.record``).

    Attributes
    ----------
    name : str          e.g. ``scene-camera``, ``scene-camera-depth``, ``depth``, ``origins-inside``, ``depth-maps``
    seconds : float     wall time of the pass, its POV-Ray runs and the reading of their images
    shots : int         images POV-Ray traced for it (0: all from the cache)
    runs : int          POV-Ray processes it started
    from_cache : bool   its result came from the cache, no POV-Ray run
    beside : bool       True: it ran beside the render (``renderer.passes.beside``), its seconds
                        within the render's; omitted for a pass before or after it
    """

    name: str
    seconds: float
    shots: int
    runs: int
    from_cache: bool = False
    beside: bool | None = None

    def to_json(self) -> dict[str, JSONValue]:
        return {"name": self.name, "seconds": round(self.seconds, 4), "shots": self.shots, "runs": self.runs,
                "from_cache": self.from_cache, **({"beside": self.beside} if self.beside is not None else {})}


class _ReadsAsJSON:
    """A record read as a mapping of its JSON (``{**side, ...}``, ``side["kind"]``, ``record["depth"]``):
    the file's keys and values, never a way to change them (``with_``, ``updated``)."""

    if TYPE_CHECKING:   # the record's own (``jsontext.Record``): nothing here to shadow it at run time
        def to_json(self) -> dict[str, JSONValue]: ...

    def keys(self) -> KeysView[str]:
        return self.to_json().keys()

    def __getitem__(self, key: str) -> JSONValue:
        return self.to_json()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.to_json())

    def __len__(self) -> int:
        return len(self.to_json())

    def __contains__(self, key: object) -> bool:
        return key in self.to_json()


@dataclass(frozen=True, kw_only=True)
class PlacementRecord(Record, _ReadsAsJSON):
    """Where the display sits in the scene and what the depth pass saw (``renderer.placement``): the
    sidecar's ``placement``.  The keys the render reads are typed; the rest (the pose's axes,
    the depth report's numbers) are kept as written."""

    source: str | None = None
    units_per_mm: float | None = None
    warnings: tuple[str, ...] | None = None
    depth: JSONObject | None = None
    depth_budget_mm: float | None = None
    front_clearance_limit_mm: float | None = None
    ray_state: JSONObject | None = None
    extra: JSONObject = field(default_factory=dict)
    order: tuple[str, ...] = field(default=(), compare=False)

    def get(self, key: str, default: JSONValue = None) -> JSONValue:
        """The JSON value of ``key`` (a typed field or a kept one)."""
        return self.to_json().get(key, default)


@dataclass(frozen=True, kw_only=True)
class QuiltRecord(Record):
    """A Looking Glass render's quilt beside the image (``renderer.outputs.device_quilt``)."""

    device: str
    file: str
    grid: tuple[int, int]
    quilt_size: tuple[int, int] | None = None
    tile_size: tuple[int, int] | None = None
    aspect: float | None = None
    view_cone_deg: float | None = None
    view_cone_from: str | None = None
    native: str | None = None
    extra: JSONObject = field(default_factory=dict)
    order: tuple[str, ...] = field(default=(), compare=False)


@dataclass(frozen=True, kw_only=True)
class AnimationRecord(Record):
    """An animation frame's place in its sequence (``renderer.animation``)."""

    frame: int
    clock: float | None = None
    frames: tuple[int, int] | None = None
    clock_range: tuple[float, float] | None = None
    scene_uses_clock: bool | None = None
    extra: JSONObject = field(default_factory=dict)
    order: tuple[str, ...] = field(default=(), compare=False)


@dataclass(frozen=True, kw_only=True)
class Sidecar(Record, _ReadsAsJSON):
    """One sidecar.  ``kind``: ``h3d``, ``panel``, ``views``, ``quilt``, ``refocus``, ``replay``, ...

    Built by ``Sidecar.new`` (``renderer.records.base_record``) and grown by ``with_``, each new key
    after the others, as the file shows them.
    """

    FIX: ClassVar[str] = "delete the sidecar or render the image again"

    povh3d_version: str
    kind: str
    lens_array: LensArrayRecord | None = None
    method: str | None = None
    scene: str | None = None
    scene_sha256: str | None = None
    quality: QualityRecord | None = None
    output_gamma: str | None = None
    povray_version: str | None = None
    sandbox: str | None = None
    scheduler: str | None = None
    timings: Timings | None = None
    display: JSONObject | None = None          # ``display.display.Display.as_record``'s ``display``
    method_chosen: bool | None = None
    method_note: str | None = None
    method_fallback: str | None = None
    camera_model: JSONObject | None = None
    crop: JSONObject | None = None
    placement: PlacementRecord | None = None
    mapping: str | None = None
    size_px: tuple[int, int] | None = None
    dataset: JSONObject | None = None
    depth_maps: JSONObject | None = None
    quilt: QuiltRecord | None = None
    passes: tuple[PassCost, ...] | None = None
    animation: AnimationRecord | None = None
    objects: JSONObject | None = None
    warnings: tuple[str, ...] | None = None
    image_sha256: str | None = None
    extra: JSONObject = field(default_factory=dict)   # every other key: a command's own, a newer povh3d's
    order: tuple[str, ...] = field(default=(), compare=False)

    @classmethod
    def new(cls, kind: str, lens_array: LensArray | None = None, **entries: object) -> Sidecar:
        """``povh3d_version``, ``kind``, the lens array, then ``entries`` in the order given."""
        side = cls(povh3d_version=__version__, kind=kind, order=("povh3d_version", "kind"))
        if lens_array is not None:
            side = side.with_(lens_array=LensArrayRecord.of(lens_array))
        return side.with_(**entries)

    def with_(self, **entries: object) -> Sidecar:
        """This sidecar with ``entries`` set: a new key after the others, a known one in its place.
        A typed field takes its record or its JSON; the whole is read back as ``from_json`` reads a
        file, so every entry is checked; any other key is kept as given."""
        return Sidecar.from_json({**self.to_json(), **{k: to_json_value(v) for k, v in entries.items()}})

    def get(self, key: str, default: JSONValue = None) -> JSONValue:
        """The JSON value of ``key``, typed or kept (a command's own keys: ``side.get("depths_mm")``)."""
        if key in _TYPED:
            value = getattr(self, key)
            return default if value is None and key not in self.order else to_json_value(value)
        return self.extra.get(key, default)



_TYPED = frozenset(f.name for f in dataclasses.fields(Sidecar)) - {"extra", "order"}

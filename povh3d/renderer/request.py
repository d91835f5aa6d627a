"""One render, described whole: the ``RenderRequest`` that the CLI and the Python
API both build, and that ``renderer.render.render`` carries out.

A request names the content (a POV-Ray scene or a mesh model), the display
(``display.display.Display``: lens array, and the pixel mapping of a slanted panel), the method and its
options, the quality, and every output (image, views, animation frames, video).
It is frozen and checked on construction: a request that exists can be rendered.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping as MappingABC
from dataclasses import dataclass, field
from dataclasses import replace as _replace
from pathlib import Path

from .methods.registry import get_method
from .methods.quality import RenderSettings
from ..errors import ConfigError, param
from ..jsontext import JSONValue
from ..geometry.crop import CropSettings
from ..geometry.lens_array import LensArray
from ..image.video import check_video_path
from ..mesh.formats import is_mesh_file
from .animation import FrameRange
from ..display.display import Display
from .placement.pose import PlacementOptions

SHADINGS = ("auto", "smooth", "flat")


@dataclass(frozen=True)
class ModelOptions:
    """How a mesh model is put on the default stage (``renderer.content.model``).

    Attributes
    ----------
    depth : float or None, mm      the model's depth (None: the display's depth budget)
    shading : {'auto', 'smooth', 'flat'}
    max_triangles : int, 'auto' or None   simplify to this many triangles
    up : {'x', 'y', 'z', '-x', '-y', '-z'} or None   the model's up axis (None: the format's, or detected)
    rotate : (3,) degrees or None  turn the model (POV-Ray's ``rotate``) after ``up``
    unit : {'mm', 'cm', 'm', 'in'} or None   the model's unit (None: the file's); only the record
                                   shows it, since the stage scales the model to the panel
    """

    depth: float | None = None
    shading: str = "auto"
    max_triangles: int | str | None = None
    up: str | None = None
    rotate: tuple[float, float, float] | None = None
    unit: str | None = None

    def __post_init__(self) -> None:
        if self.depth is not None and not (math.isfinite(self.depth) and self.depth > 0):
            raise ConfigError(f"{param('depth')} must be a positive number of mm, got {self.depth!r}")
        if self.shading not in SHADINGS:
            raise ConfigError(f"shading must be one of {', '.join(SHADINGS)}, got {self.shading!r}")
        m = self.max_triangles
        if m is not None and m != "auto" and (isinstance(m, bool) or not isinstance(m, int) or m < 4):
            raise ConfigError(f"{param('max_triangles')} takes a whole number >= 4 or 'auto', got {m!r}")
        if self.up is not None and self.up not in ("x", "y", "z", "-x", "-y", "-z"):
            raise ConfigError(f"{param('up')} must be one of x, y, z, -x, -y, -z, got {self.up!r}")
        if self.rotate is not None and (len(self.rotate) != 3 or not all(math.isfinite(a) for a in self.rotate)):
            raise ConfigError(f"{param('rotate')} takes three angles X,Y,Z in degrees, got {self.rotate!r}")


@dataclass(frozen=True)
class VolumeOptions:
    """How a volume is drawn and placed (``renderer.content.volume``).

    Attributes
    ----------
    spacing : (3,) mm or None       voxel size (needed by ``.npy``; replaces a file's own)
    series : str or None            the DICOM series UID, when a folder holds several
    labels : tuple of int, 'all' or None   one surface per label (a segmentation)
    iso : tuple of float or None    one surface per iso value (scalar data: CT in HU)
    opacity : tuple of float or None   one for every surface, or one per surface in order
    smoothing : int or None         smoothing iterations (None: 16 for labels, none for iso)
    orientation : {'coronal', 'axial', 'sagittal'}   the radiological view (``volume.orient``)
    rotate : (3,) degrees or None   then turned as POV-Ray's ``rotate``
    volume : bool                   direct volume rendering (participating media) instead of surfaces
    transfer : str                  its transfer function: a preset name, a file, or auto (chosen from the values)
    df3_bits : {8, 16}              its density file's bits per voxel
    """

    spacing: tuple[float, float, float] | None = None
    series: str | None = None
    labels: tuple[int, ...] | str | None = None
    iso: tuple[float, ...] | None = None
    opacity: tuple[float, ...] | None = None
    smoothing: int | None = None
    orientation: str = "coronal"
    rotate: tuple[float, float, float] | None = None
    volume: bool = False
    transfer: str = "auto"
    df3_bits: int = 16

    def __post_init__(self) -> None:
        from ..volume.orient import ORIENTATIONS

        if self.orientation not in ORIENTATIONS:
            raise ConfigError(f"{param('orientation')} must be one of {', '.join(ORIENTATIONS)}, got {self.orientation!r}")
        chosen = [name for name, on in ((param("labels"), self.labels is not None), (param("iso"), self.iso is not None),
                                        (param("volume"), self.volume)) if on]
        if len(chosen) > 1:
            raise ConfigError(f"{' and '.join(chosen)} exclude each other; choose one way to draw the volume")
        if self.iso is not None and not (self.iso and all(math.isfinite(v) for v in self.iso)):
            raise ConfigError(f"{param('iso')} takes numbers VALUE[,VALUE...], got {self.iso!r}")
        if self.smoothing is not None and (isinstance(self.smoothing, bool) or self.smoothing < 0):
            raise ConfigError(f"{param('smoothing')} takes a whole number of iterations >= 0, got {self.smoothing!r}")
        if self.df3_bits not in (8, 16):
            raise ConfigError(f"{param('df3_bits')} must be 8 or 16, got {self.df3_bits!r}")


@dataclass(frozen=True)
class RenderRequest:
    """Everything one render needs.

    Attributes
    ----------
    source : Path                  a POV-Ray scene (.pov) or a mesh model (.obj .stl .ply ...)
    display : Display              the display: its lens array, preset and mapping (``build_display``)
    output : Path                  the PNG to write (frames: ``OUT_nnnn.png``)
    method : str                   a name in ``renderer.methods.registry.METHODS``
    method_chosen : bool           False: ``method`` is the default, which the render may trade for one
                                   that renders the scene right (``renderer.placement.ray_state``; the sidecar says so)
    method_options : mapping       the method's own options (single-stage: lenslet, ior);
                                   defaults filled in from the method, unknown names refused;
                                   subpixel's ``sheet_shift_mm`` comes from the display's sheet
    settings : RenderSettings      quality and how POV-Ray runs
    crop : CropSettings or None    trace only where objects can be (methods that crop)
    include_dirs : tuple of Path   extra folders POV-Ray searches for includes
    views_dir : Path or None       also write the view stack here (stills only)
    model : ModelOptions           how a mesh model is staged (models only)
    frames : FrameRange or None    render an animation: one image per clock value
    video : Path or None           with ``frames``: also assemble them into this .mp4 or .gif
    fps : float                    video frames per second
    placement : PlacementOptions   where the display sits in the scene (scenes only; ``renderer.placement.pose``)
    depth_maps : Path or None      also write per-view depth and disparity maps here (stills only)
    depth_format : {'npy', 'png'}  float32 arrays, or 16-bit PNGs with the scale in depth_maps.json
    volume : VolumeOptions         how a volume is drawn (volume files and DICOM folders only)
    dataset : Path or None         also write the HCI 4D light-field layout here (stills; ``renderer.outputs.dataset``)
    dataset_all_views : bool       with ``dataset``: disparity and depth for every view, not only the centre
    objects : Path or None         also write every view's object masks here (``renderer.passes.object_masks``)
    viewing_distance : float or None  mm: a lenticular array's rows rendered as an eye at the screen centre's
                                   height that far in front sees them (``geometry.view_bank``); None: the
                                   preset's design distance (a custom array: none); ``math.inf``: orthographic rows
    """

    source: Path
    display: Display
    output: Path
    method: str = "multi-ortho"
    method_chosen: bool = True
    method_options: MappingABC[str, JSONValue] = field(default_factory=dict)
    settings: RenderSettings = field(default_factory=RenderSettings)
    crop: CropSettings | None = None
    include_dirs: tuple[Path, ...] = ()
    views_dir: Path | None = None
    model: ModelOptions = field(default_factory=ModelOptions)
    frames: FrameRange | None = None
    video: Path | None = None
    fps: float = 24.0
    placement: PlacementOptions = field(default_factory=PlacementOptions)
    depth_maps: Path | None = None
    depth_format: str = "npy"
    volume: VolumeOptions = field(default_factory=VolumeOptions)
    dataset: Path | None = None
    dataset_all_views: bool = False
    objects: Path | None = None
    viewing_distance: float | None = None

    def __post_init__(self) -> None:
        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731  (frozen)
        set_("source", Path(self.source))
        set_("output", Path(self.output))
        set_("include_dirs", tuple(Path(d) for d in self.include_dirs))
        if self.views_dir is not None:
            set_("views_dir", Path(self.views_dir))
        if not isinstance(self.display, Display):
            raise ConfigError(f"display must be a Display (display.display.build_display), got "
                              f"{type(self.display).__name__}")
        if not isinstance(self.settings, RenderSettings):
            raise ConfigError(f"settings must be a RenderSettings, got {type(self.settings).__name__}")
        if self.output.suffix.lower() != ".png":
            raise ConfigError(f"the output {str(self.output)!r} must be a .png file")
        options = dict(self.method_options)
        if self.display.sheet_shift_mm is not None and self.method == "subpixel":
            options.setdefault("sheet_shift_mm", self.display.sheet_shift_mm)
        options.pop("viewing_distance", None)   # the request's own (a replaced request carries the last one)
        distance, _ = self.viewing()
        if distance is not None:
            options["viewing_distance"] = distance
        set_("method_options", get_method(self.method).resolve_options(self.method, options))
        if self.frames is None:
            for name in ("video",):
                if getattr(self, name) is not None:
                    raise ConfigError(f"--{name} needs {param('frames')} FIRST:LAST")
        elif self.views_dir is not None:
            raise ConfigError(f"{param('views_dir')} cannot be combined with {param('frames')}; render one frame for its views")
        if self.video is not None:
            set_("video", check_video_path(self.video))
        if not (isinstance(self.fps, (int, float)) and math.isfinite(self.fps) and self.fps > 0):
            raise ConfigError(f"{param('fps')} must be a positive number, got {self.fps}")
        if self.views_dir is not None:
            self.render_array.require_views()
        if self.depth_format not in ("npy", "png"):
            raise ConfigError(f"{param('depth_format')} must be npy or png, got {self.depth_format!r}")
        if self.depth_maps is not None:
            set_("depth_maps", Path(self.depth_maps))
            if self.frames is not None:
                raise ConfigError(f"{param('depth_maps')} cannot be combined with {param('frames')}; render one frame for them")
            self.render_array.require_views()
        if self.dataset is not None:
            set_("dataset", Path(self.dataset))
            if self.frames is not None:
                raise ConfigError(f"{param('dataset')} cannot be combined with {param('frames')}; render one frame for it")
        elif self.dataset_all_views:
            raise ConfigError(f"{param('dataset_all_views')} needs {param('dataset')} DIR")
        if not self.is_volume and _replace(self.volume, rotate=None) != VolumeOptions():
            raise ConfigError(f"{self.source.name!r} is not a volume; the volume options ({param('labels')}, {param('iso')}, {param('volume')}, "
                              f"{param('orientation')}, {param('spacing')}, {param('series')} ...) apply to volume files and DICOM folders")

    def viewing(self) -> tuple[float | None, dict[str, JSONValue]]:
        """The viewing distance the rows are rendered for (mm; None: orthographic rows) and the
        sidecar's record of it: what was used and where it came from."""
        given, array = self.viewing_distance, self.render_array
        # The depth passes trace orthographic cameras along each view's direction (passes.depth).
        orthographic = next((name for name, value in (("depth_maps", self.depth_maps), ("dataset", self.dataset))
                             if value is not None), None)
        lenticular = array.grid == "lenticular" and array.views is not None
        if given is not None:
            if isinstance(given, bool) or not isinstance(given, (int, float)) or not given > 0:
                raise ConfigError(f"{param('viewing_distance')} takes a distance in mm > 0 (or inf: orthographic rows), "
                                  f"got {given!r}")
            if math.isinf(given):
                return None, {"mm": None, "source": "given: infinite (orthographic rows)"}
            if not lenticular or self.display.quilt is not None:
                raise ConfigError(f"{param('viewing_distance')} renders the rows of a lenticular sheet with whole pixels "
                                  f"per lens; this display's lens array is {array.grid}{'' if array.views else ' with fractional pixels per lens'}"
                                  f"; drop {param('viewing_distance')}")
            if self.method != "multi-ortho":
                raise ConfigError(f"{param('viewing_distance')} is traced by {param('method')} multi-ortho's view bank, not "
                                  f"{self.method}; drop one of them")
            if orthographic is not None:
                raise ConfigError(f"{param(orthographic)} measures the views' orthographic rows, not rows seen from "
                                  f"{given:g} mm; drop one of them")
            return float(given), {"mm": float(given), "source": "given"}
        used, source = self.display.viewing_distance_mm, self.display.viewing_distance_source
        if used is None or not lenticular or self.display.quilt is not None:
            return None, {"mm": None, "source": "none: orthographic rows (no design distance for this display)"}
        if self.method != "multi-ortho":
            return None, {"mm": None, "source": f"none: {self.method} traces orthographic rows; the preset's "
                                                  f"{used:g} mm applies to multi-ortho"}
        if orthographic is not None:
            return None, {"mm": None, "source": f"none: {param(orthographic)} measures orthographic rows; the "
                                                  f"preset's {used:g} mm applies without it"}
        return float(used), {"mm": float(used), "source": f"preset {self.display.preset}: {source}"}

    @property
    def display_frame(self) -> PlacementOptions:
        """``placement`` by its name before issue 36 (deprecated)."""
        _deprecated("RenderRequest.display_frame")
        return self.placement

    @property
    def is_model(self) -> bool:
        """Whether ``source`` is put on the default stage (a mesh model, or a volume) rather than a scene."""
        return is_mesh_file(str(self.source)) or self.is_volume

    @property
    def is_volume(self) -> bool:
        """Whether ``source`` is a volume (a volume file or a DICOM folder), put on the volume stage."""
        from ..volume.sources import is_volume_source

        return is_volume_source(self.source)

    @property
    def content_kind(self) -> str:
        """``'scene'``, ``'model'`` (a mesh model, or a VTK polygon mesh) or ``'volume'``: the sidecar
        entry that describes the content."""
        from ..volume.sources import is_polydata_vtk

        if not self.is_model:
            return "scene"
        return "volume" if self.is_volume and not is_polydata_vtk(self.source) else "model"

    @property
    def render_array(self) -> LensArray:
        """The array the method renders (``Display.render_array``)."""
        return self.display.render_array

    @property
    def image_size(self) -> tuple[int, int]:
        """``(W, H)`` of the image written (``Display.image_size``)."""
        return self.display.image_size


def _deprecated(old: str) -> None:
    import warnings

    warnings.warn(f"{old} is deprecated; its name is placement (a PlacementOptions)", DeprecationWarning, stacklevel=3)


def _init_taking_display_frame(init: Callable[..., None]) -> Callable[..., None]:
    """``RenderRequest(display_frame=...)``, the name of ``placement`` before issue 36, still taken."""
    def __init__(self: RenderRequest, *args: object, display_frame: PlacementOptions | None = None,
                 **kwargs: object) -> None:
        if display_frame is not None:
            _deprecated("RenderRequest(display_frame=...)")
            kwargs.setdefault("placement", display_frame)
        init(self, *args, **kwargs)
    return __init__


setattr(RenderRequest, "__init__", _init_taking_display_frame(RenderRequest.__init__))

"""A still's optional outputs as one registry of check-and-write steps.

Each ``OutputStep`` says when a request wants it, what it checks before any work (a folder it
may not replace, a request it cannot be made for) and what it writes once the still is
rendered, with the sidecar entry it adds.  ``renderer.render`` runs every check first and every
write in this order, so the render path grows no ``if`` per output: a new output is one entry
here (docs/architecture.md, "Where a new thing goes").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from ...display.looking_glass import device
from ...errors import param
from ...image.io import check_output, check_output_folder
from .dataset import check_dataset_dir, dataset_depth, write_dataset
from .depth_maps import check_depth_dir, write_depth_maps
from .device_quilt import check_device_render, quilt_outputs, write_device_outputs
from .views import check_views_dir, write_views
from ..passes.beside import stop_either

if TYPE_CHECKING:  # for annotations only: keeps the render's import chain short

    from ..animation import RenderedImage
    from ..methods.quality import Progress, RenderSettings
    from ..request import RenderRequest
    from ...scene.scene import Scene


@dataclass
class Still:
    """What a step reads: the request, its scene and settings, the rendered still (whose ``record``
    the steps add to) and where it goes; the depth maps, made once for the steps that read them."""

    request: RenderRequest
    scene: Scene
    settings: RenderSettings
    image: RenderedImage
    output: Path
    units_per_mm: float
    progress: Progress | None = None
    _depth: np.ndarray | None = field(default=None, repr=False)

    @property
    def front_clearance(self) -> float:
        """mm: where the render's rays started, so where the depth maps' rays start."""
        quality = self.image.record.quality
        if quality is None or quality.front_clearance_mm is None:  # a bug: render_image records it
            raise RuntimeError("the still's record has no front_clearance_mm")
        return float(quality.front_clearance_mm)

    def add(self, **entries: object) -> None:
        """Add ``entries`` to the still's record (``image.sidecar.Sidecar.with_``)."""
        self.image = replace(self.image, record=self.image.record.with_(**entries))

    def depth_maps(self) -> np.ndarray:
        """Every view's depth along its rays (``passes.depth.view_depth_maps``), made on first use."""
        if self._depth is None:
            self._depth = self._depth_of("maps")
        return self._depth

    def dataset_depth(self) -> np.ndarray:
        """The depth along the rays of a dataset's exported pixels (``outputs.dataset.dataset_depth``)."""
        return self._depth_of("dataset")

    def _depth_of(self, kind: str) -> np.ndarray:
        # The pass run beside the render where it was started for this kind (``depth_beside``), else now.
        if self.image.depth is not None and depth_beside(self.request, self.settings, None) == kind:
            return self.image.depth.result(self.progress)
        return request_depth(kind, self.request, self.scene, self.settings, self.front_clearance,
                             self.units_per_mm, progress=self.progress)


def depth_beside(request: RenderRequest, settings: RenderSettings, clock: float | None) -> str | None:
    """Which depth pass a still's outputs read, to be run beside its render (``passes.beside``): ``"maps"``
    (``--depth-maps``, and a camera bank's dataset with them), ``"dataset"`` (a dataset alone), or None: no
    depth pass read, an animation's frame, or a Dask cluster (whose jobs the render's own run submits)."""
    if request.frames is not None or clock is not None or settings.scheduler:
        return None
    if request.depth_maps is not None:
        return "maps"
    return "dataset" if request.dataset is not None else None


def request_depth(kind: str, request: RenderRequest, scene: Scene, settings: RenderSettings, front_clearance: float,
                  units_per_mm: float, should_stop: Callable[[], bool] | None = None,
                  progress: Progress | None = None) -> np.ndarray:
    """The depth pass of ``kind`` (``depth_beside``) along the rays of ``request``'s render, which started
    ``front_clearance`` mm out.  ``should_stop``: polled while its POV-Ray runs (a pass run beside the render)."""
    from ..passes.depth import view_depth_maps

    if should_stop is not None:
        settings = replace(settings, should_stop=stop_either(should_stop, settings.should_stop))
    if kind == "maps":
        return view_depth_maps(scene, request.render_array, settings, front_clearance, units_per_mm, progress=progress)
    return dataset_depth(scene, request.render_array, settings, front_clearance, units_per_mm, progress=progress)


@dataclass(frozen=True)
class OutputStep:
    """One optional output of a still: ``wanted`` by the request, ``check`` before any work (given the
    output path), ``against`` once the render's inputs are known (given the output path and the inputs:
    refuse writing over one), ``write`` after the render (adding its entry to ``still.image.record``)."""

    name: str
    wanted: Callable[[RenderRequest], bool]
    check: Callable[[RenderRequest, Path], object]  # what it returns is not read
    against: Callable[[RenderRequest, Path, tuple[Path, ...]], object]
    write: Callable[[Still], None]


_T = TypeVar("_T")


def _wanted(value: _T | None) -> _T:
    """A step's own field of the request: set, as the step's ``wanted`` found it."""
    if value is None:  # a bug, never the user's doing
        raise RuntimeError("an output step ran for a request that does not want it")
    return value


def _write_views(still: Still) -> None:
    if still.image.views is not None:
        write_views(_wanted(still.request.views_dir), still.image.views, still.request.render_array, still.image.record)


def _write_dataset(still: Still) -> None:
    request = still.request
    # A camera bank exports its own lens centres: the depth maps' pass, when one is made, is the same
    # (a hex array's dataset is the grid of lens columns: its own pass).
    same = request.depth_maps is not None and request.render_array.views is not None
    depth = still.depth_maps() if same else still.dataset_depth()
    write_dataset(_wanted(request.dataset), still.image.image, request.render_array, depth,
                  all_views=request.dataset_all_views, scene=still.scene.path.stem)
    still.add(dataset={"folder": str(request.dataset), "layout": "HCI 4D light field"})


def _write_depth_maps(still: Still) -> None:
    depth = still.depth_maps()
    write_depth_maps(_wanted(still.request.depth_maps), depth, still.request.render_array, still.image.record,
                     still.request.depth_format)
    still.add(depth_maps={"folder": str(still.request.depth_maps), "nan_fraction": float(np.isnan(depth).mean())})


def _write_quilt(still: Still) -> None:
    quilt: Any = still.request.display.quilt
    still.add(quilt=write_device_outputs(still.output, still.image.image, still.request.render_array, quilt,
                                         still.image.views))


def _folder_against(field: str) -> Callable[[RenderRequest, Path, tuple[Path, ...]], object]:
    """The ``against`` check of a folder output (the request's ``field``): it neither is nor holds an input."""
    return lambda r, out, inputs: check_output_folder(_wanted(getattr(r, field)), inputs,
                                                      what=f"{param(field)} folder")


def _quilt_against(request: RenderRequest, output: Path, inputs: tuple[Path, ...]) -> None:
    quilt: Any = _wanted(request.display.quilt)
    for path in quilt_outputs(output, device(quilt["device"]), quilt.get("calibration") is not None):
        if path is not None:
            check_output(path, inputs)


def _check_quilt(request: RenderRequest, output: Path) -> None:
    check_device_render(_wanted(request.display.quilt), output, request.frames is not None, request.depth_maps is not None,
                        request.settings.quality == "auto")


#: The optional outputs, in the order they are checked and written (the dataset reads the depth
#: maps, made on first use, before they are written).
OUTPUT_STEPS: tuple[OutputStep, ...] = (
    OutputStep("views", lambda r: r.views_dir is not None, lambda r, out: check_views_dir(_wanted(r.views_dir)),
               _folder_against("views_dir"), _write_views),
    OutputStep("dataset", lambda r: r.dataset is not None,
               lambda r, out: check_dataset_dir(_wanted(r.dataset), r.render_array, mapped=r.display.mapping is not None),
               _folder_against("dataset"), _write_dataset),
    OutputStep("depth-maps", lambda r: r.depth_maps is not None, lambda r, out: check_depth_dir(_wanted(r.depth_maps)),
               _folder_against("depth_maps"), _write_depth_maps),
    OutputStep("quilt", lambda r: r.display.quilt is not None, _check_quilt, _quilt_against, _write_quilt),
)


def check_outputs(request: RenderRequest, output: Path) -> None:
    """Every wanted output's check, before any work."""
    for step in OUTPUT_STEPS:
        if step.wanted(request):
            step.check(request, output)


def check_outputs_against(request: RenderRequest, output: Path, inputs: tuple[Path, ...]) -> None:
    """Every wanted output refused where it would write over one of ``inputs`` (the render's scene and
    every file it reads), once they are known and before any POV-Ray run."""
    for step in OUTPUT_STEPS:
        if step.wanted(request):
            step.against(request, output, inputs)


def write_outputs(still: Still) -> None:
    """Every wanted output written, in order, after the still is rendered."""
    for step in OUTPUT_STEPS:
        if step.wanted(still.request):
            step.write(still)

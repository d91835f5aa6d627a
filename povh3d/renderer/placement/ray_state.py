"""Refuse (or, where the method was not chosen, re-route) a render whose fog, media or refraction would
depend on which ray POV-Ray traces first.

POV-Ray leaves fog and media out of a ray segment inside a solid (non-hollow) object, and
refracts a ray leaving one by its interior's ``ior``, so it must know which solids a ray
starts in.  Its orthographic camera works that out for every ray; its mesh camera
(``--method multi-ortho``, ``subpixel``) in POV-Ray 3.7 works it out once, for the first ray
a render thread traces, and gives every later ray the same state (tests/renderer/test_ray_state.py).
Where the display's rays start partly inside a solid and partly outside (a ground plane the
front clearance reaches below, a room or a sky sphere the placement cuts), a mesh-camera image
puts fog where an orthographic view has none, or the other way round: a wrong image with
nothing to show it.  A fog pass over the plane that holds every view's ray origins (the
lens array's field widened by the clearance times the most oblique slope: an oblique view's
rays start further out, ``renderer.passes.depth.origins_inside``) measures the share inside a solid.
Any of them: refused, or, where the user did not choose ``--method``, rendered with
``multi-ortho-views`` (an orthographic camera a view), and the sidecar says why.
"""

from __future__ import annotations

import re
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .clearance import planned_front_clearance
from ..passes.depth import origins_inside
from ..methods.registry import pose_units, get_method
from ..passes.scene_camera import uses_image_size
from ...errors import ConfigError, param, warn
from ...geometry.rays import depth_scaled_rays
from ...scene.features import Features, features_of_text, strip_comments
from ...scene.scene import Scene, load_scene, source_text

if TYPE_CHECKING:  # only for annotations: keeps the import chain short
    from ..methods.quality import Progress
    from ..request import RenderRequest

#: The method a render falls back to when the default's mesh camera would share one state.
FALLBACK = "multi-ortho-views"

#: Features whose look POV-Ray works out from the solids a ray starts in: fog and media, left out
#: inside a solid; an interior's ior, by which a ray refracts (or reflects, with fresnel) on leaving one.
STATE_FEATURES = ("fog", "media", "ior")


def _own_sources(scene: Scene) -> list[Path]:
    return [p for p in scene.files if p.suffix.lower() in (".pov", ".inc", ".mcr") and p.is_file()]


#: An interior or material an include declares, applied in the scene's own text (``interior { I_Glass_Exp(2)``).
_APPLIED = re.compile(r"\b(?:interior\s*\{\s*I_|material\s*\{\s*M_)\w")


def state_features(scene: Scene) -> Features:
    """The scene's features that depend on a ray's inside/outside state: fog and media wherever they are
    written; an ``ior`` in the scene's own files, or in an include whose interior (``I_...``) or material
    (``M_...``) the scene's own text applies.  POV-Ray's textures.inc and glass.inc declare glass
    interiors with an ior that most scenes including them never apply (advanced/sunsethf.pov)."""
    texts = [source_text(p.read_bytes()) for p in _own_sources(scene)]
    own = features_of_text(texts)
    applied = "ior" in scene.features and any(_APPLIED.search(strip_comments(t)) for t in texts)
    return Features(frozenset(f for f in STATE_FEATURES
                              if f in (own if f == "ior" and not applied else scene.features)))


#: Features that depend on the hollow objects a ray starts in too: media inside them, the ior a ray leaves
#: by (fog fills a hollow object: the state of a hollow one does not change it).
HOLLOW_FEATURES = ("media", "ior")
_HOLLOW = re.compile(r"\bhollow\b(?:\s+(?:on|off|true|false|yes|no)\b)?")


def without_hollow(scene: Scene, folder: Path) -> Scene | None:
    """A copy of the scene in ``folder`` with every ``hollow`` of its own files turned off, so that the
    origin pass's fog stops at a hollow object too; None when no own file names ``hollow``."""
    sources = _own_sources(scene)
    if not any(_HOLLOW.search(strip_comments(source_text(p.read_bytes()))) for p in sources):
        return None
    root = scene.path.parent
    for p in sources:
        if p.is_relative_to(root):   # an include from elsewhere stays as it is
            target = folder / p.relative_to(root)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(_HOLLOW.sub("hollow off", source_text(p.read_bytes())), encoding="latin-1")
    # The original folders after the copy's: images, fonts and data files are read from there.
    return load_scene(folder / scene.path.relative_to(root), (root, *scene.include_dirs))


@dataclass(frozen=True)
class MethodProblem:
    """Why a method would render the scene wrong: the refusal's one line and the fallback's note are both
    made from it, so they say the same.

    Attributes
    ----------
    cause : str    what goes wrong with the method, and why
    fix : str      what renders it right (the refusal names it; the fallback does it)
    short : str    the cause in a few words, for the summary line (``method_fallback``)
    """

    cause: str
    fix: str
    short: str

    def line(self) -> str:
        """The refusal of a chosen method."""
        return f"{self.cause}: {self.fix}"

    def note(self, default: str) -> str:
        """The sidecar's ``method_note`` when the default ``default`` falls back to ``FALLBACK``."""
        return f"{FALLBACK}, not the default {default} (slower: one shot a view): {self.cause}"


_ORIGINS_INSIDE = "rays start inside an object"
_MESH_CAMERA = ("traces with POV-Ray's mesh camera, which gives every ray the inside/outside state of the first "
                "one it traces, so part of the image would be wrong")
_ORTHOGRAPHIC = f"use {param('method')} {FALLBACK} (an orthographic camera a view, which tests each ray)"


def ray_state_problem(method: str, shares_ray_state: bool, features: Features, inside: float | None
                      ) -> MethodProblem | None:
    """Why ``method`` would give rays inside and outside a solid one state, or None.

    Parameters
    ----------
    method : str                 the method's name, for the message
    shares_ray_state : bool      whether it traces with POV-Ray's mesh camera (``Method``)
    features : Features          the scene's (``state_features``)
    inside : float or None       the share of the ray origins inside a solid (``origins_inside``); None: not measured
    """
    if not shares_ray_state or inside is None:
        return None
    used = [f for f in STATE_FEATURES if f in features]
    # All inside would be one state for every ray, but the pass cannot tell it from a scene whose own fog
    # hides the pass's (templates/Basic_Scenes/Desert_blue_sky.pov's ground fog: 1.0 there, 29.9 dB past it).
    if not used or not inside > 0.0:
        return None
    return MethodProblem(
        f"{100 * inside:.3g} % of the display's ray origins (every view's) lie inside a solid object (a ground "
        f"'plane' the rays start below, a room or a sky around the camera) and the scene has {' and '.join(used)}, "
        f"which POV-Ray works out from the solids a ray starts in; {param('method')} {method} {_MESH_CAMERA}",
        f"add 'hollow' to that object, or {_ORTHOGRAPHIC}", _ORIGINS_INSIDE)


def check_ray_state(method: str, shares_ray_state: bool, features: Features, inside: float | None) -> None:
    """Raise ConfigError when ``method`` would give rays inside and outside a solid one state
    (``ray_state_problem``, whose parameters these are)."""
    problem = ray_state_problem(method, shares_ray_state, features, inside)
    if problem is not None:
        raise ConfigError(problem.line())


def hollow_problem(method: str, used: list[str], inside: float) -> MethodProblem | None:
    """Why a mesh-camera ``method`` would render wrong with ``inside`` of the ray origins inside an object,
    hollow ones counted (``without_hollow``), and the scene's media or ior; None where none are."""
    if not inside > 0.0:
        return None
    return MethodProblem(
        f"{100 * inside:.3g} % of the display's ray origins (every view's) lie inside an object, hollow ones "
        f"counted (a room or a sky around the camera that the placement cuts), and the scene has {' and '.join(used)}, "
        f"which POV-Ray works out from the objects a ray starts in, hollow or not; {param('method')} {method} {_MESH_CAMERA}",
        _ORTHOGRAPHIC, _ORIGINS_INSIDE)


def image_size_problem(scene: Scene, method: str, views: tuple[int, int] | None) -> MethodProblem | None:
    """Why ``method`` renders a scene that builds something from ``image_width``/``image_height`` (other
    than their ratio) unlike each view's own render, or None.  POV-Ray gives them the size of the run:
    ``FALLBACK`` renders each view in a run of the view's size, as a plain render of that view is;
    the other methods trace many views (or lenses) in one run of another size."""
    if method == FALLBACK or not uses_image_size(scene):
        return None
    fix = (f"use {param('method')} {FALLBACK} (each view a POV-Ray run of its own size)" if views is not None
           else f"use a display with whole views and {param('method')} " + FALLBACK)
    return MethodProblem(
        f"{scene.path.name} builds something from image_width or image_height (other than their ratio), "
        f"which POV-Ray sets to the size of each run; {param('method')} {method} traces many views in one run of "
        "another size, so each view would differ from a render of that view",
        f"{fix}, or #declare the sizes the scene needs", "the scene reads image_width/image_height")


def fallback_beside_pass(request: RenderRequest, scene: Scene) -> bool:
    """Whether ``settle_method`` would run the inside-solid pass for ``request`` and may then trade its method for
    ``FALLBACK``: a still of the default mesh-camera method on a scene with fog, media or an ior, the method not
    chosen, whole views, no viewing distance, no ``--quality auto`` (which probes with the method) and no cluster.
    Such a render traces ``FALLBACK``'s views beside the pass (``renderer.render``): exact whatever the pass finds,
    and where the pass finds the mesh camera right after all, stopped for it.  On POV-Ray's example scenes with
    fog the pass mostly finds the fallback (a ground plane the rays start below), whose views then wait for no pass."""
    from ..methods.quality import AUTO

    s, views = request.settings, request.render_array.views
    if request.is_model or request.frames is not None or request.method_chosen or views is None:
        return False
    if s.quality == AUTO or s.scheduler or (request.viewing_distance is not None
                                           and request.viewing_distance < float("inf")):
        return False
    if not get_method(request.method).shares_ray_state or image_size_problem(scene, request.method, views) is not None:
        return False
    return bool(state_features(scene).used)


def settle_method(request: RenderRequest, scene: Scene,
                  progress: Progress | None = None) -> tuple[RenderRequest, dict[str, Any] | None]:
    """``request`` as it may render (its display placed): unchanged, or with the default method replaced by
    ``FALLBACK`` where it would render the scene wrong (its mesh camera's one ray state, or the size of its
    runs seen through ``image_width``); and the sidecar's record of the check (None: nothing to check).
    A chosen method is refused instead, in one line naming the fix.  ``progress(done, total)``: the
    inside-solid passes' shots."""
    if request.is_model:
        return request, None
    method, views = get_method(request.method), request.render_array.views
    features = state_features(scene)
    record: dict[str, Any] = {}
    problem = image_size_problem(scene, request.method, views)
    if problem is None and method.shares_ray_state and features.used:
        s = request.settings
        clearance = planned_front_clearance(method, request.render_array, s)
        rays = depth_scaled_rays(request.render_array, s.depth_scale)
        inside = origins_inside(scene, rays, s, clearance, pose_units(s.pose), progress=progress)
        record = {"origins_inside_fraction": inside, "front_clearance_mm": clearance,
                  "depends_on": sorted(features.used)}
        problem = ray_state_problem(request.method, True, features, inside)
        hollow_used = [f for f in HOLLOW_FEATURES if f in features]
        if problem is None and hollow_used:
            with tempfile.TemporaryDirectory(prefix="povh3d-hollow-") as folder:
                solid = without_hollow(scene, Path(folder))
                anywhere = None if solid is None else origins_inside(solid, rays, s, clearance, pose_units(s.pose),
                                                                        "origins-inside-hollow", progress)
            if anywhere is not None:
                record["origins_inside_hollow_or_solid_fraction"] = anywhere
                problem = hollow_problem(request.method, hollow_used, anywhere)
    if problem is None:
        if request.method == FALLBACK and uses_image_size(scene):
            warn(f"{scene.path.name} uses image_width or image_height other than as their ratio: each view is "
                 "a POV-Ray run of the view's own size, which the scene sees there (not the panel's, as in its "
                 "2D render)")
        return request, record or None
    given = request.viewing_distance   # rows seen from a distance: only multi-ortho traces them
    if request.method_chosen or views is None or (given is not None and given < float("inf")):
        raise ConfigError(problem.line())
    return replace(request, method=FALLBACK, method_options={}), {**record, "method_note": problem.note(request.method),
                                                                  "method_fallback": problem.short}

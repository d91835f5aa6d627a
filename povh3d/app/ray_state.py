"""Refuse a render whose fog, media or refraction would depend on which ray POV-Ray traces first.

POV-Ray leaves fog and media out of a ray segment inside a solid (non-hollow) object, and
refracts a ray leaving one by its interior's ``ior``, so it must know which solids a ray
starts in.  Its orthographic camera works that out for every ray; its mesh camera
(``--method multi-ortho``, ``subpixel``) in POV-Ray 3.7 works it out once, for the first ray
a render thread traces, and gives every later ray the same state (tests/app/test_ray_state.py).
Where the display's rays start partly inside a solid and partly outside (a ground plane the
front clearance reaches below, a room or a sky sphere the frame cuts), a mesh-camera image
puts fog where an orthographic view has none, or the other way round: a wrong image with
nothing to show it.  The depth pass (an orthographic camera from about the same clearance)
measures that share: the pixels its fog did not reach (``unmeasured_fraction``).  It looks
along the display normal only: a ray of an oblique view that starts inside a solid where the
normal's rays do not is not seen (docs/methods.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..errors import ConfigError
from ..scene.features import Features, features_of_text
from ..scene.scene import Scene

#: Features whose look POV-Ray works out from the solids a ray starts in: fog and media, left out
#: inside a solid; an interior's ior, by which a ray refracts (or reflects, with fresnel) on leaving one.
STATE_FEATURES = ("fog", "media", "ior")


def state_features(scene: Scene) -> Features:
    """The scene's features that depend on a ray's inside/outside state: fog and media wherever they are
    written, an ``ior`` only in the scene's own files.  POV-Ray's textures.inc and glass.inc declare glass
    interiors with an ior that most scenes including them never apply (advanced/sunsethf.pov)."""
    own = features_of_text(p.read_text(encoding="latin-1") for p in scene.files
                           if p.suffix.lower() in (".pov", ".inc", ".mcr") and p.is_file())
    return Features(frozenset(f for f in STATE_FEATURES if f in (own if f == "ior" else scene.features)))


def check_ray_state(method: str, shares_ray_state: bool, features: Features,
                    depth: Mapping[str, Any] | None) -> None:
    """Raise ConfigError when ``method`` would give rays inside and outside a solid one state.

    Parameters
    ----------
    method : str                 the method's name, for the message
    shares_ray_state : bool      whether it traces with POV-Ray's mesh camera (``Method``)
    features : Features          the scene's (``state_features``)
    depth : mapping or None      the depth pass's record (``display_frame.depth``); None: not measured
    """
    if not shares_ray_state or not depth:
        return
    used = [f for f in STATE_FEATURES if f in features]
    inside = float(depth.get("unmeasured_fraction", 0.0))
    # All of the depth pass's rays inside is no safer than some: the views' oblique rays start beyond its
    # field, and the mesh camera's first ray (a corner view's) may start outside (the gallery's skies).
    if not used or not inside > 0.0:
        return
    raise ConfigError(
        f"{100 * inside:.3g} % of the display's rays start inside a solid object (a ground 'plane' the rays "
        f"start below, a room or a sky around the camera) and the scene has {' and '.join(used)}, which POV-Ray "
        f"works out from the solids a ray starts in; --method {method} traces with POV-Ray's mesh camera, which "
        f"gives every ray the inside/outside state of the first one it traces, so part of the image would be "
        "wrong: add 'hollow' to that object, or use --method multi-ortho-views (an orthographic camera a view, "
        "which tests each ray)")

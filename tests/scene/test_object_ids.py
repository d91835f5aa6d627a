"""Object masks rendered by POV-Ray from the mask copy of a scene: every pixel's id against the
first hit of its conventions ray on an analytic scene (spheres and a box at known places)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from povh3d.engine.methods import run_method
from povh3d.engine.quality import RenderSettings
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.rays import pixel_rays
from povh3d.hyper.ids import decode_ids
from povh3d.scene.object_ids import UNRESOLVED, ObjectsError, mask_scene
from povh3d.scene.scene import load_scene
from tests.support.hit_oracle import border_margin_px

# (kind, centre or min corner, radius or max corner), display mm: screen z = 0, viewer on -z
SPHERES = [((-6.0, 3.0, 4.0), 4.0), ((5.0, -3.0, -2.0), 3.0)]
BOX = ((0.0, 2.0, -1.0), (9.0, 8.0, 3.0))
SCENE = f"""#version 3.7;
global_settings {{ assumed_gamma 2.2 }}
#declare Glass = texture {{ pigment {{ rgbt <1, 1, 1, 0.9> }} finish {{ reflection 0.5 }} }}
light_source {{ <-20, 30, -60> rgb 1 }}
sky_sphere {{ pigment {{ rgb <0.3, 0.5, 0.9> }} }}
fog {{ distance 50 rgb 0.5 }}
sphere {{ <{SPHERES[0][0][0]}, {SPHERES[0][0][1]}, {SPHERES[0][0][2]}>, {SPHERES[0][1]}
  texture {{ Glass }} }}
#declare Ball = sphere {{ <{SPHERES[1][0][0]}, {SPHERES[1][0][1]}, {SPHERES[1][0][2]}>, {SPHERES[1][1]}
  pigment {{ checker rgb 1 rgb 0 scale 0.5 }} finish {{ phong 1 }} }};
object {{ Ball }}
union {{ box {{ <{BOX[0][0]}, {BOX[0][1]}, {BOX[0][2]}>, <{BOX[1][0]}, {BOX[1][1]}, {BOX[1][2]}>
              pigment {{ rgb <1, 0, 0> }} normal {{ bumps 0.5 }} }}
        interior {{ ior 1.5 }} }}
"""
ARRAYS = {
    "square": LensArray("square", 40, 30, 0.8, 0.8, 1.5, Panel(320, 240, 0.1, 0.1)),
    "lenticular": LensArray("lenticular", 40, 240, 0.8, 0.1, 1.5, Panel(320, 240, 0.1, 0.1)),
}


def first_hit_ids(origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(H, W) id (1, 2: the spheres in scene order, 3: the box, 0: nothing) of the first object
    along the whole line ``origins + t directions`` (the scene in front of the screen counts)."""
    best = np.full(origins.shape[:2], np.inf)
    ids = np.zeros(origins.shape[:2], np.int64)
    for ident, (centre, radius) in enumerate(SPHERES, start=1):
        oc = origins - np.array(centre)
        b = (oc * directions).sum(-1)
        disc = b * b - ((oc * oc).sum(-1) - radius * radius)
        t = np.where(disc > 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)
        ids = np.where(t < best, ident, ids)
        best = np.minimum(best, t)
    lo, hi = np.array(BOX[0]), np.array(BOX[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - origins) / directions, (hi - origins) / directions
    near = np.nanmax(np.minimum(t0, t1), -1)
    far = np.nanmin(np.maximum(t0, t1), -1)
    t = np.where(near < far, near, np.inf)
    return np.where(t < best, 3, ids)


def expected(lens_array: LensArray) -> tuple[np.ndarray, np.ndarray]:
    """The ids of every pixel's ray and where they can be scored: away from lens borders and from
    object edges (the id is the same for the ray moved half a lens pitch each way)."""
    c, d, inside = pixel_rays(lens_array)
    origins = np.concatenate([np.nan_to_num(c), np.zeros(c.shape[:2] + (1,))], axis=-1)
    d = np.nan_to_num(d, nan=1.0)
    want = first_hit_ids(origins, d)
    clear = inside & (border_margin_px(lens_array) > 0.1)
    step = lens_array.pitch_x / 2
    for shift in ((step, 0, 0), (-step, 0, 0), (0, step, 0), (0, -step, 0)):
        clear &= first_hit_ids(origins + np.array(shift), d) == want
    return want, clear


def test_mask_scene_names_and_strips() -> None:
    mask = mask_scene(SCENE)
    assert mask.names == {1: "sphere_7", 2: "Ball", 3: "union_12"}
    for gone in ("checker", "bumps", "ior", "sky_sphere", "fog", "phong 1"):
        assert gone not in mask.text
    assert "#declare Glass = texture" in mask.text          # a declared texture stays (unused)


def test_a_scene_without_top_level_objects_is_one_line() -> None:
    with pytest.raises(ObjectsError, match="no top-level object"):
        mask_scene("#macro M() sphere { 0, 1 } #end\nM()\n")


@pytest.mark.povray
@pytest.mark.parametrize("method, grid", [("multi-ortho", "square"), ("multi-ortho", "lenticular"),
                                          ("single-stage", "square")])
def test_masks_match_the_analytic_first_hits(tmp_path: Path, method: str, grid: str) -> None:
    lens_array = ARRAYS[grid]
    mask = mask_scene(SCENE)
    path = tmp_path / "mask.pov"
    path.write_text(mask.text)
    settings = RenderSettings(quality="draft", use_cache=False, bit_depth=16, front_clearance=8.0)
    h3d = run_method(method, load_scene(path), lens_array, settings).h3d
    got = decode_ids(h3d, len(mask.names))
    want, clear = expected(lens_array)
    assert clear.mean() > 0.6 and len(np.unique(want[clear])) == 4
    share = (got[clear] == want[clear]).mean()
    assert share >= 0.995, f"{100 * share:.2f} % of {clear.sum()} clear pixels right"
    assert (got == UNRESOLVED).mean() < 0.001
    # negative control: the oracle tells a mask with the two spheres swapped from the render
    swapped = np.choose(want, [0, 2, 1, 3])
    on_objects = clear & (want > 0)
    assert (swapped[on_objects] == got[on_objects]).mean() < 0.8
    print(f"{method} {grid}: {100 * share:.3f} % of {clear.sum()} clear pixels right")

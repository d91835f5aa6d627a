"""Object masks rendered by POV-Ray from the mask copy of a scene: every pixel's id against the
first hit of its conventions ray on an analytic scene (spheres and a box at known places)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from povh3d.engine.methods import run_method
from povh3d.engine.quality import RenderSettings
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.hyper.ids import decode_ids
from povh3d.scene.object_ids import UNRESOLVED, ObjectsError, mask_scene
from povh3d.scene.scene import load_scene
from tests.support.id_oracle import expected_ids

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
# ids 1, 2: the spheres in scene order, 3: the box
SHAPES = [("sphere", *SPHERES[0]), ("sphere", *SPHERES[1]), ("box", *BOX)]


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
    want, clear = expected_ids(lens_array, SHAPES)
    assert clear.mean() > 0.6 and len(np.unique(want[clear])) == 4
    share = (got[clear] == want[clear]).mean()
    assert share >= 0.995, f"{100 * share:.2f} % of {clear.sum()} clear pixels right"
    assert (got == UNRESOLVED).mean() < 0.001
    # negative control: the oracle tells a mask with the two spheres swapped from the render
    swapped = np.choose(want, [0, 2, 1, 3])
    on_objects = clear & (want > 0)
    assert (swapped[on_objects] == got[on_objects]).mean() < 0.8
    print(f"{method} {grid}: {100 * share:.3f} % of {clear.sum()} clear pixels right")

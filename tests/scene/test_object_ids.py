"""Object masks rendered by POV-Ray from the mask copy of a scene: every pixel's id against the
first hit of its conventions ray on an analytic scene (spheres and a box at known places)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from povh3d.engine.methods import run_method
from povh3d.engine.quality import RenderSettings
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.hyper.ids import decode_ids
from povh3d.scene.object_ids import UNRESOLVED, ObjectsError, mask_scene
from povh3d.scene.scene import load_scene
from tests.support.id_oracle import SCENE, SHAPES, expected_ids

ARRAYS = {
    "square": LensArray("square", 40, 30, 0.8, 0.8, 1.5, Panel(320, 240, 0.1, 0.1)),
    "lenticular": LensArray("lenticular", 40, 240, 0.8, 0.1, 1.5, Panel(320, 240, 0.1, 0.1)),
    # no camera bank: a lens mesh with one ray per panel pixel
    "hex": LensArray("hex", 39, 34, 0.8, 0.8 * math.sqrt(3) / 2, 1.5, Panel(320, 240, 0.1, 0.1)),
    "fractional": LensArray("square", 42, 31, 0.75, 0.75, 1.5, Panel(320, 240, 0.1, 0.1)),
}


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
                                          ("single-stage", "square"), ("multi-ortho", "hex"),
                                          ("multi-ortho", "fractional")])
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

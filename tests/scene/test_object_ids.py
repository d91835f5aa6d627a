"""Object masks rendered by POV-Ray from the mask copy of a scene: every pixel's id against the
first hit of its conventions ray on an analytic scene (spheres and a box at known places)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from povh3d.renderer.methods.registry import run_method
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.hyper.ids import decode_ids
from povh3d.scene.object_ids import MAX_OBJECTS, UNRESOLVED, ObjectsError, id_code, id_colour, mask_scene
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


def test_every_id_code_reads_back_at_8_and_16_bits_and_other_colours_are_no_id() -> None:
    from povh3d.image.colour import linear_to_srgb

    ids = np.arange(MAX_OBJECTS + 1)
    codes = np.array([(0, 0, 0)] + [id_code(k) for k in ids[1:]], np.uint8)[None]
    # the pigment is what sRGB output writes back as the codes (POV-Ray's own encoding: the renders below)
    pigments = np.array([[float(v) for v in id_colour(k).strip("<>").split(",")] for k in ids[1:]])
    assert (np.rint(linear_to_srgb(pigments) * 255) == codes[0, 1:]).all()
    assert (decode_ids(codes, MAX_OBJECTS)[0] == ids).all()
    assert (decode_ids(codes.astype(np.uint16) * 257, MAX_OBJECTS)[0] == ids).all()
    assert (decode_ids(codes, 5)[0] == np.where(ids <= 5, ids, UNRESOLVED)).all()   # past the count: no id
    # negative controls: a code one off in any channel, a 16-bit code not 257 times a byte, greys, the red
    for channel in range(3):
        off = codes.copy()
        off[..., channel] ^= 1
        assert (decode_ids(off, MAX_OBJECTS)[0, 1:] == UNRESOLVED).mean() > 0.99
    assert (decode_ids(codes.astype(np.uint16) * 257 + 1, MAX_OBJECTS) == UNRESOLVED).all()
    grey = np.repeat(np.arange(1, 256, dtype=np.uint8)[:, None], 3, axis=1)[None]
    assert (decode_ids(grey, MAX_OBJECTS) == UNRESOLVED).all()
    assert decode_ids(np.array([[[255, 0, 0]]], np.uint8), MAX_OBJECTS)[0, 0] == UNRESOLVED


@pytest.mark.povray
@pytest.mark.parametrize("method, grid, bits", [("multi-ortho", "square", 8), ("multi-ortho", "lenticular", 16),
                                                ("single-stage", "square", 8), ("multi-ortho", "hex", 8),
                                                ("multi-ortho", "fractional", 16)])
def test_masks_match_the_analytic_first_hits(tmp_path: Path, method: str, grid: str, bits: int) -> None:
    lens_array = ARRAYS[grid]
    mask = mask_scene(SCENE)
    path = tmp_path / "mask.pov"
    path.write_text(mask.text)
    settings = RenderSettings(quality="draft", use_cache=False, bit_depth=bits, front_clearance=8.0)
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

"""``povh3d render VOLUME``: radiological left/right on the screen, the stage and its cache, the frog."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from povh3d.image.interleave import extract
from povh3d.image.io import read_png
from povh3d.volume.orient import display_box, volume_to_display
from tests.support.volumes import asymmetric_phantom, write_nifti, write_vti

pytestmark = pytest.mark.povray  # every test here starts POV-Ray

ARRAY = ("--grid", "square", "--lenses", "32x24", "--ppl", "4x4", "--pixel-pitch", "0.2", "--focal", "2",
         "--quality", "draft")
REPO = Path(__file__).resolve().parents[2]
FROG = Path(__import__("pyvista").__file__).parent / "examples" / "frog_tissues.vti"


def centre_view(path: Path) -> np.ndarray:
    return extract(read_png(path), (4, 4))[2, 2].astype(int)


def hue_centroid(view: np.ndarray, channel: int) -> np.ndarray:
    """(row, column) centre of the pixels whose strongest channel is ``channel`` by a clear margin
    (the palette: label 1 blue, 2 orange (red), 3 green; the background is grey)."""
    others = np.delete(view, channel, axis=-1).max(axis=-1)
    mask = view[..., channel] > others + 25
    assert mask.sum() >= 2, "the marker is not in the view"
    return np.argwhere(mask).mean(axis=0)


@pytest.mark.parametrize("orientation", ["coronal", "axial"])
def test_patients_left_is_on_the_screens_right(cli, tmp_path, orientation):
    # Written as NIfTI (RAS on disk): the reader's LPS turn and the radiological preset together.
    path = write_nifti(asymmetric_phantom(), tmp_path / "phantom.nii")
    out = tmp_path / f"{orientation}.png"
    result = cli("render", path, "-o", out, "--orientation", orientation, *ARRAY)
    assert result.code == 0, result.err
    assert "drawing every one" in result.err          # labels chosen, and said so
    view = centre_view(out)
    height, width = view.shape[:2]
    body = hue_centroid(view, 2)           # label 1, blue
    left_marker = hue_centroid(view, 0)    # label 2, orange
    front_top = hue_centroid(view, 1)      # label 3, green: anterior and superior
    assert left_marker[1] > body[1] + 0.15 * width    # on the screen's right
    assert front_top[0] < body[0] - 0.1 * height      # coronal: superior up; axial: anterior up
    record = json.loads(out.with_suffix(".json").read_text())["volume"]
    assert [s["label"] for s in record["surfaces"]] == [1, 2, 3]
    assert record["orientation"] == orientation and record["volume"]["shape"] == [24, 20, 16]


def test_sagittal_and_rotate_turn_the_marker_away(cli, tmp_path):
    # Negative control of the test above: rotated 180 degrees about y the left marker is on the left.
    path = write_vti(asymmetric_phantom(), tmp_path / "phantom.vti")
    out = tmp_path / "turned.png"
    result = cli("render", path, "-o", out, "--labels", "1,2", "--rotate", "0,180,0", *ARRAY)
    assert result.code == 0, result.err
    view = centre_view(out)
    assert hue_centroid(view, 0)[1] < hue_centroid(view, 2)[1] - 0.15 * view.shape[1]


def test_stage_is_cached_and_decimated(cli, tmp_path):
    path = write_vti(asymmetric_phantom(), tmp_path / "phantom.vti")
    runs = []
    for name in ("a", "b"):
        result = cli("render", path, "-o", tmp_path / f"{name}.png", "--labels", "1", "--max-triangles", "100",
                     "--opacity", "0.5", *ARRAY)
        assert result.code == 0, result.err
        runs.append(json.loads((tmp_path / f"{name}.json").read_text())["volume"])
    assert [r["surfaces_from_cache"] for r in runs] == [False, True]
    (surface,) = runs[0]["surfaces"]
    assert surface["triangles_extracted"] > 100 >= surface["triangles"] * 0.9
    assert surface["opacity"] == 0.5
    include = Path(json.loads((tmp_path / "a.json").read_text())["scene"]).parent / "surfaces.inc"
    assert "rgbt" in include.read_text()        # the opacity became POV-Ray's transmit


def test_volume_rendering_gets_the_world_to_display_matrix(cli, tmp_path, monkeypatch):
    # The direct volume render (renderer.content.volume_media) receives the matrix that puts the volume's box where
    # the surfaces go: centred on the screen, scaled to the panel.
    import povh3d.renderer.content.volume_media as media

    seen = {}

    def fake_media_stage(volume, world_to_display, lens_array, *, transfer, bits, folder):
        seen.update(volume=volume, matrix=world_to_display, transfer=transfer, bits=bits)
        stage = folder / "stage.pov"
        stage.write_text("#version 3.7;\nbackground { rgb 0.5 }\nlight_source { <0, 0, -100> rgb 1 }\n"
                         "sphere { 0, 2 pigment { rgb 1 } }\n")
        return stage, {"fake": True}

    monkeypatch.setattr(media, "media_stage", fake_media_stage)
    phantom = asymmetric_phantom()
    path = write_vti(phantom, tmp_path / "phantom.vti")
    result = cli("render", path, "-o", tmp_path / "m.png", "--volume", "--transfer", "mri", "--df3-bits", "8",
                 "--orientation", "axial", *ARRAY)
    assert result.code == 0, result.err
    assert (seen["transfer"], seen["bits"]) == ("mri", 8)
    corners = np.c_[phantom.corners(), np.ones(8)] @ np.asarray(seen["matrix"]).T
    lo, hi = corners[:, :3].min(axis=0), corners[:, :3].max(axis=0)
    assert lo + hi == pytest.approx([0, 0, 0], abs=1e-9)             # centred on the screen
    width, height = 32 * 0.8, 24 * 0.8
    assert max((hi - lo)[0] / width, (hi - lo)[1] / height) == pytest.approx(0.9)   # fills 90 % of the panel
    # Its linear part is the preset's turn, scaled: the same box as display_box.
    turned = display_box(phantom.corners(), volume_to_display("axial"))
    assert (hi - lo) / (turned[1] - turned[0]) == pytest.approx([(hi - lo)[0] / (turned[1] - turned[0])[0]] * 3)
    assert json.loads((tmp_path / "m.json").read_text())["volume"]["media"] == {"fake": True}


def test_frog_tissues_renders(cli, tmp_path):
    out = tmp_path / "frog.png"
    result = cli("render", FROG, "-o", out, "--labels", "2,6,10", "--orientation", "axial", *ARRAY)
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())["volume"]
    assert record["volume"]["shape"] == [500, 470, 136] and record["volume"]["spacing_mm"] == [1.0, 1.0, 1.5]
    surfaces = record["surfaces"]
    assert [s["label"] for s in surfaces] == [2, 6, 10]
    # Extracted from voxels at most a fifth of a lens across (a lens spans many frog voxels here), then
    # decimated to the display.
    fifth = 0.8 / record["fit"]["scale"] / 5                     # a fifth of a lens, in frog mm
    step, spacing = np.asarray(record["voxel_step"]), np.asarray([1.0, 1.0, 1.5])
    assert np.all(step * spacing <= fifth) and np.all((step + 1) * spacing > fifth) and min(step) > 1
    assert all(s["triangles_extracted"] > 2 * s["triangles"] for s in surfaces)
    assert sum(s["triangles"] for s in surfaces) <= record["triangle_budget"] * 1.02
    assert record["triangle_budget"] == 4 * 32 * 24
    # Where the tissues must appear: their voxels' box through the record's world-to-display matrix, in
    # lenses of the centre view (x right, y up; 0.8 mm lenses, 32 x 24), a lens of slack for the view's slant.
    from povh3d.volume.read import read_volume

    frog = read_volume(FROG)
    index = np.argwhere(np.isin(frog.values, (2, 6, 10)))
    corners = np.array([[a, b, c, 1.0] for a in (index[:, 0].min(), index[:, 0].max())
                        for b in (index[:, 1].min(), index[:, 1].max()) for c in (index[:, 2].min(), index[:, 2].max())])
    display = corners @ (np.asarray(record["world_to_display"]) @ frog.index_to_world()).T
    columns = (display[:, 0] + 12.8) / 0.8
    rows = (9.6 - display[:, 1]) / 0.8
    view = centre_view(out)
    drawn = np.argwhere(np.abs(view - view[0, 0]).max(axis=-1) > 10)
    assert len(drawn) >= 15                                                           # the tissues are there
    inside = ((drawn[:, 0] >= rows.min() - 1.5) & (drawn[:, 0] <= rows.max() + 0.5)
              & (drawn[:, 1] >= columns.min() - 1.5) & (drawn[:, 1] <= columns.max() + 0.5))
    assert inside.all()


def test_python_api_takes_volume_options(tmp_path):
    import povh3d

    path = write_vti(asymmetric_phantom(), tmp_path / "phantom.vti")
    record = povh3d.render(path, tmp_path / "api.png", lens_array=povh3d.presets.lens_array("demo", lenses=(16, 12)),
                           quality="draft", volume=povh3d.VolumeOptions(iso=(1.5,), orientation="sagittal"))
    assert record["volume"]["draw"] == "iso" and record["volume"]["surfaces"][0]["iso"] == 1.5


def test_a_vtk_polygon_mesh_is_a_model_and_volume_options_need_a_volume(cli, tmp_path):
    import pyvista

    mesh = tmp_path / "ball.vtk"
    pyvista.Sphere(radius=3.0).save(mesh)
    result = cli("render", mesh, "-o", tmp_path / "ball.png", *ARRAY)
    assert result.code == 0, result.err
    record = json.loads((tmp_path / "ball.json").read_text())
    assert "model" in record and "volume" not in record and record["model"]["triangles"] > 100
    refused = cli("render", mesh, "-o", tmp_path / "b2.png", "--iso", "1", *ARRAY)
    assert refused.code == 2 and "not a volume" in refused.err
    scene = cli("render", REPO / "sample_models" / "sample.pov", "-o", tmp_path / "s.png", "--labels", *ARRAY)
    assert scene.code == 2 and "is not a volume" in scene.err


def test_an_unusable_cache_is_a_warning(cli, tmp_path):
    cache = tmp_path / "not-a-folder"
    cache.write_text("a file where the cache should be")   # fails as a read-only folder would, even for root
    path = write_vti(asymmetric_phantom(), tmp_path / "phantom.vti")
    result = cli("render", path, "-o", tmp_path / "ro.png", "--labels", "2", *ARRAY, env={"POVH3D_CACHE": str(cache)})
    assert result.code == 0, result.err
    assert "volume cache" in result.err and (tmp_path / "ro.png").is_file()

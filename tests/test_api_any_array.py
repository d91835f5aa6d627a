"""``povh3d.extract``, ``povh3d.refocus`` and ``povh3d.preview`` on an image and the lens array
``povh3d.read_h3d`` gives, with no camera bank to hand them (a hex array, fractional pixels per
lens) and on ``ipad-retina``'s layout (whole lenses centred on a panel a pixel wider each side):
each gives, pixel for pixel, what its command writes from the same file and sidecar."""

from __future__ import annotations

import math

import numpy as np
import pytest

import povh3d
from povh3d.renderer.records import base_record, write_image
from povh3d.renderer.outputs.views import read_views
from povh3d.errors import ConfigError
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.io import read_png
from povh3d.image.refocus import contact_sheet

ARRAYS = {
    "hex": LensArray("hex", 6, 5, 0.5, 0.5 * math.sqrt(3) / 2, 1.5, Panel(34, 23, 0.1, 0.1)),
    "fractional": LensArray("square", 6, 5, 0.55, 0.55, 1.5, Panel(34, 28, 0.1, 0.1)),
    "ipad-like": LensArray("lenticular", 7, 12, 0.6, 0.1, 1.25, Panel(44, 12, 0.1, 0.1)),
}


@pytest.fixture(params=list(ARRAYS))
def image(request, tmp_path):
    """An H3D image with its sidecar, read back through the API: ``(path, image, lens array)``."""
    la = ARRAYS[request.param]
    noise = np.random.default_rng(7).integers(0, 256, (la.panel.height, la.panel.width, 3), dtype=np.uint8)
    write_image(tmp_path / "h.png", noise, base_record("h3d", la))
    got, array = povh3d.read_h3d(tmp_path / "h.png")
    assert array == la
    return tmp_path / "h.png", got, array


def _ok(result):
    assert result.code == 0, result.err
    return result


def test_extract_is_the_commands(image, tmp_path, cli):
    path, h3d, la = image
    _ok(cli("extract", path, "-o", tmp_path / "views"))
    views = povh3d.extract(h3d, la)
    assert np.array_equal(views, read_views(tmp_path / "views"))
    with pytest.raises(ConfigError):   # negative control: an image that is not the panel's
        povh3d.extract(h3d[:, :-1], la)


def test_refocus_is_the_commands(image, tmp_path, cli):
    path, h3d, la = image
    _ok(cli("refocus", path, "--depth", "2", "-o", tmp_path / "f.png"))
    expected = read_png(tmp_path / "f.png")
    assert np.array_equal(povh3d.refocus(h3d, la, 2.0), expected)
    assert not np.array_equal(povh3d.refocus(h3d, la, -2.0), expected)   # negative control


def test_preview_is_the_commands(image, tmp_path, cli):
    path, h3d, la = image
    _ok(cli("preview", path, "--frames", "4", "-o", tmp_path / "p.gif"))
    frames = povh3d.preview(h3d, la, frames=4)
    assert np.array_equal(contact_sheet(list(frames)), read_png(tmp_path / "p.png"))
    assert not np.array_equal(contact_sheet(list(frames[::-1])), read_png(tmp_path / "p.png"))  # the other way


def test_resample_through_the_library_is_the_commands(image, tmp_path, cli):
    """The panel path from Python (docs/api.md): ``resample_panel`` onto ``resampled_array``."""
    from povh3d.image.resample import resample_panel, resampled_array

    path, h3d, la = image
    _ok(cli("resample", path, "--ppl-out", "3.5", "-o", tmp_path / "r.png"))
    out, array = povh3d.read_h3d(tmp_path / "r.png")
    ppl = (1, 3.5) if la.grid == "lenticular" else (3.5, 3.5)
    assert array == resampled_array(la, ppl)
    assert np.array_equal(resample_panel(h3d, la, array), out)
    assert not np.array_equal(resample_panel(h3d[:, ::-1], la, array), out)   # negative control


def test_povh3d_resample_takes_any_array_as_the_command_does(image, tmp_path, cli):
    """``povh3d.resample`` itself on a hex, fractional or ipad-like array (its lens array in)."""
    path, h3d, la = image
    _ok(cli("resample", path, "--ppl-out", "3.5", "-o", tmp_path / "r.png"))
    ppl = (1, 3.5) if la.grid == "lenticular" else (3.5, 3.5)
    assert np.array_equal(povh3d.resample(h3d, la, ppl), read_png(tmp_path / "r.png"))
    assert not np.array_equal(povh3d.resample(h3d[:, ::-1], la, ppl), read_png(tmp_path / "r.png"))  # control


def test_povh3d_quilt_takes_any_render_as_the_command_does(image, tmp_path, cli):
    """``povh3d.quilt`` on any array with its lens array: the views ``extract`` gives, tiled."""
    path, h3d, la = image
    rows = None if la.grid == "lenticular" else "centre"
    _ok(cli("quilt", path, "--quilt", "auto", *(["--rows", rows] if rows else []), "-o", tmp_path / "q"))
    (quilt_path,) = (tmp_path / "q").glob("*.png")
    assert np.array_equal(povh3d.quilt(h3d, la, "auto", rows=rows), read_png(quilt_path))
    assert not np.array_equal(povh3d.quilt(h3d[:, ::-1], la, "auto", rows=rows), read_png(quilt_path))

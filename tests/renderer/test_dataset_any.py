"""HCI export of arrays without a camera bank (docs/datasets.md, "Hex and fractional PPL"): the
views ``extract`` writes, a hex array's interpolated onto the square grid of its lens columns, and
the ground truth made along the rays of the exported pixels.

The oracle is a plane at depth z0 whose pigment is a linear ramp (``(x + 8 + (y + 8) / 2) / 24``
in linear light): the view pixel at screen point (X, Y) with view offset (u, v) shows the ramp at
``(X, Y) + (u, v) z0 / f``, so both where each exported pixel sits and its disparity
``-z0 s / (f p)`` are known exactly."""

from __future__ import annotations

import configparser
import math

import numpy as np
import pytest

from povh3d.renderer.outputs.dataset import export_grid, hex_onto_grid
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.colour import decode, encode
from tests.dataset.test_hci import toolkit_read_parameters, toolkit_read_pfm
from tests.support.cli import one_error_line

S, F = 0.1, 1.5
HEX = ["--grid", "hex", "--lenses", "8x6", "--ppl", "5", "--pixel-pitch", "0.1", "--focal", "1.5",
       "--quality", "draft", "--bit-depth", "16"]          # p = 0.5 mm, 5x5 views
FRACTIONAL = ["--grid", "lenticular", "--lenses", "12", "--ppl", "6.6", "--rows", "6", "--pixel-pitch", "0.1",
              "--focal", "1.5", "--quality", "draft", "--bit-depth", "16"]   # p = 0.66 mm, 7 views


def _ramp(folder, z0):
    path = folder / f"ramp_{z0:+g}.pov"
    path.write_text(f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
background {{ rgb 0 }}
plane {{ -z, {-z0!r} pigment {{ function {{ (x + 8 + 0.5 * (y + 8)) / 24 }} color_map {{ [0 rgb 0] [1 rgb 1] }} }}
        finish {{ ambient 1 diffuse 0 }} }}
""")
    return path


def _ramp_error(view, xs, ys, u, v, z0):
    """Largest error of a view against the ramp, in pixels (of x) of the exported grid's pitch."""
    want = (xs[None, :] + u * z0 / F + 8 + 0.5 * (ys[:, None] + v * z0 / F + 8)) / 24
    return float(np.abs(decode(view)[..., 0] - want).max() * 24 / (xs[1] - xs[0]))


# -- the hex resampling, without POV-Ray -----------------------------------------------------------
def test_hex_views_onto_the_grid_are_exact_for_a_linear_scene():
    la = LensArray("hex", 9, 7, 0.5, 0.5 * math.sqrt(3) / 2, F, Panel(100, 40, S, S))
    grid = export_grid(la)
    assert (grid.cols, grid.rows, grid.pitch_x, grid.pitch_y, grid.resampled) == (8, 6, 0.5, 0.5, True)
    c = la.lens_centres()
    ramp = lambda x, y: 0.3 + 0.04 * x + 0.03 * y             # linear light, any linear scene
    views = encode(np.broadcast_to(ramp(c[..., 0], c[..., 1])[None, None, :, :, None], (1, 1, 7, 9, 3)), np.uint16)
    out = decode(hex_onto_grid(views, la, grid))[0, 0, ..., 0]
    xs = (np.arange(8) + 0.5 - 4) * 0.5
    ys = (3 - np.arange(6) - 0.5) * 0.5
    truth = ramp(xs[None, :], ys[:, None])
    assert np.abs(out - truth).max() < 1e-4
    # control: the samples placed as if the odd rows were unshifted (a square lattice) miss
    flat = ramp(c[..., 0] - (np.arange(7) % 2)[:, None] * 0.25, c[..., 1])
    views = encode(np.broadcast_to(flat[None, None, :, :, None], (1, 1, 7, 9, 3)), np.uint16)
    wrong = decode(hex_onto_grid(views, la, grid))[0, 0, ..., 0]
    assert np.abs(wrong - truth).max() > 0.004


# -- end to end ------------------------------------------------------------------------------------
@pytest.mark.povray
@pytest.mark.parametrize("z0", [-3.0, 3.0])
def test_hex_render_exports_exact_disparity_and_views_on_the_grid(tmp_path, cli, z0):
    out, folder = tmp_path / "h.png", tmp_path / "hci"
    result = cli("render", _ramp(tmp_path, z0), *HEX, "--dataset", folder, "-o", out)
    assert result.code == 0, result.err
    p = 0.5
    disp = toolkit_read_pfm(folder / "gt_disp_lowres.pfm")
    expected = -z0 * S / (F * p)                          # +-0.4 px per view step, positive in front
    assert disp.shape == (5, 7) and np.isfinite(disp).all()
    assert np.abs(disp - expected).max() < 0.01 and (expected > 0) == (z0 < 0)
    assert np.abs(disp + expected).max() > 0.5            # control: the opposite sign fails
    cfg = toolkit_read_parameters(folder / "parameters.cfg")
    assert (int(cfg["num_cams_x"]), int(cfg["num_cams_y"])) == (5, 5)
    assert (int(cfg["image_resolution_x_px"]), int(cfg["image_resolution_y_px"])) == (7, 5)
    assert float(cfg["baseline_mm"]) == pytest.approx(1000 * S / F)
    extra = configparser.ConfigParser()
    extra.read(folder / "parameters.cfg")
    outside = {int(c) for c in extra.get("meta", "povh3d_cameras_outside_lens_cell").split(",")}
    assert outside == {0, 4, 20, 24}                      # the cell's corners: (+-2, +-2) px
    # the views sit on the grid of lens columns: the centre camera shows the ramp at those columns
    xs, ys = (np.arange(7) + 0.5 - 3.5) * p, (np.arange(5)[::-1] + 0.5 - 2.5) * p
    from povh3d.image.io import read_png

    centre = read_png(folder / "input_Cam012.png")
    assert _ramp_error(centre, xs, ys, 0.0, 0.0, z0) < 0.05       # measured 0.0007
    hex_rows = (3 - np.arange(5) - 0.5) * p * math.sqrt(3) / 2
    assert _ramp_error(centre, xs, hex_rows, 0.0, 0.0, z0) > 0.2   # control: the lens rows' heights (0.35)
    # control: the same views without the odd rows' half pitch (extract's lens order) miss by p / 2
    from povh3d.renderer.outputs.dataset import export_views
    from povh3d.renderer.outputs.views import sidecar_bank
    from povh3d.display.display import Display
    from povh3d.image.io import read_sidecar

    la = Display.from_record(read_sidecar(out)).lens_array
    assert np.array_equal(export_views(read_png(out), la)[2, 2], centre)
    raw = sidecar_bank(read_png(out), la)[2, 2, :5, :7]
    assert _ramp_error(raw, xs, ys, 0.0, 0.0, z0) > 0.4
    # the inner 3x3 cameras show the ramp shifted by -d per camera to the right (the outer ones read
    # pixels on or near the cell's edge, half a pixel off their ray at odd PPL: extract's limit)
    for cam in (6, 7, 8, 11, 13, 16, 17, 18):
        r, c = divmod(cam, 5)
        u, v = (5 - 1 - c + 0.5 - 2.5) * S, (2.5 - (5 - 1 - r) - 0.5) * S     # bank view (4 - r, 4 - c)
        view = read_png(folder / f"input_Cam{cam:03d}.png")
        assert _ramp_error(view, xs, ys, u, v, z0) < 0.1, cam       # measured 0.001
        if v:   # control: the bank's own vertical order (camera row r as bank view l = r) fails
            assert _ramp_error(view, xs, ys, u, -v, z0) > 0.2, cam
    if z0 > 0:   # from the render and its sidecar afterwards, every camera's ground truth
        again = tmp_path / "again"
        result = cli("dataset", out, "-o", again, "--all-views")
        assert result.code == 0, result.err
        assert np.array_equal(toolkit_read_pfm(again / "gt_disp_lowres.pfm"), disp)
        for cam in range(25):
            assert np.abs(toolkit_read_pfm(again / f"gt_disp_lowres_Cam{cam:03d}.pfm") - expected).max() < 0.01


@pytest.mark.povray
def test_fractional_ppl_render_and_its_dataset_afterwards(tmp_path, cli):
    z0 = 3.0
    out, folder = tmp_path / "f.png", tmp_path / "hci"
    result = cli("render", _ramp(tmp_path, z0), *FRACTIONAL, "--dataset", folder, "-o", out)
    assert result.code == 0, result.err
    p = 0.66
    disp = toolkit_read_pfm(folder / "gt_disp_lowres.pfm")
    expected = -z0 * S / (F * p)                          # -0.303 px: behind the screen, negative
    assert disp.shape == (6, 12) and np.abs(disp - expected).max() < 0.01
    assert np.abs(disp - (-z0 * S / (F * 0.7))).max() > 0.01   # control: the whole-PPL lens pitch fails
    from povh3d.image.io import read_png

    xs, ys = (np.arange(12) + 0.5 - 6) * p, (np.arange(6)[::-1] + 0.5 - 3) * S
    # the inner cameras show the ramp on the lens centres (the outer ones read near the lens's edge,
    # where extract's in-lens interpolation falls back to the nearest pixel: 0.18 px measured)
    for cam in (2, 3, 4):
        assert _ramp_error(read_png(folder / f"input_Cam{cam:03d}.png"), xs, ys, (6 - cam + 0.5 - 3.5) * S, 0.0,
                           z0) < 0.1
    again = tmp_path / "again"
    result = cli("dataset", out, "-o", again)
    assert result.code == 0, result.err
    assert np.array_equal(toolkit_read_pfm(again / "gt_disp_lowres.pfm"), disp)


def test_slanted_sheet_is_one_line_and_nothing_written(tmp_path, cli):
    out = tmp_path / "s.png"
    line = one_error_line(cli("render", _ramp(tmp_path, 2.0), "--grid", "lenticular", "--lenses", "12", "--ppl", "7",
                              "--rows", "6", "--lens-rotation", "9.46", "--quality", "draft",
                              "--dataset", tmp_path / "d", "-o", out))
    assert "slanted" in line and "--lens-rotation 0" in line
    assert not out.exists() and not (tmp_path / "d").exists()


def test_even_views_are_refused_before_any_work(tmp_path):
    """``check_dataset_dir`` runs before the render: an even view count (bank or resampled) stops there."""
    from povh3d.renderer.outputs.dataset import check_dataset_dir
    from povh3d.errors import ConfigError

    bank = LensArray("lenticular", 10, 4, 0.8, S, F, Panel(80, 4, S, S))                 # 8 views
    hex6 = LensArray("hex", 6, 5, 0.6, 0.6 * math.sqrt(3) / 2, F, Panel(66, 30, S, S))   # 6x6 views
    for la, fix in ((bank, "odd count each way"), (hex6, "odd ppl")):
        with pytest.raises(ConfigError, match=fix):
            check_dataset_dir(tmp_path / "d", la)
    check_dataset_dir(tmp_path / "d", LensArray("hex", 6, 5, 0.5, 0.5 * math.sqrt(3) / 2, F, Panel(56, 30, S, S)))
    assert not (tmp_path / "d").exists()

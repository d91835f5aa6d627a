"""HCI 4D light-field export: PFM as the toolkit reads it, camera order, disparity sign and size."""

from __future__ import annotations

import configparser
import math

import numpy as np
import pytest

from povh3d.dataset.hci import BankGeometry, centre_camera, to_hci_order, write_hci
from povh3d.errors import ConfigError, OutputError
from povh3d.image.io import read_png
from povh3d.image.pfm import decode_pfm, encode_pfm


# -- an independent reader, line for line the toolkit's file_io.read_pfm ---------------------------
def _next_line(f):
    line = f.readline().rstrip()
    while line.startswith(b"#"):
        line = f.readline().rstrip()
    return line


def toolkit_read_pfm(path, flip=True):
    with open(path, "rb") as f:
        assert _next_line(f) == b"Pf"
        dims = _next_line(f).split(b" ")
        width, height = int(dims[0].strip()), int(dims[1].strip())
        scale = float(_next_line(f))
        assert scale != 0
        endianness = "<" if scale < 0 else ">"
        data = np.fromfile(f, "%sf" % endianness)
        data = np.reshape(data, (height, width))
        if flip:
            data = np.flipud(data)
        with np.errstate(invalid="ignore"):
            data *= abs(scale)
        return data


def toolkit_read_parameters(path):
    """The keys the toolkit's read_parameters reads (it raises on any missing one)."""
    p = configparser.ConfigParser()
    p.read(path)
    keys = {"intrinsics": ["image_resolution_x_px", "image_resolution_y_px", "focal_length_mm", "sensor_size_mm",
                           "fstop"],
            "extrinsics": ["num_cams_x", "num_cams_y", "baseline_mm", "focus_distance_m", "center_cam_x_m",
                           "center_cam_y_m", "center_cam_z_m", "center_cam_rx_rad", "center_cam_ry_rad",
                           "center_cam_rz_rad"],
            "meta": ["disp_min", "disp_max", "frustum_disp_min", "frustum_disp_max", "depth_map_scale", "scene",
                     "category", "date", "version", "authors", "contact"]}
    return {k: p.get(section, k) for section, names in keys.items() for k in names}


def test_pfm_round_trip_through_the_toolkit_reader(tmp_path):
    data = np.arange(12, dtype=np.float32).reshape(3, 4) - 5.5
    data[0, 0] = np.nan
    (tmp_path / "a.pfm").write_bytes(encode_pfm(data))
    back = toolkit_read_pfm(tmp_path / "a.pfm")
    assert np.array_equal(back, data, equal_nan=True)
    assert np.array_equal(decode_pfm(encode_pfm(data)), data, equal_nan=True)
    assert (tmp_path / "a.pfm").read_bytes().startswith(b"Pf\n4 3\n-1\n")    # little-endian: negative scale
    # negative control: a reader that forgets PFM's bottom-to-top rows reads it upside down
    assert not np.array_equal(toolkit_read_pfm(tmp_path / "a.pfm", flip=False), data, equal_nan=True)


# -- an analytic plane ------------------------------------------------------------------------------
S, P, F = 0.1, 0.9, 1.5        # pixel pitch, lens pitch, focal (mm): 9 views per lens
NY, NX, LY, LX = 3, 9, 4, 64


def plane_bank(z, x0=0.0, width=0.6):
    """Views of the plane at depth z with one bright Gaussian stripe at X = x0, by the ray definition."""
    geo = BankGeometry(S, P, F, (NY, NX))
    bank = np.zeros((NY, NX, LY, LX, 3), np.uint16)
    depth = np.zeros((NY, NX, LY, LX))
    cx = (np.arange(LX) + 0.5 - LX / 2) * P
    for l in range(NY):
        for k in range(NX):
            u, v = geo.offsets(l, k)
            x_hit = cx + u * z / F                      # the ray through lens centre cx meets z here
            bank[l, k] = (60000 * np.exp(-((x_hit - x0) / width) ** 2))[None, :, None]
            depth[l, k] = z * math.sqrt(u * u + v * v + F * F) / F     # along the ray
    return bank, depth, geo


def stripe_column(image):
    row = image[0, :, 0].astype(float)
    return float((row * np.arange(len(row))).sum() / row.sum())


@pytest.mark.parametrize("z", [-2.0, 3.0])
def test_plane_disparity_matches_geometry_with_hcis_sign(tmp_path, z):
    bank, depth, geo = plane_bank(z)
    write_hci(tmp_path, bank, depth, geo)
    disp = toolkit_read_pfm(tmp_path / "gt_disp_lowres.pfm")
    expected = -z * S / (F * P)                          # pixels per view step; > 0 in front (z < 0)
    assert np.all(np.abs(disp - expected) < 0.01)
    assert (expected > 0) == (z < 0)
    # the views themselves: in HCI's order the stripe steps by -d per camera to the right
    cams = [read_png(tmp_path / f"input_Cam{i:03d}.png") for i in range(NY * NX)]
    row = NY // 2
    cols = [stripe_column(cams[row * NX + c]) for c in range(NX)]
    step = np.polyfit(np.arange(NX), cols, 1)[0]
    assert step == pytest.approx(-float(disp.mean()), abs=0.01)
    # negative control: the bank's own order (no reversal) steps the other way
    naive = bank.reshape(NY * NX, LY, LX, 3)
    wrong = np.polyfit(np.arange(NX), [stripe_column(naive[row * NX + c]) for c in range(NX)], 1)[0]
    assert wrong != pytest.approx(-float(disp.mean()), abs=0.01)
    # depth as Z in metres from the equivalent cameras, and the cfg the toolkit reads
    zmap = toolkit_read_pfm(tmp_path / "gt_depth_lowres.pfm")
    assert np.allclose(zmap, (geo.viewing_distance_mm + z) / 1000.0)
    cfg = toolkit_read_parameters(tmp_path / "parameters.cfg")
    assert (int(cfg["num_cams_x"]), int(cfg["num_cams_y"])) == (NX, NY)
    assert (int(cfg["image_resolution_x_px"]), int(cfg["image_resolution_y_px"])) == (LX, LY)
    assert float(cfg["disp_min"]) == pytest.approx(expected, abs=1e-4)
    # the toolkit's depth2disp on that cfg agrees to first order in z / D
    b, f, fd, sensor = (float(cfg[k]) for k in ("baseline_mm", "focal_length_mm", "focus_distance_m",
                                                "sensor_size_mm"))
    q = (b / 1000.0) * f * max(LX, LY)
    toolkit_disp = (q * fd / zmap - q) / fd / sensor
    assert np.allclose(toolkit_disp, disp, rtol=2 * abs(z) / geo.viewing_distance_mm)


def test_hci_order_and_centre_camera():
    bank = np.arange(NY * NX).reshape(NY, NX)
    cams = to_hci_order(bank)
    assert cams[0] == bank[NY - 1, NX - 1]            # Cam000: the top-left camera sees from top-left
    cam, l, k = centre_camera((NY, NX))
    assert cam == int(NX * NY / 2) and cams[cam] == bank[l, k] and (l, k) == (1, 4)
    with pytest.raises(ConfigError, match="odd"):
        centre_camera((1, 8))


def test_all_views_and_refusals(tmp_path):
    bank, depth, geo = plane_bank(-1.0)
    written = write_hci(tmp_path / "out", bank, depth, geo, all_views=True)
    assert len(written) == NY * NX + 3 + 2 * NY * NX
    for i in (0, 13, 26):        # a plane parallel to the screen has the same disparity in every view
        assert np.allclose(toolkit_read_pfm(tmp_path / "out" / f"gt_disp_lowres_Cam{i:03d}.pfm"), S / (F * P))
    before = (tmp_path / "out" / "parameters.cfg").read_bytes()
    with pytest.raises(OutputError, match="already holds"):
        write_hci(tmp_path / "out", bank, depth, geo)
    assert (tmp_path / "out" / "parameters.cfg").read_bytes() == before
    with pytest.raises(ConfigError):
        write_hci(tmp_path / "new", bank[:, :8], depth[:, :8], geo)
    assert not (tmp_path / "new").exists()

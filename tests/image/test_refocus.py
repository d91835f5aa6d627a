"""Refocusing a rendered scene: the plane's depth is the sharpest of the sweep."""

import pytest
import numpy as np

from tests.support.render import render
from povh3d.commands.images import lens_info, refocus_file
from povh3d.image.io import read_png, read_sidecar
from povh3d.image.refocus import gradient_energy, refocus_linear
from povh3d.renderer.methods.quality import RenderSettings

from tests.support.arrays import square_array
from tests.support.scenes import write_checker_plane

DEPTH = 6.0
SWEEP = [-6.0, -3.0, 0.0, 3.0, DEPTH, 9.0, 12.0]


@pytest.mark.povray
def test_refocus_is_sharpest_at_the_textured_plane(tmp_path):
    la = square_array(lx=24, ly=16, nx=6, ny=6, s=0.1, f=1.5)
    scene = write_checker_plane(tmp_path, DEPTH, 1.2)
    out = tmp_path / "h3d.png"
    render(scene, la, out, settings=RenderSettings(quality="draft"))
    sheet = tmp_path / "sweep.png"
    record = refocus_file(out, sheet, lens_info(out, None, None, None), sweep=(SWEEP[0], SWEEP[-1], len(SWEEP)))
    energy = record["gradient_energy"]
    assert record["depths_mm"] == SWEEP
    assert record["sharpest_depth_mm"] == DEPTH
    assert energy[SWEEP.index(DEPTH)] > 1.2 * max(e for d, e in zip(SWEEP, energy) if d != DEPTH)
    assert read_png(sheet).shape[0] > 16 and (tmp_path / "sweep_004.png").is_file()
    assert read_sidecar(sheet)["kind"] == "refocus"


def test_shift_sign_follows_the_ray_of_a_pixel():
    # Views of a point at depth z: view k sees it at lens j = j0 - z u_k / (f px).  Build such views
    # and check refocusing at +z (not -z) gathers them into one sharp point.
    nx, lx, f, s = 5, 40, 1.5, 0.1
    px = nx * s
    u = (np.arange(nx) + 0.5 - nx / 2) * s
    z = 7.5  # whole-lens shifts: z u_k / (f px) = k - 2
    views = np.zeros((1, nx, 1, lx, 1), np.float32)
    for k in range(nx):
        views[0, k, 0, int(round(20 - z * u[k] / (f * px)))] = 1
    sharp = refocus_linear(views, (u, np.zeros(1)), (px, s), f, z)
    wrong = refocus_linear(views, (u, np.zeros(1)), (px, s), f, -z)
    assert sharp.max() == 1 and gradient_energy(sharp) > 2 * gradient_energy(wrong)


def _lattices():
    from povh3d.geometry.lens_array import LensArray, Panel, lattice_array

    s = 0.1
    yield "hex", LensArray("hex", 24, 20, 0.5, 0.5 * np.sqrt(3) / 2, 1.5, Panel(124, 88, s, s))
    yield "hex turned", LensArray("hex", 24, 20, 0.5, 0.5 * np.sqrt(3) / 2, 1.5, Panel(124, 88, s, s), 7.0)
    yield "square 5.5 PPL", LensArray("square", 20, 16, 0.55, 0.55, 1.5, Panel(110, 88, s, s))
    yield "lattice", lattice_array(((0.5, 0.0), (0.15, 0.5)), 20, 16, 1.5, Panel(124, 88, s, s))


@pytest.mark.parametrize("name, la", list(_lattices()), ids=[n for n, _ in _lattices()])
def test_lens_steps_bring_every_view_of_a_plane_onto_its_lens_centres(name, la):
    """Views made from the ray of a pixel (view (l, k) at lens c sees the plane at c + z (u, v) / f),
    shifted by ``lens_steps`` and summed, give the plane's texture at the lens centres (hex, a
    turned hex, fractional PPL, a parallelogram lattice: every array ``extract`` resamples); at the
    mirrored depth in front of the screen they do not (negative control)."""
    from povh3d.image.elemental import view_offsets
    from povh3d.image.refocus import lens_steps, shift_and_add

    z, period = 6.0, 5.0

    def texture(x, y):
        return 0.5 + 0.25 * (np.sin(2 * np.pi * x / period) + np.cos(2 * np.pi * y / period))

    views = (5, 5)
    u, v = view_offsets(la, views)
    c = la.lens_centres()
    stack = np.stack([[texture(c[..., 0] + z * uk / la.focal, c[..., 1] + z * vl / la.focal) for uk in u]
                      for vl in v])[..., None]
    steps, used, row_shift = lens_steps(la, views)
    truth = texture(c[..., 0], c[..., 1])[3:-3, 3:-3]
    errors = [np.abs(shift_and_add(stack, steps * d, row_shift=row_shift, used=used)[3:-3, 3:-3, 0] - truth).max()
              for d in (z, -z)]
    assert errors[0] < 0.03 and errors[1] > 4 * errors[0], (name, errors)   # measured 0.010-0.021 and 0.16-0.38
    if la.grid == "hex":   # control: the odd rows' half pitch left out
        wrong = np.abs(shift_and_add(stack, steps * z, used=used)[3:-3, 3:-3, 0] - truth).max()
        assert wrong > 2 * errors[0], (name, wrong, errors)

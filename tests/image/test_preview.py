import numpy as np
import pytest

from povh3d.geometry.lens_array import LensArray, Panel

from povh3d.geometry.rays import pixel_rays
from povh3d.image.interleave import interleave
from povh3d.image.preview import preview_frames, viewer_angles

COLOURS = np.random.default_rng(3).integers(0, 256, (64, 3), dtype=np.uint8)


@pytest.mark.parametrize("grid, ny, nx", [("lenticular", 1, 8), ("square", 4, 4), ("lenticular", 1, 5)])
def test_preview_shows_the_colour_of_the_view_the_viewer_sees(grid, ny, nx):
    s, f, lx, ly = 0.1, 1.5, 6, 4
    views = np.zeros((ny, nx, ly, lx, 3), np.uint8)
    for l in range(ny):
        for k in range(nx):
            views[l, k] = COLOURS[l * nx + k]  # each view one flat colour
    h3d = interleave(views)
    la = LensArray(grid, lx, ly, nx * s, ny * s if grid == "square" else s, f,
                   Panel(lx * nx, ly * ny, s, s))
    angles = viewer_angles(nx * s, f, 3 * nx)
    frames = preview_frames(h3d, (ny, nx), s, f, angles)
    # Oracle from the ray of every pixel: the viewer at angle a (right of the screen) looks along
    # (-sin a, 0, cos a); it sees, under the first lens, the pixel whose ray is best aligned with that.
    _, dirs, _ = pixel_rays(la)
    centre_row = ny - 1 - ny // 2  # vertical viewer at 0 deg: v = 0, a tie between two rows goes to the upper
    lens_dirs = dirs[centre_row, :nx]
    for a, frame in zip(angles, frames):
        sight = np.array([-np.sin(np.radians(a)), 0.0, np.cos(np.radians(a))])
        k = int(np.argmax(lens_dirs @ sight))
        expect = views[centre_row % ny, k, 0, 0]
        assert (frame == expect).all(), (a, k)
    # a viewer walking left to right sees the views from right to left under the lens
    assert (frames[0] == views[centre_row % ny, -1, 0, 0]).all()
    assert (frames[-1] == views[centre_row % ny, 0, 0, 0]).all()

"""Radiosity's lighting follows POV-Ray's image grid (the cause of raddem's 31 dB, issue 21).

POV-Ray's radiosity pretrace traces one pixel in every block of ``pretrace_start`` .. ``pretrace_end``
times the image's larger side, on the image's own pixel grid, and fills its irradiance cache from
those pixels.  Two renders of the very same rays whose image grids start at other points give two
realizations of the lighting.  A view of ``multi-ortho`` (POV-Ray's mesh camera, all views tiled in
one image) lies on another grid than the view's own orthographic render: it differs from it as such a
realization does, not more.  The premise is checked on POV-Ray (a 32x24 orthographic render), with a
control without radiosity, where a shifted grid changes nothing."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.image.io import read_image
from povh3d.image.metrics import psnr
from povh3d.povray.process import PovrayJob, run_jobs

pytestmark = pytest.mark.povray

# A closed white room lit by one light, a red ball on its floor: its walls take light bounced off each
# other, which radiosity samples.
ROOM = """#version 3.7;
global_settings {{ assumed_gamma 1 {radiosity} }}
box {{ -3, 3 inverse pigment {{ rgb 1 }} finish {{ ambient 0 diffuse 0.8 }} }}
sphere {{ <0.5, -2, 1>, 1 pigment {{ rgb <1, 0.2, 0.1> }} finish {{ ambient 0 diffuse 0.8 }} }}
light_source {{ <-1, 2.5, -1> rgb 1 }}
camera {{ orthographic location <{x}, 0, -2.9> direction z right {width} * x up 3 * y }}
"""
# Few rays a sample, one sample reused a pixel, the final trace taking no new ones, pretrace blocks of
# 16 and 8 pixels: the grid's mark on the lighting is plain in a small image.
RADIOSITY = ("radiosity { count 5 nearest_count 1 error_bound 1.8 pretrace_start 0.5 pretrace_end 0.25 "
             "always_sample off brightness 3 }")
WIDTH, HEIGHT, SPAN = 32, 24, 4.0      # pixels; the view is 4 units wide


def _render(tmp_path, radiosity: str, shift: int = 0) -> np.ndarray:
    """The 32x24 view, its image grid started ``shift`` pixels further left (the image that much wider,
    its camera that much longer and its centre half of it to the left): the same rays, cut back."""
    pixel = SPAN / WIDTH
    script = ROOM.format(radiosity=radiosity, x=-shift * pixel / 2, width=SPAN + shift * pixel)
    images = []
    run_jobs([PovrayJob(name="room", script=script, width=WIDTH + shift, height=HEIGHT, options=("-A",), threads=1)],
             processes=1, workdir=tmp_path, on_result=lambda r: images.append(read_image(r.images[0])))
    return images[0][:, shift:, :3]


@pytest.mark.parametrize("shift", [1, 3, 7])
def test_radiosity_changes_with_where_the_image_grid_starts(tmp_path, shift):
    """The same rays, the grid shifted: another realization of radiosity's lighting (43-45 dB apart
    when written), while without radiosity the image is the same to the bit (the control)."""
    assert psnr(_render(tmp_path, "", shift), _render(tmp_path, "")) == float("inf")
    assert psnr(_render(tmp_path, RADIOSITY, shift), _render(tmp_path, RADIOSITY)) < 50.0


def test_the_same_grid_renders_the_same_lighting(tmp_path):
    """Control of the premise: with the grid where it was, radiosity gives the same image again
    (one thread), so the shifted grid, not chance, makes the difference above."""
    assert psnr(_render(tmp_path, RADIOSITY), _render(tmp_path, RADIOSITY)) == float("inf")

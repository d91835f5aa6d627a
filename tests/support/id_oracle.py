"""Object-id oracle: the id of the first analytic shape (sphere, axis-aligned box) along each
pixel's conventions ray, and the pixels clear enough of lens borders and object edges to score."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from povh3d.geometry.lens_array import LensArray
from povh3d.geometry.rays import pixel_rays
from tests.support.hit_oracle import border_margin_px

# ("sphere", centre, radius) or ("box", min corner, max corner), display mm; id = place in the list + 1
Shape = tuple[str, Sequence[float], object]

# The analytic scene of the mask tests, display mm (screen z = 0, viewer on -z): textures, a fog and a
# sky the mask copy must strip, one object declared and one in a union
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
# ids 1, 2: the spheres in scene order, 3: the box
SHAPES = [("sphere", *SPHERES[0]), ("sphere", *SPHERES[1]), ("box", *BOX)]


def first_hit_ids(origins: np.ndarray, directions: np.ndarray, shapes: Sequence[Shape]) -> np.ndarray:
    """(H, W) id of the first shape along the whole line ``origins + t directions`` (also in front of
    the screen), 0 where it meets none."""
    best = np.full(origins.shape[:2], np.inf)
    ids = np.zeros(origins.shape[:2], np.int64)
    for ident, (kind, a, b) in enumerate(shapes, start=1):
        if kind == "sphere":
            oc = origins - np.asarray(a)
            proj = (oc * directions).sum(-1)
            disc = proj * proj - ((oc * oc).sum(-1) - float(b) ** 2)
            t = np.where(disc > 0, -proj - np.sqrt(np.maximum(disc, 0)), np.inf)
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                t0, t1 = (np.asarray(a) - origins) / directions, (np.asarray(b) - origins) / directions
            near = np.nanmax(np.minimum(t0, t1), -1)
            far = np.nanmin(np.maximum(t0, t1), -1)
            t = np.where(near < far, near, np.inf)
        ids = np.where(t < best, ident, ids)
        best = np.minimum(best, t)
    return ids


def _scored(origins: np.ndarray, directions: np.ndarray, clear: np.ndarray, step: float,
            shapes: Sequence[Shape]) -> tuple[np.ndarray, np.ndarray]:
    """The ids along the rays, and ``clear`` where the id stays for the ray moved ``step`` each way."""
    want = first_hit_ids(origins, directions, shapes)
    for shift in ((step, 0, 0), (-step, 0, 0), (0, step, 0), (0, -step, 0)):
        clear = clear & (first_hit_ids(origins + np.array(shift), directions, shapes) == want)
    return want, clear


def expected_ids(lens_array: LensArray, shapes: Sequence[Shape]) -> tuple[np.ndarray, np.ndarray]:
    """The ids of every pixel's ray and where they can be scored: away from lens borders and from
    object edges (the id is the same for the ray moved half a lens pitch each way)."""
    c, d, inside = pixel_rays(lens_array)
    origins = np.concatenate([np.nan_to_num(c), np.zeros(c.shape[:2] + (1,))], axis=-1)
    d = np.nan_to_num(d, nan=1.0)
    clear = inside & (border_margin_px(lens_array) > 0.1)
    return _scored(origins, d, clear, lens_array.pitch_x / 2, shapes)


def expected_view_ids(lens_array: LensArray, views: tuple[int, int],
                      shapes: Sequence[Shape]) -> tuple[np.ndarray, np.ndarray]:
    """``(Ny, Nx, Ly, Lx)`` ids along the rays of the views a resampled array's views stand for: view
    ``(l, k)`` pixel ``(i, j)`` is the ray through lens ``(j, i)``'s centre along ``(u_k, v_l, f)``,
    with the multi-ortho offsets; scored away from object edges as ``expected_ids``."""
    ny, nx = views
    s = lens_array.panel.pitch_x
    u = (np.arange(nx) + 0.5 - nx / 2) * s
    v = (ny / 2 - np.arange(ny) - 0.5) * lens_array.panel.pitch_y
    centres = lens_array.lens_centres()
    ly, lx = centres.shape[:2]
    origins = np.zeros((ny, nx, ly, lx, 3))
    origins[..., :2] = centres
    d = np.zeros((ny, nx, ly, lx, 3))
    d[..., 0], d[..., 1], d[..., 2] = u[None, :, None, None], v[:, None, None, None], lens_array.focal
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    flat = (ny * nx * ly, lx, 3)
    want, clear = _scored(origins.reshape(flat), d.reshape(flat), np.ones(flat[:2], bool), lens_array.pitch_x / 2,
                          shapes)
    return want.reshape(ny, nx, ly, lx), clear.reshape(ny, nx, ly, lx)

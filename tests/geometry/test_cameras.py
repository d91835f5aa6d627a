"""The camera geometry, checked against the ray of a pixel without POV-Ray.

The mesh camera is simulated as POV-Ray 3.7 runs it (measured): image pixel
(col, row) looks up UV (col/W, 1 - row/H), finds the face holding it and
interpolates position and normal barycentrically.
"""

import numpy as np
import pytest

from povh3d.geometry.cameras import camera_mesh, ortho_view_shots, pinhole_shots
from povh3d.geometry.rays import pixel_rays

from tests.support.arrays import lenticular_array, square_array
from tests.support.oracles import mesh_in_mm, view_bank_mesh


def _simulate_mesh_camera(mesh):
    mesh = mesh_in_mm(mesh)  # POV-Ray applies the mesh's scale to origins and directions
    W, H1 = mesh.image_size
    cols, rows = np.meshgrid(np.arange(W), np.arange(H1))
    p = np.stack([cols / W, 1 - rows / H1], axis=-1).reshape(-1, 2)  # as POV-Ray (but row 0, last col)
    tri = mesh.uvs[mesh.faces]  # (m, 3, 2)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1 = b - a, c - a
    d = p[:, None, :] - a[None]
    den = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    w1 = (d[..., 0] * v1[:, 1] - d[..., 1] * v1[:, 0]) / den
    w2 = (v0[:, 0] * d[..., 1] - v0[:, 1] * d[..., 0]) / den
    w0 = 1 - w1 - w2
    w = np.stack([w0, w1, w2], axis=-1)  # (pixels, faces, 3)
    margin = w.min(axis=-1)
    face = margin.argmax(axis=1)
    best = margin[np.arange(len(p)), face]
    bary = w[np.arange(len(p)), face]
    idx = mesh.faces[face]
    origin = np.einsum("pk,pkd->pd", bary, mesh.vertices[idx])
    normal = np.einsum("pk,pkd->pd", bary, mesh.normals[idx] / np.linalg.norm(mesh.normals[idx], axis=-1, keepdims=True))
    # Clearance of each lookup from the border of its lens's quad, in pixels: the
    # quad's inner diagonal is harmless (both triangles interpolate one affine map).
    quad_uv = mesh.uvs[mesh.faces[(face // 2) * 2]].reshape(len(p), 3, 2)
    quad_uv = np.concatenate([quad_uv, mesh.uvs[mesh.faces[(face // 2) * 2 + 1]]], axis=1)
    lo, hi = quad_uv.min(axis=1), quad_uv.max(axis=1)
    clearance = np.minimum(p - lo, hi - p) * np.array([W, H1])
    shape = (H1, W)
    return (origin.reshape(*shape, 3), normal.reshape(*shape, 3), clearance.min(axis=1).reshape(shape),
            best.reshape(shape))


def _assert_hits_lens_centres(la, hit, centres):
    """Rays cross z = 0 at their lens centre (lenticular: at the pixel's own row height)."""
    if la.grid == "lenticular":
        _, Y = la.panel.pixel_centres()
        np.testing.assert_allclose(hit[..., 0], centres[..., 0], atol=1e-9)
        np.testing.assert_allclose(hit[..., 1], np.broadcast_to(Y[:, None], hit.shape[:2]), atol=1e-9)
    else:
        np.testing.assert_allclose(hit, centres, atol=1e-9)


@pytest.mark.parametrize("la", [square_array(lx=6, ly=4, nx=4, ny=3), lenticular_array(lx=5, rows=7, nx=6),
                                square_array(lx=3, ly=2, nx=1, ny=1)], ids=["square", "lenticular", "1ppl"])
def test_mesh_camera_traces_the_ray_of_every_pixel(la):
    front_clearance = 50.0
    mesh = camera_mesh(la, front_clearance)
    origin, normal, margin, inside_face = (a[1:, :-1] for a in _simulate_mesh_camera(mesh))  # cut off
    assert np.all(inside_face > -1e-12), "a lookup fell outside every face"
    centres, dirs, inside = pixel_rays(la)
    assert inside.all()
    # Every lookup falls inside a face, well clear of its edges (no edge ambiguity).
    assert margin.min() == pytest.approx(0.5)
    d = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    np.testing.assert_allclose(d, dirs, atol=1e-12)
    # The ray crosses z = 0 at the lens centre.
    t = -origin[..., 2] / d[..., 2]
    hit = origin[..., :2] + t[..., None] * d[..., :2]
    _assert_hits_lens_centres(la, hit, centres)


def test_mesh_camera_normals_have_equal_length_per_lens():
    # Interpolating normalised normals is exact only if the corners share one length.
    mesh = camera_mesh(square_array(nx=5, ny=3), 10.0)
    lengths = np.linalg.norm(mesh.normals, axis=-1).reshape(-1, 4)
    np.testing.assert_allclose(lengths, lengths[:, :1].repeat(4, axis=1), rtol=1e-14)


def test_ortho_view_frames_sample_the_lens_centres():
    la = square_array(lx=6, ly=4, nx=3, ny=2)
    common, frames = ortho_view_shots(la)
    assert len(frames) == 6 and frames[4]["view"] == (1, 1)
    # POV-Ray orthographic pixel (j, i) origin: location + ((j+.5)/W - .5) right + (.5 - (i+.5)/H) up,
    # location = -D * direction; moving D along direction lands on z = 0 at:
    j, i = np.meshgrid(np.arange(common["width"]), np.arange(common["height"]))
    x = ((j + 0.5) / common["width"] - 0.5) * common["right"][0]
    y = (0.5 - (i + 0.5) / common["height"]) * common["up"][1]
    np.testing.assert_allclose(np.stack([x, y], -1), la.lens_centres(), atol=1e-12)
    u, v = la.view_offsets()
    assert frames[5]["direction"] == pytest.approx((u[2] / la.focal, v[1] / la.focal, 1.0))


def test_pinhole_pixels_look_along_view_directions():
    la = square_array(nx=4, ny=3, f=2.0)
    common, frames = pinhole_shots(la)
    k, l = np.meshgrid(np.arange(4), np.arange(3))
    d = (np.array(common["direction"]) + ((k + 0.5) / 4 - 0.5)[..., None] * np.array(common["right"])
         + (0.5 - (l + 0.5) / 3)[..., None] * np.array(common["up"]))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    np.testing.assert_allclose(d, la.view_directions(), atol=1e-12)
    assert frames[1]["centre"][:2] == pytest.approx(tuple(la.lens_centres()[0, 1]))


@pytest.mark.parametrize("la", [square_array(lx=6, ly=4, nx=4, ny=3), lenticular_array(lx=5, rows=7, nx=6)],
                         ids=["square", "lenticular"])
def test_view_bank_mesh_traces_every_view_pixel(la):
    from povh3d.image.interleave import interleave, untile_views

    mesh = view_bank_mesh(la, 40.0)
    origin, normal, margin, inside_face = (a[1:, :-1] for a in _simulate_mesh_camera(mesh))
    assert np.all(inside_face > -1e-12)
    assert margin.min() == pytest.approx(0.5)
    views = la.views
    d = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    t = -origin[..., 2] / d[..., 2]
    hit = origin[..., :2] + t[..., None] * d[..., :2]
    # Re-order tiled pixels into panel order the way the method does, then compare.
    hit = interleave(untile_views(hit, views))
    d = interleave(untile_views(d, views))
    centres, dirs, _ = pixel_rays(la)
    np.testing.assert_allclose(d, dirs, atol=1e-12)
    _assert_hits_lens_centres(la, hit, centres)


@pytest.mark.parametrize("la", [square_array(lx=5, ly=3, nx=3, ny=2), lenticular_array(lx=4, rows=5, nx=4)],
                         ids=["square", "lenticular"])
def test_view_bank_mesh_stacks_one_bank_per_footprint_sample(la):
    # Bank b traces the ray of the conventions' pixel footprint sample b: through
    # c + (ax*px, ay*py) with direction (u + du*s, v + dv*s, f).
    from povh3d.geometry.footprint import latin_hypercube
    from povh3d.image.interleave import interleave, untile_views

    samples = latin_hypercube(3, seed=7)
    mesh = view_bank_mesh(la, 40.0, samples)
    origin, normal, margin, inside_face = (a[1:, :-1] for a in _simulate_mesh_camera(mesh))
    assert np.all(inside_face > -1e-12) and margin.min() == pytest.approx(0.5)
    centres, dirs, _ = pixel_rays(la)
    s = la.panel.pitch_x
    for b, (ax, ay, du, dv) in enumerate(samples):
        rows = slice(b * origin.shape[0] // 3, (b + 1) * origin.shape[0] // 3)
        o, n = (interleave(untile_views(a[rows], la.views)) for a in (origin, normal))
        expected = dirs / dirs[..., 2:] * la.focal + np.array([du * s, dv * la.panel.pitch_y, 0.0])
        np.testing.assert_allclose(n / n[..., 2:] * la.focal, expected, atol=1e-12)
        hit = o[..., :2] - o[..., 2:] / n[..., 2:] * n[..., :2]
        _assert_hits_lens_centres(la, hit - np.array([ax * la.pitch_x, ay * la.pitch_y]), centres)


@pytest.mark.parametrize("count, faces, rays, size", [
    (256, 128, 16 * 12 * 64, 64),      # the --quality auto probe: few rays, few frames
    (256, 128, 60 * 34 * 64, 16),      # 480x272
    (256, 128, 240 * 136 * 64, 4),     # 1920x1088: many rays, short face scans
    (49, 128, 60 * 34 * 64, 7), (7, 128, 60 * 34 * 64, 7), (1, 10_000, 10**7, 1), (13, 10**6, 10**7, 1)])
def test_bank_groups_split_samples_into_equal_frames_by_cost(count, faces, rays, size):
    # POV-Ray scans every face of a mesh camera per ray and a further frame costs a fixed
    # time: the groups take the cheapest size, equal for all frames (a divisor of the count).
    from povh3d.geometry.view_bank import FRAME_SECONDS, SCAN_SECONDS, bank_groups
    from povh3d.geometry.footprint import latin_hypercube

    samples = latin_hypercube(count, seed=2)
    groups = bank_groups(samples, faces, rays)
    assert {len(g) for g in groups} == {size}
    assert np.array_equal(np.concatenate(groups), samples)
    cost = lambda g: count / g * FRAME_SECONDS + count * rays * g * faces * SCAN_SECONDS  # noqa: E731
    divisors = [d for d in range(1, count + 1) if count % d == 0]
    assert cost(size) <= 2 * min(cost(d) for d in divisors)

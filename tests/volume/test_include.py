"""A segmentation's surfaces brought down to the display's triangle budget: pieces smaller than a
lens left out, the rest decimated to the budget (the counts are the oracles)."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.volume.grid import Volume
from povh3d.volume.include import drop_specks, surface_part, surfaces_include
from povh3d.volume.surfaces import label_surfaces


def _speckled(rng: np.random.Generator) -> Volume:
    """A 40-voxel ball (label 1) among 60 single-voxel specks of the same label."""
    n = 64
    i, j, k = np.indices((n, n, n))
    values = (((i - 32) ** 2 + (j - 32) ** 2 + (k - 32) ** 2) < 20 ** 2).astype(np.uint8)
    specks = 0
    while specks < 60:
        p = rng.integers(2, n - 2, 3)
        if not values[p[0] - 1:p[0] + 2, p[1] - 1:p[1] + 2, p[2] - 1:p[2] + 2].any():
            values[tuple(p)] = 1
            specks += 1
    return Volume(values, (1.0, 1.0, 1.0), name="speckled")


def test_specks_under_a_lens_are_left_out_and_the_ball_stays():
    surface = label_surfaces(_speckled(np.random.default_rng(3)), [1], smoothing=0)[0]
    part = surface_part(surface, np.eye(3))
    kept, dropped = drop_specks(part, 3.0)          # a speck is one voxel: diagonal sqrt(3) < 3
    assert dropped == 60
    lo, hi = kept.vertices.min(axis=0), kept.vertices.max(axis=0)
    assert np.allclose(hi - lo, 40, atol=1.01)      # only the ball (40 voxels across) is left
    # A size under every piece drops nothing; one over every piece keeps the largest.
    assert drop_specks(part, 1.0)[1] == 0
    only, gone = drop_specks(part, 1e6)
    assert gone == 60 and only.triangles == kept.triangles


def test_surfaces_reach_the_budget():
    surface = label_surfaces(_speckled(np.random.default_rng(5)), [1])[0]
    budget = 400
    text, rows, stats = surfaces_include([surface], np.eye(3), budget, ident="V", source="speckled", speck=3.0)
    assert stats["specks_left_out"] == 60
    assert rows[0]["triangles"] <= 1.1 * budget < rows[0]["triangles_extracted"]
    assert text.count("mesh2") >= 1


@pytest.mark.parametrize("seed", range(4))
def test_vertex_pieces_are_scipys_connected_components(seed):
    # Random faces over a few hundred vertices (many pieces, chains, isolated vertices) against SciPy's
    # graph search, the same numbering (each piece by its lowest vertex).
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from povh3d.volume.include import vertex_pieces

    rng = np.random.default_rng(seed)
    n = 400
    faces = rng.integers(0, n, (int(rng.integers(50, 300)), 3))
    a, b = np.concatenate([faces[:, 0], faces[:, 1]]), np.concatenate([faces[:, 1], faces[:, 2]])
    expected = connected_components(coo_matrix((np.ones(len(a), bool), (a, b)), shape=(n, n)), directed=False)
    count, piece = vertex_pieces(faces, n)
    assert count == expected[0] and np.array_equal(piece, expected[1])
    # Negative control: a strip of faces cut in the middle is two pieces and the vertex left alone.
    path = np.array([[0, 1, 2], [2, 3, 4], [4, 5, 6], [6, 7, 8]])
    assert vertex_pieces(path, 9)[0] == 1 and vertex_pieces(path[[0, 1, 3]], 9)[0] == 3

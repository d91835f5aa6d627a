"""Merging equal vertices (issue 17: a compiled hash table) against NumPy's sort-based unique."""

from __future__ import annotations

import numpy as np

from povh3d.mesh.clean import merge_equal_vertices


def _unique_oracle(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    v = np.ascontiguousarray(vertices, dtype=np.float64) + 0.0
    rows = v.view(np.dtype((np.void, 24))).ravel()
    _, first, inverse = np.unique(rows, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return v[first[order]], rank[inverse.ravel()]


def test_same_vertices_and_order_as_a_sort_based_unique():
    rng = np.random.default_rng(3)
    points = rng.integers(-3, 4, (400, 3)).astype(np.float64) / 4  # many repeats, exact values
    points[::7] *= -1.0  # and negative zeros, equal to zeros
    soup = points[rng.integers(0, 400, 3000)]
    faces = np.arange(3000).reshape(-1, 3)
    merged, refaced = merge_equal_vertices(soup, faces)
    expected, inverse = _unique_oracle(soup)
    np.testing.assert_array_equal(merged, expected)
    np.testing.assert_array_equal(refaced, inverse[faces])
    np.testing.assert_array_equal(merged[refaced], soup[faces] + 0.0)  # every corner where it was
    assert len(merged) == len(np.unique(soup + 0.0, axis=0)) < 400


def test_only_bit_identical_points_merge():
    soup = np.array([[0.1, 0.2, 0.3], [0.1, 0.2, np.nextafter(0.3, 1)], [0.1, 0.2, 0.3], [np.nan, 0, 0],
                     [np.nan, 0, 0], [-0.0, 0, 0], [0.0, 0, 0], [1, 2, 3], [1, 2, 3]])
    merged, refaced = merge_equal_vertices(soup, np.arange(9).reshape(3, 3))
    assert refaced.tolist() == [[0, 1, 0], [2, 2, 3], [3, 4, 4]]
    assert len(merged) == 5


def test_the_sort_and_the_compiled_hash_table_give_the_same_groups(monkeypatch):
    # merge_equal_vertices sorts below MERGE_SMALL corners and uses numba's hash table above it (when
    # numba is installed): the same first rows and groups, with -0.0 and NaN bit patterns among them.
    from povh3d.mesh import clean
    from povh3d.mesh.kernels import first_of_equal_rows

    rng = np.random.default_rng(5)
    points = rng.integers(-5, 6, (300, 3)).astype(np.float64) / 8
    points[::11] = np.nan
    soup = points[rng.integers(0, 300, 5000)] + 0.0
    bits = soup.view(np.uint64)
    sorted_first, sorted_inverse = clean.first_of_equal_rows_sorted(bits)
    hashed_first, hashed_inverse = first_of_equal_rows(bits)
    np.testing.assert_array_equal(sorted_first, hashed_first)
    np.testing.assert_array_equal(sorted_inverse, hashed_inverse)
    # Negative control: groups numbered in sorted order instead of first appearance differ.
    _, sorted_order_inverse = np.unique(bits.view("V24").ravel(), return_inverse=True)
    assert not np.array_equal(sorted_order_inverse.ravel(), hashed_inverse)
    # Both paths through merge_equal_vertices: the sort, then the kernel past a lowered threshold.
    faces = np.arange(5000 - 5000 % 3).reshape(-1, 3)
    by_sort = merge_equal_vertices(soup, faces)
    monkeypatch.setattr(clean, "MERGE_SMALL", 10)
    by_kernel = merge_equal_vertices(soup, faces)
    np.testing.assert_array_equal(by_sort[0], by_kernel[0])
    np.testing.assert_array_equal(by_sort[1], by_kernel[1])

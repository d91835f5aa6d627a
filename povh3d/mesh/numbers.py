"""Whole arrays as POV-Ray text in one formatting call, round-tripping exactly.

``scene.format.pov_vector_list`` builds one string per vector; a million-triangle
mesh has millions of numbers, so here the whole array goes through a single
``%``-format whose ``%r`` is ``repr`` (the shortest text that reads back as the
same double, locale-independent: docs/geometry.md, "Numbers") and whose ``%d`` is the
integer.  For plain vectors the text is byte-identical to ``pov_vector_list``
(tested), so either can write any file.
"""

from __future__ import annotations

import multiprocessing
import os

import numpy as np

from ..errors import ConfigError

#: Rows above which formatting is split over processes (one per core, at most 4).
PARALLEL_ROWS = 200_000

ITEM_SEP = ", "
LINE_SEP = ",\n    "


def format_rows(array: np.ndarray, item: str, per_line: int = 4) -> str:
    """Every row of ``array`` through the ``%``-template ``item``, comma-separated.

    Parameters
    ----------
    array : (n, k) int or float array
        Floats must be finite.
    item : str
        A template with exactly ``k`` conversions, e.g. ``"<%r, %r, %r>"`` or
        ``"<%d, %d, %d>, %d"``.
    per_line : int
        Items per output line.

    Returns
    -------
    str
        ``item, item, ...`` with ``per_line`` items per line, lines joined by
        ``",\\n    "``; empty for an empty array.
    """
    array = np.asarray(array)
    if array.ndim != 2:
        raise ValueError(f"format_rows takes an (n, k) array, got shape {array.shape}")
    if per_line < 1:
        raise ValueError(f"per_line must be at least 1, got {per_line}")
    n = len(array)
    if n == 0:
        return ""
    if np.issubdtype(array.dtype, np.floating):
        if not np.isfinite(array).all():
            raise ConfigError("cannot write non-finite numbers into a POV-Ray script")
        array = array.astype(np.float64, copy=False)
    elif np.issubdtype(array.dtype, np.integer):
        array = array.astype(np.int64, copy=False)
    if n >= PARALLEL_ROWS and _cores() > 1:
        return _format_parallel(array, item, per_line)
    return _format(array, item, per_line)


def _cores() -> int:
    try:
        return min(4, len(os.sched_getaffinity(0)))
    except AttributeError:
        return 1


def _format_parallel(array: np.ndarray, item: str, per_line: int) -> str:
    """The same text, the rows split at line boundaries over forked workers (repr is CPU-bound)."""
    workers = _cores()
    lines = -(-len(array) // per_line)
    bounds = [min(len(array), round(lines * k / workers) * per_line) for k in range(workers + 1)]
    chunks = [array[a:b] for a, b in zip(bounds, bounds[1:]) if b > a]
    with multiprocessing.get_context("fork").Pool(len(chunks)) as pool:
        texts = pool.starmap(_format, [(c, item, per_line) for c in chunks])
    return LINE_SEP.join(texts)


def _format(array: np.ndarray, item: str, per_line: int) -> str:
    n = len(array)
    full, rest = divmod(n, per_line)
    line = ITEM_SEP.join([item] * per_line)
    lines = [line] * full
    if rest:
        lines.append(ITEM_SEP.join([item] * rest))
    # tolist() turns float64 into Python floats, whose %r is the round-trip repr.
    return LINE_SEP.join(lines) % tuple(array.ravel().tolist())


def vector_item(k: int, conversion: str = "%r") -> str:
    """``"<%r, %r, %r>"`` for ``k = 3``."""
    return "<" + ITEM_SEP.join([conversion] * k) + ">"


def format_vectors(array: np.ndarray, per_line: int = 4) -> str:
    """``<a, b, c>`` rows, the same text as ``scene.format.pov_vector_list`` (ints as ints)."""
    array = np.asarray(array)
    conversion = "%d" if np.issubdtype(array.dtype, np.integer) else "%r"
    return format_rows(array, vector_item(array.shape[1] if array.ndim == 2 else 0, conversion), per_line)

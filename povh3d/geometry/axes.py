"""The one axis-order conversion (docs/geometry.md, "Axis order").

Inside povh3d every two-dimensional size or count is NumPy's ``(rows, cols)``: an
image's shape, pixels per lens ``(Ny, Nx)``, a view ``(Ly, Lx)``.  At the edges, the
command line's ``NxxNy`` / ``WxH`` strings and the sidecar's lists, it is ``x`` first,
as sizes are written.  Readers and writers of those edges convert here and nowhere else.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TypeVar

T = TypeVar("T")


def to_edge(rows_cols: Sequence[T]) -> list[T]:
    """``(rows, cols)`` -> ``[x, y]``, the order of the command line and the sidecar."""
    rows, cols = rows_cols
    return [cols, rows]


def from_edge(x_y: Sequence[T]) -> tuple[T, T]:
    """``[x, y]`` (a sidecar list, a parsed ``NxxNy``) -> ``(rows, cols)``."""
    x, y = x_y
    return (y, x)

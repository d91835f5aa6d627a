"""Small lens arrays the tests build again and again."""

from __future__ import annotations

from povh3d.geometry.lens_array import LensArray, Panel


def square_array(lx: int = 8, ly: int = 6, nx: int = 4, ny: int = 4, s: float = 0.1, f: float = 1.5) -> LensArray:
    return LensArray("square", lx, ly, nx * s, ny * s, f, Panel(lx * nx, ly * ny, s, s))


def lenticular_array(lx: int = 8, rows: int = 12, nx: int = 4, s: float = 0.1, f: float = 1.5) -> LensArray:
    return LensArray("lenticular", lx, rows, nx * s, s, f, Panel(lx * nx, rows, s, s))

"""Mesh arrays as POV-Ray text at the precision POV-Ray keeps, in compiled code.

POV-Ray 3.7 stores a ``mesh2``'s vertices and normals as single-precision
floats: it parses each number to a double and rounds that to a float.  So the
shortest text that POV-Ray reads back to the same float32 loses nothing, and
is about half as long as the double's ``repr``.  For each number this finds the
fewest significant digits ``p`` (1..9) whose decimal ``m * 10**k`` rounds, as
a double then as a float, to the float32 of the value; that is checked with the
same two roundings POV-Ray makes (``m`` and ``10**|k|`` are exact doubles, so
one multiplication or division gives the correctly rounded double, as
``strtod`` does).  The text is written straight into a byte buffer by a numba
kernel: rows ``<a, b, c>``, ``per_line`` to a line, the layout of
``numbers.format_rows``.

Numbers outside ``[1e-13, 1e13)`` (where powers of ten stop being exact
doubles) are written one by one in Python, as few as they usually are.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .numbers import format_rows

#: Magnitudes the kernel writes; the others (non-zero) are written one by one.
LOW, HIGH = 1e-13, 1e13
_POW10 = np.array([10.0 ** k for k in range(23)])  # exact doubles up to 1e22

def _write_rows():
    from .kernels import write_rows  # numba: compiled once, then loaded from its cache

    return write_rows


def format_vectors32(array: np.ndarray, per_line: int = 4) -> str:
    """``<a, b, c>`` rows as POV-Ray reads them into single precision (floats) or exactly (ints).

    Parameters
    ----------
    array : (n, k) float or int array
        Floats must be finite; they are written as their nearest float32.
    per_line : int
        Rows per line.

    Returns
    -------
    str
        The layout of ``numbers.format_vectors``: ``<a, b>, <c, d>,\\n    <e, f>``.
    """
    array = np.asarray(array)
    if array.ndim != 2 or per_line < 1:
        raise ValueError(f"format_vectors32 takes an (n, k) array and per_line >= 1, got {array.shape}, {per_line}")
    if len(array) == 0:
        return ""
    as_int = bool(np.issubdtype(array.dtype, np.integer))
    if as_int:
        values = np.ascontiguousarray(array, dtype=np.int64)
    else:
        if not np.isfinite(array).all():
            raise ConfigError("cannot write non-finite numbers into a POV-Ray script")
        values = np.ascontiguousarray(array, dtype=np.float32).astype(np.float64)
    text = _write_rows()(values, per_line, _POW10, as_int).tobytes().decode("ascii")
    if as_int or "@" not in text:
        return text
    # the few numbers the kernel left ("@"): tiny, huge, or a double-rounding corner
    magnitude = np.abs(values.ravel())
    left = values.ravel()[(magnitude != 0) & ~((magnitude >= LOW) & (magnitude < HIGH))]
    pieces = text.split("@")
    if len(pieces) - 1 != len(left):  # a corner case inside the range: find them all by value
        return _double_text(values, per_line)
    return "".join(p + t for p, t in zip(pieces, [*map(_one_float32, left), ""]))


def _one_float32(value: float) -> str:
    """Shortest text of one float32 that reads back to it through a double; else the double's repr."""
    text = np.format_float_scientific(np.float32(value), unique=True, trim="-").replace("e+", "e")
    return text if np.float32(float(text)) == np.float32(value) else repr(float(value))


def _double_text(values: np.ndarray, per_line: int) -> str:
    """The float32 values as exact double ``repr`` text: longer, read back to the same float32."""
    return format_rows(values, "<" + ", ".join(["%r"] * values.shape[1]) + ">", per_line)

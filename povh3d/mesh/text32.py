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
doubles) are left to the double ``repr`` path of ``numbers.py``.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .numbers import format_rows

#: Magnitudes the kernel writes; outside them (or non-zero below), the double repr path.
LOW, HIGH = 1e-13, 1e13
_POW10 = np.array([10.0 ** k for k in range(23)])  # exact doubles up to 1e22

_kernels = None


def _compile():
    """The numba kernels, compiled (or loaded from numba's cache) on first use."""
    global _kernels
    if _kernels is not None:
        return _kernels
    import numba

    @numba.njit(cache=True)
    def emit_digits(buf, pos, m):
        # the decimal digits of m > 0 at buf[pos:], returns the new position
        tmp = np.empty(20, np.uint8)
        n = 0
        while m > 0:
            tmp[n] = 48 + m % 10
            m //= 10
            n += 1
        for i in range(n):
            buf[pos + i] = tmp[n - 1 - i]
        return pos + n

    @numba.njit(cache=True)
    def ndigits(m):
        n = 0
        while m > 0:
            m //= 10
            n += 1
        return n

    @numba.njit(cache=True)
    def emit_float(buf, pos, x, pow10):
        """Shortest float32 text of x at buf[pos:]; -1 if no 1..9-digit decimal round-trips."""
        if x == 0.0:
            buf[pos] = 48
            return pos + 1
        target = np.float32(x)
        ax = abs(float(target))
        if x < 0:
            buf[pos] = 45
            pos += 1
        e = int(np.floor(np.log10(ax)))
        # log10 may be off by one next to a power of ten: settle e with 10**e <= ax < 10**(e+1)
        if (pow10[e] if e >= 0 else 1.0 / pow10[-e]) > ax:
            e -= 1
        elif (pow10[e + 1] if e + 1 >= 0 else 1.0 / pow10[-e - 1]) <= ax:
            e += 1
        found = False
        m = 0
        k = 0
        for p in range(1, 10):
            k = e - p + 1
            if k >= 0:
                m = int(np.rint(ax / pow10[k]))
                cand = m * pow10[k]
            else:
                m = int(np.rint(ax * pow10[-k]))
                cand = m / pow10[-k]
            if np.float32(cand) == abs(target):
                found = True
                break
        if not found:
            return -1
        while m % 10 == 0:
            m //= 10
            k += 1
        n = ndigits(m)
        point = n + k  # digits before the decimal point
        if k >= 0 and k <= 2:  # an integer: 120
            pos = emit_digits(buf, pos, m)
            for _ in range(k):
                buf[pos] = 48
                pos += 1
            return pos
        if k >= 0 or point < -3:  # 12e5, 12e-9: shorter than the zeros
            pos = emit_digits(buf, pos, m)
            buf[pos] = 101
            pos += 1
            if k < 0:
                buf[pos] = 45
                pos += 1
            return emit_digits(buf, pos, abs(k))
        if point > 0:  # 12.5
            start = pos
            pos = emit_digits(buf, pos, m)
            for i in range(n - point):  # shift the fraction right by one for the point
                buf[pos - i] = buf[pos - i - 1]
            buf[start + point] = 46
            return pos + 1
        buf[pos] = 46  # .0125
        pos += 1
        for _ in range(-point):
            buf[pos] = 48
            pos += 1
        return emit_digits(buf, pos, m)

    @numba.njit(cache=True)
    def write_rows(values, per_line, pow10, as_int):
        n, k = values.shape
        buf = np.empty(n * (k * 24 + 8) + 16, np.uint8)
        pos = 0
        for i in range(n):
            if i > 0:
                buf[pos] = 44  # ","
                pos += 1
                if i % per_line == 0:
                    buf[pos] = 10  # "\n    "
                    for j in range(4):
                        buf[pos + 1 + j] = 32
                    pos += 5
                else:
                    buf[pos] = 32
                    pos += 1
            buf[pos] = 60  # "<"
            pos += 1
            for j in range(k):
                if j > 0:
                    buf[pos] = 44
                    buf[pos + 1] = 32
                    pos += 2
                if as_int:
                    v = int(values[i, j])
                    if v == 0:
                        buf[pos] = 48
                        pos += 1
                    else:
                        if v < 0:
                            buf[pos] = 45
                            pos += 1
                        pos = emit_digits(buf, pos, abs(v))
                else:
                    pos = emit_float(buf, pos, values[i, j], pow10)
                    if pos < 0:
                        return buf[:0], False
            buf[pos] = 62  # ">"
            pos += 1
        return buf[:pos], True

    _kernels = write_rows
    return _kernels


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
        magnitude = np.abs(values)
        if ((magnitude != 0) & ((magnitude < LOW) | (magnitude >= HIGH))).any():
            return _double_text(values, per_line)
    text, ok = _compile()(values, per_line, _POW10, as_int)
    if not ok:  # a number no 9-digit decimal gives back through double rounding: exact doubles
        return _double_text(values, per_line)
    return text.tobytes().decode("ascii")


def _double_text(values: np.ndarray, per_line: int) -> str:
    """The float32 values as exact double ``repr`` text: longer, read back to the same float32."""
    return format_rows(values, "<" + ", ".join(["%r"] * values.shape[1]) + ">", per_line)

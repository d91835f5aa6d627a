"""Mesh arrays as POV-Ray text at the precision POV-Ray keeps, in NumPy or compiled code.

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

Until the kernel is loaded and for the first ``SMALL`` numbers of a process (a
volume's decimated surfaces, a small model) the same search runs in NumPy and
the text is joined in Python: the same text, without the 0.3-0.5 s it takes to
import numba and load the compiled kernel.  Past ``SMALL`` numbers the kernel
is loaded: a process never spends more than about that start-up in Python.
numba is optional (``povh3d[mesh]``): without it every number takes this path.
"""

from __future__ import annotations

import sys

import numpy as np

from ..errors import ConfigError
from ..extras import installed
from .numbers import format_rows

#: Magnitudes the kernel writes; the others (non-zero) are written one by one.
LOW, HIGH = 1e-13, 1e13
_POW10 = np.array([10.0 ** k for k in range(23)])  # exact doubles up to 1e22
#: Numbers a process writes in NumPy and Python before it loads the kernel: at 2.5 us a number there
#: (the kernel 0.7 us, both measured at load 9) that is about the kernel's start-up.
SMALL = 200_000
_written_in_python = [0]   # this process's count (a list: mutable without a global statement)

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
    if "povh3d.mesh.kernels" not in sys.modules and (_written_in_python[0] + values.size <= SMALL
                                                     or not installed("numba")):
        _written_in_python[0] += values.size
        text = _small_rows(values, per_line, as_int)
        if text is None:
            return _double_text(values, per_line)
    else:
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


def _small_rows(values: np.ndarray, per_line: int, as_int: bool) -> str | None:
    """The kernel's text (``kernels.write_rows``) from NumPy and Python, for few numbers; None where
    the kernel's text would send the caller to the double text (a double-rounding corner)."""
    texts = values.ravel().astype(str).tolist() if as_int else _float_texts(values.ravel())
    if texts is None:
        return None
    k = values.shape[1]
    rows = ["<" + ", ".join(texts[i:i + k]) + ">" for i in range(0, len(texts), k)]
    lines = [", ".join(rows[i:i + per_line]) for i in range(0, len(rows), per_line)]
    return ",\n    ".join(lines)


def _float_texts(flat: np.ndarray) -> list[str] | None:
    """The kernel's ``emit_float`` for every float64 (a float32's value) of ``flat``, vectorised: the
    fewest significant digits ``p`` whose decimal rounds, as a double then as a float, to the float32;
    "@" outside ``[LOW, HIGH)``; None when a number in range has no such decimal of 1..9 digits."""
    target = np.abs(flat.astype(np.float32))
    ax = target.astype(np.float64)
    zero = ax == 0
    special = ~zero & ((ax < LOW) | (ax >= HIGH))
    ok = ~zero & ~special
    a = np.where(ok, ax, 1.0)

    def pow10(e: np.ndarray) -> np.ndarray:   # the kernel's exact powers: 10**e, or 1 / 10**-e
        return np.where(e >= 0, _POW10[np.clip(e, 0, 22)], 1.0 / _POW10[np.clip(-e, 0, 22)])

    e = np.floor(np.log10(a)).astype(np.int64)
    e = np.where(pow10(e) > a, e - 1, np.where(pow10(e + 1) <= a, e + 1, e))
    m = np.zeros(len(a))
    k = np.zeros(len(a), dtype=np.int64)
    found = ~ok
    for p in range(1, 10):
        kp = e - p + 1
        scale = _POW10[np.clip(np.abs(kp), 0, 22)]
        mp = np.where(kp >= 0, np.rint(a / scale), np.rint(a * scale))
        cand = np.where(kp >= 0, mp * scale, mp / scale)
        hit = ~found & (cand.astype(np.float32) == target)
        m[hit], k[hit] = mp[hit], kp[hit]
        found |= hit
    if not found.all():
        return None
    digits = m.astype(np.int64)
    negative = flat < 0
    out = []
    for d, kk, neg, z, sp in zip(digits.tolist(), k.tolist(), negative.tolist(), zero.tolist(), special.tolist()):
        if z or sp:
            out.append("0" if z else "@")
            continue
        while d % 10 == 0:
            d //= 10
            kk += 1
        m_text = str(d)
        point = len(m_text) + kk   # digits before the decimal point
        if 0 <= kk <= 2:
            text = m_text + "0" * kk                     # 120
        elif kk >= 0 or point < -3:
            text = f"{m_text}e{kk}"                      # 12e5, 12e-9
        elif point > 0:
            text = f"{m_text[:point]}.{m_text[point:]}"  # 12.5
        else:
            text = "." + "0" * -point + m_text           # .0125
        out.append("-" + text if neg else text)
    return out

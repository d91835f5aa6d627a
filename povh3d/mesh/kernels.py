"""The compiled kernels of mesh conversion: equal vertices found through a hash table
(``clean.merge_equal_vertices``), and decimal digits of floats and integers written
into a byte buffer (``text32``).

Kept apart so that numba is imported only when a mesh is converted, and at
module level so that numba caches the compiled code between runs.
"""

from __future__ import annotations

import numba
import numpy as np


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
    """Shortest float32 text of x at buf[pos:]; "@" where the caller must write it (outside
    [1e-13, 1e13), or no 1..9-digit decimal round-trips)."""
    if x == 0.0:
        buf[pos] = 48
        return pos + 1
    target = np.float32(x)
    ax = abs(float(target))
    if ax < 1e-13 or ax >= 1e13:  # powers of ten past 1e22 are not exact doubles: the caller's
        buf[pos] = 64
        return pos + 1
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
        buf[pos] = 64
        return pos + 1
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
        buf[pos] = 62  # ">"
        pos += 1
    return buf[:pos]


@numba.njit(cache=True)
def first_of_equal_rows(bits):
    """For ``(n, k)`` uint64 rows: ``first`` (the row of each distinct value, in order of first
    appearance) and ``inverse`` (``(n,)``, the distinct value of each row); rows compared bit for bit."""
    n, k = bits.shape
    size = 1
    while size < 2 * n:
        size *= 2
    table = np.full(size, -1, np.int64)  # open addressing: the group id of each slot
    first = np.empty(n, np.int64)
    inverse = np.empty(n, np.int64)
    groups = 0
    for i in range(n):
        h = np.uint64(0)
        for c in range(k):  # splitmix64-style mixing
            h ^= bits[i, c]
            h *= np.uint64(0x9E3779B97F4A7C15)
            h ^= h >> np.uint64(29)
        slot = np.int64(h & np.uint64(size - 1))
        while True:
            g = table[slot]
            if g < 0:
                table[slot] = groups
                first[groups] = i
                inverse[i] = groups
                groups += 1
                break
            same = True
            for c in range(k):
                if bits[first[g], c] != bits[i, c]:
                    same = False
                    break
            if same:
                inverse[i] = g
                break
            slot = (slot + 1) & (size - 1)
    return first[:groups], inverse

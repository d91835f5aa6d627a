"""Compiled pixel permutations: one gather kernel that interleaving and the panel mappings share.

Every permutation here is a *row gather*: output row ``r`` (``Q`` pixels of
``m`` units each, contiguous) reads pixel ``q`` from

    src[base[r] + table[tid[r], q] : ... + m]        (offsets in units)

so a periodic permutation is stored as a few table rows (kept in cache) plus one
offset per output row.  Interleaving a view stack is one table row (the lens
layout of a row) and a base per H3D row; a slanted mapping repeats every few
panel rows with a constant source shift.

The hot case, 3-byte RGB pixels, does not copy byte by byte (NumPy's strided
3-byte loops run at a fraction of memory speed): eight pixels are read as eight
unaligned 32-bit loads, masked to 24 bits and packed with shifts into three
64-bit stores.  Rows are split over the cores with ``prange``.  Compiled code is
cached on disk (``cache=True``), so only the first run on a machine compiles.
"""

from __future__ import annotations

import os

import numba
import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.extending import intrinsic


@intrinsic
def _load_u32(typingctx, arr, idx):
    """32-bit load at byte ``idx`` of a uint8 array, no alignment assumed."""
    def codegen(context, builder, sig, args):
        ary = context.make_array(sig.args[0])(context, builder, args[0])
        ptr = builder.gep(ary.data, [args[1]])
        return builder.load(builder.bitcast(ptr, ir.IntType(32).as_pointer()), align=1)
    return types.uint32(arr, idx), codegen


@intrinsic
def _at(typingctx, arr, idx):
    """``arr[idx]`` for a 1-D C array without NumPy's negative-index wraparound.

    Numba's ``arr[i]`` adds a compare and select per load for ``i < 0``; in
    these byte gathers that doubled the time.  Callers keep indices in range.
    """
    def codegen(context, builder, sig, args):
        ary = context.make_array(sig.args[0])(context, builder, args[0])
        return builder.load(builder.gep(ary.data, [args[1]]))
    return arr.dtype(arr, idx), codegen


@intrinsic
def _store_u64(typingctx, arr, idx, val):
    """64-bit store at byte ``idx`` of a uint8 array, no alignment assumed."""
    def codegen(context, builder, sig, args):
        ary = context.make_array(sig.args[0])(context, builder, args[0])
        ptr = builder.gep(ary.data, [args[1]])
        builder.store(args[2], builder.bitcast(ptr, ir.IntType(64).as_pointer()), align=1)
        return context.get_dummy_value()
    return types.void(arr, idx, types.uint64), codegen


@njit(parallel=True, cache=True, boundscheck=False, nogil=True)
def gather_rgb8(dst, src, base, tid, table, reach):  # pragma: no cover - compiled
    """3-byte pixels; ``dst`` (R*Q*3,) uint8, offsets in bytes.

    ``reach[t]`` is the largest offset in table row ``t``: a row whose last
    pixel ends the source is copied byte by byte, since the 32-bit loads read
    one byte past each pixel.
    """
    rows = base.shape[0]
    q_count = table.shape[1]
    n = src.shape[0]
    m = np.uint64(0xFFFFFF)
    s24, s48, s16, s8, s32, s56, s40 = (np.uint64(24), np.uint64(48), np.uint64(16), np.uint64(8),
                                        np.uint64(32), np.uint64(56), np.uint64(40))
    for r in prange(rows):
        b = base[r]
        t = table[tid[r]]
        d = r * q_count * 3
        groups = q_count // 8 if b + reach[tid[r]] + 4 <= n else 0
        for g in range(groups):
            q = 8 * g
            p0 = np.uint64(_load_u32(src, b + t[q])) & m
            p1 = np.uint64(_load_u32(src, b + t[q + 1])) & m
            p2 = np.uint64(_load_u32(src, b + t[q + 2])) & m
            p3 = np.uint64(_load_u32(src, b + t[q + 3])) & m
            p4 = np.uint64(_load_u32(src, b + t[q + 4])) & m
            p5 = np.uint64(_load_u32(src, b + t[q + 5])) & m
            p6 = np.uint64(_load_u32(src, b + t[q + 6])) & m
            p7 = np.uint64(_load_u32(src, b + t[q + 7])) & m
            o = d + 24 * g
            _store_u64(dst, o, p0 | (p1 << s24) | (p2 << s48))
            _store_u64(dst, o + 8, (p2 >> s16) | (p3 << s8) | (p4 << s32) | (p5 << s56))
            _store_u64(dst, o + 16, (p5 >> s8) | (p6 << s16) | (p7 << s40))
        for q in range(8 * groups, q_count):
            s = b + t[q]
            o = d + 3 * q
            dst[o] = _at(src, s)
            dst[o + 1] = _at(src, s + 1)
            dst[o + 2] = _at(src, s + 2)


@njit(parallel=True, cache=True, boundscheck=False, nogil=True)
def gather_bytes(dst, src, base, tid, table):  # pragma: no cover - compiled
    """1-byte items (uint8 subpixels): eight byte loads packed into one 64-bit store."""
    rows = base.shape[0]
    q_count = table.shape[1]
    groups = q_count // 8
    for r in prange(rows):
        b = base[r]
        t = table[tid[r]]
        d = r * q_count
        for g in range(groups):
            q = 8 * g
            w = (np.uint64(_at(src, b + t[q])) | (np.uint64(_at(src, b + t[q + 1])) << np.uint64(8))
                 | (np.uint64(_at(src, b + t[q + 2])) << np.uint64(16))
                 | (np.uint64(_at(src, b + t[q + 3])) << np.uint64(24))
                 | (np.uint64(_at(src, b + t[q + 4])) << np.uint64(32))
                 | (np.uint64(_at(src, b + t[q + 5])) << np.uint64(40))
                 | (np.uint64(_at(src, b + t[q + 6])) << np.uint64(48))
                 | (np.uint64(_at(src, b + t[q + 7])) << np.uint64(56)))
            _store_u64(dst, d + q, w)
        for q in range(8 * groups, q_count):
            dst[d + q] = _at(src, b + t[q])


@njit(parallel=True, cache=True, boundscheck=False, nogil=True)
def gather_units(dst, src, base, tid, table, m):  # pragma: no cover - compiled
    """Any pixel of ``m`` units (``dst``, ``src`` 1-D of one unsigned dtype); offsets in units."""
    rows = base.shape[0]
    q_count = table.shape[1]
    for r in prange(rows):
        b = base[r]
        t = table[tid[r]]
        d = r * q_count * m
        if m == 1:
            for q in range(q_count):
                dst[d + q] = _at(src, b + t[q])
        else:
            for q in range(q_count):
                s = b + t[q]
                o = d + q * m
                for c in range(m):
                    dst[o + c] = _at(src, s + c)


_UNITS = {1: np.uint8, 2: np.uint16, 4: np.uint32, 8: np.uint64}
_MIN_PARALLEL_BYTES = 1 << 20


@njit(cache=True, boundscheck=False, nogil=True)
def unfilter_png_rows(rows, bpp):  # pragma: no cover - compiled
    """Undo each row's filter in place (byte 0 of a row is its type); the first bad row, or -1."""
    height, n = rows.shape
    for r in range(height):
        kind = rows[r, 0]
        if kind == 0:
            continue
        if kind > 4:
            return r
        for i in range(1, n):
            left = np.int32(rows[r, i - bpp]) if i > bpp else np.int32(0)
            up = np.int32(rows[r - 1, i]) if r > 0 else np.int32(0)
            if kind == 1:
                add = left
            elif kind == 2:
                add = up
            elif kind == 3:
                add = (left + up) >> 1
            else:  # Paeth
                corner = np.int32(rows[r - 1, i - bpp]) if r > 0 and i > bpp else np.int32(0)
                p = left + up - corner
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - corner)
                add = left if pa <= pb and pa <= pc else (up if pb <= pc else corner)
            rows[r, i] = (np.int32(rows[r, i]) + add) & 255
    return -1


def threads_for(nbytes: int) -> int:
    """Threads for a gather of ``nbytes``: every core, unless the job is small or the cores are busy.

    ``prange`` splits rows statically, so when another process holds a core the
    kernel waits a whole scheduler time slice (about 4 ms) for its descheduled
    half: measured 4-10x slower than one thread while other jobs ran.  The
    one-minute load average is the cheap signal for that.
    """
    cores = numba.config.NUMBA_NUM_THREADS
    if nbytes < _MIN_PARALLEL_BYTES or cores < 2:
        return 1
    try:
        busy = os.getloadavg()[0]
    except OSError:  # pragma: no cover - no load average on this platform
        busy = 0.0
    return 1 if busy >= cores - 0.5 else cores


def row_gather(src: np.ndarray, pixel_bytes: int, base: np.ndarray, tid: np.ndarray,
               table: np.ndarray, out: np.ndarray,
               span: tuple[np.ndarray, np.ndarray] | None = None) -> bool:
    """Run the row gather, offsets in *bytes*; return False when no kernel fits (caller falls back).

    Parameters
    ----------
    src : C-contiguous array, read as raw bytes
    pixel_bytes : int         bytes per pixel
    base : (R,) int64         byte offset of each output row's source
    tid : (R,) intp           table row of each output row
    table : (T, Q) int32/64   byte offset of each output pixel from its row base (multiples of pixel_bytes
                              need not hold; offsets must be multiples of the unit chosen below)
    out : C-contiguous array of R*Q*pixel_bytes bytes, written in place
    span : ((T,), (T,)) or None  each table row's smallest and largest offset, if the caller keeps them
                              (a large table's min and max cost more than the gather)
    """
    if not (src.flags.c_contiguous and out.flags.c_contiguous) or out.nbytes != base.size * table.shape[1] * pixel_bytes:
        return False
    if base.size == 0 or table.shape[1] == 0:
        return True
    s8 = src.reshape(-1).view(np.uint8)
    d8 = out.reshape(-1).view(np.uint8)
    low, reach = span if span is not None else (table.min(axis=1), table.max(axis=1))
    # The kernels load without bounds checks: every pixel read must lie in the source.
    if int((base + low[tid]).min()) < 0 or int((base + reach[tid]).max()) + pixel_bytes > s8.size:
        raise IndexError("row gather: a table offset points outside the source")
    numba.set_num_threads(threads_for(out.nbytes))
    if pixel_bytes == 3:
        gather_rgb8(d8, s8, base, tid, table, reach)
        return True
    if pixel_bytes == 1:
        gather_bytes(d8, s8, base, tid, table)
        return True
    # The widest unit that divides the pixel, every offset and both buffers' addresses.
    for unit in (8, 4, 2, 1):
        if pixel_bytes % unit or src.ctypes.data % unit or out.ctypes.data % unit or s8.size % unit:
            continue
        if unit > 1 and ((base % unit).any() or (table % unit).any()):
            continue
        gather_units(d8.view(_UNITS[unit]), s8.view(_UNITS[unit]), base // unit, tid, table // unit,
                     pixel_bytes // unit)
        return True
    return False  # pragma: no cover - unit 1 always fits

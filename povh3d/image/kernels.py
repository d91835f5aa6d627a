"""Pixel permutations in NumPy: one row gather that interleaving and the panel mappings share.

Every permutation here is a *row gather*: output row ``r`` (``Q`` pixels of
``b`` bytes each, contiguous) reads pixel ``q`` from

    src[base[r] + table[tid[r], q] : ... + b]        (offsets in bytes)

so a periodic permutation is stored as a few table rows plus one offset per
output row.  Interleaving a view stack is one table row (the lens layout of a
row) and a base per H3D row; a slanted mapping repeats every few panel rows
with a constant source shift.

The gather is ``np.take`` of whole pixels (a 1-, 2-, 4- or 8-byte integer, or a
row of ``b`` bytes), a few MB of indices at a time, split over the cores when
the machine is idle (``take`` drops the GIL).  A numba kernel did the same in
0.7 ms instead of 18 ms at 1920x1080 RGB, but importing numba and loading its
compiled code cost 0.3-6 s a process: more than the gathers of any render.
"""

from __future__ import annotations

import functools
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..system import cpu_count

_UNITS = {1: np.uint8, 2: np.uint16, 4: np.uint32, 8: np.uint64}
_MIN_PARALLEL_BYTES = 1 << 20
#: Output pixels gathered per ``take``: its int64 indices are 8 bytes each.
_BLOCK_ITEMS = 1 << 18


def threads_for(nbytes: int) -> int:
    """Threads for a gather of ``nbytes``: every core, unless the job is small or the cores are busy.

    Blocks are split statically, so when another process holds a core the
    gather waits for its descheduled share; the one-minute load average is the
    cheap signal for that.
    """
    cores = cpu_count()
    if nbytes < _MIN_PARALLEL_BYTES or cores < 2:
        return 1
    try:
        busy = os.getloadavg()[0]
    except OSError:  # pragma: no cover - no load average on this platform
        busy = 0.0
    return 1 if busy >= cores - 0.5 else cores


@functools.cache
def _pool() -> ThreadPoolExecutor:
    return ThreadPoolExecutor(cpu_count(), thread_name_prefix="povh3d-gather")


def gather(dst8: np.ndarray, s8: np.ndarray, pixel_bytes: int, base: np.ndarray, tid: np.ndarray,
           table: np.ndarray) -> None:
    """``dst8`` (R*Q*b,) uint8 from ``s8`` (uint8, 1-D): the row gather, offsets in bytes, already
    checked to lie inside ``s8``."""
    b = pixel_bytes
    rows, q_count = base.size, table.shape[1]
    if s8.size % b == 0 and not (base % b).any() and not (table % b).any():
        # Pixels on a grid of their size: a contiguous array of pixels, indexed by pixel.
        src = s8.view(_UNITS[b]) if b in _UNITS else s8.reshape(-1, b)
        step, contiguous = b, True
    else:
        # Pixels at any byte: a b-byte item at every byte of the source (overlapping, stride 1).
        src = np.ndarray((s8.size - b + 1,), dtype=f"V{b}", buffer=s8, strides=(1,))
        step, contiguous = 1, False
    if contiguous:
        dst = dst8.view(_UNITS[b]) if b in _UNITS else dst8.reshape(-1, b)
    else:
        dst = dst8.view(f"V{b}")
    block = max(1, _BLOCK_ITEMS // q_count)

    def part(start: int, stop: int) -> None:
        for top in range(start, stop, block):
            end = min(stop, top + block)
            index = base[top:end, None] + table[tid[top:end]]
            if step > 1:
                index //= step
            out = dst[top * q_count:end * q_count]
            if contiguous:  # mode="clip": no buffered copy of ``out`` (the bounds are checked already)
                np.take(src, index.reshape(-1), axis=0, out=out, mode="clip")
            else:
                out[...] = src[index.reshape(-1)]

    threads = min(threads_for(dst8.nbytes), rows)
    if threads == 1:
        part(0, rows)
        return
    bounds = [rows * p // threads for p in range(threads + 1)]
    list(_pool().map(lambda p: part(bounds[p], bounds[p + 1]), range(threads)))


def row_gather(src: np.ndarray, pixel_bytes: int, base: np.ndarray, tid: np.ndarray,
               table: np.ndarray, out: np.ndarray,
               span: tuple[np.ndarray, np.ndarray] | None = None) -> bool:
    """Run the row gather, offsets in *bytes*; return False when the arrays do not fit it (caller falls back).

    Parameters
    ----------
    src : C-contiguous array, read as raw bytes
    pixel_bytes : int         bytes per pixel
    base : (R,) int64         byte offset of each output row's source
    tid : (R,) intp           table row of each output row
    table : (T, Q) int32/64   byte offset of each output pixel from its row base
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
    # NumPy would wrap a negative index and ``take`` clips: every pixel read must lie in the source.
    if int((base + low[tid]).min()) < 0 or int((base + reach[tid]).max()) + pixel_bytes > s8.size:
        raise IndexError("row gather: a table offset points outside the source")
    gather(d8, s8, pixel_bytes, base.astype(np.int64, copy=False), tid, table.astype(np.int64, copy=False))
    return True

"""PFM (portable float map), greyscale, as the HCI 4D light-field toolkit writes and reads it.

Header ``Pf``, then ``width height``, then the scale, each on its own line; a negative
scale means little-endian float32.  Rows are stored bottom to top.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from .io import atomic_path


def encode_pfm(data: np.ndarray) -> bytes:
    """``(H, W)`` float array -> PFM bytes (little-endian float32, rows bottom to top)."""
    data = np.asarray(data)
    if data.ndim != 2:
        raise ValueError(f"a greyscale PFM holds an (H, W) array, got shape {data.shape}")
    h, w = data.shape
    body = np.ascontiguousarray(np.flipud(data), dtype="<f4").tobytes()
    return f"Pf\n{w} {h}\n-1\n".encode("ascii") + body


def decode_pfm(raw: bytes, name: str = "PFM") -> np.ndarray:
    """PFM bytes -> ``(H, W)`` float32, row 0 at the top, values times ``|scale|``."""
    lines: list[bytes] = []
    pos = 0
    while len(lines) < 3:
        end = raw.find(b"\n", pos)
        if end < 0:
            raise InputError(f"{name} is not a PFM file: its header is cut short")
        line = raw[pos:end].rstrip()
        pos = end + 1
        if not line.startswith(b"#"):
            lines.append(line)
    if lines[0] != b"Pf":
        raise InputError(f"{name} is not a greyscale PFM file (header {lines[0][:8]!r}, expected b'Pf')")
    try:
        w, h = (int(v) for v in lines[1].split())
        scale = float(lines[2])
    except ValueError:
        raise InputError(f"{name} has a malformed PFM header") from None
    if scale == 0:
        raise InputError(f"{name} has a PFM scale of 0")
    data = np.frombuffer(raw, "<f4" if scale < 0 else ">f4", count=w * h, offset=pos) if len(raw) - pos >= 4 * w * h \
        else None
    if data is None:
        raise InputError(f"{name} holds fewer than {w} x {h} values")
    return np.flipud(data.reshape(h, w)).astype(np.float32) * abs(scale)


def write_pfm(path: str | Path, data: np.ndarray) -> None:
    """Write ``data`` to ``path`` atomically."""
    raw = encode_pfm(data)
    with atomic_path(path) as tmp:
        tmp.write_bytes(raw)


def read_pfm(path: str | Path) -> np.ndarray:
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read {str(path)!r}: {exc.strerror}") from None
    return decode_pfm(raw, repr(str(path)))

"""Binary PPM (P6), the frames POV-Ray writes for povh3d (``+FP8`` / ``+FP16``).

POV-Ray compresses a PNG at about 15 ms a frame and povh3d spent 4 ms inflating it again,
only to keep the pixels in memory: a PPM is the pixels themselves after a short header
(``P6``, POV-Ray's ``#`` comment lines, width, height, maxval 255 or 65535, one
whitespace byte), 8-bit, or 16-bit big-endian.  It has no alpha channel: a job that
asks for alpha keeps PNG (``povray.job.PovrayJob.image_suffix``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

MAGIC = b"P6"


@dataclass(frozen=True)
class PpmLayout:
    """Where a P6 file's pixels sit: ``offset`` bytes of header, then ``height x width x 3``
    samples of ``depth`` bytes each."""

    width: int
    height: int
    depth: int
    offset: int

    @property
    def size(self) -> int:
        """The whole file's length, bytes."""
        return self.offset + self.width * self.height * 3 * self.depth


def ppm_layout(head: bytes) -> PpmLayout | None:
    """The layout from the start of a P6 file (its whole header at least); None if `head` is
    not a complete P6 header with maxval 255 or 65535."""
    if not head.startswith(MAGIC):
        return None
    fields: list[int] = []
    at = len(MAGIC)
    while len(fields) < 3:
        # whitespace, and comments from '#' to the end of their line, between the fields
        while at < len(head) and (head[at:at + 1].isspace() or head[at:at + 1] == b"#"):
            if head[at:at + 1] == b"#":
                end = head.find(b"\n", at)
                if end < 0:
                    return None
                at = end
            at += 1
        start = at
        while at < len(head) and head[at:at + 1].isdigit():
            at += 1
        if at == start or at >= len(head):
            return None
        fields.append(int(head[start:at]))
    if not head[at:at + 1].isspace() or fields[2] not in (255, 65535) or not fields[0] or not fields[1]:
        return None   # one whitespace byte ends the header
    return PpmLayout(fields[0], fields[1], 1 if fields[2] == 255 else 2, at + 1)


def decode_ppm(source: Path | bytes, name: str) -> np.ndarray:
    """A P6 file or its bytes as ``(H, W, 3)`` uint8 or (native) uint16; ``ValueError`` naming
    `name` unless it is a whole P6 image of maxval 255 or 65535."""
    import numpy as np

    if isinstance(source, Path):
        with open(source, "rb") as fh:
            layout = ppm_layout(fh.read(1024))
            length = fh.seek(0, 2)
    else:
        layout, length = ppm_layout(source[:1024]), len(source)
    if layout is None:
        raise ValueError(f"{name!r} is not a P6 PPM image of 8 or 16 bits")
    if length != layout.size:
        raise ValueError(f"{name!r} holds {length} bytes where its {layout.width}x{layout.height} "
                         f"{8 * layout.depth}-bit pixels need {layout.size}: it is cut short or damaged")
    dtype = np.dtype(np.uint8 if layout.depth == 1 else ">u2")
    count = layout.width * layout.height * 3
    if isinstance(source, Path):
        pixels = np.fromfile(source, dtype=dtype, count=count, offset=layout.offset)
    else:
        pixels = np.frombuffer(source, dtype=dtype, count=count, offset=layout.offset).copy()
    if layout.depth == 2:   # big-endian in the file: swapped in place to the machine's order
        if np.little_endian:
            pixels.byteswap(inplace=True)
        pixels = pixels.view(np.uint16)
    return pixels.reshape(layout.height, layout.width, 3)


def encode_ppm(image: np.ndarray) -> bytes:
    """``(H, W, 3)`` uint8 or uint16 as P6 bytes (what POV-Ray writes, without its comments)."""
    import numpy as np

    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"a PPM holds (H, W, 3) uint8 or uint16, got {image.shape} {image.dtype}")
    maxval = 255 if image.dtype == np.uint8 else 65535
    head = f"P6\n{image.shape[1]} {image.shape[0]}\n{maxval}\n".encode()
    return head + image.astype(image.dtype.newbyteorder(">"), copy=False).tobytes()

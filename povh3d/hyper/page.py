"""The viewer page: one HTML file that holds every view of every frame and plays them.

The views of a frame are tiled into one sprite sheet (row ``l`` of views above row
``l + 1``, as the camera bank's rows) and embedded as a PNG data URI, so the page
opens from ``file://`` with no server and decodes one image per frame.
"""

from __future__ import annotations

import base64
import io
import json
from dataclasses import dataclass
from importlib import resources
from typing import Any

import numpy as np

_DATA_MARK = "/*POVH3D_VIEWER_DATA*/null"


@dataclass(frozen=True)
class ViewerContent:
    """What a page shows: the frames' view stacks and how to step through them.

    frames : tuple of (Ny, Nx, Ly, Lx, C) uint8 arrays, one per animation frame
    grid : the lens grid ("square", "hex", "lenticular", ...); a lenticular sheet has one view row
    fps : frames per second of play
    title : the page's title
    cdp : a 3DCDP header (XML text) to hyperlink, or None
    numbers : the animation frame number of each frame (default 0, 1, ...)
    view_boxes : per frame, per view row, per view column ``{object id: (x_min, y_min, x_max, y_max)}``
        from the object masks; without them every view shows the header's centre-view boxes
    pixel_aspect : width over height of a view's pixel on the display: a lens pitch wide and a lens
        pitch high, so a lenticular sheet's (a pitch wide, one panel pixel high) is far from square
    """

    frames: tuple[np.ndarray, ...]
    grid: str = "square"
    fps: float = 12.0
    title: str = "povh3d viewer"
    cdp: str | None = None
    numbers: tuple[int, ...] | None = None
    view_boxes: tuple[Any, ...] | None = None
    pixel_aspect: float = 1.0

    def __post_init__(self) -> None:
        if not self.frames:
            raise ValueError("frames: a viewer needs at least one frame")
        for name in ("numbers", "view_boxes"):
            value = getattr(self, name)
            if value is not None and len(value) != len(self.frames):
                raise ValueError(f"{name}: one per frame ({len(self.frames)}), got {len(value)}")
        shapes = {f.shape for f in self.frames}
        if len(shapes) != 1:
            raise ValueError(f"frames: every frame must have the same views and size, got {sorted(shapes)}")
        if self.frames[0].ndim != 5 or self.frames[0].shape[4] not in (1, 3, 4):
            raise ValueError(f"frames: each is (Ny, Nx, Ly, Lx, C), got {self.frames[0].shape}")
        if not (self.fps > 0):
            raise ValueError(f"fps: must be positive, got {self.fps}")
        if not 1e-3 <= self.pixel_aspect <= 1e3:
            raise ValueError(f"pixel_aspect: a view pixel's width over height within 1e-3..1e3, got {self.pixel_aspect}")

    @property
    def views(self) -> tuple[int, int]:
        """``(Ny, Nx)``."""
        return self.frames[0].shape[0], self.frames[0].shape[1]

    @property
    def view_size(self) -> tuple[int, int]:
        """``(Ly, Lx)`` pixels of one view."""
        return self.frames[0].shape[2], self.frames[0].shape[3]


def sprite_sheet(views: np.ndarray) -> np.ndarray:
    """Tile ``(Ny, Nx, Ly, Lx, C)`` views into ``(Ny Ly, Nx Lx, C)``: view ``(l, k)`` at rows
    ``l Ly ..``, columns ``k Lx ..``."""
    ny, nx, ly, lx, c = views.shape
    return views.transpose(0, 2, 1, 3, 4).reshape(ny * ly, nx * lx, c)


def _to_8bit(views: np.ndarray) -> np.ndarray:
    if views.dtype == np.uint16:  # a browser shows 8 bits; round, do not truncate
        return ((views.astype(np.uint32) * 255 + 32767) // 65535).astype(np.uint8)
    return views


def png_data_uri(image: np.ndarray) -> str:
    """``data:image/png;base64,...`` of an ``(H, W, C)`` uint8 image."""
    from ..image import png_codec

    buffer = io.BytesIO()
    png_codec.encode(buffer, image[..., 0] if image.shape[2] == 1 else image, level=6)
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")


def page_data(content: ViewerContent) -> dict[str, Any]:
    """The JSON the page's script reads (sizes as (rows, cols), the sprites, the header)."""
    ny, nx = content.views
    ly, lx = content.view_size
    return {"views": [ny, nx], "view_size": [ly, lx], "grid": content.grid, "fps": content.fps,
            "pixel_aspect": content.pixel_aspect,
            "sprites": [png_data_uri(sprite_sheet(_to_8bit(f))) for f in content.frames],
            "cdp": content.cdp, "numbers": list(content.numbers or range(len(content.frames))),
            "view_boxes": None if content.view_boxes is None else [
                [[{str(i): list(b) for i, b in view.items()} for view in row] for row in frame]
                for frame in content.view_boxes]}


def viewer_html(content: ViewerContent) -> str:
    """The whole page as text."""
    template = resources.files(__package__).joinpath("viewer.html").read_text(encoding="utf-8")
    data = json.dumps(page_data(content), separators=(",", ":"))
    # "</" inside a script would end it early (a description with "</script>")
    data = data.replace("</", "<\\/")
    title = content.title.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return template.replace(_DATA_MARK, data).replace("{{title}}", title)

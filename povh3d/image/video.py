"""Assemble a sequence of H3D frames into a video file, registered by suffix.

An H3D image is only right pixel for pixel: blurring neighbouring pixels
mixes views and chroma subsampling mixes the subpixels of a lens.  So MP4 is
lossless H.264 in RGB (``libx264rgb -crf 0``, 4:4:4, no colour conversion),
written by the ffmpeg that ``imageio-ffmpeg`` bundles; a frame decodes back
to the very pixels it was made of.  GIF (Pillow) is limited to 256 colours
per frame and meant for previews.  16-bit frames are rounded to 8 bits.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ..errors import ConfigError, InputError, OutputError, param
from .io import atomic_path

__all__ = ["VIDEO_WRITERS", "write_video", "to_rgb8"]


def to_rgb8(image: np.ndarray) -> np.ndarray:
    """``(H, W, 3)`` uint8 from an 8- or 16-bit RGB, RGBA or grey image."""
    if image.dtype == np.uint16:
        image = ((image.astype(np.uint32) * 255 + 32767) // 65535).astype(np.uint8)
    elif image.dtype != np.uint8:
        raise InputError(f"video frames must be 8- or 16-bit images, got {image.dtype}")
    if image.ndim == 2:
        image = image[..., None]
    if image.shape[2] == 1:
        image = np.repeat(image, 3, axis=2)
    return np.ascontiguousarray(image[..., :3])


def _write_mp4(frames: Sequence[np.ndarray], path: Path, fps: float) -> None:
    from ..extras import require

    imageio_ffmpeg = require("imageio_ffmpeg", "video", "an MP4 video")

    height, width = frames[0].shape[:2]
    writer = imageio_ffmpeg.write_frames(
        str(path), (width, height), pix_fmt_in="rgb24", pix_fmt_out="rgb24", fps=fps,
        codec="libx264rgb", quality=None, macro_block_size=1, ffmpeg_log_level="error",
        output_params=["-crf", "0", "-preset", "veryfast", "-f", "mp4"])
    try:
        writer.send(None)  # start ffmpeg
        for frame in frames:
            writer.send(frame.tobytes())
    except (OSError, RuntimeError) as error:
        raise OutputError(f"ffmpeg could not write {path.name}: {error}") from None
    finally:
        writer.close()


class _Rgb8(Sequence):
    """``frames`` as ``to_rgb8`` images, one at a time (a sequence of files is read frame by frame, so an
    MP4 of many large frames, a Looking Glass quilt video, holds one in memory), each checked to have
    the first frame's size."""

    def __init__(self, frames: Sequence[np.ndarray]) -> None:
        self.frames = frames
        self.shape: tuple[int, ...] | None = None

    def __len__(self) -> int:
        return len(self.frames)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        frame = to_rgb8(self.frames[index])
        if self.shape is None:
            self.shape = frame.shape
        elif frame.shape != self.shape:
            raise InputError("the frames of a video must all have one size")
        return frame


def _write_gif(frames: Sequence[np.ndarray], path: Path, fps: float) -> None:
    from PIL import Image

    images = [Image.fromarray(frame) for frame in frames]
    images[0].save(path, format="GIF", save_all=True, append_images=images[1:],
                   duration=max(1, round(1000 / fps)), loop=0, optimize=False)


#: Suffix -> writer(frames, path, fps); tests loop over it.
VIDEO_WRITERS: dict[str, Callable[[Sequence[np.ndarray], Path, float], None]] = {
    ".mp4": _write_mp4,
    ".gif": _write_gif,
}


def check_video_path(path: str | Path) -> Path:
    """`path` as a Path when its suffix names a known format; ConfigError otherwise."""
    path = Path(path)
    if path.suffix.lower() not in VIDEO_WRITERS:
        raise ConfigError(f"{param('video')} {str(path)!r}: the file name must end in "
                          f"{' or '.join(VIDEO_WRITERS)}")
    if path.suffix.lower() == ".mp4":  # before any frame is rendered, not after the last
        from ..extras import require

        require("imageio_ffmpeg", "video", "an MP4 video")
    return path


def write_video(frames: Sequence[np.ndarray], path: str | Path, *, fps: float = 24.0) -> Path:
    """Write `frames` (each ``(H, W, C)``, one size) as a video, atomically.

    Parameters
    ----------
    frames : sequence of (H, W, C) uint8 or uint16 arrays
    path : str or Path         ``.mp4`` (lossless RGB H.264) or ``.gif``
    fps : float                frames per second, > 0
    """
    path = check_video_path(path)
    if not fps > 0:
        raise ConfigError(f"{param('fps')} must be a positive number, got {fps}")
    if not frames:
        raise ConfigError("a video needs at least one frame")
    rgb = _Rgb8(frames)   # each frame converted as the writer takes it: a lazy sequence stays lazy
    with atomic_path(path) as tmp:
        VIDEO_WRITERS[path.suffix.lower()](rgb, tmp, fps)
    return path

"""Tests of povh3d.image.video: videos round-trip their frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from povh3d.errors import ConfigError
from povh3d.image.video import VIDEO_WRITERS, write_video


@pytest.mark.parametrize("suffix", sorted(VIDEO_WRITERS))
def test_video_round_trip(tmp_path: Path, suffix: str) -> None:
    rng = np.random.default_rng(7)
    if suffix == ".gif":  # 256 colours at most: a few colours survive exactly
        palette = rng.integers(0, 256, (6, 3), dtype=np.uint8)
        frames = [palette[rng.integers(0, 6, (9, 11))] for _ in range(4)]
    else:
        frames = [rng.integers(0, 256, (9, 11, 3), dtype=np.uint8) for _ in range(4)]
    path = write_video(frames, tmp_path / f"v{suffix}", fps=12)
    if suffix == ".gif":
        from PIL import Image, ImageSequence

        decoded = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(Image.open(path))]
    else:
        import imageio_ffmpeg

        reader = imageio_ffmpeg.read_frames(str(path))
        next(reader)
        decoded = [np.frombuffer(f, np.uint8).reshape(9, 11, 3) for f in reader]
    assert len(decoded) == 4 and all(np.array_equal(a, b) for a, b in zip(decoded, frames))
    assert [p.name for p in tmp_path.iterdir()] == [f"v{suffix}"]  # no temporary left


def test_video_16_bit_and_bad_input(tmp_path: Path) -> None:
    from povh3d.image.video import to_rgb8

    assert to_rgb8(np.array([[[0, 32896, 65535]]], np.uint16)).tolist() == [[[0, 128, 255]]]
    with pytest.raises(ConfigError):
        write_video([], tmp_path / "e.mp4")
    with pytest.raises(ConfigError, match="fps"):
        write_video([np.zeros((2, 2, 3), np.uint8)], tmp_path / "e.gif", fps=0)

import numpy as np
import pytest
from PIL import Image

from povh3d.errors import InputError, OutputError
from povh3d.image.io import read_png, write_png, write_sidecar, read_sidecar


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("channels", [1, 3, 4])
def test_png_round_trip_keeps_depth(tmp_path, dtype, channels):
    rng = np.random.default_rng(7)
    image = rng.integers(0, np.iinfo(dtype).max, size=(13, 17, channels), endpoint=True).astype(dtype)
    path = tmp_path / "x.png"
    write_png(path, image)
    back = read_png(path)
    assert back.dtype == dtype
    assert np.array_equal(back, image)


def test_pillow_would_have_lost_16_bit(tmp_path):
    # The reason for pypng: Pillow opens 16-bit RGB as 8-bit without a word.
    image = np.full((2, 2, 3), 257 * 3 + 1, dtype=np.uint16)
    write_png(tmp_path / "x.png", image)
    with Image.open(tmp_path / "x.png") as im:
        assert np.asarray(im).dtype == np.uint8
    assert read_png(tmp_path / "x.png").dtype == np.uint16


def test_failed_write_leaves_nothing(tmp_path):
    with pytest.raises(ValueError):
        write_png(tmp_path / "x.png", np.zeros((2, 2), dtype=np.float64))
    assert list(tmp_path.iterdir()) == []


def test_missing_folder_and_file(tmp_path):
    with pytest.raises(OutputError, match="does not exist"):
        write_png(tmp_path / "no" / "x.png", np.zeros((2, 2), np.uint8))
    with pytest.raises(InputError, match="does not exist"):
        read_png(tmp_path / "missing.png")
    (tmp_path / "bad.png").write_bytes(b"not a png")
    with pytest.raises(InputError, match="cannot read"):
        read_png(tmp_path / "bad.png")


def test_sidecar_beside_image(tmp_path):
    write_sidecar(tmp_path / "a.png", {"x": 1})
    assert (tmp_path / "a.json").is_file()
    assert read_sidecar(tmp_path / "a.png") == {"x": 1}


@pytest.mark.parametrize("during", ["write", "probe"])
def test_a_signal_as_the_temporary_file_is_made_leaves_none(tmp_path, monkeypatch, during):
    """Ctrl-C (or SIGTERM) landing right after the hidden ``.part`` file is created, before the write
    that owns it has begun: the file goes with the interrupted write (a fault test under load found one
    left beside ``out.json``).  Negative control: without the deferral the same moment leaves it."""
    import os
    import signal
    import tempfile as tempfile_module

    from povh3d.image import io as image_io

    real = tempfile_module.mkstemp

    def interrupted(*args, **kwargs):
        made = real(*args, **kwargs)
        os.kill(os.getpid(), signal.SIGINT)   # Python raises it at its next step, still in _temp_beside
        return made

    monkeypatch.setattr(image_io.tempfile, "mkstemp", interrupted)
    # Python's own Ctrl-C handler, not the CLI's quiet exit (which the test run may have installed)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        _interrupted_writes(tmp_path, monkeypatch, during)
    finally:
        signal.signal(signal.SIGINT, previous)


def _interrupted_writes(tmp_path, monkeypatch, during):
    import os

    from povh3d.image import io as image_io

    target = tmp_path / "out.json"

    def attempt():
        if during == "write":
            with image_io.atomic_path(target) as tmp:
                tmp.write_text("{}")
        else:
            image_io.check_writable(target)

    with pytest.raises(KeyboardInterrupt):
        attempt()
    assert sorted(os.listdir(tmp_path)) == []
    monkeypatch.setattr(image_io, "deferred_signals", lambda: __import__("contextlib").nullcontext())
    with pytest.raises(KeyboardInterrupt):
        attempt()
    assert [p.suffix for p in tmp_path.iterdir()] == [".part"]

"""Tests of povh3d.renderer.animation: clock values, skipped frames, the frames and video options."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from povh3d.renderer.animation import FrameRange, frame_path, parse_clock, parse_frames
from povh3d.renderer.methods.quality import RenderSettings
from tests.support.render import DRAFT, DRAFT_CACHED, render_animation
from povh3d.errors import ConfigError, PovrayError
from povh3d.image.io import read_png
from povh3d.scene.scene import load_scene
from tests.support.arrays import square_array

LENS = square_array(3, 2, 2, 2)


def srgb8(linear: float) -> int:
    encoded = 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1 / 2.4) - 0.055
    return round(255 * encoded)


def write_scene(folder: Path, name: str, pigment: str, comment: str = "") -> Path:
    path = folder / name
    path.write_text(f"#version 3.7;\nglobal_settings {{ assumed_gamma 1.0 }}\n{comment}\n"
                    f"plane {{ z, 3 pigment {{ {pigment} }} finish {{ emission 1 diffuse 0 ambient 0 }} }}\n")
    return path


# -- clock values ---------------------------------------------------------------

def test_clock_follows_povray() -> None:
    # +KFI0 +KFF4 +KI0 +KF1: clock = n/4; +KI2 +KF-2 over 10..12: 2, 0, -2.
    assert [FrameRange(0, 4).clock(n) for n in range(5)] == [0, 0.25, 0.5, 0.75, 1]
    assert [FrameRange(10, 12, 2, -2).clock(n) for n in (10, 11, 12)] == [2, 0, -2]
    assert FrameRange(7, 7, 0.3, 0.9).clock(7) == 0.3  # one frame: the initial clock


@given(st.integers(0, 10**6), st.integers(1, 5000), st.floats(-1e6, 1e6), st.floats(-1e6, 1e6))
def test_clock_ends_are_povrays_and_monotone(first: int, count: int, a: float, b: float) -> None:
    # POV-Ray's own arithmetic (delta * (n - first) + start): exact at the first frame, within a
    # few ulps at the last (where POV-Ray itself lands; it then rounds to single precision).
    frames = FrameRange(first, first + count, a, b)
    assert frames.clock(first) == a
    assert abs(frames.clock(first + count) - b) <= 4 * np.spacing(max(abs(a), abs(b), 1e-300))
    middle = frames.clock(first + count // 2)
    assert min(a, b) <= middle <= max(a, b)


@pytest.mark.parametrize("text", ["", "3", "a:b", "1:2:3", "-1:4", "1.5:3"])
def test_bad_frame_ranges(text: str) -> None:
    with pytest.raises(ConfigError, match="frames"):
        parse_frames(text)


def test_reversed_range_is_refused() -> None:
    with pytest.raises(ConfigError, match="reversed"):
        FrameRange(*parse_frames("5:2"))
    with pytest.raises(ConfigError, match="clock"):
        parse_clock("0")
    assert parse_clock("0:2.5") == (0.0, 2.5)


def test_frame_names() -> None:
    assert frame_path("out/a.png", 7) == Path("out/a_0007.png")
    assert frame_path("a.png", 12345, 5) == Path("a_12345.png")


# -- does the scene read the clock? ------------------------------------------------

def test_clock_detection(tmp_path: Path) -> None:
    uses = write_scene(tmp_path, "uses.pov", "rgb clock")
    ignores = write_scene(tmp_path, "ignores.pov", "rgb 0.5", "// the clock is not read; clock")
    (tmp_path / "moves.inc").write_text("#declare X = frame_number;\n")
    nested = write_scene(tmp_path, "nested.pov", "rgb 1", '#include "moves.inc"')
    system = write_scene(tmp_path, "system.pov", "rgb 1", '#include "colors.inc"')
    assert load_scene(uses).uses_clock
    assert not load_scene(ignores).uses_clock
    assert load_scene(nested).uses_clock
    assert not load_scene(system).uses_clock


# -- rendering -------------------------------------------------------------------

@pytest.mark.povray
def test_clock_scene_renders_each_frame_with_its_clock(tmp_path: Path) -> None:
    scene = write_scene(tmp_path, "fade.pov", "rgb clock")
    out = tmp_path / "out" / "fade.png"
    out.parent.mkdir()
    report = render_animation(scene, LENS, out, FrameRange(0, 4), settings=DRAFT_CACHED)
    assert report["rendered"] == 5 and report["copied"] == 0 and report["scene_uses_clock"]
    for n in range(5):
        image = read_png(frame_path(out, n))
        assert image.shape[:2] == (4, 6)
        assert np.all(image[..., :3] == srgb8(n / 4)), n  # the oracle: sRGB of clock n/4
        record = json.loads(frame_path(out, n).with_suffix(".json").read_text())
        assert record["animation"]["clock"] == n / 4 and record["animation"]["frame"] == n
    # A second run, and a range that shares clock values, come from the cache.
    again = render_animation(scene, LENS, out, FrameRange(0, 4), settings=DRAFT_CACHED)
    assert again["rendered"] == 0 and again["from_cache"] == 5
    wider = render_animation(scene, LENS, out, FrameRange(0, 8, 0, 2), settings=DRAFT_CACHED)
    assert wider["from_cache"] == 5 and wider["rendered"] == 4  # clocks 0, .25, .. 1 known


@pytest.mark.povray
def test_static_scene_is_rendered_once(tmp_path: Path) -> None:
    scene = write_scene(tmp_path, "still.pov", "rgb 0.5")
    out = tmp_path / "still.png"
    settings = DRAFT
    report = render_animation(scene, LENS, out, FrameRange(3, 6), settings=settings)
    assert (report["rendered"], report["copied"]) == (1, 3) and not report["scene_uses_clock"]
    first = read_png(frame_path(out, 3))
    assert all(np.array_equal(read_png(frame_path(out, n)), first) for n in range(4, 7))
    assert np.all(first[..., :3] == srgb8(0.5))
    # Negative control: the same scene reading the clock is rendered per frame.
    write_scene(tmp_path, "still.pov", "rgb 0.5 + 0 * clock")
    report = render_animation(scene, LENS, out, FrameRange(3, 6), settings=settings)
    assert (report["rendered"], report["copied"]) == (4, 0)


@pytest.mark.povray
def test_failure_leaves_no_partial_sequence(tmp_path: Path) -> None:
    # Frame 2 (clock 0.5) fails: frames 0 and 1 were fine but none is written.
    scene = tmp_path / "breaks.pov"
    scene.write_text("#version 3.7;\n#if (clock > 0.4) #error \"broken at half time\" #end\n"
                     "plane { z, 3 pigment { rgb clock } finish { emission 1 } }\n")
    out = tmp_path / "b.png"
    with pytest.raises(PovrayError, match="broken at half time"):
        render_animation(scene, LENS, out, FrameRange(0, 4), settings=DRAFT_CACHED, video=tmp_path / "b.mp4")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["breaks.pov"]


@pytest.mark.povray
def test_cli_frames_and_video(tmp_path: Path, cli) -> None:
    scene = write_scene(tmp_path, "fade.pov", "rgb clock")
    out, video = tmp_path / "f.png", tmp_path / "f.mp4"
    result = cli("render", scene, "-o", out, "--frames", "1:3", "--clock", "0:0.5",
                 "--video", video, "--quality", "draft", "--lenses", "3x2", "--ppl", "2", "-q")
    assert result.code == 0
    assert "3 frames" in result.out
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(video))
    meta = next(reader)
    assert meta["size"] == (6, 4)
    decoded = [np.frombuffer(f, np.uint8).reshape(4, 6, 3) for f in reader]
    frames = [read_png(frame_path(out, n))[..., :3] for n in (1, 2, 3)]
    assert len(decoded) == 3 and all(np.array_equal(a, b) for a, b in zip(decoded, frames))


@pytest.mark.parametrize("argv, message", [
    (["--frames", "4:1"], "reversed"),
    (["--frames", "x"], "--frames takes"),
    (["--video", "v.mp4"], "--video needs --frames"),
    (["--frames", "0:1", "--video", "v.avi"], "must end in .mp4 or .gif"),
    (["--frames", "0:1", "--views-dir", "views"], "--views-dir cannot"),
])
def test_cli_bad_animation_input(tmp_path: Path, argv: list[str], message: str, cli) -> None:
    scene = write_scene(tmp_path, "s.pov", "rgb clock")
    result = cli("render", scene, "-o", tmp_path / "o.png", "-q", *argv)
    assert result.code == 2
    assert message in result.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.pov"]  # nothing written


# -- clock sequences (renderer.shots.clock_runs) -------------------------------------------

def write_moving_scene(folder: Path, name: str = "moving.pov", extra: str = "") -> Path:
    """A lit ball crossing a checker as the clock runs: every frame differs."""
    path = folder / name
    path.write_text("#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n"
                    "light_source { <-20, 30, -40> rgb 1 }\n"
                    "plane { z, 0.4 pigment { checker rgb 0.8 rgb <0.2, 0.3, 0.6> scale 0.1 } }\n"
                    f"sphere {{ <-0.3 + 0.6 * clock, 0, -0.1>, 0.15 pigment {{ rgb <0.9, 0.2, 0.1> }} }}\n{extra}\n")
    return path


def per_frame_oracle(scene: Path, lens, frames: FrameRange, folder: Path, settings: RenderSettings,
                     method: str) -> list[np.ndarray]:
    """Each frame rendered alone as a one-frame animation at that frame's clock (+K, no sequence)."""
    images = []
    for n in frames.numbers:
        c = frames.clock(n)
        out = folder / f"alone{n}.png"
        render_animation(scene, lens, out, FrameRange(0, 0, c, c), settings=settings, method=method)
        images.append(read_png(frame_path(out, 0)))
    return images


@pytest.mark.povray  # starts POV-Ray (the marker main registers for make test-fast)
@pytest.mark.parametrize("method, quality", [("multi-ortho", "draft"), ("multi-ortho-views", "draft"),
                                             ("multi-ortho", "normal"), ("pinhole", "draft")])
def test_clock_sequence_is_pixel_identical_to_frames_rendered_alone(tmp_path: Path, method: str,
                                                                    quality: str) -> None:
    # One shot per frame (multi-ortho draft), a shot per view (multi-ortho-views), the footprint
    # bank of normal quality, and pinhole's shots sharing runs (not sequenced: its frame_number is
    # its shot index) all give the pixels of each frame rendered alone.
    scene = write_moving_scene(tmp_path)
    lens = square_array(6, 4, 2, 2)
    frames = FrameRange(0, 4)
    settings = RenderSettings(quality=quality, cache_dir=tmp_path / "cache")
    out = tmp_path / "seq" / "m.png"
    out.parent.mkdir()
    report = render_animation(scene, lens, out, frames, settings=settings, method=method)
    assert report["rendered"] == 5 and report["from_cache"] == 0
    alone = per_frame_oracle(scene, lens, frames, tmp_path, RenderSettings(quality=quality, use_cache=False), method)
    timings = [json.loads(frame_path(out, n).with_suffix(".json").read_text())["timings"] for n in frames.numbers]
    for n in frames.numbers:
        assert np.array_equal(read_png(frame_path(out, n)), alone[n]), n
    # Negative control: the frames differ from one another, so a frame rendered at a neighbour's clock fails.
    assert not np.array_equal(read_png(frame_path(out, 1)), alone[2])
    if method == "pinhole":
        assert all(t["povray_jobs"] >= 1 for t in timings)  # every frame its own runs
    else:
        assert timings[0]["povray_jobs"] >= 2 and all(t["povray_jobs"] == 0 for t in timings[1:])


@pytest.mark.povray  # starts POV-Ray (the marker main registers for make test-fast)
def test_clock_sequence_needs_a_scene_reading_only_the_clock(tmp_path: Path) -> None:
    # frame_number differs between a frame alone and inside a sequence: such a scene runs per frame.
    scene = write_moving_scene(tmp_path, extra="#declare Unused = frame_number;")
    out = tmp_path / "f.png"
    render_animation(scene, LENS, out, FrameRange(0, 2), settings=RenderSettings(quality="draft", use_cache=False))
    timings = [json.loads(frame_path(out, n).with_suffix(".json").read_text())["timings"] for n in range(3)]
    assert all(t["povray_jobs"] == 1 for t in timings)


@pytest.mark.povray  # starts POV-Ray (the marker main registers for make test-fast)
def test_clock_sequence_without_cache_and_resume(tmp_path: Path) -> None:
    scene = write_moving_scene(tmp_path)
    frames = FrameRange(0, 5)
    out = tmp_path / "n.png"
    report = render_animation(scene, LENS, out, frames, settings=RenderSettings(quality="draft", use_cache=False))
    assert report["rendered"] == 6
    no_cache = [read_png(frame_path(out, n)) for n in frames.numbers]
    # A run that stopped after some frames (here: frames 0..2 rendered earlier into the cache)
    # resumes with only the missing frames.
    cached = RenderSettings(quality="draft", cache_dir=tmp_path / "cache")
    render_animation(scene, LENS, tmp_path / "part.png", FrameRange(0, 2, 0, 0.4),
                     settings=cached)
    again = render_animation(scene, LENS, out, frames, settings=cached)
    assert (again["from_cache"], again["rendered"]) == (3, 3)
    assert all(np.array_equal(read_png(frame_path(out, n)), no_cache[n]) for n in frames.numbers)
    first = json.loads(frame_path(out, 0).with_suffix(".json").read_text())["timings"]
    assert first["shots_from_cache"] == 1 and first["povray_jobs"] >= 1


@pytest.mark.povray
@pytest.mark.parametrize("method, word", [("multi-ortho-views", "clock"), ("pinhole", "clock"),
                                          ("multi-ortho-views", "frame_number")])
def test_a_still_of_a_clock_scene_sees_clock_0_in_every_view(tmp_path: Path, method: str, word: str) -> None:
    """Methods that render a still as several POV-Ray frames in one run (a view or a lens each) must
    give each the still's clock 0 and frame_number 0, not POV-Ray's animation values running over
    them (a sphere at x = 3 clock moved between views).  Control: the scene at 1 differs."""
    from tests.support.cli import run_in_process

    body = ("light_source {{ <0, 0, -100> rgb 1 }}\n"
            "sphere {{ <{x} * 3, 0, 2>, 2 pigment {{ rgb <1, 0.5, 0.2> }} finish {{ ambient 0.2 }} }}\n"
            "plane {{ z, 8 pigment {{ checker rgb 0.2 rgb 0.9 scale 2 }} }}\n")
    images = {}
    for name, x in (("clock", word), ("zero", "0"), ("one", "1")):
        scene = tmp_path / f"{name}.pov"
        scene.write_text("#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n" + body.format(x=x))
        run = run_in_process("render", scene, "--grid", "square", "--lenses", "8x6", "--ppl", "3", "--quality",
                             "draft", "--method", method, "--no-cache", "-q", "-o", tmp_path / f"{name}.png")
        assert run.code == 0, run.err
        images[name] = read_png(tmp_path / f"{name}.png").astype(int)
    assert (images["clock"] == images["zero"]).all()
    assert np.abs(images["one"] - images["zero"]).max() > 50

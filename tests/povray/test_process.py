"""Tests of povh3d.povray: they run the real POV-Ray (skipped only without it).

Scenes are a few pixels of flat colour, so the colour of every pixel is known;
an endless ``#while`` loop stands in for a slow render.
"""

from __future__ import annotations

import multiprocessing
import os
import shutil
import signal
import struct
import sys
import tempfile
import threading
import time
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from PIL import Image

from povh3d.errors import (ConfigError, OutputError, PovrayError, PovrayNotFound, PovrayTimeout,
    RenderInterrupted)
from povh3d.povray.process import (JobResult, PovrayJob, build_command, povray_conf, povray_version,
    run_jobs)
from povh3d.system import ENV_VAR, find_povray

HAVE_POVRAY = bool(os.environ.get(ENV_VAR) or shutil.which("povray"))
needs_povray = pytest.mark.skipif(not HAVE_POVRAY, reason="POV-Ray is not installed")

HEAD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { orthographic location <0, 0, -1> look_at 0 right x up y }
"""


def flat(pigment: str) -> str:
    """A scene whose every pixel has the colour of `pigment`, unlit."""
    return HEAD + f"plane {{ z, 0 pigment {{ {pigment} }} finish {{ ambient 1 diffuse 0 }} }}\n"


FAST = flat("rgb <1, 0, 0>")
SLOW = HEAD + "#declare I = 0;\n#while (1)\n  #declare I = I + 1;\n#end\n"
BROKEN = HEAD + "\n\nFoo\n"  # the error is on line 6


def proc_stat(pid: int) -> tuple[str, str, int] | None:
    """``(command name, state, parent pid)`` of a process, None if it is gone."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    comm = stat[stat.index("(") + 1:stat.rindex(")")]
    state, ppid = stat[stat.rindex(")") + 2:].split()[:2]
    return comm, state, int(ppid)


def povray_children(parent: int | None = None) -> list[int]:
    """Pids of the povray children of `parent` (this process), zombies included.

    Only our own children count: other POV-Ray runs on the machine are not ours.
    """
    parent = os.getpid() if parent is None else parent
    pids = [int(entry.name) for entry in Path("/proc").iterdir() if entry.name.isdigit()]
    return [pid for pid in pids
            if (stat := proc_stat(pid)) and stat[0] == "povray" and stat[2] == parent]


def assert_clean(workdir: Path) -> None:
    """No child left, no temporary folder left."""
    assert povray_children() == []
    assert list(workdir.iterdir()) == []


def srgb(linear: float) -> int:
    """8-bit sRGB code of a linear value."""
    encoded = 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1 / 2.4) - 0.055
    return round(255 * encoded)


def write_png(path: Path, rgb: tuple[int, int, int], size: int = 4) -> None:
    """A small flat 8-bit RGB PNG, written without Pillow's help."""
    row = b"\x00" + bytes(rgb) * size

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    path.write_bytes(b"\x89PNG\r\n\x1a\n"
                     + chunk(b"IHDR", struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(row * size)) + chunk(b"IEND", b""))


@pytest.fixture
def outside() -> Iterator[Path]:
    """A folder outside /tmp (and outside HOME, unless the repo is in it)."""
    path = Path(tempfile.mkdtemp(prefix=".povh3d-test-", dir=Path(__file__).parent))
    yield path
    shutil.rmtree(path, ignore_errors=True)


def collect(store: dict[str, list]) -> Callable[[JobResult], None]:
    """An on_result keeping each job's (file name, RGB image): files go later."""
    def on_result(result: JobResult) -> None:
        assert all(path.is_file() for path in result.images)
        store[result.job.name] = [(path.name, Image.open(path).convert("RGB"))
                                  for path in result.images]
    return on_result


# -- pure parts ---------------------------------------------------------------

def test_build_command() -> None:
    job = PovrayJob("v", FAST, 10, 6, frames=3, include_dirs=("/a b", "rel"),
                    options=("+A0.3",), threads=2, bit_depth=16, file_gamma="1.0",
                    start_row=0, end_row=1)
    command = build_command(job, "/usr/bin/povray")
    assert command[:11] == ["/usr/bin/povray", "+Iscene.pov", "+Oframe.ppm", "+W10",
                            "+H6", "+FP16", "File_Gamma=1.0", "-D", "+V", "+MI128",
                            '+L"/a b"']
    assert f'+L"{os.path.abspath("rel")}"' in command
    # three shots of a still: the clock held at a still's 0 (POV-Ray would run it 0..1 over them)
    assert command[-8:] == ["+WT2", "+KFI1", "+KFF3", "+KI0", "+KF0", "+SR1.5", "+ER1.5", "+A0.3"]


def test_povray_conf() -> None:
    text = povray_conf(["/scene dir", 'with"quote'], "/tmp/job")
    assert "restricted" in text
    assert 'read* = "/scene dir"' in text
    assert "read* = 'with\"quote'" in text
    assert 'read+write* = "/tmp/job"' in text


@pytest.mark.parametrize("change", [
    {"width": 0}, {"height": -1}, {"frames": 0}, {"bit_depth": 12}, {"threads": 0},
    {"timeout": 0}, {"file_gamma": ""}, {"start_row": 3, "end_row": 3},
    {"end_row": 9}, {"start_row": -1}, {"include_dirs": "/one/dir"}, {"width": 2.5},
    {"links": (("/etc/x", "/a"),)}, {"links": (("../x", "/a"),)}, {"links": (("", "/a"),)},
])
def test_job_rejects_bad_values(change: dict) -> None:
    with pytest.raises(ConfigError):
        PovrayJob("v", FAST, **{"width": 4, "height": 8, **change})


def test_job_stores_lists_as_tuples() -> None:
    job = PovrayJob("v", FAST, 4, 4, include_dirs=["/a"], options=["-A"])
    assert job.include_dirs == ("/a",) and job.options == ("-A",)
    assert hash(job)


def test_find_povray_honours_env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    fake = tmp_path / "my-povray"
    fake.write_text("#!/bin/sh\n")
    fake.chmod(0o755)
    monkeypatch.setenv(ENV_VAR, str(fake))
    assert find_povray() == str(fake)
    monkeypatch.setenv(ENV_VAR, str(tmp_path / "missing"))
    with pytest.raises(PovrayNotFound, match=ENV_VAR):
        find_povray()


def test_find_povray_hint_when_missing(monkeypatch: pytest.MonkeyPatch,
                                       tmp_path: Path) -> None:
    monkeypatch.delenv(ENV_VAR, raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(PovrayNotFound) as caught:
        find_povray()
    message = str(caught.value)
    assert "\n" not in message
    assert "sudo apt-get install -y povray" in message and ENV_VAR in message


def test_run_jobs_rejects_bad_processes() -> None:
    with pytest.raises(ConfigError):
        run_jobs([], processes=0)


def test_run_jobs_without_jobs() -> None:
    assert run_jobs([], processes=2) == []


def test_missing_binary(workdir: Path) -> None:
    with pytest.raises(PovrayNotFound, match="apt-get"):
        run_jobs([PovrayJob("v", FAST, 2, 2)], processes=1,
                 binary=str(workdir.parent / "no-povray"), workdir=workdir)
    assert_clean(workdir)


def test_missing_workdir(tmp_path: Path) -> None:
    with pytest.raises(OutputError):
        run_jobs([PovrayJob("v", FAST, 2, 2)], processes=1, binary="povray",
                 workdir=tmp_path / "absent")


# -- rendering ----------------------------------------------------------------

@pytest.mark.povray
@needs_povray
def test_povray_version() -> None:
    assert povray_version().startswith("3.")


@pytest.mark.povray
@needs_povray
def test_image_larger_than_povrays_default_buffer_stays_in_memory(workdir: Path) -> None:
    # Past +MI (default 128 MB, ~5 floats a pixel) POV-Ray 3.7 backs the image
    # with /tmp/pov<pid>, which the sandbox refuses ("Unknown error code").
    images: dict[str, list] = {}
    job = PovrayJob("big", flat("rgb <0, 1, 0>"), 2600, 2600, options=("-A",))
    assert "+MI258" in build_command(job, "povray")
    run_jobs([job], processes=1, on_result=collect(images), workdir=workdir)
    (_, image), = images["big"]
    assert image.size == (2600, 2600) and image.getpixel((2599, 2599)) == (0, 255, 0)


@pytest.mark.povray
def test_single_frame_and_animation(workdir: Path) -> None:
    images: dict[str, list] = {}
    progress: list[tuple[int, int]] = []
    threads: set[int] = set()
    logs: list[str] = []
    jobs = [PovrayJob("still", flat("rgb <1, 0.5, 0>"), 3, 2),
            PovrayJob("anim", flat("rgb <frame_number / 3, 0, 0>"), 2, 2, frames=3,
                      file_gamma="1.0")]

    def on_result(result: JobResult) -> None:
        threads.add(threading.get_ident())
        logs.append(result.log)
        collect(images)(result)

    seconds = run_jobs(jobs, processes=2, on_result=on_result,
                       on_progress=lambda done, total: progress.append((done, total)),
                       workdir=workdir)
    (name, still), = images["still"]
    assert name == "frame.ppm" and still.size == (3, 2)
    assert still.getpixel((2, 1)) == (255, srgb(0.5), 0)
    assert [name for name, _ in images["anim"]] == ["frame1.ppm", "frame2.ppm", "frame3.ppm"]
    assert [image.getpixel((0, 0))[0] for _, image in images["anim"]] == [85, 170, 255]
    assert threads == {threading.get_ident()}
    assert progress == [(1, 2), (2, 2)]
    for log in logs:  # the private HOME's povray.conf was read
        assert "Trace Time" in log and "configuration file" not in log
        # taken once its images were complete, without waiting out POV-Ray's shutdown
        assert "POV-Ray finished" not in log
    assert len(seconds) == 2 and all(s > 0 for s in seconds)
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
def test_sixteen_bit(workdir: Path) -> None:
    values = []

    def on_result(result: JobResult) -> None:
        # a 16-bit PPM (+FP16): the header's maxval 65535, big-endian samples
        from povh3d.image.io import read_image
        from povh3d.image.ppm import ppm_layout

        layout = ppm_layout(result.images[0].read_bytes())
        values.append((8 * layout.depth, read_image(result.images[0])[0, 0].tolist()))

    run_jobs([PovrayJob("deep", flat("rgb <0.5, 0.25, 1>"), 2, 2, bit_depth=16,
                        file_gamma="1.0")], processes=1, on_result=on_result,
             workdir=workdir)
    (depth, rgb), = values
    assert depth == 16
    assert rgb == pytest.approx([32768, 16384, 65535], abs=2)


@pytest.mark.povray
@needs_povray
@pytest.mark.parametrize(("start", "end"), [(2, 5), (0, 1), (7, 8)])
def test_partial_rows(workdir: Path, start: int, end: int) -> None:
    images: dict[str, list] = {}
    run_jobs([PovrayJob("rows", FAST, 2, 8, start_row=start, end_row=end)],
             processes=1, on_result=collect(images), workdir=workdir)
    (_, image), = images["rows"]
    assert image.size == (2, 8)  # full size, unrendered rows black
    rendered = [row for row in range(8) if image.getpixel((0, row)) == (255, 0, 0)]
    assert rendered == list(range(start, end))


@pytest.mark.povray
@needs_povray
def test_include_and_image_map_outside_tmp(outside: Path) -> None:
    scene = outside / "scene folder"  # a space too, to test quoting
    work = outside / "work"
    scene.mkdir()
    work.mkdir()
    (scene / "colours.inc").write_text("#declare Left = rgb <0, 0, 1>;\n")
    write_png(scene / "tex.png", (0, 255, 0))
    script = HEAD + """#include "colours.inc"
plane { z, 0 pigment { image_map { png "tex.png" } } finish { ambient 1 diffuse 0 }
        clipped_by { plane { x, 0 } } }
plane { z, 0 pigment { Left } finish { ambient 1 diffuse 0 } clipped_by { plane { -x, 0 } } }
"""
    images: dict[str, list] = {}
    run_jobs([PovrayJob("outside", script, 4, 4, include_dirs=(str(scene),))],
             processes=1, on_result=collect(images), workdir=work)
    (_, image), = images["outside"]
    assert image.getpixel((0, 0)) == (0, 255, 0)  # x < 0: the image map
    assert image.getpixel((3, 0)) == (0, 0, 255)  # x > 0: the included colour
    assert_clean(work)


# -- failures -----------------------------------------------------------------

@pytest.mark.povray
@needs_povray
def test_parse_error_names_the_line(workdir: Path) -> None:
    with pytest.raises(PovrayError) as caught:
        run_jobs([PovrayJob("view 3,5", BROKEN, 2, 2)], processes=1, workdir=workdir)
    error = caught.value
    assert not isinstance(error, PovrayTimeout)
    assert str(error).startswith("view 3,5: scene.pov line 6: Parse Error: ")
    assert "'Foo'" in str(error) and "\n" not in str(error)
    assert error.returncode not in (0, None)
    assert "+Iscene.pov" in error.command
    assert "Parse Error" in error.log_tail and len(error.log_tail.splitlines()) <= 40
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
def test_missing_include_names_the_file(workdir: Path) -> None:
    with pytest.raises(PovrayError, match=r"view 1: .*nothere\.inc"):
        run_jobs([PovrayJob("view 1", HEAD + '#include "nothere.inc"\n', 2, 2)],
                 processes=1, workdir=workdir)
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
def test_timeout(workdir: Path) -> None:
    began = time.monotonic()
    with pytest.raises(PovrayTimeout, match="slow view: .*within 1 s"):
        run_jobs([PovrayJob("slow view", SLOW, 2, 2, timeout=1)], processes=1,
                 workdir=workdir)
    assert time.monotonic() - began < 5
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
def test_failure_stops_the_other_jobs(workdir: Path) -> None:
    started: list[str] = []
    jobs = [PovrayJob("slow 1", SLOW, 2, 2), PovrayJob("slow 2", SLOW, 2, 2),
            PovrayJob("broken", BROKEN, 2, 2), PovrayJob("never", FAST, 2, 2)]
    began = time.monotonic()
    with pytest.raises(PovrayError, match="^broken: "):
        run_jobs(jobs, processes=3, workdir=workdir,
                 on_result=lambda result: started.append(result.job.name))
    assert time.monotonic() - began < 8
    assert started == []  # "never" was not started after the failure
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
def test_interrupt_from_callback(workdir: Path) -> None:
    jobs = [PovrayJob("fast", FAST, 2, 2), PovrayJob("slow 1", SLOW, 2, 2),
            PovrayJob("slow 2", SLOW, 2, 2)]

    def on_result(result: JobResult) -> None:
        raise KeyboardInterrupt

    with pytest.raises(RenderInterrupted):
        run_jobs(jobs, processes=3, on_result=on_result, workdir=workdir)
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
def test_interrupt_by_signal(workdir: Path) -> None:
    # Ctrl-C in a terminal sends SIGINT to Python only: children have their
    # own session.  The jobs never end, so the signal surely arrives inside.
    # A shell starts background jobs with SIGINT ignored, and Python keeps that:
    # give this test Python's own handler, whatever started pytest.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT))
    jobs = [PovrayJob(f"slow {n}", SLOW, 2, 2, timeout=30) for n in range(3)]
    timer.start()
    try:
        with pytest.raises(RenderInterrupted):
            run_jobs(jobs, processes=2, workdir=workdir)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
def test_callback_error_cleans_up(workdir: Path) -> None:
    def on_result(result: JobResult) -> None:
        raise RuntimeError("callback failed")

    with pytest.raises(RuntimeError, match="callback failed"):
        run_jobs([PovrayJob("fast", FAST, 2, 2), PovrayJob("slow", SLOW, 2, 2)],
                 processes=2, on_result=on_result, workdir=workdir)
    assert_clean(workdir)


# -- parallelism --------------------------------------------------------------

@pytest.mark.povray
@needs_povray
def test_processes_limit_concurrency(workdir: Path) -> None:
    counts: list[int] = []
    stop = threading.Event()

    def sample() -> None:
        while not stop.is_set():
            counts.append(len(povray_children()))
            time.sleep(0.01)

    sampler = threading.Thread(target=sample)
    sampler.start()
    try:
        seconds = run_jobs([PovrayJob(f"v{n}", FAST, 2, 2) for n in range(4)],
                           processes=2, workdir=workdir)
    finally:
        stop.set()
        sampler.join()
    assert max(counts) == 2
    assert len(seconds) == 4
    assert_clean(workdir)


def _render_forever(workdir: str) -> None:
    run_jobs([PovrayJob("slow", SLOW, 2, 2)], processes=1, workdir=workdir)


@pytest.mark.povray
@needs_povray
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux-only prctl")
def test_children_die_with_python(workdir: Path) -> None:
    # SIGKILL gives Python no chance to clean up; PR_SET_PDEATHSIG must.
    python = multiprocessing.get_context("fork").Process(
        target=_render_forever, args=(str(workdir),))
    python.start()
    try:
        deadline = time.monotonic() + 10
        while not (children := povray_children(python.pid)) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert children
    finally:
        python.kill()
        python.join()
    deadline = time.monotonic() + 5
    while (time.monotonic() < deadline
           and any((stat := proc_stat(pid)) and stat[1] != "Z" for pid in children)):
        time.sleep(0.02)
    assert not any((stat := proc_stat(pid)) and stat[0] == "povray" and stat[1] != "Z"
                   for pid in children)


# -- frames handed over one by one (a stopped run keeps every finished frame) --------------------

def _paced(frames: int, last: str = "") -> str:
    """An animation whose frame n is flat red n / frames after about 0.2 s of parsing;
    `last` is appended to the last frame's text (an endless loop, a syntax error)."""
    return (flat(f"rgb <frame_number / {frames}, 0, 0>")
            + "#declare I = 0;\n#while (I < 150000)\n  #declare I = I + 1;\n#end\n"
            + f"#if (frame_number = {frames})\n{last}\n#end\n")


@pytest.mark.povray
@needs_povray
def test_each_frame_is_handed_over_while_the_job_runs(workdir: Path) -> None:
    handed: list[tuple[int, int, bool]] = []
    images: dict[str, list] = {}

    def on_frame(job: PovrayJob, index: int, path: Path) -> None:
        # The last frame's file does not exist yet while an earlier frame is handed over.
        handed.append((index, Image.open(path).convert("RGB").getpixel((0, 0))[0],
                       (path.parent / "frame4.ppm").exists()))

    run_jobs([PovrayJob("anim", _paced(4), 2, 2, frames=4, file_gamma="1.0")], processes=1,
             on_result=collect(images), on_frame=on_frame, workdir=workdir)
    assert [index for index, _, _ in handed][:3] == [0, 1, 2]  # in order, the last one maybe at the end
    assert [red for _, red, _ in handed] == [64, 128, 191, 255][:len(handed)]  # n / 4 of 255, gamma 1
    assert not handed[0][2], "the first frame was handed over before the job wrote its last"
    assert [image.getpixel((0, 0))[0] for _, image in images["anim"]] == [64, 128, 191, 255]
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
@pytest.mark.parametrize("fault, error", [("#while (1) #end", PovrayTimeout), ("Foo", PovrayError)])
def test_frames_before_a_timeout_or_a_failure_are_kept(workdir: Path, fault: str, error: type) -> None:
    handed: list[int] = []
    job = PovrayJob("anim", _paced(3, fault), 2, 2, frames=3, timeout=4)
    with pytest.raises(error):
        run_jobs([job], processes=1, on_frame=lambda job, index, path: handed.append(index), workdir=workdir)
    assert handed == [0, 1]
    assert_clean(workdir)


# -- a POV-Ray that crashes by its own fault is run once more --------------------------------------

def _crashing_povray(tmp_path: Path, first_run: str, later_runs: str = 'exec "$POVRAY" "$@"') -> Path:
    """A POV-Ray wrapper whose first run does `first_run` and the later ones `later_runs`;
    each run appends a line to ``runs`` beside it.  POV-Ray 3.7 aborts (SIGABRT) on its own
    about once in some thousands of runs; this makes it do so on demand."""
    wrapper = tmp_path / "povray"
    wrapper.write_text(f"""#!/bin/sh
POVRAY={shutil.which("povray")}
echo run >> {tmp_path / "runs"}
if [ "$(wc -l < {tmp_path / "runs"})" -eq 1 ]; then
  {first_run}
fi
{later_runs}
""")
    wrapper.chmod(0o755)
    return wrapper


@pytest.mark.povray
@needs_povray
def test_a_crashed_run_is_run_once_more(workdir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("POVH3D_SANDBOX", "off")  # the wrapper counts its runs outside the job's folder
    binary = _crashing_povray(workdir.parent, "kill -ABRT $$")
    images: dict[str, list] = {}
    with pytest.warns(UserWarning, match=r"flat: POV-Ray was killed by signal 6 .*running it once more"):
        run_jobs([PovrayJob("flat", flat("rgb <1, 0, 0>"), 2, 2, file_gamma="1.0")], processes=1,
                 on_result=collect(images), binary=str(binary), workdir=workdir)
    assert (workdir.parent / "runs").read_text().count("run") == 2
    assert images["flat"][0][1].getpixel((0, 0)) == (255, 0, 0)
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
def test_a_second_crash_is_the_error(workdir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("POVH3D_SANDBOX", "off")
    binary = _crashing_povray(workdir.parent, "kill -ABRT $$", "kill -ABRT $$")
    with pytest.warns(UserWarning), pytest.raises(PovrayError, match="flat: POV-Ray was killed by signal 6$"):
        run_jobs([PovrayJob("flat", flat("rgb <1, 0, 0>"), 2, 2)], processes=1, binary=str(binary),
                 workdir=workdir)
    assert (workdir.parent / "runs").read_text().count("run") == 2
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
def test_a_scene_error_is_not_run_again(workdir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Control: a failure of the scene's own (a parse error, exit code 1) is not POV-Ray's crash."""
    monkeypatch.setenv("POVH3D_SANDBOX", "off")
    binary = _crashing_povray(workdir.parent, ":")
    with pytest.raises(PovrayError, match="Parse Error"):
        run_jobs([PovrayJob("bad", HEAD + "Foo\n", 2, 2)], processes=1, binary=str(binary), workdir=workdir)
    assert (workdir.parent / "runs").read_text().count("run") == 1
    assert_clean(workdir)


@pytest.mark.povray
@needs_povray
def test_frames_handed_before_a_crash_are_not_handed_again(workdir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("POVH3D_SANDBOX", "off")
    # The first run renders frames 1-2 of 3 (a later +KFF wins), then aborts.
    binary = _crashing_povray(workdir.parent, '"$POVRAY" "$@" +KFF2; kill -ABRT $$')
    handed: list[int] = []
    images: dict[str, list] = {}
    with pytest.warns(UserWarning, match="running it once more"):
        run_jobs([PovrayJob("anim", _paced(3), 2, 2, frames=3, file_gamma="1.0")], processes=1,
                 on_result=collect(images), on_frame=lambda job, index, path: handed.append(index),
                 binary=str(binary), workdir=workdir)
    assert sorted(handed) == list(range(len(handed))) and handed[:2] == [0, 1]  # each once, in order
    assert [image.getpixel((0, 0))[0] for _, image in images["anim"]] == [85, 170, 255]
    assert_clean(workdir)

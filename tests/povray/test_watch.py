"""Waiting on POV-Ray children without polling, and reading their progress (issue 17)."""

from __future__ import annotations

import os
import signal
import time
from dataclasses import replace
from pathlib import Path

import pytest

from povh3d.povray.job import ClockRun, PovrayJob, build_command, collect_images, expected_images, frame_image
from povh3d.povray.watch import LogProgress, sleep_until_exit
from tests.support.waiting import wait_until


def _is_zombie(pid: int) -> bool:
    """The child has exited and nobody has reaped it yet (its state in /proc is Z)."""
    with open(f"/proc/{pid}/stat") as stat:
        return stat.read().rsplit(")", 1)[1].split()[0] == "Z"


def _child(seconds: float) -> int:
    """A child process that sleeps `seconds` and exits (not reaped until the test waits)."""
    pid = os.fork()
    if pid == 0:
        time.sleep(seconds)
        os._exit(0)
    return pid


def test_an_exit_wakes_the_wait_at_once():
    pid = _child(0.3)
    try:
        start = time.monotonic()
        sleep_until_exit([pid], 20.0)
        woke = time.monotonic() - start
        assert 0.2 < woke < 5.0  # woken by the exit, not by the 20 s limit
    finally:
        os.waitpid(pid, 0)


def test_the_limit_ends_the_wait_while_children_run():
    pid = _child(30.0)
    try:
        start = time.monotonic()
        sleep_until_exit([pid], 0.2)
        assert 0.15 < time.monotonic() - start < 5.0
    finally:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)


def test_an_exited_unreaped_child_returns_at_once():
    pid = _child(0.0)
    try:
        wait_until(lambda: _is_zombie(pid), 10.0, "a zombie")
        start = time.monotonic()
        sleep_until_exit([pid], None)
        assert time.monotonic() - start < 1.0
    finally:
        os.waitpid(pid, 0)


def test_log_progress_reads_whole_lines_as_they_come(tmp_path):
    log = tmp_path / "povray.log"
    progress = LogProgress(log, frames=2)
    assert progress.frames_rendered() == 0.0  # no log yet
    with open(log, "w") as f:
        f.write("Rendering frame 1 of 2\nRendered 50 of 100 pixels (50%)\rRendered 7")
        f.flush()
        assert progress.frames_rendered() == 0.5  # "Rendered 7" is not a whole line yet
        f.write("5 of 100 pixels (75%)\r")
        f.flush()
        assert progress.frames_rendered() == 0.75
        f.write("Rendered 100 of 100 pixels (100%)\nRendering frame 2 of 2\nRendered 10 of 100 pixels (10%)\r")
        f.flush()
        assert abs(progress.frames_rendered() - 1.1) < 1e-12


def _png_bytes() -> bytes:
    import io

    from PIL import Image

    buffer = io.BytesIO()
    Image.new("RGB", (2, 2)).save(buffer, format="PNG")
    return buffer.getvalue()


def _ppm_bytes(width: int = 2, height: int = 2) -> bytes:
    """A P6 file with POV-Ray's kind of header: comment lines before the size."""
    return (b"P6\n# Software: POV-Ray 3.7\n# Render Date: now\n"
            + f"{width} {height}\n255\n".encode() + bytes(range(width * height * 3)))


def test_a_ppm_is_complete_once_it_holds_every_pixel_its_header_names(tmp_path):
    from povh3d.povray.watch import complete_image

    ppm, path = _ppm_bytes(3, 2), tmp_path / "frame.ppm"
    for length in (0, 2, 20, len(ppm) - 18, len(ppm) - 1):
        path.write_bytes(ppm[:length])
        assert not complete_image(path), length
    path.write_bytes(ppm)
    assert complete_image(path)
    path.write_bytes(ppm + b"\0")          # longer than its header says: not POV-Ray's whole frame
    assert not complete_image(path)
    path.write_bytes(ppm.replace(b"\n255\n", b"\n65535\n"))   # 16-bit: twice the bytes
    assert not complete_image(path)
    path.write_bytes(ppm.replace(b"\n255\n", b"\n65535\n") + bytes(18))
    assert complete_image(path)


def test_a_png_is_complete_once_its_end_chunk_is_written(tmp_path):
    from povh3d.povray.watch import complete_image

    png, path = _png_bytes(), tmp_path / "frame.png"
    path.write_bytes(png[:-4])
    assert not complete_image(path)
    path.write_bytes(png)
    assert complete_image(path)
    assert not complete_image(tmp_path / "missing.png")


def test_a_job_writes_ppm_frames_and_png_ones_only_for_alpha(tmp_path):
    plain, alpha = job_of(3), replace(job_of(3), options=("-A", "+Q0", "+UA"))
    assert plain.image_suffix == ".ppm" and alpha.image_suffix == ".png"
    assert {"+Oframe.ppm", "+FP8"} <= set(build_command(plain, "povray"))
    assert {"+Oframe.png", "+FN8"} <= set(build_command(alpha, "povray"))    # a PPM has no alpha
    assert "+FP16" in build_command(replace(plain, bit_depth=16), "povray")
    assert frame_image(tmp_path, alpha, 2).name == "frame2.png"
    assert expected_images(plain) == "the 3 frames frame1.ppm..frame3.ppm"


def test_images_done_needs_complete_images_and_the_log_s_last_count(tmp_path):
    from povh3d.povray.watch import JobWatch

    watch = JobWatch(tmp_path / "povray.log", 1, lambda: collect_images(tmp_path, job_of(1)))
    assert watch.fd is not None  # Linux: inotify
    try:
        assert not watch.images_done()  # nothing written
        ppm = _ppm_bytes()
        (tmp_path / "frame.ppm").write_bytes(ppm[:-1])  # cut short: a byte short of its pixels
        assert not watch.images_done()
        (tmp_path / "povray.log").write_text("Rendered 2 of 4 pixels (50%)\n")
        (tmp_path / "frame.ppm").write_bytes(ppm)
        assert not watch.images_done()  # the image is there, the log not at 100 % yet
        with open(tmp_path / "povray.log", "a") as f:
            f.write("Rendered 4 of 4 pixels (100%)\n")
        assert watch.images_done()
    finally:
        watch.close()


def test_images_done_gives_up_without_the_log_s_confirmation(tmp_path):
    from povh3d.povray.watch import JobWatch

    watch = JobWatch(tmp_path / "povray.log", 2, lambda: collect_images(tmp_path, job_of(2)))
    try:
        (tmp_path / "frame1.ppm").write_bytes(_ppm_bytes())
        assert not watch.images_done() and not watch.written  # one of two frames
        (tmp_path / "frame2.ppm").write_bytes(_ppm_bytes())
        (tmp_path / "povray.log").write_text("Rendering frame 1 of 2\nRendered 4 of 4 pixels (100%)\n")
        results = [watch.images_done() for _ in range(100)]
        assert not any(results)  # frame 2 never reported: the runner waits for the exit instead
        assert watch.fd is None and not watch.written
    finally:
        watch.close()


def test_finished_frames_need_the_whole_file_and_the_log_past_them(tmp_path):
    from povh3d.povray.watch import JobWatch

    watch = JobWatch(tmp_path / "povray.log", 12, lambda: collect_images(tmp_path, job_of(12)),
                     lambda n: frame_image(tmp_path, job_of(12), n))
    ppm = _ppm_bytes()
    log = tmp_path / "povray.log"
    try:
        log.write_text("Rendering frame 1 of 12\nRendered 2 of 4 pixels (50%)\n")
        (tmp_path / "frame01.ppm").write_bytes(ppm[:-1])  # being written: a byte short of its pixels
        assert watch.finished_frames() == []
        (tmp_path / "frame01.ppm").write_bytes(ppm)
        assert watch.finished_frames() == [] and watch.awaiting_log  # the log has not reached its end
        with open(log, "a") as f:
            f.write("Rendered 4 of 4 pixels (100%)\n")
        assert watch.finished_frames() == [1] and not watch.awaiting_log
        (tmp_path / "frame02.ppm").write_bytes(ppm)
        (tmp_path / "frame03.ppm").write_bytes(ppm)  # left by an earlier run, say: not past frame 2 yet
        with open(log, "a") as f:
            f.write("Rendering frame 2 of 12\nRendered 4 of 4 pixels (100%)\n")
        assert watch.finished_frames() == [2]
        with open(log, "a") as f:
            f.write("Rendering frame 3 of 12\nRendering frame 4 of 12\nRendered 1 of 4 pixels (25%)\n")
        assert watch.finished_frames() == [3]  # frame 4 has no file yet
        assert watch.finished_frames() == []  # each frame once
        assert frame_image(tmp_path, job_of(1), 1).name == "frame.ppm" \
            and frame_image(tmp_path, job_of(100), 7).name == "frame007.ppm"
    finally:
        watch.close()



def job_of(frames: int, clock_run: ClockRun | None = None) -> PovrayJob:
    return PovrayJob(name="t", script="", width=2, height=2, frames=frames, clock_run=clock_run)


def test_a_clock_run_is_a_subset_of_the_whole_animation(tmp_path: Path) -> None:
    # Frames 5..7 of a 24-frame animation: POV-Ray numbers them as in the whole (padded to 2 digits)
    # and gives them the whole animation's clock through +KFI/+KFF/+KI/+KF and the subset +SF/+EF.
    job = job_of(3, ClockRun(first=5, total=24, clock_start=0.0, clock_end=2.5))
    assert [frame_image(tmp_path, job, n).name for n in (1, 2, 3)] == ["frame05.ppm", "frame06.ppm", "frame07.ppm"]
    command = build_command(job, "povray")
    assert ["+KFI1", "+KFF24", "+KI0.0", "+KF2.5", "+SF5", "+EF7"] == [c for c in command if c[:3] in
                                                                        ("+KF", "+KI", "+SF", "+EF")]
    for n in (5, 6):
        (tmp_path / f"frame{n:02d}.ppm").write_bytes(b"")
    assert collect_images(tmp_path, job) is None          # frame 7 missing
    (tmp_path / "frame07.png").write_bytes(b"")              # not this job's kind of image
    assert collect_images(tmp_path, job) is None
    (tmp_path / "frame07.ppm").write_bytes(b"")
    assert [p.name for p in collect_images(tmp_path, job)] == ["frame05.ppm", "frame06.ppm", "frame07.ppm"]
    with pytest.raises(Exception, match="clock_run"):
        job_of(3, ClockRun(first=23, total=24, clock_start=0.0, clock_end=1.0))   # frames 23..25 of 24

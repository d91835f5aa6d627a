"""Soak: 200 random kills over renders, view writes and cache writes, every output checked
against a clean render (docs/reliability.md, "Soak").  Minutes long: ``make soak`` runs it,
``make test`` leaves it out (marker ``soak``).  ``POVH3D_SOAK_KILLS`` sets the count."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import time

import numpy as np
import pytest

from povh3d.renderer.outputs.views import read_views
from povh3d.image.io import read_png, read_sidecar
from tests.conftest import SAMPLE
from tests.support.cli import cli_command

KILLS = int(os.environ.get("POVH3D_SOAK_KILLS", "200"))
# Small, but many POV-Ray frames (pinhole: one per lens), so that kills land in POV-Ray runs, in
# cache writes between frames, and in the views and image writes at the end.
RENDER = ["render", str(SAMPLE), "-o", "out.png", "--preset", "demo", "--lenses", "6x4", "--ppl", "4",
          "--quality", "draft", "-q", "--method", "pinhole", "--views-dir", "views"]


@pytest.mark.soak
def test_soak_random_kills_never_leave_a_wrong_output(tmp_path):
    env = {**os.environ, "POVH3D_CACHE": str(tmp_path / "cache")}
    clean_dir = tmp_path / "clean"
    clean_dir.mkdir()
    start = time.monotonic()
    subprocess.run(cli_command(*RENDER, "--no-cache"), cwd=clean_dir, env=env, check=True, capture_output=True)
    full = time.monotonic() - start
    clean, clean_views = read_png(clean_dir / "out.png"), read_views(clean_dir / "views")
    work = tmp_path / "w"
    work.mkdir()
    rng = np.random.default_rng(25)
    outcomes = {"killed": 0, "finished": 0, "cache_cleared": 0}
    for trial in range(KILLS):
        if trial % 25 == 0:  # start again from an empty cache now and then: kills in the first frames' writes
            shutil.rmtree(tmp_path / "cache", ignore_errors=True)
            outcomes["cache_cleared"] += 1
        proc = subprocess.Popen(cli_command(*RENDER), cwd=work, env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE)
        time.sleep(rng.uniform(0.0, full * 1.2))
        signum = rng.choice([signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=300)
        outcomes["finished" if proc.returncode == 0 else "killed"] += 1
        assert b"Traceback" not in err and b"internal error" not in err, (trial, err)
        if (work / "out.png").exists():  # every output there is whole and the clean render's
            assert read_sidecar(work / "out.png") is not None, trial
            assert np.array_equal(read_png(work / "out.png"), clean), f"trial {trial}: a wrong image"
        if (work / "views").exists():
            assert np.array_equal(read_views(work / "views"), clean_views), f"trial {trial}: wrong views"
    # and the cache the kills wrote into gives the clean image
    done = subprocess.run(cli_command(*RENDER), cwd=work, env=env, capture_output=True)
    assert done.returncode == 0, done.stderr
    assert np.array_equal(read_png(work / "out.png"), clean)
    assert np.array_equal(read_views(work / "views"), clean_views)
    print(f"soak: {KILLS} kills, {outcomes}, one render {full:.2f} s")

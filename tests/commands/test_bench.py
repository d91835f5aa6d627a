"""The time-against-error bench (commands/bench.py): trials scored against a footprint reference."""

import csv

import numpy as np
import pytest
from PIL import Image

from povh3d.commands.bench import Trial, run_bench, write_report
from povh3d.commands.timing import time_povh3d
from povh3d.scene.scene import load_scene
from tests.support.arrays import square_array
from tests.support.scenes import write_textured_scene

pytestmark = pytest.mark.povray  # every test here starts POV-Ray


@pytest.fixture(scope="module")
def textured(tmp_path_factory):
    return write_textured_scene(tmp_path_factory.mktemp("bench"))


def test_bench_times_whole_commands_and_scores_against_a_stated_floor(tmp_path, textured):
    out = tmp_path / "out"
    args = ["--grid", "square", "--lenses", "8x6", "--ppl", "4", "--pixel-pitch", "0.1", "--focal", "1.5"]
    la = square_array(lx=8, ly=6, nx=4, ny=4)
    trials = [Trial("multi-ortho", "draft"), Trial("multi-ortho", "16"), Trial("multi-ortho", "high"),
              Trial("pinhole", "normal")]
    report = run_bench(load_scene(textured), la, trials, scene_args=[str(textured), *args], reference_samples=512)
    by = {r.trial: r for r in report.results}
    assert np.isfinite(report.noise_floor_db) and report.noise_floor_db > 30
    assert by[trials[1]].psnr_db > by[trials[0]].psnr_db + 3  # footprint samples converge
    # --quality high (256 samples) is scored against the converged image, not the noise of one
    # 256-sample reference: within 1.5 dB of the floor of two 512-sample seeds, or above it.
    assert by[trials[2]].psnr_db >= report.noise_floor_db - 1.5
    assert any(r.pareto for r in report.results) and by[trials[2]].pareto
    # Whole commands: every trial takes at least an interpreter's start-up and exit.
    startup = min(time_povh3d(["--version"]) for _ in range(2))
    assert all(r.seconds > startup for r in report.results)
    paths = write_report(report, out)
    rows = list(csv.DictReader(paths["csv"].open()))
    assert [r["setting"] for r in rows] == [t.label for t in trials]
    table = paths["table"].read_text()
    assert "| setting |" in table and "noise floor" in table and "interpreter start to exit" in table
    assert Image.open(paths["plot"]).size[0] > 300

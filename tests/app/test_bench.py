"""The time-against-error bench (app/bench.py): trials scored against a footprint reference."""

import csv

import numpy as np
import pytest
from PIL import Image

from povh3d.app.bench import Trial, run_bench, write_report
from povh3d.engine.quality import QUALITY_LEVELS, Quality
from povh3d.scene.scene import load_scene
from tests.support.arrays import square_array
from tests.support.scenes import write_textured_scene

pytestmark = pytest.mark.povray  # every test here starts POV-Ray


@pytest.fixture(scope="module")
def textured(tmp_path_factory):
    return load_scene(write_textured_scene(tmp_path_factory.mktemp("bench")))


def test_bench_scores_trials_and_writes_csv_table_and_plot(tmp_path, textured):
    la = square_array(lx=8, ly=6, nx=4, ny=4)
    trials = [Trial("multi-ortho", Quality()), Trial("multi-ortho", Quality(footprint=16, seed=7)),
              Trial("multi-ortho", QUALITY_LEVELS["high"]), Trial("pinhole", Quality(antialias=0.3))]
    report = run_bench(textured, la, trials, reference_samples=256)
    by = {r.trial: r for r in report.results}
    assert np.isfinite(report.noise_floor_db) and report.noise_floor_db > 30
    assert by[trials[1]].psnr_db > by[trials[0]].psnr_db + 3  # footprint samples converge
    # --quality high is within 1 dB of the reference's own noise floor.
    assert by[trials[2]].psnr_db >= report.noise_floor_db - 1.0
    assert any(r.pareto for r in report.results) and by[trials[2]].pareto
    paths = write_report(report, tmp_path / "out")
    rows = list(csv.DictReader(paths["csv"].open()))
    assert [r["setting"] for r in rows] == [t.label for t in trials]
    assert "| setting |" in paths["table"].read_text()
    assert Image.open(paths["plot"]).size[0] > 300

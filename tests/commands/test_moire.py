"""``povh3d moire``: the plot and its sidecar, and one-line errors that leave nothing behind."""

from __future__ import annotations

import json

import numpy as np
import pytest

from povh3d.commands.moire import parse_range
from povh3d.errors import ConfigError
from povh3d.image.io import read_png

from tests.support.cli import one_error_line


def test_moire_writes_the_plot_and_its_numbers(tmp_path, cli):
    out = tmp_path / "moire.png"
    result = cli("moire", "-o", out, "--slant-range", "0:6.5:3.25", "--panel", "400x300")
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())
    m = record["moire"]
    assert m["slant_deg"] == [0.0, 3.25, 6.5] and len(m["row_contrast"]) == 3
    assert record["lens_array"]["grid"] == "lattice"
    assert m["row_contrast"][0] > 3 * m["row_contrast"][2]  # unslanted moire, gone near 6.34
    image = read_png(out)
    assert image.ndim == 3 and image.shape[2] == 3 and image.std() > 0


@pytest.mark.parametrize("args", [["--slant-range", "0:50:1"], ["--slant-range", "5:0:1"], ["--slant-range", "x"],
                                  ["--distance", "-3"], ["--slant-range", "0:20:0.001"]])
def test_bad_moire_options_are_one_line(tmp_path, cli, args):
    out = tmp_path / "moire.png"
    assert one_error_line(cli("moire", "-o", out, *args)) and not out.exists()


def test_parse_range_includes_the_stop_on_the_grid():
    np.testing.assert_allclose(parse_range("0:1:0.25"), [0, 0.25, 0.5, 0.75, 1.0])
    with pytest.raises(ConfigError):
        parse_range("0:1:0")

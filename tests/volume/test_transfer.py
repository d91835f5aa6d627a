"""Transfer functions: presets, the text format and its one-line errors."""

import numpy as np
import pytest

from povh3d.errors import ConfigError, InputError
from povh3d.volume.transfer import NAMES, PRESETS, auto_transfer, label_transfer, load_transfer, parse_transfer

EXAMPLE = """\
# bone and soft tissue of a CT, in HU
kind absolute
-500   0    0    0    0        # air: clear
  40   0.8  0.3  0.25 0.01     # soft tissue
 300   1    0.95 0.85 0.3      # bone
"""


@pytest.mark.parametrize("name", list(PRESETS))
def test_presets_are_valid(name):
    t = PRESETS[name]
    assert np.all(np.diff(t.values) > 0)
    assert np.all(t.colour >= 0) and np.all(t.colour <= 1) and np.all(t.extinction >= 0)
    assert t.extinction.max() > 0, "a preset that shows nothing"
    # Opaque slabs show their colour: emission / extinction is the colour wherever sigma > 0.
    dense = t.extinction > 0
    assert np.allclose(t.emission[dense] / t.extinction[dense, None], t.colour[dense])
    assert load_transfer(name) is t


def test_ct_presets_in_hounsfield_units_and_mri_relative():
    assert PRESETS["ct-bone"].kind == PRESETS["ct-soft"].kind == "absolute"
    assert PRESETS["mri"].kind == "relative"
    # Air (-1000 HU) is clear in both CT presets; bone (1000 HU) is visible in both.
    for name in ("ct-bone", "ct-soft"):
        t = PRESETS[name]
        assert np.interp(-1000, t.values, t.extinction) == 0
        assert np.interp(1000, t.values, t.extinction) > 0.1
    # ct-bone leaves soft tissue (40 HU) clear.
    assert np.interp(40, PRESETS["ct-bone"].values, PRESETS["ct-bone"].extinction) == 0


def test_relative_window():
    values = np.arange(1001, dtype=float)  # 0..1000: 99.5th percentile 995
    t = PRESETS["mri"]
    assert t.window(values) == pytest.approx((0.0, 995.0))
    assert t.data_values(values) == pytest.approx(t.values * 995.0)


def test_parse_example(tmp_path):
    t = parse_transfer(EXAMPLE, "bones.tf")
    assert t.kind == "absolute"
    assert t.values.tolist() == [-500, 40, 300]
    assert t.colour[1].tolist() == [0.8, 0.3, 0.25] and t.extinction.tolist() == [0, 0.01, 0.3]
    path = tmp_path / "bones.tf"
    path.write_text(EXAMPLE)
    assert load_transfer(path).values.tolist() == [-500, 40, 300]


def test_label_file_and_built_labels():
    t = parse_transfer("kind labels\n3 1 0 0 0.1\n7 0 1 0 0.2\n", "tissues.tf")
    assert t.kind == "labels" and t.values.tolist() == [3, 7]
    built = load_transfer("labels", [0, 2, 5, 9])
    assert built.values.tolist() == [2, 5, 9] and len({tuple(c) for c in built.colour}) == 3
    assert "labels" in NAMES


@pytest.mark.parametrize("text, message", [
    ("0 0 0 0 0\n100 1 1 1\n", "tf line 2: expected 5 numbers"),
    ("0 0 0 0 0\n100 1 one 1 0.1\n", "tf line 2: 'one' is not a number"),
    ("# c\n\n100 0 0 0 0\n50 1 1 1 0.1\n", "tf line 4: value 50 does not increase"),
    ("0 0 0 0 0\n100 1 1 1 -0.1\n", "tf line 2: colour and extinction must not be negative"),
    ("0 0 0 0 0\nkind relative\n1 1 1 1 1\n", "tf line 2: 'kind' must come before"),
    ("kind surfaces\n", "tf line 1: write 'kind absolute'"),
    ("kind labels\n2.5 1 1 1 1\n", "tf line 2: a label is a whole number"),
    ("0 0 0 0 nan\n1 1 1 1 1\n", "tf line 1: numbers must be finite"),
    ("0 0 0 0 0\n", "tf: needs at least 2 control points"),
])
def test_errors_name_the_line(text, message):
    with pytest.raises(InputError) as info:
        parse_transfer(text, "tf")
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_unknown_name_lists_presets(tmp_path):
    with pytest.raises(InputError, match="ct-bone, ct-soft, mri, labels, auto"):
        load_transfer(tmp_path / "nope.tf")
    with pytest.raises(ConfigError, match="label volume"):
        load_transfer("labels")
    with pytest.raises(ConfigError, match="no labels other than 0"):
        label_transfer([0])


def test_auto_choice():
    rng = np.random.default_rng(1)
    segmentation = rng.integers(0, 30, size=(20, 20, 20)).astype(np.uint8)
    ct = rng.integers(-1024, 2000, size=(20, 20, 20)).astype(np.int16)
    mri = rng.integers(0, 4000, size=(20, 20, 20)).astype(np.uint16)
    assert auto_transfer(segmentation) == "labels"
    assert auto_transfer(ct) == "ct-soft" and auto_transfer(ct.astype(np.float32)) == "ct-soft"
    assert auto_transfer(mri) == "mri" and auto_transfer(mri.astype(np.float64) / 7) == "mri"
    assert auto_transfer(mri, has_label_table=True) == "labels"
    with pytest.raises(ConfigError, match="chosen from the volume"):
        load_transfer("auto")

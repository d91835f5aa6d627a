"""The issue's bad volume inputs: one error line each, a non-zero exit, and nothing written."""

from __future__ import annotations

import numpy as np
import pytest

from tests.support.cli import one_error_line
from tests.support.volumes import asymmetric_phantom, ellipsoid_field, write_dicom_series, write_vti

ARRAY = ("--grid", "square", "--lenses", "16x12", "--ppl", "4x4", "--pixel-pitch", "0.2", "--focal", "2",
         "--quality", "draft")


def _bad_file(folder, name, text="not a volume\n"):
    path = folder / name
    path.write_text(text)
    return path


CASES = {
    "unreadable vti": (lambda d: _bad_file(d, "bad.vti"), (), "cannot read 'bad.vti'"),
    "unreadable nifti": (lambda d: _bad_file(d, "bad.nii.gz"), (), "cannot read 'bad.nii.gz'"),
    "truncated nrrd": (lambda d: _bad_file(d, "bad.nrrd", "NRRD0004\ntype: short\ndimension: 3\nsizes: 4 5 6\n"
                                           "encoding: raw\nendian: little\n\n\0\1"), (), "bad.nrrd"),
    "empty folder": (lambda d: (d / "empty").mkdir() or d / "empty", (), "holds no DICOM image slices"),
    "npy without spacing": (lambda d: np.save(d / "a.npy", np.zeros((4, 4, 4))) or d / "a.npy", (),
                            "give --spacing SX,SY,SZ"),
    "bad spacing": (lambda d: np.save(d / "a.npy", np.zeros((4, 4, 4))) or d / "a.npy", ("--spacing", "1,0,1"),
                    "three positive voxel sizes"),
    "iso out of range": (lambda d: write_vti(ellipsoid_field((4.0, 4.0, 4.0), (1.0, 1.0, 1.0), (10, 10, 10)),
                                             d / "e.vti"),
                         ("--iso", "5"), "outside the data range of e.vti, -"),
    "scalar data, nothing chosen": (lambda d: write_vti(ellipsoid_field((4.0, 4.0, 4.0), (1.0, 1.0, 1.0),
                                                                        (10, 10, 10)), d / "e.vti"),
                                    (), "say what to draw: --iso VALUE"),
    "missing label": (lambda d: write_vti(asymmetric_phantom(), d / "p.vti"), ("--labels", "2,8"),
                      "label 8 not in p.vti; it has 1, 2, 3"),
    "labels and iso": (lambda d: write_vti(asymmetric_phantom(), d / "p.vti"), ("--labels", "--iso", "1"),
                       "--labels and --iso exclude each other"),
    "mixed dicom series": (lambda d: write_dicom_series(asymmetric_phantom(dtype="int16"), d / "dcm", uid="1.2.9")
                           and write_dicom_series(asymmetric_phantom(dtype="int16"), d / "dcm", uid="1.2.8"),
                           (), "holds 2 DICOM series; pick one with --series UID: 1.2."),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_volume_input_is_one_line_and_writes_nothing(cli, tmp_path, case):
    make, options, expected = CASES[case]
    source = make(tmp_path)
    out = tmp_path / "out" / "h3d.png"
    out.parent.mkdir()
    result = cli("render", source, "-o", out, *options, *ARRAY)
    line = one_error_line(result)
    assert expected in line, line
    assert sorted(p.name for p in out.parent.iterdir()) == []


def test_an_existing_output_is_left_as_it_was(cli, tmp_path):
    out = tmp_path / "h3d.png"
    out.write_bytes(b"the user's image")
    result = cli("render", _bad_file(tmp_path, "bad.mha"), "-o", out, *ARRAY)
    assert "not a MetaImage file" in one_error_line(result)
    assert out.read_bytes() == b"the user's image"


@pytest.mark.povray
def test_series_picks_one_of_several(cli, tmp_path):
    folder = tmp_path / "dcm"
    write_dicom_series(asymmetric_phantom(dtype="int16"), folder, uid="1.2.9", description="a")
    write_dicom_series(asymmetric_phantom(dtype="int16"), folder, uid="1.2.8", description="b")
    result = cli("render", folder, "-o", tmp_path / "s.png", "--series", "1.2.8", "--iso", "0.5", *ARRAY)
    assert result.code == 0, result.err

"""Every volume format read back as written: values, spacing, origin and direction (LPS)."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.errors import ConfigError, InputError
from povh3d.volume.read import is_polydata_vtk, is_volume_source, read_volume
from tests.support.volumes import (asymmetric_phantom, turn, write_dicom_series, write_legacy_vtk, write_meta,
                                   write_nifti, write_nifti_qform_flipped, write_nrrd, write_vti)

WRITERS = {
    "phantom.vti": write_vti, "phantom.mha": write_meta, "phantom.mhd": write_meta,
    "phantom.nrrd": write_nrrd, "phantom.nhdr": write_nrrd, "phantom.nii": write_nifti,
    "phantom.nii.gz": write_nifti,
}


def assert_same(read, written, *, values_equal=True):
    assert read.shape == written.shape
    if values_equal:
        assert np.array_equal(read.values, written.values)
    assert read.spacing == pytest.approx(written.spacing, abs=1e-6)
    assert read.origin == pytest.approx(written.origin, abs=1e-5)
    assert np.allclose(read.direction, written.direction, atol=1e-6)
    # The oracle that matters: every voxel centre lands where it was written.
    assert np.allclose(read.corners(), written.corners(), atol=1e-4)


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_formats_round_trip_with_orientation(tmp_path, name):
    volume = asymmetric_phantom(direction=turn(30.0))
    path = WRITERS[name](volume, tmp_path / name)
    assert is_volume_source(path)
    assert_same(read_volume(path), volume)


def test_legacy_vtk_round_trips_without_direction(tmp_path):
    volume = asymmetric_phantom()
    path = write_legacy_vtk(volume, tmp_path / "phantom.vtk")
    assert not is_polydata_vtk(path)
    assert_same(read_volume(path), volume)


def test_nifti_ras_becomes_lps(tmp_path):
    # The file stores RAS: the patient's left is -x there; the voxel written at the left marker must
    # come back at +x in LPS (a mirror here would put it on the right).
    volume = asymmetric_phantom()
    path = write_nifti(volume, tmp_path / "p.nii")
    import struct
    srow_x = struct.unpack_from("<4f", path.read_bytes(), 280)
    assert srow_x[0] < 0                         # RAS in the file: i runs towards -x_RAS (left)
    read = read_volume(path)
    left = np.argwhere(read.values == 2).mean(axis=0)
    world = read.index_to_world() @ np.append(left, 1.0)
    body = read.index_to_world() @ np.append(np.argwhere(read.values == 1).mean(axis=0), 1.0)
    assert world[0] > body[0] + 5                # LPS: left is +x


def test_nifti_qform_with_reversed_slices(tmp_path):
    # qfac = -1: the k axis runs towards the feet.  Every voxel must land at RAS offset + (i, 1.5 j, -2 k).
    volume = asymmetric_phantom()
    read = read_volume(write_nifti_qform_flipped(volume, tmp_path / "q.nii", (10.0, 20.0, 30.0)))
    for label in (1, 2, 3):
        written = np.argwhere(volume.values == label).mean(axis=0)
        ras = np.array([10.0, 20.0, 30.0]) + written * np.array([1.0, 1.5, -2.0])
        found = read.index_to_world() @ np.append(np.argwhere(read.values == label).mean(axis=0), 1.0)
        assert found[:3] == pytest.approx(ras * [-1, -1, 1])


def test_nrrd_in_ras_space(tmp_path):
    volume = asymmetric_phantom(direction=turn(-20.0))
    assert_same(read_volume(write_nrrd(volume, tmp_path / "r.nrrd", space="right-anterior-superior")), volume)


def test_dicom_series_sorted_and_rescaled(tmp_path):
    volume = asymmetric_phantom(direction=turn(15.0), dtype="int16")
    folder = write_dicom_series(volume, tmp_path / "dicom")
    read = read_volume(folder)
    assert_same(read, volume)


def test_npy_needs_spacing(tmp_path):
    volume = asymmetric_phantom()
    path = tmp_path / "p.npy"
    np.save(path, volume.values)
    with pytest.raises(ConfigError, match="spacing"):
        read_volume(path)
    read = read_volume(path, spacing="1,1.5,2")
    assert read.spacing == (1.0, 1.5, 2.0) and np.array_equal(read.values, volume.values)


def test_several_dicom_series_are_listed_and_one_picked(tmp_path):
    volume = asymmetric_phantom(dtype="int16")
    folder = tmp_path / "mixed"
    write_dicom_series(volume, folder, uid="1.2.3.4.1", description="bone")
    write_dicom_series(asymmetric_phantom(dtype="int16", direction=turn(90)), folder, uid="1.2.3.4.2",
                       description="soft")
    with pytest.raises(ConfigError) as error:
        read_volume(folder)
    message = str(error.value)
    assert "1.2.3.4.1 (bone, 16 slices)" in message and "1.2.3.4.2 (soft, 16 slices)" in message
    assert "\n" not in message
    assert_same(read_volume(folder, series="1.2.3.4.1"), volume)
    with pytest.raises(ConfigError, match="no DICOM series '9.9'"):
        read_volume(folder, series="9.9")


def test_unreadable_files_are_input_errors(tmp_path):
    for name in ("bad.vti", "bad.nii", "bad.mha", "bad.nrrd", "bad.vtk"):
        (tmp_path / name).write_text("not a volume\n")
        with pytest.raises(InputError):
            read_volume(tmp_path / name)
    with pytest.raises(InputError, match="no DICOM"):
        (tmp_path / "empty").mkdir()
        read_volume(tmp_path / "empty")


def test_slicer_segmentation_label_table(tmp_path):
    # 3D Slicer writes its segment names and colours as NRRD key:=value fields.
    import nrrd

    volume = asymmetric_phantom()
    path = tmp_path / "seg.nrrd"
    header = {"space": "left-posterior-superior", "space directions": np.diag(volume.spacing),
              "space origin": np.asarray(volume.origin), "Segment0_LabelValue": "2", "Segment0_Name": "marker",
              "Segment0_Color": "1 0.5 0", "Segment1_LabelValue": "1", "Segment1_Name": "body"}
    nrrd.write(str(path), volume.values, header)
    read = read_volume(path)
    assert read.label_names == {2: "marker", 1: "body"}
    assert read.label_colours == {2: (1.0, 0.5, 0.0)}


def test_a_missing_dicom_slice_is_refused(tmp_path):
    folder = write_dicom_series(asymmetric_phantom(dtype="int16"), tmp_path / "gap", uid="1.2.3")
    sorted(folder.iterdir())[5].unlink()
    with pytest.raises(InputError, match="unevenly spaced .*2 to 4 mm"):
        read_volume(folder)


@pytest.mark.parametrize("kind", ["npy", "nrrd", "nii", "mha", "dicom", "vtk"])
def test_the_header_tells_the_voxels_before_they_are_read(tmp_path, kind):
    """``volume_size`` from the header alone equals the voxels the reading gives (issue 38: the memory
    is weighed before the reading); a legacy VTK file's header does not tell (None, never a wrong count)."""
    from povh3d.volume.read import read_volume, volume_size
    from tests.support.volumes import (asymmetric_phantom, write_dicom_series, write_legacy_vtk, write_meta,
                                       write_nifti, write_nrrd)

    volume = asymmetric_phantom(dtype="int16")
    if kind == "npy":
        path = tmp_path / "v.npy"
        np.save(path, volume.values)
    elif kind == "dicom":
        path = write_dicom_series(volume, tmp_path / "series")
    else:
        writer = {"nrrd": write_nrrd, "nii": write_nifti, "mha": write_meta, "vtk": write_legacy_vtk}[kind]
        path = writer(volume, tmp_path / f"v.{kind}")
    size = volume_size(path)
    if kind == "vtk":
        assert size is None
        return
    spacing = (1.0, 1.0, 1.0) if kind == "npy" else None
    assert size is not None and size[0] == read_volume(path, spacing=spacing).values.size == volume.values.size
    assert size[1] in (2, 8)


@pytest.mark.povray
def test_a_volume_past_the_memory_budget_is_refused_before_it_is_read(tmp_path, cli):
    """Its estimate (voxels times their bytes and 12 more, measured) against --max-memory, before a voxel
    is read; the control, the same volume with room, renders."""
    from tests.support.cli import one_error_line

    z, y, x = np.mgrid[:96, :96, :96] / 96 - 0.5
    path = tmp_path / "ball.npy"
    np.save(path, ((np.sqrt(x * x + y * y + z * z) < 0.35) * 1000).astype(np.int16))   # 12 MB estimated
    args = ["render", path, "--spacing", "1,1,1", "--iso", "500", "--preset", "demo", "--quality", "draft",
            "-o", tmp_path / "v.png"]
    line = one_error_line(cli(*args, "--max-memory", "8M"), 2)
    assert "reading the volume ball.npy" in line and "--max-memory" in line, line
    assert not (tmp_path / "v.png").exists()
    ok = cli(*args, "--max-memory", "2G")
    assert ok.code == 0, ok.err


@pytest.mark.parametrize("kind", ["npy", "dicom"])
def test_the_reading_weighs_the_volume_before_reading_it(tmp_path, kind):
    """``read_volume(weigh=...)`` is told the size once, from the headers it reads anyway (a DICOM
    series' headers are not read twice), and a refusal there stops the reading."""
    from povh3d.volume.read import read_volume
    from tests.support.volumes import asymmetric_phantom, write_dicom_series

    volume = asymmetric_phantom(dtype="int16")
    if kind == "npy":
        path = tmp_path / "v.npy"
        np.save(path, volume.values)
    else:
        path = write_dicom_series(volume, tmp_path / "series")
    told: list[tuple[int, int]] = []
    read = read_volume(path, spacing=(1.0, 1.0, 1.0) if kind == "npy" else None, weigh=lambda *s: told.append(s))
    assert told == [(read.values.size, 2)]

    def refuse(voxels: int, itemsize: int) -> None:
        raise ConfigError("too big")

    with pytest.raises(ConfigError, match="too big"):   # negative control: the weigher decides
        read_volume(path, spacing=(1.0, 1.0, 1.0) if kind == "npy" else None, weigh=refuse)

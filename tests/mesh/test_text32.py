"""Mesh numbers in single precision (issue 17): the shortest text POV-Ray reads back to the same
float32, checked against Python's correctly rounded parse and against POV-Ray itself."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.errors import ConfigError
from povh3d.mesh.numbers import format_vectors
from povh3d.mesh.text32 import HIGH, LOW, format_vectors32
from povh3d.povray.process import PovrayJob, run_jobs

_NUMBER = re.compile(r"-?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?")


def numbers(text: str) -> list[str]:
    return _NUMBER.findall(text)


def read_back(text: str) -> np.ndarray:
    """What POV-Ray keeps: each number parsed to a double, then rounded to a float."""
    return np.array([float(t) for t in numbers(text)], dtype=np.float64).astype(np.float32)


def digits(text: str) -> int:
    mantissa = text.lstrip("-").split("e")[0].replace(".", "").strip("0")
    return max(1, len(mantissa))


finite32 = st.floats(width=32, allow_nan=False, allow_infinity=False)


@given(st.lists(st.tuples(finite32, finite32, finite32), min_size=1, max_size=40))
@settings(max_examples=300, deadline=None)
def test_every_float32_reads_back_exactly(rows):
    values = np.array(rows, dtype=np.float32)
    text = format_vectors32(values)
    np.testing.assert_array_equal(read_back(text), values.ravel() + np.float32(0))


def test_shortest_digits_and_layout():
    rng = np.random.default_rng(1)
    values = (rng.standard_normal((2000, 3)) * 10 ** rng.uniform(-8, 8, (2000, 3))).astype(np.float32)
    text = format_vectors32(values)
    # as few significant digits as NumPy's shortest float32 repr (Ryu-like, direct rounding)
    ours = [digits(t) for t in numbers(text)]
    shortest = [digits(np.format_float_scientific(v, unique=True)) for v in values.ravel()]
    assert ours == shortest
    # far shorter than the double repr of the same values, in the same layout
    double = format_vectors(values.astype(np.float64))
    assert len(text) < 0.75 * len(double)
    assert text.count("\n") == double.count("\n") and text.count("<") == 2000
    assert format_vectors32(np.array([[0.5, -0.0, 120.0], [1e-5, 3e9, 0.125]])) == \
        "<.5, 0, 120>, <1e-5, 3e9, .125>"
    assert format_vectors32(np.array([[1, -2, 30]]), per_line=1) == "<1, -2, 30>"


def test_out_of_range_and_bad_numbers():
    values = np.array([[LOW / 10, 1.0, 2.0], [HIGH * 10, 0.0, 1e-30]], dtype=np.float32)
    np.testing.assert_array_equal(read_back(format_vectors32(values)), values.ravel())  # double repr path
    with pytest.raises(ConfigError):
        format_vectors32(np.array([[np.nan, 0.0, 0.0]]))
    assert format_vectors32(np.zeros((0, 3))) == ""


def _scaled(x: float) -> int:
    """The power of two that makes float32 `x` an integer below 2**53 (so POV-Ray prints it exactly)."""
    return 23 - math.frexp(x)[1] + 1 if x else 0


@pytest.mark.povray
def test_povray_itself_reads_the_same_floats(workdir):
    # One triangle per value, the value its lowest x: min_extent is POV-Ray's float bounding box,
    # so it shows the float POV-Ray stored.  Printed times a power of two, as an exact integer.
    # Bounding boxes stop at POV-Ray's BOUND_HUGE (2e10): values stay below 1e10.
    rng = np.random.default_rng(7)
    values = np.concatenate([
        (rng.standard_normal(120) * 10 ** rng.uniform(-12, 9.5, 120)),  # every form: 12e-9, .0125, 12.5, 3e9
        rng.uniform(-100, 100, 120),                                  # model coordinates, mm
        [0.1, 1 / 3, 16777217.0, 1e-5, 7e9, -2.5e-13],
    ]).astype(np.float32)
    texts = numbers(format_vectors32(np.column_stack([values, values, values])))[::3]
    lines = ["#version 3.7;", "camera { location <0, 0, -10> look_at 0 }"]
    for i, (value, text) in enumerate(zip(values, texts)):
        far = 4 * abs(float(value)) + 1
        lines.append(f"#declare M = mesh2 {{ vertex_vectors {{ 3, <{text}, 0, 0>, <{far!r}, 1, 0>, "
                     f"<{far!r}, 0, 1> }} face_indices {{ 1, <0, 1, 2> }} }}")
        lines.append(f'#debug concat("V{i} ", str(min_extent(M).x * pow(2, {_scaled(float(value))}), 0, 0), "\\n")')
    job = PovrayJob("float32 round trip", "\n".join(lines) + "\n", 4, 4, options=("-A",))
    logs: list[str] = []
    run_jobs([job], processes=1, on_result=lambda r: logs.append(r.log), workdir=workdir)
    got = dict(re.findall(r"^V(\d+) (-?\d+)$", logs[0], re.MULTILINE))
    assert len(got) == len(values)
    for i, value in enumerate(values):
        assert int(got[str(i)]) == float(value) * 2.0 ** _scaled(float(value)), (i, value, texts[i])
    # POV-Ray keeps floats, not the doubles it parsed: "0.1" is stored as float32(0.1), which is not 0.1
    assert int(got["240"]) == 13421773 != 0.1 * 2.0 ** _scaled(0.1)


@pytest.mark.parametrize("seed", range(6))
def test_numpy_path_writes_the_kernels_text(seed):
    # The NumPy-and-Python writer (a process's first numbers) against the numba kernel, character for
    # character: every form (120, 12e5, 12.5, .0125), signs, zeros, the out-of-range slots ("@").
    from povh3d.mesh.text32 import _POW10, _small_rows, _write_rows

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 2000))
    values = (rng.standard_normal((n, 3)) * 10 ** rng.uniform(-16, 16, (n, 3))).astype(np.float32)
    values[rng.random((n, 3)) < 0.05] = 0
    values = values.astype(np.float64)
    kernel = _write_rows()(values, 3, _POW10, False).tobytes().decode("ascii")
    assert _small_rows(values, 3, False) == kernel
    ints = rng.integers(-10 ** 6, 10 ** 6, (n, 3))
    assert _small_rows(ints, 4, True) == _write_rows()(ints, 4, _POW10, True).tobytes().decode("ascii")
    # Negative control: Python's shortest double repr is another text.
    assert _small_rows(values, 3, False) != format_vectors(values, per_line=3)


def test_the_python_path_stops_at_small_numbers(monkeypatch):
    # A process writes at most SMALL numbers in Python, then loads the kernel (the same text either way).
    import sys

    from povh3d.mesh import text32

    monkeypatch.delitem(sys.modules, "povh3d.mesh.kernels", raising=False)
    monkeypatch.setattr(text32, "_written_in_python", [0])
    monkeypatch.setattr(text32, "SMALL", 10)
    calls = []
    monkeypatch.setattr(text32, "_small_rows", lambda *a: calls.append(a[0].size) or "")
    monkeypatch.setattr(text32, "_write_rows", lambda: lambda *a: calls.append(-a[0].size) or np.zeros(0, np.uint8))
    for _ in range(3):
        format_vectors32(np.ones((2, 3)))
    assert calls == [6, -6, -6]


def test_without_numba_every_number_takes_the_python_path(monkeypatch):
    # numba is optional (povh3d[mesh]): past SMALL numbers a process without it keeps writing in Python.
    import sys

    from povh3d.mesh import text32

    monkeypatch.delitem(sys.modules, "povh3d.mesh.kernels", raising=False)
    monkeypatch.setattr(text32, "_written_in_python", [0])
    monkeypatch.setattr(text32, "SMALL", 10)
    monkeypatch.setattr(text32, "installed", lambda module: module != "numba")
    calls = []
    monkeypatch.setattr(text32, "_small_rows", lambda *a: calls.append(a[0].size) or "")
    monkeypatch.setattr(text32, "_write_rows", lambda: lambda *a: calls.append(-a[0].size) or np.zeros(0, np.uint8))
    for _ in range(3):
        format_vectors32(np.ones((2, 3)))
    assert calls == [6, 6, 6]

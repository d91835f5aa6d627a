"""Hostile command lines: every subcommand, driven by hypothesis with random and hostile
arguments and files, ends in one line and an exit code, never a traceback, and never
changes or removes a file that was there before unless it succeeded in writing that
very output.

The files are empty, truncated, of the wrong type, claim a huge size, and sit under
non-ASCII and space-containing paths.  Renders use a tiny panel and draft quality so
that the few command lines that succeed stay fast.  ``CASES`` counts the command lines
run (docs/reliability.md quotes it).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import resource
import shutil
import struct
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from povh3d.renderer.records import base_record, write_image
from povh3d.renderer.outputs.views import write_views
from povh3d.cli.main import build_parser
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.interleave import extract
from povh3d.calibration.gridfile import write_grid
from povh3d.calibration.lattice import calibrate
from tests.support.cli import run_in_process, run_subprocess
from tests.support.synth import WhiteSpec, render_white, to_uint

# Cases of each kind: a cheap subset in ``make test``; ``make fuzz`` runs 2,000 (docs/reliability.md).
LINES = int(os.environ.get("POVH3D_FUZZ_LINES", "100"))          # command lines, in this process
DAMAGED = int(os.environ.get("POVH3D_FUZZ_DAMAGED", "100"))      # damaged files, in this process
PROCESSES = int(os.environ.get("POVH3D_FUZZ_PROCESSES", "6"))    # command lines, as a process of their own
SECONDS, BYTES = 60, 2 * 1024**3                                  # every case's bounds
TINY = ["--preset", "demo", "--lenses", "4x3", "--ppl", "2", "--quality", "draft", "-q", "--timeout", "5"]
# Options whose real values would leave this machine or run for minutes; the fuzz
# gives them only values that must be refused.
SLOW = {"--scheduler", "--reference-samples", "--max-error", "--fps"}
NUMBERS = ["0", "-1", "1", "2", "3", "2x2", "4x3", "0.5", "-0.5", "nan", "inf", "-inf", "1e308", "1e-308",
           "100000x100000", "", " ", "abc", "é", "8x", "x8", "1:2", "2:1", "0:1", "0x0", "3.5x2"]
FILES = ["white.png", "grid.json", "good.png", "good.json", "empty.png", "truncated.png", "text.png", "huge.png", "scene.pov",
         "broken.pov", "Téléchargements/scène 1.pov", "model.obj", "bad.obj", "garbage.json", "views",
         "dossier é", "missing.png", "missing/x.png", "sub dir/é.png", "out.png", "out.gif", "out.json",
         "out dir", "new views"]
OUTPUTS = ["out.png", "good.png", "sub dir/é.png", "missing/out.png", "dossier é", "out.json", "out.gif",
           "new views", "views", "out.inc", "out.mp4"]
# Values that make sense, so that half the cases get past parsing into the work itself.
GOOD = {
    "--ppl": ["8x8", "8", "2", "4x4"], "--ppl-out": ["4", "4x4", "2"], "--quilt": ["8x8", "4x2", "2x2"],
    "--mapping": ["alioscopy", "philips", "slanted", "smart:4"], "--grid": ["grid.json"],
    "--depth": ["2", "-1", "0"], "--lenses": ["4x3", "3x2"], "--panel-size": ["32x24", "64x48"],
    "--views-dir": ["new views", "views", "Téléchargements"], "--frames": ["0:1", "1:0", "0:2"],
    "--clock": ["0:1", "1:1"], "--pixel-pitch": ["0.1", "0.05"], "--focal": ["1.5", "3"],
    "--sweep": ["2", "3"], "--near": ["-1"], "--far": ["1"], "--timeout": ["0.01", "2"],
    # pinhole runs one camera per lens and multi-ortho-views one per view: slow, and
    # their failures are those of multi-ortho
    "--method": ["multi-ortho", "single-stage", "bogus"],
    "--include": ["Téléchargements", "dossier é"], "--video": ["out.mp4", "out.gif"],
}
GOOD_POSITIONAL = {"render": ["scene.pov", "Téléchargements/scène 1.pov", "model.obj", "broken.pov"],
                   "convert-mesh": ["model.obj", "bad.obj"], "interleave": ["views"],
                   "layout": ["scene.pov", "model.obj", "broken.pov", "Téléchargements/scène 1.pov"]}
GOOD_OUTPUT = {"render": ["out.png", "good.png", "sub dir/é.png"], "extract": ["new views", "views"],
               "quilt": ["dossier é", "new views"], "viewpoints": ["new views"], "calibrate": ["out.json"],
               "preview": ["out.gif"], "convert-mesh": ["out.inc", "sub dir/é.inc"],
               "layout": ["out.png", "good.png", "sub dir/é.png"]}
CASES = {"run": 0, "failed": 0, "damaged": 0, "processes": 0, "slowest": 0.0}


def _png_header(width: int, height: int) -> bytes:
    """A PNG signature and IHDR claiming ``width x height`` RGB pixels, with no pixel data."""
    body = b"IHDR" + struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + body + struct.pack(">I", zlib.crc32(body))


def _make_files(root: Path) -> None:
    array = LensArray("square", 4, 3, 0.8, 0.8, 1.5, Panel(32, 24, 0.1, 0.1))
    rng = np.random.default_rng(7)
    image = rng.integers(0, 256, (24, 32, 3), dtype=np.uint8)
    write_image(root / "good.png", image, base_record("h3d", array))
    write_views(root / "views", extract(image, (8, 8)), array)
    data = (root / "good.png").read_bytes()
    (root / "empty.png").write_bytes(b"")
    (root / "truncated.png").write_bytes(data[: len(data) // 2])
    (root / "text.png").write_text("not a picture\n")
    (root / "huge.png").write_bytes(_png_header(100000, 100000))
    scene = ("#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\nlight_source { <0, 0, -50> rgb 1 }\n"
             "sphere { <0, 0, 0>, 1 pigment { rgb 1 } }\n")
    (root / "scene.pov").write_text(scene)
    (root / "broken.pov").write_text("sphere { <0, 0, 0>, \n")
    (root / "Téléchargements").mkdir()
    (root / "Téléchargements" / "pièce.inc").write_text("sphere { <0, 0, 0>, 1 pigment { rgb 1 } }\n")
    (root / "Téléchargements" / "scène 1.pov").write_text(
        "#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\nlight_source { <0, 0, -50> rgb 1 }\n"
        '#include "pièce.inc"\n')
    (root / "model.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    (root / "bad.obj").write_bytes(b"\x00\xff garbage\nf 1 2 3\n")
    (root / "garbage.json").write_text("{not json")
    (root / "dossier é").mkdir()
    white = to_uint(render_white(WhiteSpec((96, 72), pitch_px=6.37, supersample=2)))
    write_image(root / "white.png", white, base_record("capture"))
    write_grid(root / "grid.json", calibrate(white))
    (root / "sub dir").mkdir()


def _snapshot(root: Path) -> dict[str, tuple[str, int]]:
    out = {}
    for path in root.rglob("*"):
        if path.is_file():
            out[str(path.relative_to(root))] = (hashlib.sha256(path.read_bytes()).hexdigest(),
                                                path.stat().st_mode)
    return out


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


COMMANDS = _commands()


@st.composite
def command_lines(draw) -> list[str]:
    name = draw(st.sampled_from(sorted(COMMANDS)))
    parser = COMMANDS[name]
    args = [name]
    options = [a for a in parser._actions if a.option_strings and a.dest not in ("help",)]
    positionals = [a for a in parser._actions if not a.option_strings]
    for action in positionals:
        args.append(draw(st.sampled_from(GOOD_POSITIONAL.get(name, ["good.png"])) | st.sampled_from(FILES)))
    if name == "render":
        args += TINY
    if any("-o" in a.option_strings for a in options):
        args += ["-o", draw(st.sampled_from(GOOD_OUTPUT.get(name, ["out.png"])) | st.sampled_from(OUTPUTS))]
    required = [a for a in options if a.required and "-o" not in a.option_strings]
    chosen = draw(st.lists(st.sampled_from(options), max_size=3)) if options else []
    for action in required + chosen:
        flag = next((f for f in action.option_strings if f.startswith("--")), action.option_strings[-1])
        if action.nargs == 0:
            args.append(flag)
        elif action.choices and flag not in ("--quality", "--method"):
            args += [flag, draw(st.sampled_from([*map(str, action.choices), "bogus"]))]
        elif flag == "--method":
            args += [flag, draw(st.sampled_from(GOOD[flag]))]
        elif flag == "--quality":
            args += [flag, draw(st.sampled_from(["draft", "bogus", "normal"]))]
        elif flag in SLOW:
            args += [flag, draw(st.sampled_from(["nan", "-1", "", "abc"]))]
        elif flag in GOOD and draw(st.booleans()):
            args += [flag, draw(st.sampled_from(GOOD[flag]))]
        else:
            args += [flag, draw(st.sampled_from(NUMBERS) | st.sampled_from(FILES))]
    if name == "bench":  # the bench renders every method at every quality: only its failures here
        args[1] = draw(st.sampled_from(["broken.pov", "missing.png", "garbage.json", "huge.png"]))
    return args


def _changed(before: dict, after: dict) -> list[str]:
    return sorted(name for name, value in before.items() if after.get(name) != value)


def _may_change(name: str, args: list[str]) -> bool:
    """A run that succeeded may replace what it was asked to write (and the sidecar beside it)."""
    path = Path(name)
    named = {Path(a) for a in args}
    return path in named or path.with_suffix(".png") in named or path.with_suffix(".gif") in named \
        or any(parent in named for parent in path.parents if str(parent) != ".")


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    root = tmp_path_factory.mktemp("fuzz-pristine")
    _make_files(root)
    return root


def _peak_bytes() -> int:
    """The largest resident size this process or any child it waited for (POV-Ray) has had."""
    return 1024 * max(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
                      resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)


def _cpu_seconds() -> float:
    """CPU time of this process and of the children it waited for (POV-Ray), user and system."""
    return sum(u.ru_utime + u.ru_stime for u in map(resource.getrusage, (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)))


def _wall_limit() -> float:
    """60 s on an idle machine; in proportion to the load average per core when other work shares the cores."""
    return SECONDS * max(1.0, os.getloadavg()[0] / (os.cpu_count() or 1))


def _bounded(run, args: list[str], work: Path):
    """``run(args)`` in ``work``, checked against the bounds every case keeps: 60 s of CPU, 60 s of
    wall time on an idle machine (more in proportion when other work loads the cores), 2 GB.  The
    peak sizes only grow, so a peak under 2 GB after the case is one under 2 GB during it."""
    start, cpu = time.monotonic(), _cpu_seconds()
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(work)
        result = run(args)  # in this process: an exception escaping main fails the test here
    seconds, cpu = time.monotonic() - start, _cpu_seconds() - cpu
    CASES["slowest"] = max(CASES["slowest"], seconds)
    CASES["most_cpu"] = max(CASES.get("most_cpu", 0.0), cpu)
    assert cpu < SECONDS, (args, cpu)
    assert seconds < _wall_limit(), (args, seconds)
    assert _peak_bytes() < BYTES, (args, _peak_bytes())
    return result


def _one_line_or_output(args: list[str], result, before: dict, after: dict, *extra) -> None:
    """One final error line and every file untouched, or success and only the asked-for outputs changed."""
    assert "Traceback" not in result.err, (args, *extra, result.err)
    assert "internal error" not in result.err, (args, *extra, result.err)
    if result.code != 0:
        lines = [line for line in result.err.splitlines() if line.strip()]
        errors = [line for line in lines if line.startswith("povh3d: error: ")]
        assert len(errors) == 1 and errors[0] == lines[-1], (args, *extra, result.err)
        assert not _changed(before, after), (args, *extra, _changed(before, after), result.err)
    else:
        assert all(_may_change(name, args) for name in _changed(before, after)), \
            (args, *extra, _changed(before, after))


def _fresh(pristine: Path, work: Path) -> dict:
    if work.exists():
        shutil.rmtree(work)
    shutil.copytree(pristine, work)
    return _snapshot(work)


def _one_case(args: list[str], pristine: Path, work: Path) -> None:
    """One command line run in a fresh copy of ``pristine``: one error line or the asked-for output."""
    before = _fresh(pristine, work)
    if os.environ.get("POVH3D_FUZZ_LOG"):
        with open(os.environ["POVH3D_FUZZ_LOG"], "a", encoding="utf-8") as log:
            log.write(f"run\t{args}\n")
    result = _bounded(lambda a: run_in_process(*a), args, work)
    after = _snapshot(work)
    CASES["run"] += 1
    if os.environ.get("POVH3D_FUZZ_LOG"):  # to see what the cases reach: one line per case
        with open(os.environ["POVH3D_FUZZ_LOG"], "a", encoding="utf-8") as log:
            log.write(f"{result.code}\t{args}\t{(result.err.strip().splitlines() or [''])[-1]}\n")
    CASES["failed"] += result.code != 0
    _one_line_or_output(args, result, before, after)


@pytest.fixture(scope="module")
def fuzz(pristine, tmp_path_factory):
    """The hypothesis run, once per module whichever of its two tests comes first: the count of
    command lines it ran and the error it ended in (None when every case passed)."""
    work = tmp_path_factory.mktemp("fuzz-work") / "w"

    @settings(max_examples=LINES, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow])
    @given(args=command_lines())
    def run_cases(args):
        _one_case(args, pristine, work)

    CASES.update(run=0, failed=0)
    with pytest.MonkeyPatch.context() as patch:  # set up before any test's own cache folder
        patch.setenv("POVH3D_CACHE", str(tmp_path_factory.mktemp("fuzz-cache")))
        try:
            run_cases()
        except Exception as error:  # noqa: BLE001 - reported by the test that owns it
            return dict(CASES), error
    return dict(CASES), None


@pytest.mark.povray
def test_hostile_command_lines_end_in_one_line(fuzz):
    cases, error = fuzz
    if error is not None:
        raise error


@pytest.mark.povray
def test_fuzz_ran_every_case(fuzz):
    # The count of the hypothesis run of the fixture, whichever test asked for it first.
    cases, _ = fuzz
    assert cases["run"] >= LINES * 0.9, cases
    print(f"fuzz: {cases['run']} command lines, {cases['failed']} refused, 0 tracebacks")


@pytest.mark.povray
@settings(max_examples=PROCESSES, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(args=command_lines())
def test_fuzzed_command_lines_as_a_process_end_by_their_exit_code(args, pristine, tmp_path):
    """The command as users run it (``python -m povh3d.cli``, its own process): the exit code the
    in-process runs read from SystemExit is the process's, never an end by signal, and the same
    one line or output."""
    env = {"POVH3D_CACHE": str(tmp_path / "cache")}
    before = _fresh(pristine, tmp_path / "p")
    done = _bounded(lambda a: run_subprocess(*a, cwd=tmp_path / "p", env=env, timeout=_wall_limit()), args, tmp_path / "p")
    CASES["processes"] += 1
    assert done.code >= 0, (args, done.code, done.err)  # negative: ended by a signal
    _one_line_or_output(args, done, before, _snapshot(tmp_path / "p"), "as a process")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("POVH3D_CACHE", env["POVH3D_CACHE"])
        _fresh(pristine, tmp_path / "i")
        inside = _bounded(lambda a: run_in_process(*a), args, tmp_path / "i")
    if "did not finish within" not in done.err + inside.err:  # a timeout depends on the machine's load
        assert inside.code == done.code, (args, inside.err, done.err)


# -- damaged and forged files: sidecars, views folders, calibration files ------------------------------
DAMAGED_FILES = ["good.json", "views/views.json", "grid.json"]
BAD_VALUES = ["abc", "", None, 0, -1, 0.0, 1e308, -1e308, float("nan"), float("inf"), True, [], [0, 0], [1],
              [float("nan"), 1], ["a", "b"], {}, {"x": 1}, [[0, 0], [0, 0]], 10**12, 2.5]
# Which commands read each file, with the arguments that make them read it.
READERS = {
    "good.json": [["map", "good.png", "-o", "out.png", "--mapping", "alioscopy"],
                  ["resample", "good.png", "-o", "out.png", "--ppl-out", "4"],
                  ["refocus", "good.png", "-o", "out.png", "--depth", "1"],
                  ["refocus", "good.png", "-o", "out.png", "--sweep", "2"],
                  ["preview", "good.png", "-o", "out.gif", "--frames", "2"],
                  ["extract", "good.png", "-o", "new views"],
                  ["quilt", "good.png", "-o", "dossier é", "--quilt", "2x2"]],
    "views/views.json": [["interleave", "views", "-o", "out.png"]],
    "grid.json": [["undistort", "white.png", "--grid", "grid.json", "-o", "out.png"],
                  ["borders", "white.png", "--grid", "grid.json", "-o", "out.png"],
                  ["viewpoints", "white.png", "--grid", "grid.json", "-o", "new views"]],
}


def _json_paths(value, prefix=()):
    """Every path to a value inside a JSON document (keys and list indices)."""
    yield prefix
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, item in items:
        if len(prefix) < 3:
            yield from _json_paths(item, (*prefix, key))


def _damage(document, path, bad):
    if not path:
        return bad
    target = document
    for key in path[:-1]:
        target = target[key]
    if bad is _DELETE:
        del target[path[-1]]
    else:
        target[path[-1]] = bad
    return document


_DELETE = object()


@st.composite
def damaged_cases(draw):
    name = draw(st.sampled_from(DAMAGED_FILES))
    return name, draw(st.integers(0, 10**6)), draw(st.sampled_from([*BAD_VALUES, _DELETE])), \
        draw(st.sampled_from([c for c in COMMANDS_READING(name)]))


def COMMANDS_READING(name):  # noqa: N802 - a table, spelt as one
    return [c for c in READERS[name] if c[0] in COMMANDS]


@settings(max_examples=DAMAGED, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=damaged_cases())
def test_damaged_sidecars_views_and_calibrations_end_in_one_line(case, pristine, tmp_path):
    """One field of a sidecar, a views.json or a calibration file replaced by a wrong type, a NaN, a
    zero, a huge number, or removed: one line or a success, never an internal error; under 60 s and
    2 GB each."""
    import json

    name, pick, bad, args = case
    work = tmp_path / "w"
    _fresh(pristine, work)
    document = json.loads((work / name).read_text(encoding="utf-8"))
    paths = [p for p in _json_paths(document) if p and p[-1] != "image_sha256"]
    path = paths[pick % len(paths)]
    (work / name).write_text(json.dumps(_damage(document, path, bad)), encoding="utf-8")
    before = _snapshot(work)
    result = _bounded(lambda a: run_in_process(*a), args, work)
    CASES["damaged"] += 1
    _one_line_or_output(args, result, before, _snapshot(work), path, bad)


def test_fuzz_summary():
    # Last in the file: what ``make fuzz`` reports (docs/reliability.md quotes it).
    print(f"\nfuzz: {CASES['run']} command lines ({CASES['failed']} refused), {CASES['damaged']} damaged files, "
          f"{CASES['processes']} command lines as processes; slowest case {CASES['slowest']:.1f} s "
          f"({CASES.get('most_cpu', 0.0):.1f} s of CPU at most), load {os.getloadavg()[0]:.1f}, "
          f"peak resident size {_peak_bytes() / 1024**2:.0f} MB")


def test_negative_control_a_removed_file_is_seen(tmp_path):
    (tmp_path / "a.png").write_bytes(b"x")
    before = _snapshot(tmp_path)
    (tmp_path / "a.png").unlink()
    assert _changed(before, _snapshot(tmp_path)) == ["a.png"]
    assert not _may_change("a.png", ["render", "s.pov", "-o", "b.png"])
    assert _may_change("b.json", ["render", "s.pov", "-o", "b.png"])

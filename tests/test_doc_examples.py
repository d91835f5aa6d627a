"""Every ``povh3d`` line of the README's and docs/commands.md's shell blocks, run (issue 38 item 9).

A line is a synopsis: ``[...]`` is optional (left out), ``a|b`` and ``{a,b}`` are choices (the
first taken), and capitals name the user's files (``SCENE.pov``: the bundled sample; ``H3D.png``:
a small render made first; ``VIEWS_DIR``: its views).  Renders get a small lens count where the
line gives none, so the whole runs in about a minute; each line runs as written otherwise, in
order, in one folder, so a line may read what an earlier one wrote.  Lines that need what this
machine has not (a Dask cluster) are listed in ``NOT_RUN`` with the reason, and that list is
checked against the docs too: a line that leaves the docs must leave it.
"""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import REPO, SAMPLES

DOCS = (REPO / "README.md", REPO / "docs" / "commands.md")
_BLOCK = re.compile(r"```(?:sh|bash|shell|console)\n(.*?)```", re.S)
_OPTIONAL = re.compile(r"\[[^\[\]]*\]")
_BRACES = re.compile(r"\{([^{},]*),[^{}]*\}")

#: Placeholders of the docs and what stands for them here.
FILES = {"SCENE.pov": "sample.pov", "SCENE": "sample.pov", "MODEL.glb": "still_life.glb",
         "MODEL.obj": "letter_f.obj", "MODEL": "letter_f.obj", "VOLUME.nrrd": "phantom.nrrd", "VOLUME": "phantom.nrrd",
         "NAME": "demo", "MM": "20", "IMG.png": "WHITE.png", "UNITS": "200"}
#: Values of an option whose placeholder is a vector.
VECTORS = {"--display-center": "0,0,0", "--display-normal": "0,0,1", "--display-up": "0,1,0", "--eye": "0,0,-300"}
#: Small sizes: the docs' counts, shortened where a line would run for minutes.
SHORTER = {"--frames 0:47": "--frames 0:1", "povh3d moire -o PLOT.png": "povh3d moire -o PLOT.png --slant-range 0:20:4"}
SMALL = ["--lenses", "6x4"]
#: Lines not run here, by their start, and why.
NOT_RUN = {"povh3d render SCENE.pov -o OUT.png --scheduler": "needs a Dask cluster (tests/povray/test_cluster.py)"}


def shell_lines(text: str) -> list[str]:
    """The commands of every shell block of ``text``: continuation lines joined, comments dropped,
    ``a; b`` split."""
    out = []
    for block in _BLOCK.findall(text):
        joined: list[str] = []
        for line in block.splitlines():
            line = re.split(r"\s#\s|^#", line)[0].rstrip()
            if not line.strip():
                continue
            if line[0].isspace() and joined:
                joined[-1] += " " + line.strip()
            else:
                joined.append(line.strip())
        out += [part.strip() for line in joined for part in line.split("; ")]
    return out


def povh3d_lines() -> list[tuple[str, str]]:
    return [(doc.name, line) for doc in DOCS for line in shell_lines(doc.read_text(encoding="utf-8"))
            if line.startswith(("povh3d ", ".venv/bin/povh3d "))]


def runnable(line: str) -> list[str]:
    """The arguments of a synopsis line: optional parts out, first choices, placeholders filled."""
    for short, small in SHORTER.items():
        line = line.replace(short, small)
    while _OPTIONAL.search(line):
        line = _OPTIONAL.sub("", line)
    line = _BRACES.sub(r"\1", line)
    args = shlex.split(line)[1:]
    out = []
    for i, arg in enumerate(args):
        if arg.startswith("--") and "=" in arg:
            name, value = arg.split("=", 1)
            arg = f"{name}={value.split('|')[0]}"
        elif "|" in arg:
            arg = arg.split("|")[0]
        if i and args[i - 1] in VECTORS:
            arg = VECTORS[args[i - 1]]
        out.append(FILES.get(arg, arg))
    if out[0] in ("render", "bench") and "--lenses" not in out and "looking-glass" not in " ".join(out):
        out += SMALL
    return out


def test_the_synopsis_reader():
    """The reader's own check, with a line that must change (its negative control: the raw line)."""
    line = "povh3d quilt H3D.png --quilt auto|8x6 [--rows centre|all] -o DIR   # a comment"
    (doc, parsed), = [("x", s) for s in shell_lines(f"```sh\n{line}\n```\n")]
    assert parsed == "povh3d quilt H3D.png --quilt auto|8x6 [--rows centre|all] -o DIR"
    assert runnable(parsed) == ["quilt", "H3D.png", "--quilt", "auto", "-o", "DIR"]
    assert runnable("povh3d render MODEL.{obj,stl} --iso=-500[,300] --display-normal X,Y,Z") == \
        ["render", "letter_f.obj", "--iso=-500", "--display-normal", "0,0,1", *SMALL]
    assert shell_lines("```sh\npovh3d a; povh3d b\npovh3d c\n  --d\n```") == ["povh3d a", "povh3d b", "povh3d c --d"]
    assert any(line.startswith("povh3d render") for _, line in povh3d_lines())


def test_every_line_not_run_is_still_in_the_docs():
    lines = [line for _, line in povh3d_lines()]
    for start in NOT_RUN:
        assert any(line.startswith(start) for line in lines), start


def _inputs(folder: Path, cli) -> None:
    """The user's files the docs name: the samples, a volume, a white capture, a small H3D image
    with odd views (a dataset's), its views and object masks, a lenticular image to map."""
    from tests.support.synth import WhiteSpec, render_white, to_uint
    from tests.support.volumes import asymmetric_phantom, write_nrrd
    from povh3d.image.io import write_png

    for name in ("sample.pov", "still_life.glb", "letter_f.obj", "letter_f.mtl", "letter_f.png"):
        shutil.copy(SAMPLES / name, folder / name)
    write_nrrd(asymmetric_phantom(), folder / "phantom.nrrd")
    # an unmapped lenticular image in view space, without a sidecar: 8 views a lens, 6 lenses, 24 rows
    write_png(folder / "IN.png", np.random.default_rng(0).integers(0, 256, (24, 48, 3), dtype=np.uint8))
    write_png(folder / "WHITE.png", to_uint(render_white(WhiteSpec((96, 72), pitch_px=6.37, supersample=2)), 8))
    made = cli("render", "sample.pov", "--preset", "demo", "--lenses", "8x6", "--ppl", "5", "--quality", "draft",
               "-o", "H3D.png", "--objects", "MASKS_DIR", "-q", cwd=folder)
    assert made.code == 0, made.err
    assert cli("extract", "H3D.png", "-o", "VIEWS_DIR", cwd=folder).code == 0


@pytest.mark.povray
def test_every_documented_command_runs_as_written(tmp_path, cli):
    import time

    _inputs(tmp_path, cli)
    failed, times = [], []
    for doc, line in povh3d_lines():
        if any(line.startswith(start) for start in NOT_RUN):
            continue
        args = runnable(line)
        start = time.perf_counter()
        result = cli(*args, cwd=tmp_path)
        times.append((time.perf_counter() - start, line))
        if result.code != 0:
            failed.append(f"{doc}: {line}\n    ran: povh3d {shlex.join(args)}\n    {result.err.strip()[:300]}")
    slowest = sorted(times, reverse=True)[:6]
    print("\n".join(f"{t:6.1f} s  {line}" for t, line in slowest))
    assert not failed, "\n".join(failed)
    assert (tmp_path / "OUT.png").is_file() and np.isfinite(sum(t for t, _ in times))

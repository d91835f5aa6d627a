"""Benchmark: what `povh3d render` spends before its first POV-Ray starts (issue 37).

For each render path (the bundled sample; a scene with a camera, whose depth pass
is a 16-bit PNG; 16-bit depth maps and a dataset; a slanted panel mapping) and
each source tree given (``--tree``, default this checkout: before and after a
change, side by side), interleaved runs measure the import time
(``python -X importtime``: the sum of the top-level imports), the time from the
process's start to the first POV-Ray's (``strace -f -e trace=execve``, filtered
in the kernel: the other system calls run untraced) and the whole process.  The bundled sample is also timed against a
whole-process 2D ``povray`` render of its panel (``bench_command``'s).

    .venv/bin/python benchmarks/bench_startup.py [--repeats 5] [--tree DIR ...] [--no-docs]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import publish, table  # noqa: E402
from bench_command import plain_2d_command  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "sample_models" / "sample.pov"
CAMERA_SCENE = """#version 3.7;
camera { location <0, 1, -6> look_at <0, 0, 0> }
light_source { <4, 6, -8> rgb 1 }
sphere { <0, 0, 0>, 1 pigment { rgb <1, 0.4, 0.2> } }
plane { y, -1 pigment { checker rgb 1 rgb 0.3 } }
"""
SMALL = ["--lenses", "12x8", "--ppl", "5x5"]


def cases(tmp: Path) -> dict[str, list[str]]:
    scene = tmp / "camera.pov"
    scene.write_text(CAMERA_SCENE)
    return {
        "sample, `demo`": [str(SAMPLE), "--preset", "demo"],
        "scene camera (16-bit depth pass), 60x40": [str(scene), *SMALL],
        "`--depth-maps` (16-bit PNG) and `--dataset`, 60x40": [str(scene), *SMALL, "--depth-maps", str(tmp / "maps"),
                                                                 "--depth-format", "png", "--dataset", str(tmp / "hci")],
        "sample, `ipad-retina` (slanted mapping), 2048x1536": [str(SAMPLE), "--preset", "ipad-retina"],
    }


def import_seconds(stderr: str) -> float:
    """The sum of the top-level (not nested) cumulative import times of an ``-X importtime`` log."""
    total = 0
    for line in stderr.splitlines():
        if line.startswith("import time:") and line.count("|") == 2:
            _, cumulative, name = line.split("|")
            if cumulative.strip().isdigit() and not name.startswith("  "):
                total += int(cumulative)
    return total / 1e6


def run(tree: Path, args: list[str], tmp: Path, log: Path, importtime: bool) -> tuple[float, float, float]:
    """(whole seconds, seconds to the first POV-Ray, import seconds or NaN) of one ``povh3d render``."""
    for folder in ("maps", "hci"):  # a dataset goes to an empty folder
        shutil.rmtree(tmp / folder, ignore_errors=True)
    env = {**os.environ, "PYTHONPATH": str(tree), "POVH3D_CACHE": str(tmp / "cache")}
    povray = os.path.realpath(shutil.which("povray"))
    command = ["strace", "-f", "--seccomp-bpf", "-e", "trace=execve", "-e", "signal=none", "-qq", "-ttt",
               "-o", str(log), sys.executable, *(["-X", "importtime"] if importtime else []), "-m", "povh3d", "render", *args,
               "--quality", "draft", "--no-cache", "-q", "-o", str(tmp / "o.png")]
    start = time.time()
    done = subprocess.run(command, cwd=tmp, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                          check=False)
    whole = time.time() - start
    if done.returncode:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-2000:]}")
    execs = [line.split()[1:3] for line in log.read_text().splitlines() if "execve(" in line]
    python = float(execs[0][0])  # the traced process's own start: strace's start-up not counted
    first = min(float(t) for t, call in execs if call.startswith(f'execve("{povray}"'))
    whole = whole - (python - start)
    return whole, first - python, import_seconds(done.stderr) if importtime else float("nan")


def spread(values: list[float]) -> str:
    return f"{statistics.median(values):.2f} ({min(values):.2f}-{max(values):.2f})"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--tree", action="append", type=Path, help="a source tree to time (repeat to compare)")
    ap.add_argument("--no-docs", action="store_true", help="print the table, leave docs/benchmarks.md alone")
    args = ap.parse_args()
    trees = args.tree or [REPO]
    if shutil.which("strace") is None:
        raise SystemExit("bench_startup.py times the first POV-Ray with strace, which is not installed: "
                         "apt-get install strace")
    load_before = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        folder = tmp / "2d"
        folder.mkdir()
        plain = plain_2d_command([], folder)
        for case, case_args in cases(tmp).items():
            got = {tree: ([], [], []) for tree in trees}
            two_d = []
            for tree in trees:  # once each, untimed: bytecode and any compiled-code cache written
                run(tree, case_args, tmp, tmp / "log", importtime=False)
            for _ in range(args.repeats):
                if case.startswith("sample, `demo`"):
                    start = time.time()
                    subprocess.run(plain, cwd=folder, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    two_d.append(time.time() - start)
                for tree in trees:  # interleaved: a change of load hits every tree
                    whole, first, _ = run(tree, case_args, tmp, tmp / "log", importtime=False)
                    imports = run(tree, case_args, tmp, tmp / "log", importtime=True)[2]
                    for values, value in zip(got[tree], (whole, first, imports)):
                        values.append(value)
            for tree in trees:
                whole, first, imports = got[tree]
                ratio = f"{statistics.median(whole) / statistics.median(two_d):.2f}x" if two_d else ""
                rows.append((case, tree.name if len(trees) > 1 else "", spread(imports), spread(first), spread(whole),
                             ratio))
                print(rows[-1], flush=True)
            if two_d:
                rows.append((case, "plain `povray` 2D of the panel", "", "", spread(two_d), "1.00x"))
    text = table(f"Seconds, median (min-max) of {args.repeats} interleaved runs",
                 ["render", "tree", "imports", "first POV-Ray starts", "whole process", "vs 2D"], rows, load_before)
    return publish("bench_startup", text, docs=not args.no_docs)


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: large panels and a large model, whole ``povh3d render`` processes: peak memory
of the Python process and of POV-Ray, wall time.

Issue 17's target: an 8K panel (7680x4320, 8x8 views) renders with the Python side
under 2 GB.  Each case runs once in a child that reports its own peak resident
memory (``ru_maxrss``) and its children's (the largest POV-Ray).  The table is
written into docs/benchmarks.md between the ``bench_large`` markers.

    .venv/bin/python benchmarks/bench_large.py [--no-docs] [--skip-16bit]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import table, write_table  # noqa: E402
from bench_mesh import sphere  # noqa: E402 - the same 1,000,000-triangle sphere

REPO = Path(__file__).resolve().parents[1]
SCENE = """#version 3.7;
global_settings { assumed_gamma 1 }
light_source { <-300, 400, -600> rgb 1 }
sphere { <0, 0, 20>, 40 pigment { rgb <0.9, 0.5, 0.2> } }
plane { z, 80 pigment { checker rgb 0.2 rgb 0.8 scale 20 } }
"""
CHILD = """
import json, resource, sys, time
from povh3d.cli.main import main
start = time.perf_counter()
code = main(sys.argv[1:])
me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"code": code, "wall": time.perf_counter() - start,
                  "python_mb": me.ru_maxrss / 1024, "povray_mb": kids.ru_maxrss / 1024}))
"""
ENV = {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}, "PYTHONPATH": str(REPO)}


def run(*args: str) -> dict:
    done = subprocess.run([sys.executable, "-c", CHILD, *args], capture_output=True, text=True, check=True, env=ENV)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--no-docs", action="store_true", help="print the table, leave docs/benchmarks.md alone")
    ap.add_argument("--skip-16bit", action="store_true", help="leave out the 16-bit 8K render (the longest)")
    args = ap.parse_args()
    load_before = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        os.environ["POVH3D_CACHE"] = ENV["POVH3D_CACHE"] = str(tmp / "cache")
        scene = tmp / "ball.pov"
        scene.write_text(SCENE)
        model = tmp / "sphere.stl"
        model.write_bytes(sphere(1_000_000).export(file_type="stl"))
        k8 = ["--lenses", "960x540", "--ppl", "8x8", "--quality", "draft", "--no-cache", "-q"]
        cases = [("8K panel 7680x4320, 8x8 views, draft, 8-bit, a sphere over a plane",
                  ["render", str(scene), *k8, "-o", str(tmp / "k8.png")])]
        if not args.skip_16bit:
            cases.append(("the same, `--bit-depth 16`",
                          ["render", str(scene), *k8, "--bit-depth", "16", "-o", str(tmp / "k16.png")]))
        cases.append(("a 1,000,000-triangle STL sphere on the 1920x1080 omni panel (`--lenses 240x135 --ppl 8x8`), "
                      "draft, conversion included",
                      ["render", str(model), "--lenses", "240x135", "--ppl", "8x8", "--quality", "draft", "--no-cache",
                       "-q", "-o", str(tmp / "m.png")]))
        for name, command in cases:
            start = time.perf_counter()
            result = run(*command)
            wall = time.perf_counter() - start
            rows.append((name, f"**{result['python_mb']:.0f} MB**", f"{result['povray_mb']:.0f} MB", f"{wall:.1f} s"))
            print(rows[-1], flush=True)
    text = table("One run each", ["render", "Python peak", "POV-Ray peak", "wall"], rows, load_before)
    print(text)
    if not args.no_docs:
        write_table("bench_large", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: convert 1,000,000-triangle meshes end to end; POV-Ray's parse time for the result.

Two models: a binary STL sphere (500,000 shared vertices, flat) and a bumpy
torus as binary PLY (smooth normals).  Each conversion is a whole
``povh3d convert-mesh`` process, timed from outside (interpreter start-up and
imports included); it reports its own peak resident memory (``ru_maxrss``).
Targets (issue 17): at least 500,000 triangles per second, peak memory under 1 GB.

The table is written into docs/benchmarks.md between the ``bench_mesh`` markers.

    .venv/bin/python benchmarks/bench_mesh.py [--triangles 1000000] [--repeats 3] [--no-docs]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import parse_seconds, table, write_table  # noqa: E402

import numpy as np
import trimesh



CHILD = """
import json, resource, sys
from povh3d.renderer.content.convert_mesh import convert_mesh
r = convert_mesh(sys.argv[1], sys.argv[2])
print(json.dumps({"triangles": r.triangles, "vertices": r.vertices,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""
# As an installed package runs: modules compiled once, not on every run.
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def sphere(triangles: int) -> trimesh.Trimesh:
    """A UV sphere of about ``triangles`` faces and half as many shared vertices."""
    rows = int(np.sqrt(triangles / 8))
    return trimesh.creation.uv_sphere(radius=30, count=[rows, 2 * rows])


def torus(triangles: int) -> trimesh.Trimesh:
    """A bumpy torus with ``triangles`` faces (rounded to an even grid), float32 like real files."""
    nu = int(np.sqrt(triangles))
    nv = max(3, triangles // (2 * nu))
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, nu, endpoint=False), np.linspace(0, 2 * np.pi, nv, endpoint=False),
                       indexing="ij")
    r = 10 + 0.3 * np.sin(7 * u) * np.cos(5 * v)
    pts = np.stack([(40 + r * np.cos(v)) * np.cos(u), (40 + r * np.cos(v)) * np.sin(u), r * np.sin(v)], -1)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a, b = i * nv + j, ((i + 1) % nu) * nv + j
    c, d = ((i + 1) % nu) * nv + (j + 1) % nv, i * nv + (j + 1) % nv
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return trimesh.Trimesh(pts.reshape(-1, 3).astype(np.float32), faces, process=False)


def include_parse_seconds(include: Path) -> float:
    return parse_seconds(f'#version 3.7;\nglobal_settings {{ assumed_gamma 1 }}\n#include "{include.name}"\n'
                         "camera { orthographic location <0, 0, -200> direction z right <120, 0, 0> up <0, 120, 0> }\n"
                         "light_source { <0, 0, -500> rgb 1 }\n"
                         f"object {{ {include.stem} }}\n", include.parent)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--triangles", type=int, default=1_000_000)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--no-docs", action="store_true", help="print the table, leave docs/benchmarks.md alone")
    args = p.parse_args()
    rows, load_before = [], os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for stem, make, kind in (("Sphere", sphere, "stl"), ("Torus", torus, "ply")):
            model = folder / f"{stem}.{kind}"
            model.write_bytes(make(args.triangles).export(file_type=kind))
            include = folder / f"{stem}.inc"
            runs, walls = [], []
            for _ in range(args.repeats + 1):  # the first run fills numba's cache: not counted
                t = time.perf_counter()
                done = subprocess.run([sys.executable, "-c", CHILD, str(model), str(include)],
                                      capture_output=True, text=True, check=True, env=ENV)
                walls.append(time.perf_counter() - t)
                runs.append(json.loads(done.stdout))
            walls, runs = walls[1:], runs[1:]
            seconds = statistics.median(walls)
            peak = max(r["peak_mb"] for r in runs)
            tri = runs[0]["triangles"]
            t = time.perf_counter()
            parse = include_parse_seconds(include)
            povray_wall = time.perf_counter() - t
            size_mb = include.stat().st_size / 1e6
            print(f"{stem}: {tri} triangles, {runs[0]['vertices']} vertices, binary {kind.upper()} "
                  f"{model.stat().st_size / 1e6:.1f} MB -> include {size_mb:.1f} MB; load average "
                  f"{os.getloadavg()[0]:.2f}")
            print(f"  whole process (median of {args.repeats}, {min(walls):.2f}-{max(walls):.2f} s): {seconds:.2f} s = "
                  f"{tri / seconds:,.0f} triangles/s (target >= 500,000): {'ok' if tri / seconds >= 500_000 else 'MISSED'}")
            print(f"  peak memory: {peak:.0f} MB (target < 1024 MB): {'ok' if peak < 1024 else 'MISSED'}")
            print(f"  POV-Ray parse time of the include: {parse:.2f} s (whole 8x8 render run {povray_wall:.2f} s)")
            what = ("UV sphere, binary STL, flat" if kind == "stl" else "bumpy torus, binary PLY, smooth normals")
            rows.append((f"{tri:,}-triangle {what}, {runs[0]['vertices']:,} shared vertices",
                         f"{seconds:.2f} s ({min(walls):.2f}-{max(walls):.2f})", f"**{tri / seconds:,.0f}**",
                         f"{peak:.0f} MB", f"{size_mb:.1f} MB", f"{parse:.2f} s"))
    text = table(f"Median (min-max) of {args.repeats} runs after one that fills numba's cache",
                 ["model", "whole process", "triangles/s", "peak memory", "include", "POV-Ray parse"],
                 rows, load_before)
    print(text)
    if not args.no_docs:
        write_table("bench_mesh", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

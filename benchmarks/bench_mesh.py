"""Benchmark: convert a 1,000,000-triangle mesh end to end; POV-Ray's parse time for the result.

Targets: at least 300,000 triangles per second (load, clean, normals, write)
and peak memory under 2 GB.  The conversion runs in a child process so its peak
resident memory (``ru_maxrss``) is its own.

    .venv/bin/python benchmarks/bench_mesh.py [--triangles 1000000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

from povh3d.povray.process import PovrayJob, run_jobs

CHILD = """
import json, resource, sys, time
t = time.perf_counter()
from povh3d.app.convert_mesh import convert_mesh
r = convert_mesh(sys.argv[1], sys.argv[2])
seconds = time.perf_counter() - t
print(json.dumps({"seconds": seconds, "triangles": r.triangles, "vertices": r.vertices,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


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


def parse_seconds(include: Path) -> float:
    script = (f'#version 3.7;\nglobal_settings {{ assumed_gamma 1 }}\n#include "{include.name}"\n'
              "camera { orthographic location <0, 0, -200> direction z right <120, 0, 0> up <0, 120, 0> }\n"
              "light_source { <0, 0, -500> rgb 1 }\n"
              f"object {{ {include.stem} }}\n")
    job = PovrayJob(name="parse", script=script, width=8, height=8, include_dirs=(str(include.parent),),
                    options=("-A", "+V"))
    logs = []
    run_jobs([job], processes=1, on_result=lambda r: logs.append(r.log))
    m = re.search(r"Parse Time:.*?\(([\d.]+) seconds\)", logs[0])
    return float(m.group(1)) if m else float("nan")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--triangles", type=int, default=1_000_000)
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        model = folder / "Torus.ply"
        model.write_bytes(torus(args.triangles).export(file_type="ply"))
        include = folder / "Torus.inc"
        runs = []
        for _ in range(args.repeats):
            done = subprocess.run([sys.executable, "-c", CHILD, str(model), str(include)],
                                  capture_output=True, text=True, check=True)
            runs.append(json.loads(done.stdout))
        seconds = statistics.median(r["seconds"] for r in runs)
        peak = max(r["peak_mb"] for r in runs)
        tri = runs[0]["triangles"]
        t = time.perf_counter()
        parse = parse_seconds(include)
        povray_wall = time.perf_counter() - t
        size_mb = include.stat().st_size / 1e6
        print(f"mesh: {tri} triangles, {runs[0]['vertices']} vertices, binary PLY {model.stat().st_size / 1e6:.1f} MB "
              f"-> include {size_mb:.1f} MB")
        print(f"convert (median of {args.repeats}): {seconds:.2f} s = {tri / seconds:,.0f} triangles/s "
              f"(target >= 300,000): {'ok' if tri / seconds >= 300_000 else 'MISSED'}")
        print(f"peak memory: {peak:.0f} MB (target < 2048 MB): {'ok' if peak < 2048 else 'MISSED'}")
        print(f"POV-Ray parse time of the include: {parse:.2f} s (whole 8x8 render run {povray_wall:.2f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

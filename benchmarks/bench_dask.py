"""Benchmark: a Dask cluster of two local workers against the local process pool.

The same render, cold (no cache), on the same machine: once through
``povray.run_jobs`` (the local pool), once through ``--scheduler`` with a
``distributed.LocalCluster`` of two worker processes whose threads together
match the local pool's processes.  Runs alternate and the median of a few
repeats is taken, because the machine is shared: compare the ratio.  Target:
the cluster within 15 % of the pool (ratio <= 1.15).  It also checks that both
give the same pixels.

    .venv/bin/python benchmarks/bench_dask.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from distributed import LocalCluster

from povh3d.renderer.render import render
from povh3d.renderer.request import RenderRequest
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.io import read_png
from povh3d.system import cpu_count
from povh3d.renderer.methods.quality import RenderSettings

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "sample_models" / "sample.pov"
# (method, lens array): many POV-Ray jobs (views), and one (the mesh camera).
CASES = {
    "multi-ortho-views, 60x40 lenses, 6x6 views (36 frames)":
        ("multi-ortho-views", LensArray("square", 60, 40, 0.6, 0.6, 1.5, Panel(360, 240, 0.1, 0.1))),
    "multi-ortho, 120x80 lenses, 6x6 views (1 job)":
        ("multi-ortho", LensArray("square", 120, 80, 0.6, 0.6, 1.5, Panel(720, 480, 0.1, 0.1))),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quality", default="normal")
    args = parser.parse_args()
    local_processes = 4 * cpu_count()  # what multi-ortho-views asks of the local pool
    print(f"{cpu_count()} cores; cluster: 2 workers x {local_processes // 2} threads")
    print(f"{'case':58s} {'local s':>8s} {'dask s':>8s} {'ratio':>6s}  same pixels")
    worst = 0.0
    with LocalCluster(n_workers=2, threads_per_worker=max(1, local_processes // 2), processes=True,
                      dashboard_address=None) as cluster, tempfile.TemporaryDirectory() as tmp:
        for name, (method, lens) in CASES.items():
            times: dict[str, list[float]] = {"local": [], "dask": []}
            for _ in range(args.repeats):
                for where, scheduler in (("local", None), ("dask", cluster.scheduler_address)):
                    settings = RenderSettings(quality=args.quality, use_cache=False, scheduler=scheduler)
                    start = time.perf_counter()
                    render(RenderRequest(SCENE, lens, Path(tmp) / f"{where}.png", method=method, settings=settings))
                    times[where].append(time.perf_counter() - start)
            local, dask = statistics.median(times["local"]), statistics.median(times["dask"])
            same = np.array_equal(read_png(Path(tmp) / "local.png"), read_png(Path(tmp) / "dask.png"))
            worst = max(worst, dask / local)
            print(f"{name:58s} {local:8.2f} {dask:8.2f} {dask / local:6.2f}  {same}")
            if not same:
                print("the cluster's pixels differ from the local pool's", file=sys.stderr)
                return 1
    print(f"worst ratio {worst:.2f} (target <= 1.15)")
    return 0 if worst <= 1.15 else 1


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: H3D render time against the physical floor, a plain 2D render.

The floor is one POV-Ray trace of the panel's W x H rays.  Both sides are
point-sampled (--quality draft), rendered cold (no cache) in the same run, the
median of a few repeats, because these machines are noisy: compare the ratios.

    .venv/bin/python benchmarks/bench_render.py [--repeats 3] [--scene S.pov]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from povh3d.geometry.lens_array import LensArray
from povh3d.image.interleave import interleave
from povh3d.renderer.methods.registry import run_method
from povh3d.povray.process import PovrayJob, find_povray, run_jobs
from povh3d.display.presets import get_preset, lens_array_from_fields, merge_overrides
from povh3d.renderer.methods.quality import QUALITY_OPTIONS, RenderSettings
from povh3d.system import cpu_count
from povh3d.scene.scene import load_scene

REPO = Path(__file__).resolve().parents[1]
CASES = {
    "lenticular 1920x1080, 8 views": dict(grid="lenticular", lenses=240, ppl=8, rows=1080),
    "omni 960x544, 8x8 views": dict(lenses=(120, 68), ppl=(8, 8)),
}


def plain_2d_seconds(scene, la: LensArray, front_clearance: float) -> float:
    """One orthographic camera square to the screen at the panel resolution."""
    w_mm, h_mm = la.panel.size_mm
    script = (f'#version 3.7;\n#include "{scene.path}"\n'
              f"camera {{ orthographic location <0, 0, {-front_clearance!r}> direction z "
              f"right <{w_mm!r}, 0, 0> up <0, {h_mm!r}, 0> }}\n")
    if not scene.sets_assumed_gamma:
        script = "global_settings { assumed_gamma 1.0 }\n" + script
    job = PovrayJob(name="2D", script=script, width=la.panel.width, height=la.panel.height,
                    include_dirs=tuple(map(str, scene.include_dirs)), options=QUALITY_OPTIONS["draft"],
                    threads=cpu_count())
    t = time.perf_counter()
    run_jobs([job], processes=1, binary=find_povray())
    return time.perf_counter() - t


def timed(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def interleave_ratios(repeats: int = 25) -> dict:
    """Interleaving a 1920x1080 8-view stack against numpy.copy of the same bytes, hot and cold cache.

    Hot: the same stack again and again (6 MB stays in cache; min and median, the
    machine is shared).  Cold: a 64 MB buffer is written before every run.  Both
    sides allocate their output, as the library does.
    """
    views = np.random.default_rng(0).integers(0, 255, (1, 8, 1080, 240, 3), dtype=np.uint8)
    interleave(views)  # first call (thread pool, page faults) outside the timing
    flush = np.zeros(64 << 20, np.uint8)

    def runs(fn, cold):
        times = []
        for _ in range(repeats):
            if cold:
                flush[:] += 1
            t = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t)
        return times

    out = {}
    for cold in (False, True):
        c, i = runs(views.copy, cold), runs(lambda: interleave(views), cold)
        key = "cold" if cold else "hot"
        out[key] = {"copy_ms": [min(c) * 1e3, statistics.median(c) * 1e3],
                    "interleave_ms": [min(i) * 1e3, statistics.median(i) * 1e3],
                    "ratio_min": min(i) / min(c), "ratio_median": statistics.median(i) / statistics.median(c)}
        print(f"interleave 1920x1080, 8 views, {key} cache: {min(i) * 1e3:.2f} ms min / "
              f"{statistics.median(i) * 1e3:.2f} ms median = {out[key]['ratio_min']:.2f}x / "
              f"{out[key]['ratio_median']:.2f}x numpy.copy ({min(c) * 1e3:.2f} / {statistics.median(c) * 1e3:.2f} ms)")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default=str(REPO / "sample_models" / "sample.pov"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--pinhole-lenses", type=int, default=96,
                    help="lenses rendered to estimate the pinhole method (it scales linearly)")
    ap.add_argument("--json", default=str(REPO / "bench-out" / "bench.json"))
    ap.add_argument("--interleave-only", action="store_true", help="only the interleave-vs-copy ratio")
    args = ap.parse_args()
    if args.interleave_only:
        interleave_ratios()
        return 0
    scene = load_scene(args.scene)
    draft = RenderSettings(quality="draft", use_cache=False)
    results = {}
    print(f"scene {scene.path.name}, {cpu_count()} cores, median of {args.repeats}, point-sampled")
    print(f"{'case':32s} {'2D floor':>9s} {'method':>18s} {'time':>8s} {'ratio':>7s}")
    for case, overrides in CASES.items():
        la = lens_array_from_fields(merge_overrides(get_preset("demo"), overrides))
        front_clearance = 4 * max(la.panel.size_mm)
        floor = timed(lambda: plain_2d_seconds(scene, la, front_clearance), args.repeats)
        row = {"floor_seconds": floor}
        for method in ("multi-ortho", "multi-ortho-views"):
            t = timed(lambda: run_method(method, scene, la, draft), args.repeats)
            row[method] = {"seconds": t, "ratio": t / floor}
            print(f"{case:32s} {floor:9.2f} {method:>18s} {t:8.2f} {t / floor:6.2f}x")
        # Pinhole: a slice of lenses, scaled to the whole array (cost is per lens).
        n = min(args.pinhole_lenses, la.lenses_x * la.lenses_y)
        sub = LensArray(la.grid, n, 1, la.pitch_x, la.pitch_y, la.focal,
                        type(la.panel)(round(n * la.ppl_x), round(la.ppl_y), la.panel.pitch_x, la.panel.pitch_y))
        t_sub = timed(lambda: run_method("pinhole", scene, sub, draft), 1)
        est = t_sub * (la.lenses_x * la.lenses_y) / n
        row["pinhole_estimate"] = {"seconds": est, "ratio": est / floor, "lenses_rendered": n}
        print(f"{case:32s} {floor:9.2f} {'pinhole (est.)':>18s} {est:8.1f} {est / floor:6.0f}x")
        results[case] = row

    results["interleave"] = interleave_ratios()
    # A re-run with nothing changed: the CLI end to end, from the cache.
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "povh3d.cli", "render", str(scene.path), "-o", f"{tmp}/o.png",
               "--quality", "draft", "-q", "--grid", "lenticular", "--lenses", "240", "--ppl", "8", "--rows", "1080"]
        subprocess.run(cmd, check=True, capture_output=True)
        t_rerun = timed(lambda: subprocess.run(cmd, check=True, capture_output=True), 3)
    results["cached_rerun_seconds"] = t_rerun
    print(f"re-run with nothing changed (CLI, 1920x1080): {t_rerun:.2f} s")
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

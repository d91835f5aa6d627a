"""Benchmark: what skipping what a scene does not need saves.

1. Crop (``--crop auto --bbox``, ``--crop measure``): the one-pass view bank on
   omnidirectional panels, an object covering a quarter of every view, against
   the uncropped render, at each quality level (``draft`` point-sampled,
   ``normal`` POV-Ray's adaptive antialiasing, ``high`` footprint samples); the
   differing pixels are counted.
2. Global settings a plain scene does not use: what each would cost if the
   header added it anyway (radiosity, photons, max_trace_level) - the cost
   ``features.needed_settings`` saves.

Repeats alternate between the cases so that load from other processes hits
them alike; the median is reported, and the ratios are what to compare.

    .venv/bin/python benchmarks/bench_skip.py [--repeats 3] [--lenses 240x136] [--large-lenses 480x272]
                                              [--high-lenses 60x34]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from povh3d.geometry.crop import CropSettings
from povh3d.renderer.methods.registry import run_method
from povh3d.display.presets import get_preset, lens_array_from_fields, merge_overrides
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.system import cpu_count
from povh3d.scene.scene import load_scene

REPO = Path(__file__).resolve().parents[1]

# An object covering a quarter of the view: a lit, textured slab half the panel
# wide and half as high (sizes slightly off round numbers, so no ray grazes an
# edge exactly: see the README on ties).
QUARTER = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.02, 0.02, 0.03> }
light_source { <-40, 60, -80> rgb <1.0, 0.95, 0.9> }
light_source { < 60, 20, -40> rgb <0.25, 0.3, 0.4> shadowless }
#declare W = Povh3d_Panel_Width / 2 * 0.99731;
#declare H = Povh3d_Panel_Height / 2 * 0.99517;
box { <-W/2, -H/2, -3.0137>, <W/2, H/2, 2.9873>
  pigment { checker rgb <0.85, 0.85, 0.8> rgb <0.25, 0.35, 0.55> scale 1.3 translate <0.1234, 0.0567, 0.0891> }
  finish { diffuse 0.8 ambient 0.05 specular 0.3 } }
"""

SETTINGS_IF_ADDED = {
    "radiosity { }": "global_settings { radiosity { count 35 } }",
    "photons { }": "global_settings { photons { spacing 0.05 } }",
    "max_trace_level 10": "global_settings { max_trace_level 10 }",
}


def parse_lenses(text: str) -> tuple[int, int]:
    a, b = text.lower().split("x")
    return int(a), int(b)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--lenses", default="240x136", help="omni lens array for draft and normal, 8x8 pixels per lens")
    ap.add_argument("--large-lenses", default="480x272", help="a larger array for draft")
    ap.add_argument("--high-lenses", default="60x34", help="omni lens array for high (256 banks of samples)")
    ap.add_argument("--json", default=str(REPO / "bench-out" / "bench_skip.json"))
    args = ap.parse_args()
    results: dict = {"cores": cpu_count(), "repeats": args.repeats}

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "quarter.pov").write_text(QUARTER)
        scene = load_scene(tmp / "quarter.pov")
        results["crop"] = {}
        # What every POV-Ray run costs whatever it traces (start-up, mostly idle), which no crop removes.
        tiny = lens_array_from_fields(merge_overrides(get_preset("demo"), {"lenses": (2, 2), "ppl": (8, 8)}))
        starts = []
        for _ in range(args.repeats):
            t = time.perf_counter()
            run_method("multi-ortho", scene, tiny, RenderSettings(quality="draft", use_cache=False))
            starts.append(time.perf_counter() - t)
        results["povray_start_seconds"] = statistics.median(starts)
        print(f"a render of 16x16 pixels (POV-Ray start-up and povh3d overhead): {statistics.median(starts):.2f} s")
        cases_run = (("draft", args.lenses), ("draft", args.large_lenses), ("normal", args.lenses),
                     ("high", args.high_lenses))
        for quality, lenses in cases_run:
            la = lens_array_from_fields(merge_overrides(get_preset("demo"), {"lenses": parse_lenses(lenses),
                                                                              "ppl": (8, 8)}))
            W, H = la.panel.size_mm
            bbox = ((-W / 4, -H / 4, -3.02), (W / 4, H / 4, 2.99))
            print(f"crop, {quality}: {la.panel.width}x{la.panel.height} omni, 8x8 views, object over a quarter "
                  f"of each view, {cpu_count()} cores, median of {args.repeats}")
            st = RenderSettings(quality=quality, use_cache=False)
            cases = {"full": None, "bbox": CropSettings("auto", bbox), "measure": CropSettings("measure")}
            times: dict[str, list[float]] = {k: [] for k in cases}
            outputs: dict = {}
            for _ in range(args.repeats):
                for name, crop in cases.items():
                    t = time.perf_counter()
                    outputs[name] = run_method("multi-ortho", scene, la, st, crop=crop)
                    times[name].append(time.perf_counter() - t)
            full = statistics.median(times["full"])
            row = {"panel": [la.panel.width, la.panel.height], "full_seconds": full,
                   "povray_seconds": sum(outputs["full"].stats.povray_seconds)}
            print(f"  {quality:8s} full    {full:6.2f} s")
            for name in ("bbox", "measure"):
                t = statistics.median(times[name])
                info = outputs[name].crop
                diff = int(np.any(outputs[name].h3d != outputs["full"].h3d, axis=-1).sum())
                row[name] = {"seconds": t, "speedup": full / t, "differing_pixels": diff,
                             "traced_fraction": info.get("traced_fraction"), "applied": info.get("applied")}
                print(f"  {quality:8s} {name:7s} {t:6.2f} s = {full / t:4.2f}x faster, traced "
                      f"{info.get('traced_fraction', 1):.3f} of the pixels, {diff} of "
                      f"{la.panel.width * la.panel.height} pixels differ")
            results["crop"][f"{quality} {la.panel.width}x{la.panel.height}"] = row

        # Global settings the scene does not use, had the header added them anyway.
        small = lens_array_from_fields(merge_overrides(get_preset("demo"), {"lenses": (120, 68), "ppl": (8, 8)}))
        st = RenderSettings(quality="draft", use_cache=False)
        variants = {"(nothing added)": scene}
        for name, text in SETTINGS_IF_ADDED.items():
            path = tmp / f"with_{len(variants)}.pov"
            path.write_text(f'{text}\n#include "{tmp / "quarter.pov"}"\n')
            variants[name] = load_scene(path)
        times = {k: [] for k in variants}
        for _ in range(args.repeats):
            for name, sc in variants.items():
                t = time.perf_counter()
                run_method("multi-ortho", sc, small, st)
                times[name].append(time.perf_counter() - t)
        base = statistics.median(times["(nothing added)"])
        print(f"global settings on a plain scene ({small.panel.width}x{small.panel.height}, draft): "
              f"{base:.2f} s as generated")
        results["settings"] = {"base_seconds": base}
        for name in SETTINGS_IF_ADDED:
            t = statistics.median(times[name])
            results["settings"][name] = {"seconds": t, "ratio": t / base}
            print(f"  if povh3d added {name:20s} {t:6.2f} s = {t / base:5.2f}x")

    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

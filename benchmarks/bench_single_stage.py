"""Benchmark: single-stage (virtual lens array) against multi-ortho, time and error.

Same scene, same panel, point-sampled (--quality draft), cold cache, median of
a few repeats in one run (compare ratios: the machine is shared).  hex-5.6 and
fractional PPL render through the lens-aligned capture bank (single_stage doc, 5).  The error of
each method is its PSNR against multi-ortho (exact by construction, checked
against the analytic oracle in tests), for the default thin lenslets and for
real acrylic (n = 1.5).  hex-5.6 has no multi-ortho reference, so only its time is given.

    .venv/bin/python benchmarks/bench_single_stage.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.renderer.methods.registry import run_method
from povh3d.image.metrics import psnr
from povh3d.display.presets import get_preset, lens_array_from_fields, merge_overrides
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.system import cpu_count
from povh3d.scene.scene import load_scene

REPO = Path(__file__).resolve().parents[1]
CASES = {
    "demo 320x240, 8x8 views": ("demo", {}),
    "omni 960x544, 8x8 views": ("demo", dict(lenses=(120, 68), ppl=(8, 8))),
}
VARIANTS = {"conic": {"lenslet": "conic"}, "spherical": {"lenslet": "spherical"},
            "conic n=1.5": {"lenslet": "conic", "ior": 1.5}, "spherical n=1.5": {"lenslet": "spherical", "ior": 1.5}}


def timed(fn, repeats: int):
    times, result = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), result


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default=str(REPO / "sample_models" / "sample.pov"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", default=str(REPO / "bench-out" / "bench_single_stage.json"))
    args = ap.parse_args()
    scene = load_scene(args.scene)
    draft = RenderSettings(quality="draft", use_cache=False)
    results: dict = {}
    print(f"scene {scene.path.name}, {cpu_count()} cores, median of {args.repeats}, point-sampled")
    print(f"{'case':28s} {'method':>26s} {'time':>8s} {'ratio':>7s} {'PSNR vs multi-ortho':>20s}")
    for case, (preset, overrides) in CASES.items():
        la = lens_array_from_fields(merge_overrides(get_preset(preset), overrides))
        t_ref, ref = timed(lambda: run_method("multi-ortho", scene, la, draft).h3d, args.repeats)
        row = {"multi-ortho": {"seconds": t_ref}}
        print(f"{case:28s} {'multi-ortho':>26s} {t_ref:8.2f} {1:6.2f}x {'(reference)':>20s}")
        for name, options in VARIANTS.items():
            t, img = timed(lambda: run_method("single-stage", scene, la, draft, **options).h3d, args.repeats)
            err = psnr(img, ref)
            row[f"single-stage {name}"] = {"seconds": t, "ratio": t / t_ref, "psnr_db": err}
            print(f"{case:28s} {'single-stage ' + name:>26s} {t:8.2f} {t / t_ref:6.2f}x {err:17.1f} dB")
        results[case] = row
    # Fractional PPL (no view bank): multi-ortho traces one quad per lens; single-stage
    # renders a lens-aligned 7 x 7-sample capture re-centred in depth, then interpolates.
    la = LensArray("square", 40, 30, 0.65, 0.65, 1.5, Panel(260, 195, 0.1, 0.1))
    t_ref, ref = timed(lambda: run_method("multi-ortho", scene, la, draft).h3d, args.repeats)
    t, img = timed(lambda: run_method("single-stage", scene, la, draft).h3d, args.repeats)
    case = "6.5 PPL 260x195"
    results[case] = {"multi-ortho": {"seconds": t_ref},
                     "single-stage conic": {"seconds": t, "ratio": t / t_ref, "psnr_db": psnr(img, ref)}}
    print(f"{case:28s} {'multi-ortho':>26s} {t_ref:8.2f} {1:6.2f}x {'(reference)':>20s}")
    print(f"{case:28s} {'single-stage conic':>26s} {t:8.2f} {t / t_ref:6.2f}x {psnr(img, ref):17.1f} dB")
    la = lens_array_from_fields(get_preset("hex-5.6"))
    t, _ = timed(lambda: run_method("single-stage", scene, la, draft), args.repeats)
    results["hex-5.6 1280x800"] = {"single-stage conic": {"seconds": t, "lenses": la.lenses_x * la.lenses_y}}
    print(f"{'hex-5.6 1280x800':28s} {'single-stage conic':>26s} {t:8.2f}   ({la.lenses_x * la.lenses_y} lenslets)")
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

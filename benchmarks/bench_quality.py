"""Run time against error (`make bench`): every method and quality setting on the
bundled fine-texture scene, against a reference that integrates each pixel's
footprint; then --quality auto against --quality high on a larger panel.

Writes bench-out/quality/bench.{csv,md,png} and bench-out/quality.json.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

from povh3d.app.render import render
from povh3d.app.request import RenderRequest
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.app.bench import default_trials, format_table, run_bench, write_report
from povh3d.engine.quality import RenderSettings
from povh3d.scene.scene import load_scene

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "sample_models" / "fine_texture.pov"


def omni(lenses: tuple[int, int], ppl: int = 8, s: float = 0.1, f: float = 1.5) -> LensArray:
    return LensArray("square", *lenses, ppl * s, ppl * s, f, Panel(lenses[0] * ppl, lenses[1] * ppl, s, s))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(REPO / "bench-out"))
    parser.add_argument("--methods", default="multi-ortho,pinhole,single-stage:conic,single-stage:spherical")
    parser.add_argument("--auto-only", action="store_true", help="only --quality auto against high")
    args = parser.parse_args()
    out = Path(args.out)
    scene = load_scene(SCENE)
    results: dict = {"auto": []}

    # 1. Every setting on the 240x144 omnidirectional panel (30x18 lenses, 8x8 views).
    if not args.auto_only:
        report = run_bench(scene, omni((30, 18)), default_trials(omni((30, 18)), args.methods.split(",")),
                           on_trial=lambda n, total, what: print(f"  [{n + 1}/{total}] {what}", file=sys.stderr))
        write_report(report, out / "quality")
        print(format_table(report))
        results.update(bench=report.rows(), noise_floor_db=report.noise_floor_db)

    # 2. --quality auto (probe included, cold cache) against --quality high, 480x272 panel.
    la = omni((60, 34))
    results["panel"] = [la.panel.width, la.panel.height]
    base = RenderSettings(quality="draft", use_cache=False)
    t = time.perf_counter()
    render(RenderRequest(SCENE, la, out / "high.png", settings=replace(base, quality="high")))
    high = time.perf_counter() - t
    results["high_seconds"] = high
    print(f"\n480x272, --quality high: {high:.1f} s")
    for target in (25.0, 30.0, 35.0, 38.0):
        t = time.perf_counter()
        record = render(RenderRequest(SCENE, la, out / f"auto-{target:g}.png",
                                      settings=replace(base, quality="auto", max_error_db=target)))
        seconds = time.perf_counter() - t
        chosen = record["quality"]["auto"]["chosen"]
        results["auto"].append({"target_db": target, "seconds": seconds, "chosen": chosen,
                                "speedup_over_high": high / seconds})
        print(f"--quality auto --max-error {target:g}: {seconds:.1f} s = {high / seconds:.1f}x faster "
              f"than high ({chosen})")
    out.mkdir(parents=True, exist_ok=True)
    (out / "quality.json").write_text(json.dumps(results, indent=2, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())

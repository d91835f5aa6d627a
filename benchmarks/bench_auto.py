"""--quality auto against every level of its ladder, on the full image (issue 22).

For each scene (the bundled samples and one it has not seen, written here) every rung of
``AUTO_LADDER`` is rendered as a whole ``povh3d render`` command (timed, interpreter start
to exit) and scored on the full image against a converged reference of two seeds (its
noise floor stated).  Then ``--quality auto --max-error X`` runs as a whole command (its
probe included, cold cache) and is scored the same way.  A case passes when the full image
reaches X within 0.2 dB at no more than 1.25x the time of the fastest rung that reaches X.

Writes bench-out/auto.json and the table between the ``auto`` markers of docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

from _common import table, write_table
from povh3d.engine.auto import AUTO_LADDER
from povh3d.engine.commands import time_povh3d
from povh3d.engine.methods import run_method
from povh3d.engine.quality import QUALITY_LEVELS, Quality, RenderSettings
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.io import read_png
from povh3d.image.metrics import Reference
from povh3d.scene.scene import load_scene

REPO = Path(__file__).resolve().parents[1]
UNSEEN = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.1, 0.12, 0.2> }
light_source { <-40, 60, -80> rgb 1 }
plane { z, 9 pigment { granite colour_map { [0 rgb <0.2, 0.25, 0.3>] [1 rgb <0.9, 0.85, 0.7>] } scale 3 } }
sphere { <3, 1, 2>, 3.5 pigment { wood colour_map { [0 rgb <0.6, 0.3, 0.1>] [1 rgb <0.95, 0.8, 0.5>] }
  scale 0.6 rotate <30, 60, 0> } finish { specular 0.5 roughness 0.02 } }
torus { 3, 0.8 rotate <70, 0, 20> translate <-5, -2, -1> pigment { bozo colour_map {
  [0 rgb <0.1, 0.5, 0.2>] [1 rgb <0.9, 0.9, 0.3>] } scale 0.4 } }
"""
CASES = {"sample.pov": (20, 30, 40, 45), "fine_texture.pov": (25, 35, 42), "unseen.pov": (22, 33, 44)}
ARRAY_ARGS = ["--preset", "demo", "--lenses", "20x15"]


def rung_name(q: Quality) -> str:
    named = {v: k for k, v in QUALITY_LEVELS.items()}
    return named.get(q, str(q.footprint))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=REPO / "bench-out")
    parser.add_argument("--reference-samples", type=int, default=1024)
    parser.add_argument("--no-docs", action="store_true", help="do not write docs/benchmarks.md")
    args = parser.parse_args()
    load_before = os.getloadavg()
    args.out.mkdir(parents=True, exist_ok=True)
    folder = Path(tempfile.mkdtemp(prefix="bench-auto-"))
    (folder / "unseen.pov").write_text(UNSEEN)
    scenes = {"sample.pov": REPO / "sample_models" / "sample.pov",
              "fine_texture.pov": REPO / "sample_models" / "fine_texture.pov", "unseen.pov": folder / "unseen.pov"}
    rows, results = [], []
    for name, targets in CASES.items():
        path = scenes[name]
        out = folder / name.replace(".pov", "")
        out.mkdir()
        time_povh3d(["render", path, *ARRAY_ARGS, "--quality", "draft", "--no-cache", "-q", "-o", out / "a.png"])
        a = json.loads((out / "a.json").read_text())["lens_array"]
        p = a["panel"]
        la = LensArray(a["grid"], *a["lenses"], *a["lens_pitch_mm"], a["focal_mm"],
                       Panel(*p["size_px"], *p["pixel_pitch_mm"]))
        scene = load_scene(path)
        base = RenderSettings(quality="draft", bit_depth=16)
        reference = Reference(*(run_method("multi-ortho", scene, la, replace(
            base, quality=Quality(footprint=args.reference_samples, seed=seed))).h3d for seed in (1, 2)))
        ladder = []
        for q in AUTO_LADDER:
            rung = rung_name(q)
            image = out / f"{rung}.png"
            seconds = time_povh3d(["render", path, *ARRAY_ARGS, "--quality", rung, "--no-cache", "-q", "-o", image])
            ladder.append((rung, seconds, reference.psnr(read_png(image))))
            print(f"{name} {rung}: {seconds:.2f} s {ladder[-1][2]:.2f} dB", flush=True)
            if ladder[-1][2] > max(targets) + 1:
                break
        for target in targets:
            image = out / f"auto-{target}.png"
            seconds = time_povh3d(["render", path, *ARRAY_ARGS, "--quality", "auto", "--max-error", target,
                                   "--no-cache", "-q", "-o", image])
            got = reference.psnr(read_png(image))
            chosen = json.loads(image.with_suffix(".json").read_text())["quality"]["auto"]["chosen"]
            meets = [r for r in ladder if r[2] >= target]
            fastest = min(meets, key=lambda r: r[1]) if meets else None
            ok = got >= target - 0.2 and fastest is not None and seconds <= 1.25 * fastest[1]
            results.append({"scene": name, "target_db": target, "auto_s": seconds, "auto_db": got,
                            "chosen": chosen, "fastest": fastest, "floor_db": reference.floor_db, "pass": ok})
            rows.append((name, f"{target}", f"{got:.2f}", chosen, f"{seconds:.2f}",
                         f"{fastest[0]} {fastest[1]:.2f} s" if fastest else "none",
                         f"{seconds / fastest[1]:.2f}x" if fastest else "-", f"{reference.floor_db:.1f}",
                         "yes" if ok else "no"))
            print(" | ".join(rows[-1]), flush=True)
    (args.out / "auto.json").write_text(json.dumps(results, indent=1))
    text = table(f"`--quality auto --max-error X`, {' '.join(ARRAY_ARGS)}, full image against two seeds of "
                 f"{args.reference_samples} footprint samples; whole commands (auto's probe included)",
                 ["scene", "X dB", "full image dB", "chosen", "auto s", "fastest rung reaching X", "ratio",
                  "reference floor dB", "pass"], rows, load_before)
    print(text)
    if not args.no_docs:
        write_table("auto", text)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    sys.exit(main())

"""Benchmark: exact subpixel rendering of a slanted lenticular panel against the
view-then-map route and a plain 2D render (issue 16, item 2).

The panel is the Philips 20in display (1600x1200, 0.255 mm pixels, lenticules
4.5 subpixels wide along a row, slanted 9.46 deg, 9 views; thesis Table 4.1),
or a smaller panel of the same pitches for the error figures.

- **Time** (whole process, ``python -m povh3d.cli render ...`` and ``povray`` for the
  2D render, cold cache, point-sampled): the 2D render of the panel (one
  orthographic camera, ``W x H`` rays), ``--method subpixel`` (``3W x H`` rays
  through the turned sheet), and ``--preset philips-20 --mapping philips``
  (9 upright views, then the van Berkel mapping).  Interleaved runs, median and
  spread, the load average recorded.
- **Error** against a reference that integrates each subpixel over its
  angular width and its height: the subpixel method on a 4x4 finer subpixel
  grid (every cell its own ray), averaged in linear light.  PSNR of the
  subpixel method and of the view-then-map route, and the pictures.

    .venv/bin/python benchmarks/bench_subpixel.py [--repeats 3] [--size 1600x1200] [--error-size 480x360]
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from povh3d.engine.methods import run_method
from povh3d.engine.quality import RenderSettings
from povh3d.engine.subpixel import subpixel_array
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.colour import decode, encode
from povh3d.image.io import read_png, write_png
from povh3d.image.metrics import psnr
from povh3d.scene.scene import load_scene

REPO = Path(__file__).resolve().parents[1]
PITCH, FOCAL, SLANT, VIEWS = 0.255, 1.0, 9.46, 9
LENS_ALONG_ROW = 0.3825  # 4.5 subpixels
SCENE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb 0 }
// Fine detail within the panel's depth of field (a subpixel spans 0.085 mm at
// f = 1 mm): a 1.5 mm checker turned 20 deg 3 mm behind the screen, a disc of
// 1.2 mm stripes 2 mm in front of it.
plane { z, 3 pigment { checker rgb <1, 0.9, 0.7> rgb <0.05, 0.1, 0.3> scale 1.5 rotate 20*z }
        finish { emission 1 diffuse 0 } }
disc { <-8, 4, -2>, -z, 14 pigment { gradient x color_map { [0 rgb <1, 0.2, 0.1>] [0.5 rgb <1, 0.2, 0.1>]
         [0.5 rgb <0.1, 0.8, 0.3>] [1 rgb <0.1, 0.8, 0.3>] } scale 1.2 rotate 30*z }
         finish { emission 1 diffuse 0 } }
"""


def sheet_args(w: int, h: int) -> list[str]:
    ppl = LENS_ALONG_ROW * math.cos(math.radians(SLANT)) / PITCH  # across the lenticules
    return ["--preset", "demo", "--grid", "lenticular", "--panel", f"{w}x{h}", "--pixel-pitch", repr(PITCH),
            "--ppl", repr(ppl), "--rows", str(h), "--focal", repr(FOCAL), "--lens-rotation", repr(SLANT)]


def cli(*args: str) -> float:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "povh3d.cli", *args], check=True, cwd=REPO,
                   env={**os.environ, "PYTHONPATH": str(REPO)}, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t


def plain_2d(scene: Path, w: int, h: int, out: Path) -> float:
    script = out.with_suffix(".pov")
    wm, hm = w * PITCH, h * PITCH
    script.write_text(f'#include "{scene}"\ncamera {{ orthographic location <0, 0, -200> direction z '
                      f"right <{wm!r}, 0, 0> up <0, {hm!r}, 0> }}\n")
    t = time.perf_counter()
    subprocess.run(["povray", f"+I{script}", f"+O{out}", f"+W{w}", f"+H{h}", "-A", "-D", "+FN", "-GA",
                    f"+WT{os.cpu_count()}"], check=True, capture_output=True)
    return time.perf_counter() - t


def timing(folder: Path, scene: Path, size: tuple[int, int], repeats: int) -> dict[str, list[float]]:
    w, h = size
    runs = {"2D render": [], "subpixel": [], "views + philips mapping": []}
    for _ in range(repeats):  # interleaved: the load drifts
        runs["2D render"].append(plain_2d(scene, w, h, folder / "flat.png"))
        runs["subpixel"].append(cli("render", str(scene), "-o", str(folder / "sub.png"), "--quality", "draft",
                                    "--no-cache", "-q", "--method", "subpixel", *sheet_args(w, h)))
        runs["views + philips mapping"].append(cli(
            "render", str(scene), "-o", str(folder / "mapped.png"), "--quality", "draft", "--no-cache", "-q",
            "--preset", "philips-20", "--panel", f"{w}x{h}", "--mapping", "philips"))
    return runs


def reference(scene, la: LensArray, k: int = 4) -> np.ndarray:
    """Each subpixel integrated over its width (angle) and height: k x k finer cells, linear mean."""
    sub = subpixel_array(la)
    p = sub.panel
    fine = LensArray("lenticular", la.lenses_x, p.height * k, la.pitch_x, p.pitch_y / k, la.focal,
                     Panel(p.width * k, p.height * k, p.pitch_x / k, p.pitch_y / k), la.rotation)
    # A lenticular panel of k x k cells per subpixel: the subpixel method of a panel with 3W k / 3 pixels.
    img = run_method("multi-ortho", scene, fine, RenderSettings(quality="draft", use_cache=False)).h3d
    lin = decode(img[..., :3]).reshape(p.height, k, p.width, k, 3).mean(axis=(1, 3))
    cells = lin.reshape(p.height, p.width // 3, 3, 3)
    return encode(np.einsum("hwcc->hwc", cells), np.uint8)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--size", default="1600x1200")
    ap.add_argument("--error-size", default="480x360")
    args = ap.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    esize = tuple(int(v) for v in args.error_size.split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        scene_path = folder / "fine.pov"
        scene_path.write_text(SCENE)
        load_before = os.getloadavg()
        runs = timing(folder, scene_path, size, args.repeats)
        load_after = os.getloadavg()
        print(f"## time, {size[0]}x{size[1]}, {args.repeats} interleaved runs, load {load_before[0]:.2f} -> "
              f"{load_after[0]:.2f}")
        base = statistics.median(runs["2D render"])
        for name, t in runs.items():
            print(f"| {name} | {statistics.median(t):.2f} s | {min(t):.2f} to {max(t):.2f} s | "
                  f"{statistics.median(t) / base:.2f}x |")
        # Error at a smaller panel of the same pitches.
        w, h = esize
        cli("render", str(scene_path), "-o", str(folder / "esub.png"), "--quality", "draft", "--no-cache", "-q",
            "--method", "subpixel", *sheet_args(w, h))
        cli("render", str(scene_path), "-o", str(folder / "emap.png"), "--quality", "draft", "--no-cache", "-q",
            "--preset", "philips-20", "--panel", f"{w}x{h}", "--mapping", "philips")
        from povh3d.geometry.presets import get_preset, lens_array_from_fields, merge_overrides
        fields = merge_overrides(get_preset("demo"), {
            "grid": "lenticular", "panel": (w, h), "pixel_pitch": PITCH, "rows": h, "focal": FOCAL,
            "ppl": LENS_ALONG_ROW * math.cos(math.radians(SLANT)) / PITCH, "lens_rotation": SLANT})
        la = lens_array_from_fields(fields)
        ref = reference(load_scene(scene_path), la)
        sub, mapped = read_png(folder / "esub.png")[..., :3], read_png(folder / "emap.png")[..., :3]
        print(f"## error against the 4x4 subpixel-footprint reference, {w}x{h}")
        print(f"| subpixel | {psnr(sub, ref):.2f} dB |")
        print(f"| views + philips mapping | {psnr(mapped, ref):.2f} dB |")
        out = REPO / "docs" / "images"
        crop = (slice(h // 2 - 60, h // 2 + 60), slice(w // 2 - 80, w // 2 + 80))
        strip = np.concatenate([ref[crop], sub[crop], mapped[crop]], axis=1)
        write_png(out / "subpixel_compare.png", np.repeat(np.repeat(strip, 2, 0), 2, 1))
        print(f"wrote {out / 'subpixel_compare.png'} (reference | subpixel | views + mapping, 2x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

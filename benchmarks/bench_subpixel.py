"""Benchmark: exact subpixel rendering of a slanted lenticular panel against the
view-then-map route and a plain 2D render (issue 16, item 2).

The panel is the Philips 20in display (``--preset philips-20``: 1600x1200, 0.255 mm
pixels, lenticules 4.5 subpixels wide along a row, slanted atan(1/6), f = 1 mm, 9
views), or a smaller panel of the same pitches for the error figures.

- **Time** (whole processes, cold cache, point-sampled): ``povray`` rendering the
  panel in 2D (one orthographic camera, ``W x H`` rays); ``render --method subpixel``
  (``3W x H`` rays); ``render --mapping philips`` (9 upright views, then the mapping).
  Interleaved runs, median and spread, the load average recorded.
- **Error** against a footprint reference that owes nothing to either route: the
  scene is analytic (emissive planes), traced in NumPy.  Every subpixel's light
  leaves through the whole aperture of the lenticule over it, over the directions
  its own area spans (docs/geometry.md, "Pixel footprint"): stratified samples of a
  point of the subpixel, which picks its lenticule and the direction (its offset from
  that lenticule's axis over f), and a point of that lenticule's aperture (its width
  across, a pixel along), averaged in linear light.  Both routes trace the same sheet:
  the mapping gets the offset ``--method subpixel`` records.

    .venv/bin/python benchmarks/bench_subpixel.py [--repeats 5] [--size 1600x1200] [--error-size 360x270]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from povh3d.display.subpixel import subpixel_array
from povh3d.geometry.footprint import latin_hypercube
from povh3d.display.presets import lens_array_from_record
from povh3d.geometry.rays import pixel_rays
from povh3d.image.colour import encode
from povh3d.image.io import read_png, write_png
from povh3d.image.metrics import psnr

REPO = Path(__file__).resolve().parents[1]
PITCH = 0.255
# Fine detail within the panel's depth of field (a subpixel spans 0.085 mm at f = 1 mm):
# a 1.5 mm checker turned 20 deg 3 mm behind the screen, a disc of 1.2 mm stripes 2 mm in front.
CHECKER = dict(z=3.0, scale=1.5, turn=20.0, colours=((1, 0.9, 0.7), (0.05, 0.1, 0.3)))
STRIPES = dict(z=-2.0, centre=(-8.0, 4.0), radius=14.0, scale=1.2, turn=30.0,
               colours=((1, 0.2, 0.1), (0.1, 0.8, 0.3)))
SCENE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb 0 }
plane { z, 3 pigment { checker rgb <1, 0.9, 0.7> rgb <0.05, 0.1, 0.3> scale 1.5 rotate 20*z }
        finish { emission 1 diffuse 0 ambient 0 } }
disc { <-8, 4, -2>, -z, 14 pigment { gradient x color_map { [0 rgb <1, 0.2, 0.1>] [0.5 rgb <1, 0.2, 0.1>]
         [0.5 rgb <0.1, 0.8, 0.3>] [1 rgb <0.1, 0.8, 0.3>] } scale 1.2 rotate 30*z }
         finish { emission 1 diffuse 0 ambient 0 } }
"""
# POV-Ray's checker adds this before flooring (pattern.cpp, SMALL_TOLERANCE).
CHECKER_TOLERANCE = 1e-4


def cli(*args: str) -> float:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "povh3d.cli", *args], check=True, cwd=REPO,
                   env={**os.environ, "PYTHONPATH": str(REPO)}, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t


def plain_2d(scene: Path, w: int, h: int, out: Path) -> float:
    script = out.with_suffix(".pov")
    script.write_text(f'#include "{scene}"\ncamera {{ orthographic location <0, 0, -200> direction z '
                      f"right <{w * PITCH!r}, 0, 0> up <0, {h * PITCH!r}, 0> }}\n")
    t = time.perf_counter()
    subprocess.run(["povray", f"+I{script}", f"+O{out}", f"+W{w}", f"+H{h}", "-A", "-D", "+FN", "-GA",
                    f"+WT{os.cpu_count()}"], check=True, capture_output=True)
    return time.perf_counter() - t


def subpixel_render(scene: Path, size: tuple[int, int], out: Path, quality: str = "draft") -> float:
    return cli("render", str(scene), "-o", str(out), "--quality", quality, "--no-cache", "-q",
               "--preset", "philips-20", "--panel", f"{size[0]}x{size[1]}", "--method", "subpixel")


def mapped_render(scene: Path, size: tuple[int, int], out: Path, offset: float) -> float:
    return cli("render", str(scene), "-o", str(out), "--quality", "draft", "--no-cache", "-q",
               "--preset", "philips-20", "--panel", f"{size[0]}x{size[1]}", "--mapping", "philips",
               "--offset", repr(offset))


def timing(folder: Path, scene: Path, size: tuple[int, int], repeats: int, offset: float) -> dict[str, list[float]]:
    runs: dict[str, list[float]] = {"2D render": [], "subpixel": [], "views + philips mapping": []}
    for _ in range(repeats):  # interleaved: the load drifts
        runs["2D render"].append(plain_2d(scene, *size, folder / "flat.png"))
        runs["subpixel"].append(subpixel_render(scene, size, folder / "sub.png"))
        runs["views + philips mapping"].append(mapped_render(scene, size, folder / "mapped.png", offset))
    return runs


# -- the analytic scene in NumPy ------------------------------------------------------

def _turned(x: np.ndarray, y: np.ndarray, degrees: float, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """A point in a pattern's own frame: POV-Ray's ``scale S rotate A*z`` undone."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return (c * x + s * y) / scale, (-s * x + c * y) / scale


def trace(origin: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Linear RGB of rays ``(n, 3)`` from the viewer's side: the stripe disc, else the checker plane."""
    def hit(z: float) -> tuple[np.ndarray, np.ndarray]:
        t = (z - origin[:, 2]) / direction[:, 2]
        return origin[:, 0] + t * direction[:, 0], origin[:, 1] + t * direction[:, 1]

    x, y = hit(CHECKER["z"])
    qx, qy = _turned(x, y, CHECKER["turn"], CHECKER["scale"])
    qz = CHECKER["z"] / CHECKER["scale"]
    odd = (np.floor(qx + CHECKER_TOLERANCE) + np.floor(qy + CHECKER_TOLERANCE)
           + math.floor(qz + CHECKER_TOLERANCE)).astype(np.int64) & 1
    colour = np.asarray(CHECKER["colours"], dtype=np.float64)[odd]
    x, y = hit(STRIPES["z"])
    on_disc = (x - STRIPES["centre"][0]) ** 2 + (y - STRIPES["centre"][1]) ** 2 <= STRIPES["radius"] ** 2
    qx, _ = _turned(x, y, STRIPES["turn"], STRIPES["scale"])
    stripe = np.asarray(STRIPES["colours"], dtype=np.float64)[(qx - np.floor(qx) >= 0.5).astype(np.int64)]
    return np.where(on_disc[:, None], stripe, colour)


def point_sampled(sheet) -> np.ndarray:
    """Every subpixel's own ray (``pixel_rays``) traced in NumPy: what ``--method subpixel`` should show."""
    centres, dirs, _ = pixel_rays(subpixel_array(sheet))
    h, w3 = centres.shape[:2]
    origin = np.concatenate([centres, np.zeros((h, w3, 1))], axis=-1).reshape(-1, 3)
    return _to_panel(trace(origin, dirs.reshape(-1, 3)).reshape(h, w3, 3))


def footprint_reference(sheet, samples: int = 256, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The footprint reference of every subpixel (linear, panel ``(H, W, 3)``), and a second one
    from independent samples (their difference measures the reference's own noise)."""
    sub = subpixel_array(sheet)
    X, Y = np.meshgrid(*sub.panel.pixel_centres())
    sx, sy = sub.panel.pitch_x, sub.panel.pitch_y
    px, f = sheet.pitch_x, sheet.focal
    rng = np.random.default_rng(seed)
    out = []
    for run in range(2):
        base = latin_hypercube(samples, seed=seed + run)            # (n, 4): subpixel point, aperture point
        total = np.zeros(X.shape + (3,))
        for rows in np.array_split(np.arange(X.shape[0]), max(1, X.size * samples // 2_000_000)):
            xc, yc = X[rows][..., None], Y[rows][..., None]
            # A shift per subpixel (mod 1) keeps the strata but decorrelates neighbours.
            jitter = (base[None, None] + rng.random((len(rows), X.shape[1], 1, 4)) + 0.5) % 1 - 0.5
            qx, qy = sub.to_lattice(xc + jitter[..., 0] * sx, yc + jitter[..., 1] * sy)   # the emitting point
            _, ycl = sub.to_lattice(xc, yc)
            lens = np.floor(qx / px + sheet.lenses_x / 2)              # the lenticule over that point
            axis = (lens + 0.5 - sheet.lenses_x / 2) * px
            ax, ay = axis + jitter[..., 2] * px, ycl + jitter[..., 3] * sy  # a point of its aperture
            dx, dy = sub.from_lattice(qx - axis, qy - ycl)
            ox, oy = sub.from_lattice(ax, ay)
            origin = np.stack([ox, oy, np.zeros_like(ox)], axis=-1).reshape(-1, 3)
            direction = np.stack([dx, dy, np.full_like(dx, f)], axis=-1).reshape(-1, 3)
            total[rows] = trace(origin, direction).reshape(len(rows), X.shape[1], samples, 3).mean(axis=2)
        out.append(_to_panel(total))
    return out[0], out[1]


def _to_panel(subpixels: np.ndarray) -> np.ndarray:
    """``(H, 3W, 3)`` -> ``(H, W, 3)``: channel c of subpixel c."""
    h, w3 = subpixels.shape[:2]
    return np.einsum("hwcc->hwc", subpixels.reshape(h, w3 // 3, 3, 3))


def errors(folder: Path, scene: Path, size: tuple[int, int]) -> dict[str, float]:
    sub_png, map_png = folder / "esub.png", folder / "emap.png"
    subpixel_render(scene, size, sub_png)
    record = json.loads(sub_png.with_suffix(".json").read_text())
    sheet = lens_array_from_record(record["lens_array"])
    mapped_render(scene, size, map_png, record["display"]["sheet"]["mapping_offset"])
    seconds = subpixel_render(scene, size, folder / "enormal.png", "normal")
    sub, mapped = read_png(sub_png)[..., :3], read_png(map_png)[..., :3]
    normal = read_png(folder / "enormal.png")[..., :3]
    # The NumPy scene is POV-Ray's: the point-sampled subpixel render agrees with it.
    agree = float(np.mean(np.abs(encode(point_sampled(sheet)).astype(int) - sub) <= 1))
    ref_lin, ref2_lin = footprint_reference(sheet)
    ref = encode(ref_lin)
    w, h = size
    out = REPO / "docs" / "images"
    crop = (slice(h // 2 - 60, h // 2 + 60), slice(w // 2 - 80, w // 2 + 80))
    strip = np.concatenate([ref[crop], sub[crop], mapped[crop]], axis=1)
    write_png(out / "subpixel_compare.png", np.repeat(np.repeat(strip, 2, 0), 2, 1))
    return {"subpixel": psnr(sub, ref), "views + philips mapping": psnr(mapped, ref),
            "subpixel, normal (3 x 3 footprint samples)": psnr(normal, ref), "normal seconds": seconds,
            "reference noise": psnr(encode(ref2_lin), ref), "agree": agree}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--size", default="1600x1200")
    ap.add_argument("--error-size", default="360x270")
    args = ap.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    esize = tuple(int(v) for v in args.error_size.split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        scene_path = folder / "fine.pov"
        scene_path.write_text(SCENE)
        subpixel_render(scene_path, size, folder / "probe.png")
        offset = json.loads((folder / "probe.json").read_text())["display"]["sheet"]["mapping_offset"]
        load_before = os.getloadavg()
        runs = timing(folder, scene_path, size, args.repeats, offset)
        load_after = os.getloadavg()
        print(f"## time, {size[0]}x{size[1]}, {args.repeats} interleaved runs, load {load_before[0]:.2f} -> "
              f"{load_after[0]:.2f}")
        base = statistics.median(runs["2D render"])
        for name, t in runs.items():
            ratios = [a / b for a, b in zip(t, runs["2D render"])]
            print(f"| {name} | {statistics.median(t):.2f} s | {min(t):.2f} to {max(t):.2f} s | "
                  f"{statistics.median(t) / base:.2f}x | {min(ratios):.2f} to {max(ratios):.2f}x |")
        e = errors(folder, scene_path, esize)
        print(f"## error against the footprint reference (aperture x subpixel area, NumPy), {esize[0]}x{esize[1]}")
        for name in ("subpixel", "views + philips mapping", "subpixel, normal (3 x 3 footprint samples)"):
            print(f"| {name} | {e[name]:.2f} dB |")
        print(f"(subpixel at normal: {e['normal seconds']:.2f} s)")
        print(f"reference noise (two independent references): {e['reference noise']:.2f} dB; "
              f"point-sampled NumPy scene equals the subpixel render on {100 * e['agree']:.2f} % of subpixels")
        print(f"wrote {REPO / 'docs' / 'images' / 'subpixel_compare.png'} (reference | subpixel | views + mapping, 2x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

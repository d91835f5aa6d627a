"""Benchmark: how far the mesh camera's rays land from the conventions' on ``animations/fractalzoom``'s
frame, and what moving the oracle by that much does to its chaotic pigment (docs/benchmarks.md, Gallery,
"chaotic, not wrong"; the gallery's ``chaotic`` outcome).

1. Hit points: fractalzoom's camera over a plane at the screen whose pigment encodes the hit point
   (x, y) modulo a period, at 16 bits; the whole ``povh3d render --quality draft --bit-depth 16``
   command on each preset; every pixel of every view against its lens centre (the conventions' hit on
   a plane at the screen).  Periods from coarse to fine, each trusted only where the coarser one's
   miss lies well within it: the worst miss in mm, scene units, the pigment's units (fractalzoom
   scales its pigment 1e4 times) and view pixels, against ``chaotic_shift_mm``.
2. fractalzoom's oracle (the gallery's centre view) against itself moved along x and y by 1e-9 and
   1e-8 mm, by the measured miss and by the bound.

    PYTHONPATH=$PWD .venv/bin/python benchmarks/bench_ray_precision.py [--presets demo ipad-retina]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from benchmarks.gallery_oracle import EXAMPLES, chaotic_shift_mm, oracle_view  # noqa: E402

#: fractalzoom's camera over a plane whose red and green are the hit point's x and y modulo PERIOD
#: scene units (moved by SHIFT), in linear light
ENCODE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location -z*4 look_at 0 }
plane { -z, 0 pigment { average pigment_map {
    [1 function { x/PERIOD - floor(x/PERIOD) } color_map { [0 rgb 0] [1 rgb <2, 0, 0>] }]
    [1 function { y/PERIOD - floor(y/PERIOD) } color_map { [0 rgb 0] [1 rgb <0, 2, 0>] }] } translate <SHIFT, SHIFT, 0> }
  finish { ambient 1 diffuse 0 } }
"""
PERIODS = (0.133, 0.133 / 64, 0.133 / 4096)   # scene units
PIGMENT_SCALE = 1e4                           # fractalzoom's ``scale pow(10, 4 + 5 * clock)`` at clock 0


def encode_scene(folder: Path, period: float, shift: float = 0.0) -> Path:
    path = folder / f"encode_{period:.3g}_{shift:g}.pov"
    path.write_text(ENCODE.replace("PERIOD", repr(period)).replace("SHIFT", repr(shift)))
    return path


def hit_miss_mm(views_dir: Path, record: dict, period: float) -> tuple[float, float]:
    """The worst miss (mm) along x and along y of every view pixel's encoded hit (``ENCODE`` with
    ``period``) from its lens centre, each modulo the period."""
    from povh3d.image.colour import decode
    from povh3d.image.io import read_png

    la, upm = record["lens_array"], record["placement"]["units_per_mm"]
    (lx, ly), (px, py), (nx, ny) = la["lenses"], la["lens_pitch_mm"], la["views"]
    centre = np.stack(np.broadcast_arrays((np.arange(lx) + 0.5 - lx / 2)[None, :] * px,
                                          (ly / 2 - np.arange(ly) - 0.5)[:, None] * py), -1) * upm
    worst = np.zeros(2)
    for l in range(ny):
        for k in range(nx):
            got = decode(read_png(views_dir / f"v_{l:03d}_{k:03d}.png"))[..., :2]
            off = got - (centre / period) % 1.0
            worst = np.maximum(worst, np.abs((off + 0.5) % 1.0 - 0.5).reshape(-1, 2).max(axis=0))
    return float(worst[0] * period / upm), float(worst[1] * period / upm)


def _render(scene: Path, preset: str, folder: Path) -> dict:
    out = folder / "h3d.png"
    subprocess.run([sys.executable, "-m", "povh3d.cli", "render", str(scene), "--preset", preset, "--quality", "draft",
                    "-q", "--bit-depth", "16", "-o", str(out), "--views-dir", str(folder / "views"), "--jobs", "1"],
                   env={**os.environ, "PYTHONPATH": str(REPO), "POVH3D_CACHE": str(folder / "cache")},
                   check=True, capture_output=True)
    return json.loads(out.with_suffix(".json").read_text())


def measure(preset: str, folder: Path) -> tuple[dict, float]:
    """The preset's record and the worst miss (mm) of the finest trusted period; prints each period's."""
    miss, record = float("inf"), {}
    for period in PERIODS:
        run = folder / f"{preset}_{period:.3g}"
        run.mkdir()
        record = _render(encode_scene(folder, period), preset, run)
        upm = record["placement"]["units_per_mm"]
        resolution = 2.3 * period / 65535 / upm   # sRGB's steepest step: 2.3 codes per linear code
        if np.isfinite(miss) and miss > period / upm / 4:   # the coarser miss does not pin this period's wrap
            break
        mx, my = hit_miss_mm(run / "views", record, period)
        miss = max(mx, my)
        (px, py), bound = record["lens_array"]["lens_pitch_mm"], chaotic_shift_mm(record)
        print(f"{preset}: period {period:.3g} units ({period / upm:.3g} mm, resolution {resolution:.2g} mm): "
              f"worst miss x {mx:.3g} mm ({mx / px:.2g} view px), y {my:.3g} mm ({my / py:.2g} view px); "
              f"{miss * upm:.3g} scene units, {miss * upm / PIGMENT_SCALE:.3g} pigment units; "
              f"{miss / bound:.2f} of the bound {bound:.3g} mm (front clearance "
              f"{record['quality']['front_clearance_mm']:g} mm)", flush=True)
    return record, miss


def main() -> int:
    from povh3d.image.io import read_png  # noqa: F401  (fails early without povh3d)
    from povh3d.image.metrics import psnr

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", nargs="*", default=["demo", "ipad-retina"])
    args = parser.parse_args()
    scene = EXAMPLES / "animations/fractalzoom/fractalzoom.pov"
    print(f"load average {os.getloadavg()[0]:.2f} (1 min), {os.cpu_count()} cores", flush=True)
    for preset in args.presets:
        with tempfile.TemporaryDirectory() as name:
            record, miss = measure(preset, Path(name))
        la = record["lens_array"]
        nx, ny = la["views"]
        shape, view = (la["lenses"][1], la["lenses"][0]), (ny // 2, nx // 2)
        oracle = oracle_view(scene, record, view, shape, 600)[..., :3]
        moves = (1e-9, 1e-8, miss, chaotic_shift_mm(record), *la["lens_pitch_mm"])
        gaps = [psnr(oracle_view(scene, record, view, shape, 600, shift_mm=s)[..., :3], oracle) for s in moves]
        print(f"{preset}: fractalzoom's oracle moved by " + ", ".join(f"{s:.2g} mm: {g:.1f} dB"
                                                                       for s, g in zip(moves, gaps)), flush=True)
    print(f"load average {os.getloadavg()[0]:.2f} after", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

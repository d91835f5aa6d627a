"""Benchmark: lens-grid calibration time on large white images (issue 6 targets: 2000x2000
in <= 1 s, 5616x3744, the thesis camera, in <= 5 s), with the accuracy reached.

The white images are synthesised (povh3d.calibration.synth) once and kept in
bench-out/ as .npy; the timing is ``calibrate(image)`` on the in-memory 16-bit
image, median of a few repeats.

    .venv/bin/python benchmarks/bench_calibrate.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from povh3d.calibration.lattice import calibrate
from tests.support.synth import WhiteSpec, render_white, to_uint, true_centres

REPO = Path(__file__).resolve().parents[1]
CASES = {
    "2000x2000 square, 13.7 px, 0.3 deg, barrel": WhiteSpec(
        (2000, 2000), pitch_px=13.7, rotation_deg=0.3, k1=-0.02, vignetting=0.3, noise=0.01, supersample=2),
    "2000x2000 hex, 11.3 px, 9.46 deg": WhiteSpec(
        (2000, 2000), lattice="hex", pitch_px=11.3, rotation_deg=9.46, vignetting=0.3, noise=0.01, supersample=2),
    "5616x3744 square, 29.1 px (thesis camera), flat, barrel": WhiteSpec(
        (5616, 3744), pitch_px=29.1, rotation_deg=0.1, k1=-0.02, profile="flat", vignetting=0.3, noise=0.01,
        supersample=2),
}


def white(name: str, spec: WhiteSpec, folder: Path) -> np.ndarray:
    path = folder / ("white_" + "".join(ch if ch.isalnum() else "_" for ch in name) + ".npy")
    if path.is_file():
        return np.load(path)
    image = to_uint(render_white(spec), 16)
    np.save(path, image)
    return image


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", default=str(REPO / "bench-out" / "bench_calibrate.json"))
    args = ap.parse_args()
    folder = Path(args.json).parent
    folder.mkdir(parents=True, exist_ok=True)
    results = {}
    print(f"{'case':58s} {'seconds':>8s} {'RMS px':>8s} {'pitch %':>8s} {'rot deg':>8s}")
    for name, spec in CASES.items():
        image = white(name, spec, folder)
        times = []
        for _ in range(args.repeats):
            t = time.perf_counter()
            grid = calibrate(image)
            times.append(time.perf_counter() - t)
        dist, _ = cKDTree(true_centres(spec, margin=-1.0)).query(grid.centres[grid.inside])
        rms = float(np.sqrt(np.mean(dist**2)))
        period = 90.0 if spec.lattice == "square" else 60.0
        rot = (grid.rotation_deg - spec.rotation_deg + period / 2) % period - period / 2
        pitch = 100 * (grid.pitch_px / spec.pitch_px - 1)
        seconds = statistics.median(times)
        results[name] = {"seconds": seconds, "rms_px": rms, "pitch_error_percent": pitch,
                         "rotation_error_deg": rot, "lenses": int(grid.inside.sum())}
        print(f"{name:58s} {seconds:8.3f} {rms:8.4f} {pitch:8.4f} {rot:8.4f}")
    Path(args.json).write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

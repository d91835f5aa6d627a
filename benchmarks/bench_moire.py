"""Benchmark: the moire of the thesis's cross-lenticular iPad (section 5.3, Table 5.15)
against the slant of its horizontal sheet, and with the whole pair turned (issue 16, item 4).

Prints, for viewers at several distances, the moire contrast of the pixel rows (what
the horizontal sheet beats with) and of the RGB columns (the vertical sheet) at 0 deg,
6.34 deg and the resonances ``atan(n s' / p)`` where the slanted sheet realigns with the
rows; the measured moire period against the predicted one where the moire is long
enough to see; and writes the two figures of docs/moire.md (``--figures``).

    .venv/bin/python benchmarks/bench_moire.py [--figures docs/images]
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

from povh3d.geometry.moire import LUMINANCE, PanelPattern, cross_sheet, measure, predicted_moire, seen_points, slant_sweep

S, PITCH, FOCAL, LENSES = 0.0965, 2.12, 2.0, (94, 80)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--figures", help="folder to write moire-cross-lenticular{,-turned}.png into")
    args = ap.parse_args()
    pattern = PanelPattern(S, S)
    print(f"load average {os.getloadavg()[0]:.2f}; iPad 3 ({S} mm pixels, open {pattern.open_x} x {pattern.open_y}), "
          f"two {PITCH} mm sheets, f = {FOCAL} mm, {LENSES[0]}x{LENSES[1]} lenses, eye low-pass 1.5 lens pitches\n")
    print("| viewer mm | slant deg | rows contrast | columns contrast | total | rows period mm (predicted) |")
    print("|---|---|---|---|---|---|")
    for distance in (350.0, 500.0, 1000.0):
        mag = 1 + FOCAL / distance
        resonances = [math.degrees(math.atan(n * S / mag / PITCH)) for n in (1, 2, 3)]
        slants = [0.0, 6.34] + resonances
        t = time.perf_counter()
        sweep = slant_sweep(pattern, PITCH, FOCAL, slants, (0.0, 0.0, distance), LENSES)
        seconds = (time.perf_counter() - t) / len(slants)
        for n, slant in enumerate(slants):
            label = f"{slant:.2f}" + (f" (n={n - 1})" if n >= 2 else "")
            print(f"| {distance:g} | {label} | {sweep.row_contrast[n]:.3f} | {sweep.column_contrast[n]:.3f} | "
                  f"{sweep.contrast[n]:.3f} | {sweep.row_period_mm[n]:.2f} ({sweep.row_predicted_mm[n]:.2f}) |")
    turned = slant_sweep(pattern, PITCH, FOCAL, [0.0, 18.43], (0.0, 0.0, 500.0), LENSES, turn=True)
    print(f"\nwhole pair turned, viewer 500 mm: total contrast {turned.contrast[0]:.3f} -> {turned.contrast[1]:.3f} "
          f"at 18.43 deg (rows {turned.row_contrast[1]:.3f}, columns {turned.column_contrast[1]:.3f}), "
          f"period {turned.period_mm[0]:.1f} -> {turned.period_mm[1]:.1f} mm, "
          f"direction {turned.direction_deg[0]:.1f} -> {turned.direction_deg[1]:.1f} deg")
    # The period oracle on a larger sheet (more periods in the window).
    errors = []
    for slant in (0.0, 0.5, 2.5, 5.0):
        la = cross_sheet(PITCH, slant, FOCAL, (160, 160), pattern)
        p = seen_points(la, (0.0, 0.0, 500.0))
        for b, q in ((pattern.rows(p[..., 1]), (0.0, 1 / S)), (pattern.columns(p[..., 0]) @ LUMINANCE, (1 / S, 0.0))):
            errors.append(abs(measure(b, la).period_mm * np.hypot(*predicted_moire(la, q, 500.0)) - 1))
    print(f"measured against predicted moire period (8 cases, 160x160 lenses): worst {100 * max(errors):.2f} %")
    print(f"one slant (three measures of {LENSES[0]}x{LENSES[1]} lenses): {seconds * 1000:.0f} ms")
    if args.figures:
        from povh3d.commands.moire import moire_sweep_file, parse_range
        from povh3d.display.presets import lens_array

        la = lens_array("cross-lenticular-ipad")
        for name, turn in (("moire-cross-lenticular.png", False), ("moire-cross-lenticular-turned.png", True)):
            path = os.path.join(args.figures, name)
            moire_sweep_file(la, parse_range("0:20:0.1"), path, turn=turn)
            os.remove(os.path.splitext(path)[0] + ".json")  # the figure alone goes into the docs
            print(f"wrote {path}")


if __name__ == "__main__":
    main()

"""Benchmark: each lenticular preset replayed from an eye at its design distance, orthographic rows
against rows seen from that distance (docs/displays.md, "A viewing distance").

A wall ``--wall`` mm behind the screen, striped along y (white and blue, a border of one kind every
16 mm); the whole ``povh3d render --quality draft`` command on the preset with its default viewing
distance and with ``--viewing-distance inf``; ``povh3d replay --eye 0,0,-D --size 256xROWS`` of each
(one picture row a panel row); POV-Ray's own render of the same window from the eye.  The figure: the
largest distance, in panel rows, from a stripe border of the eye's render to the nearest border of the
same kind in the replay (borders from each row's mean colour, ``borders``).  And the command's CPU time (user + system of the process tree).

    PYTHONPATH=$PWD .venv/bin/python benchmarks/bench_viewing_distance.py [--presets ipad-retina] [--eye MM]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from povh3d.display.display import build_display  # noqa: E402
from povh3d.image.io import read_png  # noqa: E402

PERIOD = 16.0
SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
background {{ rgb <1, 0, 0> }}
plane {{ z, {wall} pigment {{ gradient y color_map {{ [0 rgb 1] [0.5 rgb 1] [0.5 rgb <0, 0, 1>] [1 rgb <0, 0, 1>] }}
        scale {period} }} finish {{ ambient 0 diffuse 0 emission 1 }} }}
"""


def borders(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows where the stripes change, and to which (1 white, 0 blue), from each row's mean over the
    middle half of the columns: a mapped panel's replay shows each subpixel alone, so a white row is
    one whose green is lit about as much as its blue, a blue row one with no green."""
    w = image.shape[1]
    mean = image[:, w // 4:3 * w // 4].astype(float).mean(axis=1)
    white = (mean[:, 1] > 0.5 * mean[:, 2]).astype(int)
    at = np.flatnonzero(white[1:] != white[:-1])
    return at + 0.5, white[at + 1]


def offset_rows(seen: np.ndarray, expected: np.ndarray) -> float:
    (a, ka), (b, kb) = borders(expected), borders(seen)
    apart = np.abs(a[:, None] - b[None, :]) + np.where(ka[:, None] == kb[None, :], 0, np.inf)
    return float(apart.min(axis=1).max())


def cpu_of(command: list[str]) -> float:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(command, check=True, capture_output=True, env={**os.environ, "PYTHONPATH": str(REPO)})
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--presets", nargs="+", default=["ipad-retina", "philips-20", "alioscopy-42"])
    ap.add_argument("--wall", type=float, default=20.0)
    ap.add_argument("--eye", type=float, help="eye distance, mm (default: each preset's design distance)")
    args = ap.parse_args()
    py = [sys.executable, "-m", "povh3d"]
    rows_out = []
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        scene = tmp / "wall.pov"
        scene.write_text(SCENE.format(wall=args.wall, period=PERIOD))
        for preset in args.presets:
            mapping = build_display(preset).mapping_name   # a slanted panel: rendered through its mapping
            mapped = ["--mapping", mapping] if mapping else []
            display = build_display(preset, mapping=mapping)
            distance = args.eye or display.viewing_distance_mm
            panel = display.mapped_panel or display.lens_array.panel
            w_mm, h_mm = panel.size_mm
            rows = panel.height
            eye_scene = tmp / "eye.pov"
            eye_scene.write_text(scene.read_text() + f"camera {{ perspective location <0, 0, {-distance}> "
                                 f"direction <0, 0, {distance}> right <{w_mm}, 0, 0> up <0, {h_mm}, 0> }}\n")
            subprocess.run(["povray", f"+I{eye_scene}", f"+O{tmp / 'eye.png'}", "+W256", f"+H{rows}", "-A", "-D",
                            "+FN8", "File_Gamma=sRGB"], check=True, capture_output=True)
            expected = read_png(tmp / "eye.png")[..., :3]
            entry = {"preset": preset, "mapping": mapping, "eye_mm": distance, "rows": rows,
                     "view_rows": display.render_array.lenses_y, "pixel_pitch_y_mm": panel.pitch_y}
            for name, extra in (("orthographic", ["--viewing-distance", "inf"]),
                                ("viewing_distance", ["--viewing-distance", str(distance)])):
                out = tmp / f"{preset}-{name}.png"
                cpu = cpu_of([*py, "render", str(scene), "--preset", preset, "--quality", "draft", "--no-cache",
                              "-q", "-o", str(out), *mapped, *extra])
                picture = tmp / f"{preset}-{name}-eye.png"
                subprocess.run([*py, "replay", str(out), "--eye", f"0,0,{-distance}", "--size", f"256x{rows}",
                                "-o", str(picture)], check=True, capture_output=True,
                               env={**os.environ, "PYTHONPATH": str(REPO)})
                off = offset_rows(read_png(picture)[..., :3], expected)
                entry[name] = {"rows_off": off, "mm_off": round(off * panel.pitch_y, 3), "render_cpu_s": round(cpu, 2)}
            print(json.dumps(entry), flush=True)
            rows_out.append(entry)


if __name__ == "__main__":
    main()

"""Benchmark: PyVista's frog_tissues.vti (500 x 470 x 136 voxels, 26 labels) to H3D images.

For each display preset (``demo``, ``alioscopy-42``) one ``povh3d render``
(in this process, a cold cache): reading the volume, extracting every label's
surface, decimating them to the display's triangle budget (triangles before
and after), POV-Ray's parse time of the stage scene and the render itself
(draft quality).  Rows are written to ``bench-out/bench_volume.json`` keyed by
preset and drawing; ``bench_volume_media.py`` (direct volume rendering) calls
``render_case`` with ``--volume`` and adds its rows beside them.

    .venv/bin/python benchmarks/bench_volume.py [--presets demo,alioscopy-42] [--labels all]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any


import pyvista

from povh3d.cli.main import main as povh3d
from povh3d.volume.read import read_volume

from _common import parse_seconds

REPO = Path(__file__).resolve().parents[1]
FROG = Path(pyvista.__file__).parent / "examples" / "frog_tissues.vti"
OUT = REPO / "bench-out" / "bench_volume.json"


def parse_seconds_of_scene(stage: Path) -> float:
    """POV-Ray's own parse time of a stage scene (which has no camera: one is added), an 8 x 8 render."""
    return parse_seconds(f'#include "{stage.name}"\n'
                         "camera { orthographic location <0, 0, -200> direction z right <60, 0, 0> up <0, 60, 0> }\n",
                         stage.parent)


def render_case(preset: str, drawing: str, options: list[str], folder: Path) -> dict[str, Any]:
    """One cold ``povh3d render FROG --preset PRESET OPTIONS``: the row of the table."""
    os.environ["POVH3D_CACHE"] = str(folder / f"cache-{preset}-{drawing}")
    t = time.perf_counter()
    read_volume(FROG)
    load = time.perf_counter() - t
    out = folder / f"{preset}-{drawing}.png"
    t = time.perf_counter()
    code = povh3d(["render", str(FROG), "--preset", preset, "-o", str(out), "--quality", "draft", "-q",
                   "--orientation", "axial", *options])
    wall = time.perf_counter() - t
    if code:
        raise SystemExit(f"povh3d render failed for {preset} {drawing}")
    record = json.loads(out.with_suffix(".json").read_text())
    volume = record["volume"]
    row = {"preset": preset, "drawing": drawing, "load_s": load, "wall_s": wall,
           "render_s": record["timings"]["render_seconds"], "parse_s": parse_seconds_of_scene(Path(record["scene"])),
           "load_average": os.getloadavg()[0]}
    if "surfaces" in volume:
        row.update(extract_s=volume["seconds"]["extract"], decimate_s=volume["seconds"]["decimate"],
                   triangles_before=sum(s["triangles_extracted"] for s in volume["surfaces"]),
                   triangles_after=volume["triangles"], budget=volume["triangle_budget"])
    return row


def save_rows(rows: list[dict[str, Any]], path: Path = OUT) -> list[dict[str, Any]]:
    """Merge ``rows`` into the JSON file (a row per preset and drawing, newest wins); all rows."""
    path.parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(path.read_text()) if path.is_file() else []
    keep = {(r["preset"], r["drawing"]): r for r in old}
    keep.update({(r["preset"], r["drawing"]): r for r in rows})
    merged = list(keep.values())
    path.write_text(json.dumps(merged, indent=2) + "\n")
    return merged


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table of docs/volumes.md."""
    lines = ["| preset | drawing | load s | extract s | decimate s | triangles before -> after | parse s | render s "
             "| whole command s |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        tri = f"{r['triangles_before']:,} -> {r['triangles_after']:,}" if "triangles_before" in r else "-"
        lines.append(f"| {r['preset']} | {r['drawing']} | {r['load_s']:.2f} | {r.get('extract_s', float('nan')):.2f} | "
                     f"{r.get('decimate_s', float('nan')):.2f} | {tri} | {r['parse_s']:.2f} | {r['render_s']:.2f} | "
                     f"{r['wall_s']:.1f} |")
    return "\n".join(lines)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--presets", default="demo,alioscopy-42")
    p.add_argument("--labels", default="all", help="labels to draw (default all)")
    args = p.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for preset in args.presets.split(","):
            rows.append(render_case(preset, f"surfaces ({args.labels} labels)", ["--labels", args.labels],
                                    Path(tmp)))
    merged = save_rows(rows)
    print(f"frog_tissues.vti, load average {os.getloadavg()[0]:.2f}, {os.cpu_count()} cores")
    print(table(merged))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

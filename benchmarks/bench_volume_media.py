"""Benchmark: frog_tissues (PyVista's segmented frog) as POV-Ray media on a display preset.

The volume (500 x 470 x 136 voxels, spacing 1 x 1 x 1.5 mm, 30 tissue labels)
is read with PyVista, seen along its z axis (the ``axial`` preset: the file has
no patient frame, so its axes are taken as LPS) and fitted to the display, then written
as a df3 file and a media stage (``povh3d.renderer.content.volume_media.media_stage``) with
the ``labels`` transfer, and rendered as an H3D image by ``multi-ortho``.
Reported: the df3 encode and write times and size, POV-Ray's parse time for the
stage (reading the df3), and the whole render, for the media step given.

    .venv/bin/python benchmarks/bench_volume_media.py [--preset demo] [--quality draft] [--step 1]
                                                      [--bits 8 16] [--repeats 2] [--save IMAGE.png]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import pyvista as pv
from pyvista import examples

from povh3d.geometry.fit import fit_to_display
from povh3d.renderer.content.volume_media import media_stage
from povh3d.renderer.methods.registry import run_method
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.display.presets import lens_array
from povh3d.scene.scene import load_scene
from povh3d.volume.grid import Volume
from povh3d.volume.orient import display_box, volume_to_display, world_to_display

from _common import parse_seconds

FROG = Path(examples.__file__).parent / "frog_tissues.vti"


def read_frog() -> Volume:
    grid = pv.read(FROG)
    values = np.asarray(grid.active_scalars).reshape(grid.dimensions, order="F")  # VTK: x fastest
    return Volume(values, tuple(grid.spacing), tuple(grid.origin), name=FROG.name)


def stage_parse_seconds(stage: Path) -> float:
    """POV-Ray's own parse time for the stage (the df3 is read while parsing), from a tiny render."""
    return parse_seconds(f'#include "{stage.name}"\n'
                         "camera { orthographic location <0, 0, -100> direction z right <40, 0, 0> up <0, 40, 0> }\n",
                         stage.parent, size=4)


def run_once(volume: Volume, w2d: np.ndarray, la, bits: int, args: argparse.Namespace) -> dict[str, float]:
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        stage, record = media_stage(volume, w2d, la, transfer="labels", bits=bits, folder=Path(tmp), step=args.step)
        staged = time.perf_counter() - t
        parse = stage_parse_seconds(stage)
        t = time.perf_counter()
        result = run_method("multi-ortho", load_scene(stage), la, RenderSettings(quality=args.quality, use_cache=False))
        wall = time.perf_counter() - t
        if args.save:
            from povh3d.image.io import write_png

            write_png(args.save.with_name(f"{args.save.stem}-{bits}bit{args.save.suffix}"), result.h3d)
    media = record["media"]
    return {"mb": record["df3"]["bytes"] / 1e6, "encode": record["seconds"]["df3_encode"],
            "write": record["seconds"]["write"], "stage": staged, "parse": parse, "render": wall,
            "povray": sum(result.stats.povray_seconds), "intervals": media["intervals"],
            "sub": media["sub_intervals"] // media["intervals"]}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--preset", default="demo")
    p.add_argument("--quality", default="draft")
    p.add_argument("--step", type=float, default=1.0, help="media samples along a ray, in voxels")
    p.add_argument("--bits", type=int, nargs="+", default=[8, 16])
    p.add_argument("--repeats", type=int, default=2, help="runs of each bit depth, interleaved")
    p.add_argument("--orientation", default="axial")
    p.add_argument("--save", type=Path, help="write the H3D images beside this name (PNG)")
    p.add_argument("--picture", type=Path, help="only render one 400x300 orthographic view (a lens array of "
                   "one pixel per lens) to this PNG: the picture in docs/volume-rendering.md")
    args = p.parse_args()
    la = lens_array(args.preset)
    if args.picture:
        la = LensArray("square", 400, 300, 0.1, 0.1, 1.5, Panel(400, 300, 0.1, 0.1))
    t = time.perf_counter()
    volume = read_frog()
    load = time.perf_counter() - t
    turn = volume_to_display(args.orientation)
    lo, hi = display_box(volume.corners(), turn)
    fit = fit_to_display(lo, hi, la)
    w2d = world_to_display(turn, fit.shift, fit.scale)
    before = os.getloadavg()[0]
    if args.picture:
        with tempfile.TemporaryDirectory() as tmp:
            stage, _ = media_stage(volume, w2d, la, transfer="labels", bits=8, folder=Path(tmp), step=args.step)
            result = run_method("multi-ortho", load_scene(stage), la, RenderSettings(quality="draft", use_cache=False))
        from povh3d.image.io import write_png

        write_png(args.picture, result.h3d)
        return 0
    runs: dict[int, list[dict[str, float]]] = {bits: [] for bits in args.bits}
    for _ in range(args.repeats):
        for bits in args.bits:
            runs[bits].append(run_once(volume, w2d, la, bits, args))
    print(f"frog_tissues {volume.shape} voxels, spacing {volume.spacing} mm, read with PyVista in {load:.2f} s; "
          f"preset {args.preset} ({la.panel.width}x{la.panel.height}), {args.orientation}, scale {fit.scale:.4g}, "
          f"labels transfer, multi-ortho, quality {args.quality}, step {args.step} voxel; median (min-max) of "
          f"{args.repeats} interleaved runs; load average {before:.2f} before, {os.getloadavg()[0]:.2f} after, "
          f"{os.cpu_count()} cores")

    def cell(bits: int, key: str) -> str:
        values = [r[key] for r in runs[bits]]
        return f"{statistics.median(values):.2f} s ({min(values):.2f}-{max(values):.2f})"

    print("| | " + " | ".join(f"{b} bit" for b in args.bits) + " |")
    print("|---|" + "---|" * len(args.bits))
    print("| df3 size | " + " | ".join(f"{runs[b][0]['mb']:.1f} MB" for b in args.bits) + " |")
    for key, label in (("encode", "df3 encode"), ("write", "df3 write"), ("stage", "media_stage in all"),
                       ("parse", "POV-Ray parse (reads the df3)"), ("render", "render (whole multi-ortho run)")):
        print(f"| {label} | " + " | ".join(cell(b, key) for b in args.bits) + " |")
    r = runs[args.bits[0]][0]
    print(f"({r['intervals']} intervals x {r['sub']} sub-intervals per ray)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Benchmark: POV-Ray's own sample scenes, whole command against a whole-process 2D render (issue 37).

For each scene (Debian's ``povray-examples``, scenes with a perspective camera of their own) and
each preset: ``povh3d render SCENE --preset P --quality draft`` with a cold cache, against
``povray +ISCENE -A +W +H`` at the panel's size through the scene's own camera, both at the
machine's threads and both whole processes (start to exit).  The runs are interleaved
(2D, povh3d, 2D, povh3d ...), so a change of load hits both sides; a row gives the medians and
their ratio, the table the median and p90 of the ratios per preset, and the load before and
after.  ``--gallery`` instead prints the median and p90 of the "vs 2D" column of the gallery
table already in docs/benchmarks.md (``make gallery`` writes it).

    .venv/bin/python benchmarks/bench_scenes.py [--repeats 3] [--presets demo ipad-retina] [--no-docs]
    .venv/bin/python benchmarks/bench_scenes.py --gallery
"""

from __future__ import annotations

import argparse
import math
import os
import re
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import DOCS, publish, table, whole_process_seconds  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = Path("/usr/share/doc/povray/examples")
SCENES = ("objects/primitiv.pov", "objects/mesh2.pov", "advanced/pawns.pov", "advanced/woodbox.pov",
          "advanced/desk/desk.pov", "objects/blob.pov", "objects/lathe2.pov", "lights/spotlite.pov")
PANELS = {"demo": (320, 240), "ipad-retina": (2048, 1536)}


def percentile(values: list[float], share: float) -> float:
    """The ``share`` quantile (nearest rank) of ``values``."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, math.ceil(share * len(ordered)) - 1))]


def gallery_column() -> dict[str, list[float]]:
    """The "vs 2D" ratios of the gallery table in docs/benchmarks.md, per preset."""
    ratios: dict[str, list[float]] = {}
    for line in DOCS.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 10 and cells[0].endswith(".pov") and re.fullmatch(r"[\d.]+x", cells[8]):
            ratios.setdefault(cells[1], []).append(float(cells[8][:-1]))
    return ratios


def _two_d(scene: Path, size: tuple[int, int], out: Path) -> list[str]:
    return ["povray", f"+I{scene.name}", f"+O{out}", f"+W{size[0]}", f"+H{size[1]}", "-A", "-D",
            f"+WT{os.cpu_count()}", f"+L{EXAMPLES}", "-GA"]


def _povh3d(scene: Path, preset: str, out: Path) -> list[str]:
    return [str(REPO / ".venv" / "bin" / "povh3d"), "render", str(scene), "--preset", preset, "--quality", "draft",
            "-o", str(out), "-q"]


def measure(scenes: list[str], presets: list[str], repeats: int) -> list[tuple[str, str, float, float]]:
    """(scene, preset, median 2D seconds, median povh3d seconds) of interleaved runs, cold cache."""
    rows = []
    for name in scenes:
        scene = EXAMPLES / name
        if not scene.is_file():
            continue
        for preset in presets:
            two_d, ours = [], []
            with tempfile.TemporaryDirectory() as folder:
                work = Path(folder)
                for _ in range(repeats):
                    cache = work / "cache"
                    shutil.rmtree(cache, ignore_errors=True)
                    env = {**os.environ, "POVH3D_CACHE": str(cache)}
                    two_d.append(whole_process_seconds(_two_d(scene, PANELS[preset], work / "2d.png"),
                                                       scene.parent, env))
                    ours.append(whole_process_seconds(_povh3d(scene, preset, work / "h3d.png"), scene.parent, env))
            rows.append((name, preset, statistics.median(two_d), statistics.median(ours)))
            print(f"{name} {preset}: 2D {rows[-1][2]:.2f} s, povh3d {rows[-1][3]:.2f} s", flush=True)
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--presets", nargs="+", choices=list(PANELS), default=list(PANELS))
    parser.add_argument("--scenes", nargs="+", default=list(SCENES))
    parser.add_argument("--gallery", action="store_true", help="the gallery table's vs 2D column, summarised")
    parser.add_argument("--no-docs", action="store_true")
    args = parser.parse_args()
    if args.gallery:
        for preset, ratios in sorted(gallery_column().items()):
            print(f"gallery {preset}: {len(ratios)} renders, vs 2D median {statistics.median(ratios):.2f}x, "
                  f"p90 {percentile(ratios, 0.9):.2f}x, over 2.5x: {sum(r > 2.5 for r in ratios)}")
        return 0
    load = os.getloadavg()
    rows = measure(args.scenes, args.presets, args.repeats)
    lines = [(f"`{s}`", p, f"{a:.2f}", f"{b:.2f}", f"{b / a:.2f}x") for s, p, a, b in rows]
    for preset in args.presets:
        ratios = [b / a for _, p, a, b in rows if p == preset]
        if ratios:
            lines.append((f"**{preset}: median, p90**", preset, "", "",
                          f"{statistics.median(ratios):.2f}x, {percentile(ratios, 0.9):.2f}x"))
    text = table(f"POV-Ray's sample scenes, `--quality draft` cold cache against `povray -A` at the panel size, "
                 f"median of {args.repeats} interleaved runs, both at the machine's threads",
                 ["scene", "preset", "2D s", "povh3d s", "vs 2D"], lines, load)
    return publish("bench_scenes", text, not args.no_docs)


if __name__ == "__main__":
    raise SystemExit(main())

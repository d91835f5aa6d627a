"""Benchmark: POV-Ray's own sample scenes, whole command against a whole-process 2D render (issue 37).

For each scene (Debian's ``povray-examples``, scenes with a perspective camera of their own) and
each preset: ``povh3d render SCENE --preset P --quality draft`` with a cold cache, against
``povray +ISCENE -A +W +H`` at the panel's size through the scene's own camera, both at the
machine's threads and both whole processes (start to exit).  The runs are interleaved
(2D, povh3d, 2D, povh3d ...), so a change of load hits both sides; a row gives the medians and
their ratio, the table the median and p90 of the ratios per preset, and the load before and
after.  ``--gallery`` instead prints the median and p90 of the "vs 2D" column of the gallery
table already in docs/benchmarks.md (``make gallery`` writes it).  ``--sample N`` times N scenes of
the gallery instead of the fixed list (every k-th of ``gallery.gallery_scenes``, whose order runs round
the example folders, so each folder is in it), each command capped at ``--cap`` seconds: the gallery's
median and p90 against 2D measured again, by one version of the code, in a fraction of its hours.

    .venv/bin/python benchmarks/bench_scenes.py [--repeats 3] [--presets demo ipad-retina] [--no-docs]
    .venv/bin/python benchmarks/bench_scenes.py --sample 60 --presets demo --repeats 1 [--cap 60]
    .venv/bin/python benchmarks/bench_scenes.py --gallery
"""

from __future__ import annotations

import argparse
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
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


def measure(scenes: list[str], presets: list[str], repeats: int,
            cap: float | None = None) -> tuple[list[tuple[str, str, float, float]], list[tuple[str, str]]]:
    """(scene, preset, median 2D seconds, median povh3d seconds) of interleaved runs, cold cache; and the
    (scene, preset) left out because a command ran past ``cap`` seconds.  With a ``cap`` a command that fails
    (a scene povh3d refuses, as the gallery's table counts it) is timed as it is; without, it is an error."""
    rows, capped = [], []
    for name in scenes:
        scene = EXAMPLES / name
        if not scene.is_file():
            continue
        for preset in presets:
            two_d: list[float | None] = []
            ours: list[float | None] = []
            with tempfile.TemporaryDirectory() as folder:
                work = Path(folder)
                for _ in range(repeats):
                    cache = work / "cache"
                    shutil.rmtree(cache, ignore_errors=True)
                    env = {**os.environ, "POVH3D_CACHE": str(cache)}
                    two_d.append(_seconds(_two_d(scene, PANELS[preset], work / "2d.png"), scene.parent, env, cap))
                    ours.append(_seconds(_povh3d(scene, preset, work / "h3d.png"), scene.parent, env, cap))
            if None in two_d or None in ours:
                capped.append((name, preset))
                print(f"{name} {preset}: past {cap} s", flush=True)
                continue
            rows.append((name, preset, statistics.median(two_d), statistics.median(ours)))  # type: ignore[type-var]
            print(f"{name} {preset}: 2D {rows[-1][2]:.2f} s, povh3d {rows[-1][3]:.2f} s", flush=True)
    return rows, capped


def _seconds(command: list[str], cwd: Path, env: dict[str, str], cap: float | None) -> float | None:
    """Whole-process wall seconds; None past ``cap`` (the command killed; POV-Ray children die with it)."""
    if cap is None:
        return whole_process_seconds(command, cwd, env)
    start = time.perf_counter()
    try:
        subprocess.run(command, cwd=cwd, check=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       env=env, timeout=cap)
    except subprocess.TimeoutExpired:
        return None
    return time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--presets", nargs="+", choices=list(PANELS), default=list(PANELS))
    parser.add_argument("--scenes", nargs="+", default=list(SCENES))
    parser.add_argument("--gallery", action="store_true", help="the gallery table's vs 2D column, summarised")
    parser.add_argument("--sample", type=int, help="time N scenes of the gallery instead of --scenes")
    parser.add_argument("--cap", type=float, default=60.0, help="with --sample: seconds allowed to each command")
    parser.add_argument("--no-docs", action="store_true")
    args = parser.parse_args()
    if args.gallery:
        for preset, ratios in sorted(gallery_column().items()):
            print(f"gallery {preset}: {len(ratios)} renders, vs 2D median {statistics.median(ratios):.2f}x, "
                  f"p90 {percentile(ratios, 0.9):.2f}x, over 2.5x: {sum(r > 2.5 for r in ratios)}")
        return 0
    load = os.getloadavg()
    if args.sample:
        return _sample(args, load)
    rows, _ = measure(args.scenes, args.presets, args.repeats)
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


def _sample(args: argparse.Namespace, load: tuple[float, ...]) -> int:
    """Time ``args.sample`` gallery scenes (``--sample``) and publish their median and p90 against 2D."""
    from gallery import gallery_scenes

    scenes = gallery_scenes()
    step = max(1, len(scenes) // args.sample)
    names = [str(p.relative_to(EXAMPLES)) for p in scenes[::step][:args.sample]]
    rows, capped = measure(names, args.presets, args.repeats, cap=args.cap)
    lines = []
    for preset in args.presets:
        ratios = sorted(b / a for _, p, a, b in rows if p == preset)
        if ratios:
            over = [f"`{s}` {b / a:.1f}x" for s, p, a, b in sorted(rows, key=lambda r: r[2] / r[3]) if p == preset
                    and b / a > 2.5]
            lines.append((preset, str(len(ratios)), f"{statistics.median(ratios):.2f}x",
                          f"{percentile(ratios, 0.75):.2f}x", f"{percentile(ratios, 0.9):.2f}x",
                          ", ".join(over) or "none", ", ".join(f"`{s}`" for s, p in capped if p == preset) or "none"))
    text = table(f"{len(names)} scenes of the gallery (every {step}th of its {len(scenes)}), `--quality draft` cold "
                 f"cache against `povray -A` at the panel size, median of {args.repeats} interleaved runs, both at the "
                 f"machine's threads, each command capped at {args.cap:g} s (a capped scene is left out)",
                 ["preset", "scenes", "median vs 2D", "p75", "p90", "over 2.5x", "capped"], lines, load)
    return publish("bench_scenes_sample", text, not args.no_docs)


if __name__ == "__main__":
    raise SystemExit(main())

"""Benchmark (issue 27): animations and volume labels against their references, whole commands.

Two cases, each a whole process timed around the child, interleaved with its
reference (reference, povh3d, reference, povh3d, ...) so a change of load hits
both sides; median and spread (min-max) and the load before and after; and the median CPU
seconds of each side (the command's and its children's, POV-Ray's: on a loaded machine the wall
seconds follow the scheduler, the CPU seconds much less):

- a 24-frame animation of the bundled sample with a ball crossing it as the
  clock runs (``demo``, 320x240, ``--quality draft --frames 0:23 --no-cache``)
  against ``povray +KFI0 +KFF23`` of the same scene through an orthographic
  camera square to the screen at the panel's size (POV-Ray's own 2D animation,
  its default threads);
- PyVista's frog_tissues labels (25 surfaces, ``demo``, draft) against the render of
  the resulting surfaces: ``povh3d render`` of the stage scene the first command wrote
  (its surfaces' include beside it), ``--no-cache``, whole command.  Twice: with an
  empty cache (every entry removed before the clock starts, the POV-Ray version memo
  kept: it is the machine's, not the volume's), which renders the surfaces too, and
  with only the surfaces' entries removed (the frame then comes from the cache, as in
  the figures before this distinction).

The default quality's cost (``--quality normal`` against draft) is
``bench_quality.py``'s.  ``--povh3d-path`` times another checkout's povh3d
(e.g. main) on the same cases, for before/after figures.  The table goes into
docs/benchmarks.md between the ``bench_speed`` markers.

    .venv/bin/python benchmarks/bench_speed.py [--repeats 5] [--no-docs] [--povh3d-path /work/main] [--volume-only]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import publish, summary, table, whole_process_seconds  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "sample_models" / "sample.pov"
BALL = ('#include "sample.pov"\n'
        "sphere { <-12 + 24 * clock, 6, -2> * S, 2.5 * S pigment { rgb <0.9, 0.1, 0.1> } finish { specular 0.3 } }\n")


def frog() -> Path:
    import pyvista

    return Path(pyvista.__file__).parent / "examples" / "frog_tissues.vti"


def seconds(command: list[str], cwd: Path, env: dict[str, str], before: tuple[Path, ...] = (),
            cpu: list[float] | None = None) -> float:
    """Wall seconds of ``command``; its CPU seconds (with its children's: POV-Ray's) appended to ``cpu``."""
    for path in before:  # a cold cache: removed before the clock starts
        shutil.rmtree(path, ignore_errors=True)
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = whole_process_seconds(command, cwd, env)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if cpu is not None:
        cpu.append(after.ru_utime + after.ru_stime - used.ru_utime - used.ru_stime)
    return wall


def entries(cache: Path) -> tuple[Path, ...]:
    """Every entry folder of the cache (frames, outputs, surfaces ...), not the POV-Ray version memo."""
    return tuple(path for path in cache.iterdir() if path.is_dir()) if cache.is_dir() else ()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--no-docs", action="store_true", help="print the table, leave docs/benchmarks.md alone")
    ap.add_argument("--povh3d-path", default=str(REPO), help="the checkout whose povh3d is timed (default: this one)")
    ap.add_argument("--volume-only", action="store_true", help="only the volume cases")
    args = ap.parse_args()
    env = {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}, "PYTHONPATH": args.povh3d_path}
    load_before = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cache = tmp / "cache"
        env["POVH3D_CACHE"] = str(cache)
        shutil.copy(SAMPLE, tmp / "sample.pov")
        (tmp / "ball.pov").write_text(BALL)
        (tmp / "ball2d.pov").write_text('#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n#include "ball.pov"\n'
                                        "camera { orthographic location <0, 0, -128> direction z right <32, 0, 0> "
                                        "up <0, 24, 0> }\n")
        (tmp / "frames").mkdir()
        (tmp / "h3d").mkdir()
        povh3d = [sys.executable, "-m", "povh3d.cli"]
        seconds([*povh3d, "presets"], tmp, env)
        two_d = ["povray", "+Iball2d.pov", "+Oframes/f.png", "+W320", "+H240", "-D", "-V", "+KFI0", "+KFF23"]
        anim = [*povh3d, "render", "ball.pov", "--preset", "demo", "--quality", "draft", "--frames", "0:23",
                "--no-cache", "-q", "-o", "h3d/a.png"]
        cold = [*povh3d, "render", str(frog()), "--preset", "demo", "--quality", "draft", "--orientation", "axial",
                "--labels", "all", "-q", "-o", "frog.png"]
        for case, reference, ours, ref_name, target, cold_cache in (
                ("24-frame animation, `demo` 320x240, draft, `--frames 0:23`", two_d, anim,
                 "`povray +KFI0 +KFF23` 2D", "1.1x", None),
                ("frog labels (25 surfaces), `demo`, draft, empty cache", None, cold,
                 "`povh3d render` of the resulting stage, `--no-cache`", "3x", "all"),
                ("the same, only the surfaces' entries removed", None, cold,
                 "`povh3d render` of the resulting stage, `--no-cache`", "3x", "volumes")):
            if args.volume_only and cold_cache is None:
                continue
            refs, mine, ref_cpu, my_cpu = [], [], [], []
            if cold_cache:
                # The reference renders the resulting stage (its include beside it) as any scene.
                seconds(cold, tmp, env)
                stage = Path(json.loads((tmp / "frog.json").read_text())["scene"])
                shutil.copytree(stage.parent, tmp / "stage", dirs_exist_ok=True)
                reference = [*povh3d, "render", str(tmp / "stage" / stage.name), "--preset", "demo", "--quality",
                             "draft", "--no-cache", "-q", "-o", "stage.png"]
            for _ in range(args.repeats):  # interleaved
                refs.append(seconds(reference, tmp, env, cpu=ref_cpu))
                cold_entries = (() if cold_cache is None else (cache / "volumes",) if cold_cache == "volumes"
                                else entries(cache))
                mine.append(seconds(ours, tmp, env, before=cold_entries, cpu=my_cpu))
            ratio = statistics.median(mine) / statistics.median(refs)
            cpu_ratio = statistics.median(my_cpu) / statistics.median(ref_cpu)
            rows.append((case, summary(mine), f"{ref_name}: {summary(refs)}", f"**{ratio:.2f}x**",
                         f"{statistics.median(my_cpu):.2f} s / {statistics.median(ref_cpu):.2f} s = {cpu_ratio:.2f}x",
                         target))
            print(rows[-1], flush=True)
    who = "" if Path(args.povh3d_path).resolve() == REPO else f" (povh3d from {args.povh3d_path})"
    text = table(f"Median (min-max) of {args.repeats} interleaved runs{who}",
                 ["case", "povh3d, whole process", "reference", "ratio", "CPU seconds, median (with POV-Ray's)",
                  "target"], rows, load_before)
    return publish("bench_speed", text, docs=not (args.no_docs or args.volume_only))


if __name__ == "__main__":
    sys.exit(main())

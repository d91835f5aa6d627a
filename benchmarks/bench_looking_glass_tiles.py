"""Benchmark: the whole Looking Glass command against 48 separate 2D renders of its tiles.

``povh3d render SCENE --preset looking-glass-portrait --quality draft --no-cache`` renders the
Portrait's 48 views through the vendor's sheared cameras (``renderer.methods.vendor_views``) and
writes the camera bank, the 3360 x 3360 quilt and their sidecars.  Against it: 48 separate
``povray`` processes, one per tile, each rendering the very script povh3d gave POV-Ray for that
view (captured from one untimed render, its frame index fixed), at the tile's size, with
povh3d's draft switches and one thread (``+WT1``: no thread overhead counted against POV-Ray),
writing a PNG as a 2D render does (povh3d's own runs write PPM frames).

povh3d's modules are byte-compiled first, as an installed copy's are.  The figure is CPU time, user + system of the whole process tree (``getrusage`` of the children,
as ``/usr/bin/time`` reports it): the machine is shared, so wall times spread with the load.
Rounds are interleaved (command, 48 renders, command, ...); the table gives the median and the
spread per scene and the load before and after, and is written into docs/benchmarks.md between
the ``bench_looking_glass_tiles`` markers.

    .venv/bin/python benchmarks/bench_looking_glass_tiles.py [--repeats 3] [--no-docs] [--before DIR]

``--before DIR``: a copy of another povh3d (``DIR/povh3d``, ``DIR/templates``), timed in the same
rounds, for a before/after column.
"""

from __future__ import annotations

import compileall
import os
import re
import statistics
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import repeat_arguments, table, whole_process_times, write_table  # noqa: E402

EXAMPLES = Path("/usr/share/doc/povray/examples")
SCENES = {"objects/primitiv.pov": EXAMPLES / "objects" / "primitiv.pov",
          "advanced/pawns.pov": EXAMPLES / "advanced" / "pawns.pov",
          "sample.pov": Path(__file__).resolve().parents[1] / "sample_models" / "sample.pov"}
TARGET = 1.0
_FRAME = re.compile(r"#declare Povh3d_Frame = \(frame_number > 0 \? frame_number - 1 : 0\);")


def command(scene: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "povh3d", "render", str(scene), "--preset", "looking-glass-portrait",
            "--quality", "draft", "--no-cache", "-q", "-o", str(out)]


def captured_jobs(scene: Path, out: Path) -> list:
    """The POV-Ray jobs of one render of ``scene`` (run in this process, untimed)."""
    import povh3d.renderer.shots.shots as shots
    from povh3d.cli.main import main

    jobs: list = []
    real = shots.run_jobs

    def keep(batch, **kw):
        jobs.extend(batch)
        return real(batch, **kw)

    shots.run_jobs = keep
    try:
        main(["render", str(scene), "--preset", "looking-glass-portrait", "--quality", "draft", "--no-cache",
              "-q", "-o", str(out)])
    finally:
        shots.run_jobs = real
    return jobs


def tile_commands(jobs: list, root: Path) -> list[tuple[list[str], Path, dict[str, str]]]:
    """One plain ``povray`` run per view: each job's script with its frame index fixed, one thread."""
    from povh3d.povray.job import build_command
    from povh3d.povray.process import _prepare, find_povray

    binary, runs = find_povray(), []
    view = 0
    for job in jobs:
        if not _FRAME.search(job.script):
            raise SystemExit("the vendor views' script changed: its frame index line is not found")
        for frame in range(job.frames):
            one = replace(job, script=_FRAME.sub(f"#declare Povh3d_Frame = {frame};", job.script), frames=1,
                          clock_run=None, threads=1, name=f"view {view}")
            folder = root / f"view{view:02d}"
            folder.mkdir()
            env = _prepare(folder, one)
            runs.append((as_png(build_command(one, binary)), folder, env))
            view += 1
    if view != 48:
        raise SystemExit(f"expected 48 views, captured {view}")
    return runs


def as_png(argv: list[str]) -> list[str]:
    """A 2D render's command writes a PNG (+FN), as a user's would; povh3d's shots are PPMs
    (``PovrayJob.image_suffix``), which the command is measured with."""
    return [re.sub(r"^\+FP(\d+)$", r"+FN\1", a) if a.startswith("+FP")
            else re.sub(r"\.ppm$", ".png", a) if a.startswith("+O") else a for a in argv]


def main() -> int:
    before = None
    if "--before" in sys.argv:   # taken off before the common options are read
        at = sys.argv.index("--before")
        before = Path(sys.argv[at + 1]).resolve()
        del sys.argv[at:at + 2]
        compileall.compile_dir(str(before / "povh3d"), quiet=1)
    args = repeat_arguments(__doc__, 3)
    # as installed: povh3d's modules byte-compiled (a checkout run with PYTHONDONTWRITEBYTECODE compiles
    # every module at every start, 0.2 s of CPU that no installed copy pays)
    compileall.compile_dir(str(Path(__file__).resolve().parents[1] / "povh3d"), quiet=1)
    load_before = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        os.environ["POVH3D_CACHE"] = str(tmp / "cache")
        env = dict(os.environ)
        for label, scene in SCENES.items():
            if not scene.is_file():
                continue
            work = tmp / Path(label).stem
            work.mkdir()
            tiles = tile_commands(captured_jobs(scene, work / "capture.png"), work)
            ours, theirs, old = [], [], []
            for _ in range(args.repeats):  # interleaved
                for path in work.glob("lg*"):
                    path.unlink()
                ours.append(whole_process_times(command(scene, work / "lg.png"), work, env))
                if before is not None:
                    old.append(whole_process_times(command(scene, work / "lgb.png"), work,
                                                   {**env, "PYTHONPATH": str(before)}))
                    print(label, "before", old[-1], flush=True)
                wall = cpu = 0.0
                for argv, folder, tile_env in tiles:
                    w, c = whole_process_times(argv, folder, tile_env)
                    wall, cpu = wall + w, cpu + c
                theirs.append((wall, cpu))
                print(label, "command", ours[-1], "48 renders", theirs[-1], flush=True)
            ratios = [o[1] / t[1] for o, t in zip(ours, theirs)]
            cpu_ours, cpu_theirs = [c for _, c in ours], [c for _, c in theirs]
            if before is not None:
                cpu_old = [c for _, c in old]
                label += (f" (before: {_spread(cpu_old)}, "
                          f"{statistics.median(cpu_old) / statistics.median(cpu_theirs):.2f}x)")
            rows.append((label, _spread(cpu_ours), _spread(cpu_theirs),
                         f"**{statistics.median(cpu_ours) / statistics.median(cpu_theirs):.2f}x** "
                         f"({min(ratios):.2f}-{max(ratios):.2f})",
                         f"{statistics.median([w for w, _ in ours]):.1f} s / "
                         f"{statistics.median([w for w, _ in theirs]):.1f} s"))
    text = table(f"CPU seconds (user + system, the whole process tree), median (min-max) of {args.repeats} "
                 "interleaved rounds; the ratio of the medians (and the spread of the per-round ratios)",
                 ["scene", "`povh3d render --preset looking-glass-portrait --quality draft`",
                  "48 `povray +WT1` renders of the tiles", "ratio", "wall, median (command / 48 renders)"],
                 rows, load_before)
    print(text)
    if not args.no_docs:
        write_table("bench_looking_glass_tiles", text)
    worst = max(float(r[3].split("**")[1].rstrip("x")) for r in rows)
    return 0 if worst <= TARGET else 1


def _spread(values: list[float]) -> str:
    return f"{statistics.median(values):.2f} s ({min(values):.2f}-{max(values):.2f})"


if __name__ == "__main__":
    raise SystemExit(main())

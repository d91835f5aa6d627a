"""Benchmark: whole commands as a user times them, against a whole-process 2D POV-Ray render.

Every figure is a whole process, start to exit, timed around the child process
(interpreter start-up, imports, POV-Ray, PNG writing): ``povh3d render`` of the
bundled sample against ``povray`` rendering the same scene once through an
orthographic camera square to the screen, at the panel's size, with the same
switches povh3d passes (``povray.job.build_command``, the draft quality).  The
runs are interleaved (2D, povh3d, 2D, povh3d, ...), so a change of load hits
both sides; the table gives the median and the spread (min-max) and the load
average before and after.  The table is written into docs/benchmarks.md
between the ``bench_command`` markers.

    .venv/bin/python benchmarks/bench_command.py [--repeats 5] [--no-docs]
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import publish, repeat_arguments, summary, table, whole_process_seconds  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "sample_models" / "sample.pov"
CASES = {
    "lenticular 1920x1080, 8 views": ["--grid", "lenticular", "--lenses", "240", "--ppl", "8", "--rows", "1080"],
    "square 960x544, 8x8 views": ["--lenses", "120x68", "--ppl", "8x8"],
}


def povh3d(*args: str) -> list[str]:
    return [sys.executable, "-m", "povh3d.cli", *args]


def plain_2d_command(case_args: list[str], folder: Path) -> list[str]:
    """The ``povray`` command of a 2D render of the panel (script written into `folder`)."""
    from povh3d.renderer.methods.quality import QUALITY_OPTIONS
    from povh3d.display.presets import get_preset, lens_array_from_fields, merge_overrides
    from povh3d.povray.job import SCENE_FILE, PovrayJob, build_command
    from povh3d.povray.process import find_povray
    from povh3d.system import cpu_count

    overrides = dict(zip([a.lstrip("-") for a in case_args[::2]], case_args[1::2]))
    fields = {k: (tuple(int(x) for x in v.split("x")) if "x" in v else int(v)) if k != "grid" else v
              for k, v in overrides.items()}
    la = lens_array_from_fields(merge_overrides(get_preset("demo"), fields))
    w_mm, h_mm = la.panel.size_mm
    front_clearance = 4 * max(w_mm, h_mm)  # povh3d's default front clearance
    (folder / SCENE_FILE).write_text(
        f'#version 3.7;\nglobal_settings {{ assumed_gamma 1.0 }}\n#include "{SAMPLE}"\n'
        f"camera {{ orthographic location <0, 0, {-front_clearance!r}> direction z "
        f"right <{w_mm!r}, 0, 0> up <0, {h_mm!r}, 0> }}\n")
    job = PovrayJob(name="2D", script="", width=la.panel.width, height=la.panel.height,
                    include_dirs=(str(SAMPLE.parent),), options=QUALITY_OPTIONS["draft"], threads=cpu_count())
    return build_command(job, find_povray())


# As an installed package runs: its modules compiled once (pip does it on install), not on every run.
ENV = {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}, "PYTHONPATH": str(REPO)}


def seconds(command: list[str], cwd: Path) -> float:
    return whole_process_seconds(command, cwd, ENV)


def main() -> int:
    args = repeat_arguments(__doc__, 5)
    load_before = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cache = tmp / "cache"
        os.environ["POVH3D_CACHE"] = str(cache)  # a fresh cache: the version memory is written once
        seconds(povh3d("presets"), tmp)
        for case, case_args in CASES.items():
            folder = tmp / f"2d-{len(rows)}"
            folder.mkdir()
            plain = plain_2d_command(case_args, folder)
            render = povh3d("render", str(SAMPLE), *case_args, "--quality", "draft", "--no-cache", "-q",
                            "-o", str(tmp / "o.png"))
            two_d, ours = [], []
            for _ in range(args.repeats):  # interleaved
                two_d.append(seconds(plain, folder))
                ours.append(seconds(render, tmp))
            ratio = statistics.median(ours) / statistics.median(two_d)
            rows.append((f"`povh3d render`, {case}, `--quality draft --no-cache`", summary(ours),
                         f"`povray` 2D: {summary(two_d)}", f"**{ratio:.2f}x**", "1.2x"))
            print(rows[-1])
        rerun = povh3d("render", str(SAMPLE), *CASES["lenticular 1920x1080, 8 views"], "--quality", "draft", "-q",
                       "-o", str(tmp / "o.png"))
        seconds(rerun, tmp)  # fills the cache
        for name, command, target in (("cached re-run (lenticular 1920x1080, nothing changed)", rerun, "0.2 s"),
                                      ("`povh3d --help`", povh3d("--help"), "0.15 s"),
                                      ("`povh3d presets`", povh3d("presets"), "0.15 s"),
                                      ("`python -c pass` (the interpreter alone)", [sys.executable, "-c", "pass"], "")):
            times = [seconds(command, tmp) for _ in range(args.repeats)]
            rows.append((name, summary(times), "", "", target))
            print(rows[-1])
    text = table(f"Median (min-max) of {args.repeats} interleaved runs",
                 ["command", "whole process", "against", "ratio", "target"], rows, load_before)
    return publish("bench_command", text, docs=not args.no_docs)


if __name__ == "__main__":
    sys.exit(main())

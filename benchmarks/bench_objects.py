"""Benchmark: what ``render --objects DIR`` (the object masks of every view) adds to a render,
against one more POV-Ray pass of the same rays.

Three whole commands a case, interleaved, no cache: the render at the default quality; the same
render with ``--objects``; and the same request at ``--quality draft`` (one point-sampled pass of
the same rays: what the mask pass is). The masks' cost is the difference of the first two medians;
the figure to reach is that it stays at most the draft command's own time. Each command's CPU
time (its own and POV-Ray's, user + system) is compared the same way: on a shared machine it is
the steadier figure. The table gives the medians, the spread and the load, and is written into
docs/benchmarks.md between the ``bench_objects`` markers.

    .venv/bin/python benchmarks/bench_objects.py [--repeats 5] [--no-docs]
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import repeat_arguments, table, whole_process_times, write_table  # noqa: E402
from bench_command import ENV, SAMPLE, povh3d, summary  # noqa: E402

CASES = {"sample, demo": ["--preset", "demo"], "sample, alioscopy-42": ["--preset", "alioscopy-42"]}


def main() -> int:
    args = repeat_arguments(__doc__, 5)
    load_before = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name, case in CASES.items():
            times: dict[str, list[float]] = {"render": [], "objects": [], "draft": []}
            cpu: dict[str, list[float]] = {"render": [], "objects": [], "draft": []}
            for i in range(args.repeats):
                base = povh3d("render", str(SAMPLE), *case, "--no-cache", "-q")
                for kind, extra in (("render", []), ("objects", ["--objects", f"masks{i}"]),
                                    ("draft", ["--quality", "draft"])):
                    wall, used = whole_process_times([*base, "-o", f"{kind[0]}{i}.png", *extra], folder, ENV)
                    times[kind].append(wall)
                    cpu[kind].append(used)
            for measure, figures in (("wall", times), ("CPU", cpu)):
                extra = statistics.median(figures["objects"]) - statistics.median(figures["render"])
                draft = statistics.median(figures["draft"])
                rows.append((f"{name}, {measure}", summary(figures["render"]), summary(figures["objects"]),
                             f"{extra:.2f} s", summary(figures["draft"]), f"{extra / draft:.2f}",
                             "yes" if extra <= draft else "no"))
                print(rows[-1], flush=True)
    text = table(f"`render --objects` against one more pass of the same rays, whole commands, no cache, "
                 f"{args.repeats} interleaved rounds, median (min-max); wall, and CPU (the command's and "
                 f"POV-Ray's, user + system)",
                 ["case", "render (normal)", "render --objects", "masks add", "draft pass of the same rays",
                  "masks / draft", "at most one pass"], rows, load_before)
    print(text)
    if not args.no_docs:
        write_table("bench_objects", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

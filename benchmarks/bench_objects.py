"""Benchmark: what ``render --objects DIR`` (the object masks of every view) adds to a render,
against one more POV-Ray pass of the same rays.

Three whole commands a case, interleaved, no cache: the render at the default quality; the same
render with ``--objects``; and the same request at ``--quality draft`` (one point-sampled pass of
the same rays: what the mask pass is). The masks' cost is the difference of the first two medians;
the figure to reach is that it stays at most the draft command's own time. The table gives the
medians, the spread and the load, and is written into docs/benchmarks.md between the
``bench_objects`` markers.

    .venv/bin/python benchmarks/bench_objects.py [--repeats 5] [--no-docs]
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import repeat_arguments, table, write_table  # noqa: E402
from bench_command import SAMPLE, povh3d, seconds, summary  # noqa: E402

CASES = {"sample, demo": ["--preset", "demo"], "sample, alioscopy-42": ["--preset", "alioscopy-42"]}


def main() -> int:
    args = repeat_arguments(__doc__, 5)
    load_before = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name, case in CASES.items():
            times: dict[str, list[float]] = {"render": [], "objects": [], "draft": []}
            for i in range(args.repeats):
                base = povh3d("render", str(SAMPLE), *case, "--no-cache", "-q")
                times["render"].append(seconds([*base, "-o", f"r{i}.png"], folder))
                times["objects"].append(seconds([*base, "-o", f"o{i}.png", "--objects", f"masks{i}"], folder))
                times["draft"].append(seconds([*base, "-o", f"d{i}.png", "--quality", "draft"], folder))
            extra = statistics.median(times["objects"]) - statistics.median(times["render"])
            draft = statistics.median(times["draft"])
            rows.append((name, summary(times["render"]), summary(times["objects"]), f"{extra:.2f} s",
                         summary(times["draft"]), f"{extra / draft:.2f}", "yes" if extra <= draft else "no"))
            print(rows[-1], flush=True)
    text = table(f"`render --objects` against one more pass of the same rays, whole commands, no cache, "
                 f"{args.repeats} interleaved rounds, median (min-max)",
                 ["case", "render (normal)", "render --objects", "masks add", "draft pass of the same rays",
                  "masks / draft", "at most one pass"], rows, load_before)
    print(text)
    if not args.no_docs:
        write_table("bench_objects", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

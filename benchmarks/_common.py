"""What the benchmarks share: POV-Ray's parse time of a script, the load line of a table and
writing it into docs/benchmarks.md."""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import subprocess
import time
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1] / "docs" / "benchmarks.md"


def parse_seconds(script: str, folder: Path, size: int = 8) -> float:
    """POV-Ray's own parse time (from its log) of ``script``, rendered tiny with ``folder`` on the
    include path; NaN when the log does not say."""
    from povh3d.povray.process import PovrayJob, run_jobs

    job = PovrayJob(name="parse", script=script, width=size, height=size, include_dirs=(str(folder),),
                    options=("-A", "+V"))
    logs: list[str] = []
    run_jobs([job], processes=1, on_result=lambda r: logs.append(r.log))
    m = re.search(r"Parse Time:.*?\(([\d.]+) seconds\)", logs[0])
    return float(m.group(1)) if m else float("nan")


def markers(name: str) -> tuple[str, str]:
    """The comments around benchmark ``name``'s table in docs/benchmarks.md."""
    return f"<!-- {name}: begin -->", f"<!-- {name}: end -->"


def table(caption: str, header: list[str], rows: list[tuple[str, ...]], load_before: tuple[float, ...]) -> str:
    """A Markdown table under ``caption``, which gets the core count and the load before and after."""
    note = (f"{caption}, {os.cpu_count()} cores; load average {load_before[0]:.2f} before, "
            f"{os.getloadavg()[0]:.2f} after (1 min).")
    return "\n".join([note, "", f"| {' | '.join(header)} |", "|" + "---|" * len(header)]
                     + [f"| {' | '.join(row)} |" for row in rows])


def write_table(name: str, text: str) -> None:
    """Replace benchmark ``name``'s table in docs/benchmarks.md (between its markers)."""
    begin, end = markers(name)
    docs = DOCS.read_text(encoding="utf-8")
    pattern = re.compile(re.escape(begin) + ".*?" + re.escape(end), re.DOTALL)
    if pattern.search(docs) is None:
        raise SystemExit(f"{DOCS} has no {begin} ... {end} markers")
    DOCS.write_text(pattern.sub(lambda m: f"{begin}\n{text}\n{end}", docs), encoding="utf-8")


def whole_process_seconds(command: list[str], cwd: Path, env: dict[str, str]) -> float:
    """Wall seconds of ``command`` from start to exit, its output discarded."""
    return whole_process_times(command, cwd, env)[0]


def whole_process_times(command: list[str], cwd: Path, env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU seconds (user + system, of ``command`` and the processes it waited for: POV-Ray's)
    from start to exit, its output discarded.  On a shared machine the CPU time is the steadier."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, cwd=cwd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def summary(times: list[float]) -> str:
    """``median s (min-max)``."""
    return f"{statistics.median(times):.2f} s ({min(times):.2f}-{max(times):.2f})"


def publish(name: str, text: str, docs: bool) -> int:
    """Print benchmark ``name``'s table and, with ``docs``, write it into docs/benchmarks.md; exit code 0."""
    print(text)
    if docs:
        write_table(name, text)
    return 0


def repeat_arguments(doc: str, repeats: int) -> argparse.Namespace:
    """The options every interleaved benchmark takes: ``--repeats`` rounds and ``--no-docs``."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=repeats)
    ap.add_argument("--no-docs", action="store_true", help="print the table, leave docs/benchmarks.md alone")
    return ap.parse_args()

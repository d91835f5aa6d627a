"""Measure: a signal in the first moments of ``povh3d render``, through the launcher (bin/povh3d)
and through pip's console script (the command before it), at the same moments, interleaved.

Each trial starts the command on a tiny render, sends SIGINT or SIGTERM at a uniform random moment
in the first ``--window`` seconds after the start, and sorts the end: "one line" (exit 130 and
exactly ``povh3d: error: interrupted``), "silent" (ended by the signal or 128 + signal, nothing on
stderr), "traceback" (a Python traceback on stderr), "finished" (the render was done first) or
"other".  The console script is written beside nothing: its shebang is the Python beside the
launcher, so both run the same interpreter, site-packages and povh3d.  Prints a Markdown table
for docs/reliability.md ("The start-up window").

    .venv/bin/python benchmarks/bench_startup_signals.py [--trials 100] [--launcher .venv/bin/povh3d]
"""

from __future__ import annotations

import argparse
import collections
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "sample_models" / "sample.pov"
KINDS = ("one line", "silent", "traceback", "finished", "other")

_CONSOLE_SCRIPT = """#!{python}
import sys
from povh3d.cli.main import main
if __name__ == '__main__':
    sys.argv[0] = sys.argv[0].removesuffix('.exe')
    sys.exit(main())
"""


def kind(code: int, err: str, signum: int) -> str:
    if code == 130 and err == "povh3d: error: interrupted\n":
        return "one line"
    if "Traceback" in err:
        return "traceback"
    if code in (-signum, 128 + signum) and not err:
        return "silent"
    return "finished" if code == 0 else "other"


def trial(command: list[str], delay: float, signum: int, env: dict[str, str]) -> tuple[str, int, str]:
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, text=True)
    time.sleep(delay)
    proc.send_signal(signum)
    err = proc.communicate(timeout=120)[1]
    return kind(proc.returncode, err, signum), proc.returncode, err


def _mask(pid: int, field: str) -> int | None:
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith(field):
                    return int(line.split()[1], 16)
    except (FileNotFoundError, ProcessLookupError):
        return None
    return None


def arrivals(command: list[str], env: dict[str, str], shell: str) -> dict[str, float]:
    """Milliseconds after the start until the launcher's env blocks SIGINT, Python catches it
    (under the launcher, with it blocked) and povh3d catches SIGTERM (its handlers), read from
    /proc/PID/status in a tight loop.  ``shell``: the launcher's process name, its file's (dash
    catches SIGINT while it waits for a child and blocks every signal while it forks one)."""
    bit_int, bit_term = 1 << (signal.SIGINT - 1), 1 << (signal.SIGTERM - 1)
    start = time.perf_counter()
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    seen: dict[str, float] = {}
    with open("/proc/self/cmdline", "rb") as own:
        ours = own.read()
    execed = False
    while "povh3d's handlers" not in seen and proc.poll() is None:
        try:
            if not execed:  # until its exec the child is this Python, with this Python's handlers
                with open(f"/proc/{proc.pid}/cmdline", "rb") as cmdline:
                    execed = cmdline.read() not in (ours, b"")
                continue
            with open(f"/proc/{proc.pid}/comm") as comm:
                name = comm.read().strip()
        except (FileNotFoundError, ProcessLookupError):
            continue
        blocked, caught = _mask(proc.pid, "SigBlk:"), _mask(proc.pid, "SigCgt:")
        now = (time.perf_counter() - start) * 1000
        if name == shell or blocked is None or caught is None:
            continue
        if blocked & bit_int:
            seen.setdefault("SIGINT blocked", now)
        if name != "env" and caught & bit_int:
            seen.setdefault("Python's SIGINT handler", now)
        if name != "env" and caught & bit_term:
            seen.setdefault("povh3d's handlers", now)
    proc.kill()
    proc.wait()
    return seen


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=100, help="signals of each kind (default 100)")
    parser.add_argument("--window", type=float, default=0.3, help="seconds after the start (default 0.3)")
    parser.add_argument("--launcher", type=Path, default=Path(sys.executable).parent / "povh3d",
                        help="the installed launcher (default: povh3d beside this Python)")
    parser.add_argument("--seed", type=int, default=25)
    parser.add_argument("--arrivals", type=int, default=0, metavar="N",
                        help="instead: when each command blocks and catches the signals, N starts each")
    args = parser.parse_args()
    launcher = args.launcher.resolve()
    if not launcher.read_text(errors="replace").startswith("#!/bin/sh"):
        raise SystemExit(f"{launcher} is not the shell launcher (reinstall: pip install -e .)")
    python = launcher.parent / "python3"
    rng = random.Random(args.seed)
    # Started in the background (``cmd &`` in a script), this process ignores SIGINT and so would
    # the commands: they are to start with the default action, as from a terminal.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="povh3d-startup-") as tmp:
        folder = Path(tmp)
        console = folder / "povh3d-console"
        console.write_text(_CONSOLE_SCRIPT.format(python=python))
        console.chmod(0o755)
        env = {**os.environ, "POVH3D_CACHE": str(folder / "cache")}
        render = ["render", str(SAMPLE), "-o", str(folder / "out.png"), "--preset", "demo", "--lenses", "6x4",
                  "--ppl", "4", "--quality", "draft", "-q", "--no-cache"]
        variants = {"console script": [str(console), *render], "launcher": [str(launcher), *render]}
        if args.arrivals:
            print_arrivals(variants, args.arrivals, env, load)
            return
        counts = {(v, s): collections.Counter() for v in variants for s in (signal.SIGINT, signal.SIGTERM)}
        odd: list[str] = []
        for i in range(args.trials):
            for signum in (signal.SIGINT, signal.SIGTERM):
                delay = rng.uniform(0.0, args.window)
                order = list(variants) if i % 2 else list(variants)[::-1]  # interleaved, alternating
                for name in order:
                    what, code, err = trial(variants[name], delay, signum, env)
                    counts[name, signum][what] += 1
                    if what == "other" or (what == "traceback" and name == "launcher"):
                        odd.append(f"{name} {signum.name} at {delay * 1000:.0f} ms: exit {code}: {err[-300:]!r}")
        shutil.rmtree(folder / "cache", ignore_errors=True)
    print(f"{args.trials} signals of each kind at uniform random moments in the first {args.window} s of "
          f"`povh3d render` (6x4 lenses, draft), each command given the same moments, interleaved; "
          f"{os.cpu_count()} cores, load average {load:.2f} before, {os.getloadavg()[0]:.2f} after (1 min).\n")
    print("| command | SIGINT: 130, one line / silent / traceback / other | "
          "SIGTERM: 130, one line / silent / other |")
    print("|---|---|---|")
    for name in variants:
        c_int, c_term = counts[name, signal.SIGINT], counts[name, signal.SIGTERM]
        print(f"| {name} | {c_int['one line']} / {c_int['silent']} / {c_int['traceback']} / "
              f"{c_int['other'] + c_int['finished']} | {c_term['one line']} / {c_term['silent']} / "
              f"{c_term['traceback'] + c_term['other'] + c_term['finished']} |")
    for line in odd:
        print(line, file=sys.stderr)


def print_arrivals(variants: dict[str, list[str]], starts: int, env: dict[str, str], load: float) -> None:
    times: dict[str, dict[str, list[float]]] = {name: collections.defaultdict(list) for name in variants}
    for _ in range(starts):
        for name, command in variants.items():
            shell = Path(command[0]).name[:15] if name == "launcher" else ""
            for event, ms in arrivals(command, env, shell).items():
                times[name][event].append(ms)
    print(f"{starts} starts of each command, interleaved, ms after the start (median / 90%); {os.cpu_count()} "
          f"cores, load average {load:.2f} before, {os.getloadavg()[0]:.2f} after (1 min).\n")
    events = ("SIGINT blocked", "Python's SIGINT handler", "povh3d's handlers")
    print("| command | " + " | ".join(events) + " |")
    print("|---|" + "---|" * len(events))
    for name in variants:
        cells = []
        for event in events:
            values = sorted(times[name][event])
            cells.append(f"{values[len(values) // 2]:.1f} / {values[int(len(values) * 0.9)]:.1f}" if values
                         else "never")
        print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()

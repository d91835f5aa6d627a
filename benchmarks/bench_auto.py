"""--quality auto against every level of its ladder, on the full image (issue 22).

For each scene (the bundled samples and one it has not seen, written here) every rung of
``AUTO_LADDER`` is rendered as a whole ``povh3d render`` command (timed, interpreter start
to exit) and scored on the full image against a converged reference of two seeds (its
noise floor stated).  Then ``--quality auto --max-error X`` runs as a whole command (cold
cache) and is scored the same way.  A case passes when auto's full image reaches X within
0.2 dB in every round, at no more than 1.25x the wall time of the fastest rung that reaches X.

A rung "reaches X" when each of its ``--seeds`` realizations does (the worse of them): the
command's own image (footprint seed 0) and the same count drawn with seeds 1, 2 ... (rendered
in-process, untimed: the seed does not change the cost).  One draw per rung rewards a lucky
draw (rung 192 of sample.pov reached 45.75 dB where 128 reached 42.0); the single-draw
fastest rung is kept in its own column.  ``draft`` and ``normal`` draw nothing: one image.

Every command runs ``--repeat`` times, the rounds interleaved (each round: every rung, then each
target's auto); ``--before CHECKOUT`` times that checkout's auto beside this one's in each round
(who goes first alternating), for a before/after on a shared machine.

Writes bench-out/auto.json and the table between the ``auto`` markers of docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from _common import publish, summary, table, whole_process_times
from povh3d.renderer.methods.auto import AUTO_LADDER
from povh3d.renderer.methods.registry import run_method
from povh3d.renderer.methods.quality import QUALITY_LEVELS, Quality, RenderSettings
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.io import read_png
from povh3d.image.metrics import Reference
from povh3d.scene.scene import load_scene

REPO = Path(__file__).resolve().parents[1]
UNSEEN = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.1, 0.12, 0.2> }
light_source { <-40, 60, -80> rgb 1 }
plane { z, 9 pigment { granite colour_map { [0 rgb <0.2, 0.25, 0.3>] [1 rgb <0.9, 0.85, 0.7>] } scale 3 } }
sphere { <3, 1, 2>, 3.5 pigment { wood colour_map { [0 rgb <0.6, 0.3, 0.1>] [1 rgb <0.95, 0.8, 0.5>] }
  scale 0.6 rotate <30, 60, 0> } finish { specular 0.5 roughness 0.02 } }
torus { 3, 0.8 rotate <70, 0, 20> translate <-5, -2, -1> pigment { bozo colour_map {
  [0 rgb <0.1, 0.5, 0.2>] [1 rgb <0.9, 0.9, 0.3>] } scale 0.4 } }
"""
CASES = {"sample.pov": (20, 30, 40, 45), "fine_texture.pov": (25, 35, 42), "unseen.pov": (22, 33, 44)}
ARRAY_ARGS = ["--preset", "demo", "--lenses", "20x15"]


def rung_name(q: Quality) -> str:
    named = {v: k for k, v in QUALITY_LEVELS.items()}
    return named.get(q, str(q.footprint))


def povh3d_seconds(tree: Path, args: list[object]) -> tuple[float, float]:
    """Wall and CPU seconds of ``python -m povh3d ARGS`` run from checkout ``tree`` (start-up to exit;
    CPU: the interpreter and its POV-Ray processes, which other helpers' renders do not inflate)."""
    # Bytecode kept (written by the warm-up): PYTHONDONTWRITEBYTECODE would recompile povh3d in every
    # command, a constant that pulls every ratio towards 1.
    env = {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}, "PYTHONPATH": str(tree)}
    return whole_process_times([sys.executable, "-m", "povh3d", *map(str, args)], tree, env)


def realizations(scene, la: LensArray, q: Quality, first: float, reference: Reference, seeds: int) -> list[float]:
    """dB of ``seeds`` draws of rung ``q``: ``first`` (the command's, seed 0), then seeds 1, 2 ... in-process."""
    if not q.footprint:
        return [first]
    return [first, *(reference.psnr(run_method("multi-ortho", scene, la, RenderSettings(
        quality=replace(q, seed=seed), use_cache=False)).h3d) for seed in range(1, seeds))]


def selected_cases(only: list[str] | None) -> dict[str, tuple[int, ...]]:
    """``CASES``, or those ``--only SCENE[:X,X...]`` names (a subset to develop with)."""
    if not only:
        return CASES
    cases: dict[str, tuple[int, ...]] = {}
    for item in only:
        name, _, targets = item.partition(":")
        if name not in CASES:
            raise SystemExit(f"--only: no scene {name!r}; use one of {', '.join(CASES)}")
        cases[name] = tuple(int(t) for t in targets.split(",")) if targets else CASES[name]
    return cases


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=REPO / "bench-out")
    parser.add_argument("--reference-samples", type=int, default=1024)
    parser.add_argument("--rounds", "--repeat", dest="repeat", type=int, default=3,
                        help="timed runs of every command, interleaved")
    parser.add_argument("--seeds", type=int, default=2, help="realizations of each rung it is judged by")
    parser.add_argument("--only", action="append", metavar="SCENE[:X,...]", help="a subset of the cases")
    parser.add_argument("--keep-reference", action="store_true",
                        help="reuse the converged references in --out (developing only: they are not re-checked)")
    parser.add_argument("--before", type=Path, help="another checkout whose auto is timed beside this one's")
    parser.add_argument("--no-docs", action="store_true", help="do not write docs/benchmarks.md")
    args = parser.parse_args()
    load_before = os.getloadavg()
    loads = [load_before[0]]
    args.out.mkdir(parents=True, exist_ok=True)
    folder = Path(tempfile.mkdtemp(prefix="bench-auto-"))
    (folder / "unseen.pov").write_text(UNSEEN)
    scenes = {"sample.pov": REPO / "sample_models" / "sample.pov",
              "fine_texture.pov": REPO / "sample_models" / "fine_texture.pov", "unseen.pov": folder / "unseen.pov"}
    trees = {"after": REPO, **({"before": args.before.resolve()} if args.before else {})}
    rows, results = [], []
    for tree in trees.values():   # compiled kernels and bytecode cached before anything is timed
        povh3d_seconds(tree, ["render", scenes["sample.pov"], *ARRAY_ARGS, "--quality", "auto", "--max-error", 20,
                              "--no-cache", "-q", "-o", folder / "warm.png"])
    for name, targets in selected_cases(args.only).items():
        path = scenes[name]
        out = folder / name.replace(".pov", "")
        out.mkdir()
        povh3d_seconds(REPO, ["render", path, *ARRAY_ARGS, "--quality", "draft", "--no-cache", "-q", "-o", out / "a.png"])
        a = json.loads((out / "a.json").read_text())["lens_array"]
        p = a["panel"]
        la = LensArray(a["grid"], *a["lenses"], *a["lens_pitch_mm"], a["focal_mm"],
                       Panel(*p["size_px"], *p["pixel_pitch_mm"]))
        scene = load_scene(path)
        base = RenderSettings(quality="draft", bit_depth=16)
        kept = args.out / f"reference-{name}-{args.reference_samples}-{scene.digest[:16]}.npz"
        if args.keep_reference and kept.exists():
            reference = Reference(*np.load(kept)["seeds"])
        else:
            seeds = [run_method("multi-ortho", scene, la, replace(
                base, quality=Quality(footprint=args.reference_samples, seed=seed))).h3d for seed in (1, 2)]
            np.savez(kept, seeds=np.stack(seeds))
            reference = Reference(*seeds)
        rungs: dict[str, list] = {}        # name -> [dB (worse of the realizations), seconds...]
        draws: dict[str, list[float]] = {}   # name -> dB of each realization (seed 0 first)
        autos: dict[tuple, list] = {}      # (tree, target) -> [dB (worst round), chosen, seconds...]
        runs: dict[tuple, list[int]] = {}  # (tree, target) -> POV-Ray runs auto started, each round
        cpu: dict[object, list[float]] = {}   # rung name or (tree, target) -> CPU seconds
        estimates: dict[tuple, float] = {}
        for run in range(args.repeat):
            for q in AUTO_LADDER:
                rung = rung_name(q)
                if run and rung not in rungs:
                    break
                image = out / f"{rung}.png"
                seconds, used = povh3d_seconds(REPO, ["render", path, *ARRAY_ARGS, "--quality", rung, "--no-cache",
                                                      "-q", "-o", image])
                if rung not in draws:
                    draws[rung] = realizations(scene, la, q, reference.psnr(read_png(image)), reference, args.seeds)
                rungs.setdefault(rung, [min(draws[rung])]).append(seconds)
                cpu.setdefault(rung, []).append(used)
                print(f"{name} {rung}: {seconds:.2f} s (CPU {used:.2f} s) "
                      f"{' / '.join(f'{d:.2f}' for d in draws[rung])} dB", flush=True)
                if rungs[rung][0] > max(targets) + 1:
                    break
            for target in targets:
                order = list(trees) if run % 2 == 0 else list(trees)[::-1]   # who goes first alternates
                for tree in order:
                    image = out / f"auto-{tree}-{target}.png"
                    seconds, used = povh3d_seconds(trees[tree], ["render", path, *ARRAY_ARGS, "--quality", "auto",
                                                                 "--max-error", target, "--no-cache", "-q", "-o", image])
                    cpu.setdefault((tree, target), []).append(used)
                    record = json.loads(image.with_suffix(".json").read_text())["quality"]["auto"]
                    chosen = record["chosen"]
                    estimates.setdefault((tree, target), record["tried"][-1]["psnr_db"])   # auto's own, of its image
                    runs.setdefault((tree, target), []).append(record.get("povray_runs", 0))
                    got = reference.psnr(read_png(image))
                    entry = autos.setdefault((tree, target), [got, chosen])
                    entry[0] = min(entry[0], got)   # the worst round's image
                    autos[tree, target].append(seconds)
                    print(f"{name} auto {tree} {target}: {seconds:.2f} s (CPU {used:.2f} s) {autos[tree, target][0]:.2f} "
                          f"dB {chosen}", flush=True)
            loads.append(os.getloadavg()[0])
        median = {rung: statistics.median(v[1:]) for rung, v in rungs.items()}
        for target in targets:
            meets = [r for r, v in rungs.items() if v[0] >= target]
            fastest = min(meets, key=median.get) if meets else None
            lucky = [r for r in rungs if draws[r][0] >= target]   # one draw (seed 0), the oracle before
            single = min(lucky, key=median.get) if lucky else None
            got, chosen, *times = autos["after", target]
            ratio = statistics.median(times) / median[fastest] if fastest else math.inf
            cpu_ratio = statistics.median(cpu["after", target]) / statistics.median(cpu[fastest]) if fastest else math.inf
            ok = got >= target - 0.2 and ratio <= 1.25
            before = autos.get(("before", target))
            results.append({"scene": name, "target_db": target, "auto_s": times, "auto_db": got, "chosen": chosen,
                            "fastest": fastest, "fastest_s": rungs[fastest][1:] if fastest else None,
                            "before_s": before[2:] if before else None, "before_db": before[0] if before else None,
                            "floor_db": reference.floor_db, "pass": ok, "auto_cpu_s": cpu["after", target],
                            "auto_estimate_db": estimates.get(("after", target)),
                            "fastest_cpu_s": cpu[fastest] if fastest else None, "cpu_ratio": cpu_ratio,
                            "fastest_draws_db": draws[fastest] if fastest else None, "single_draw_fastest": single,
                            "povray_runs": runs["after", target]})
            rows.append((name, f"{target}", f"{got:.2f}", f"{estimates['after', target]:.2f}",
                         chosen.replace("-A, ", "").replace("-A", "draft").replace(" footprint samples", ""),
                         "/".join(map(str, sorted(set(runs["after", target])))),
                         summary(times), f"{fastest} {summary(rungs[fastest][1:])}" if fastest else "none",
                         " / ".join(f"{d:.2f}" for d in draws[fastest]) if fastest else "-",
                         f"{single} {median[single]:.2f} s "
                         f"({statistics.median(times) / median[single]:.2f}x)" if single else "none",
                         f"{ratio:.2f}x", summary(cpu["after", target]),
                         summary(cpu[fastest]) if fastest else "-", f"{cpu_ratio:.2f}x", *((f"{before[0]:.2f}", summary(before[2:]),
                                             f"{statistics.median(before[2:]) / median[fastest]:.2f}x") if before
                                            else ()),
                         f"{reference.floor_db:.1f}", "yes" if ok else "no"))
            print(" | ".join(rows[-1]), flush=True)
    (args.out / "auto.json").write_text(json.dumps(results, indent=1))
    header = ["scene", "X dB", "full image dB (worst round)", "auto's estimate dB", "chosen (samples)", "POV-Ray runs",
              "auto s", "fastest rung reaching X (all draws)", "its draws dB", "one draw: fastest (ratio)", "ratio",
              "auto CPU s",
              "fastest rung CPU s", "CPU ratio",
              *(["before: dB", "before: auto s", "before: ratio"] if args.before else []), "reference floor dB", "pass"]
    text = table(f"`--quality auto --max-error X`, {' '.join(ARRAY_ARGS)}, full image against two seeds of "
                 f"{args.reference_samples} footprint samples; whole commands (auto's own renders included), "
                 f"median (min-max) of {args.repeat} interleaved runs, wall and CPU (user + system of the command "
                 f"and its POV-Ray processes); a rung reaches X when each of {args.seeds} draws (footprint seeds "
                 f"0..{args.seeds - 1}) does; pass: auto's image within 0.2 dB of X in every round and wall ratio "
                 f"at most 1.25; load average (1 min) after each round "
                 f"{', '.join(f'{x:.1f}' for x in loads[1:])}", header, rows, load_before)
    return publish("auto", text, not args.no_docs)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    sys.exit(main())

"""Run time against error (`make bench`): every method and quality setting on the
bundled fine-texture scene, against a reference that integrates each pixel's
footprint; then --quality auto against --quality high on a larger panel.

Writes bench-out/quality/bench.{csv,md,png} and bench-out/quality.json.

``--default-cost``: the default quality's cost instead: whole ``povh3d render`` commands of the
bundled sample at ``draft`` and ``normal`` on ``demo`` and ``alioscopy-42``, interleaved, median
and spread, with each level's PSNR against the converged footprint reference on a probe of the
central lenses (``renderer.methods.auto``); ``--tree`` times another checkout's code (before/after).
``--frontier``: the same for candidate settings of ``normal`` (antialiasing threshold, method,
depth, jitter; footprint samples), each timed as a whole command with that setting in place of
``normal``, interleaved with draft (wall and CPU seconds: the CPU time of the command and its
POV-Ray children moves less with other users' load); the table is the time-against-error frontier.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

from povh3d.renderer.render import render
from povh3d.renderer.request import RenderRequest
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.commands.bench import default_trials, format_table, run_bench, write_report
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.scene.scene import load_scene

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "sample_models" / "fine_texture.pov"


def omni(lenses: tuple[int, int], ppl: int = 8, s: float = 0.1, f: float = 1.5) -> LensArray:
    return LensArray("square", *lenses, ppl * s, ppl * s, f, Panel(lenses[0] * ppl, lenses[1] * ppl, s, s))


def probe_errors(scene, sidecar: Path, qualities: list) -> list[float]:
    """PSNR of each quality (a name or a ``Quality``) against the converged footprint reference (512
    samples, two seeds), on the central lenses of the array the render's ``sidecar`` names (a slanted
    preset's view space)."""
    from povh3d.renderer.methods.auto import probe_window, reference_quality
    from povh3d.renderer.methods.registry import run_method
    from povh3d.image.metrics import Reference

    a = json.loads(sidecar.read_text())["lens_array"]
    p = a["panel"]
    la = LensArray(a["grid"], *a["lenses"], *a["lens_pitch_mm"], a["focal_mm"],
                   Panel(*p["size_px"], *p["pixel_pitch_mm"]))
    probe, mask = probe_window(la, (48, 40))
    base = RenderSettings(quality="draft", use_cache=False)
    reference = Reference(*(run_method("multi-ortho", scene, probe, replace(
        base, quality=reference_quality(512, seed), bit_depth=16), declared=la).h3d for seed in (1, 2)), mask)
    return [reference.psnr(run_method("multi-ortho", scene, probe, replace(base, quality=quality), declared=la).h3d)
            for quality in qualities]


def default_cost(tree: Path, repeats: int, out: Path) -> list[tuple[str, ...]]:
    """Rows ``(preset, draft s, normal s, ratio, draft dB, normal dB)``: whole commands, interleaved."""
    import os
    import statistics
    import subprocess
    import tempfile


    env = {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}, "PYTHONPATH": str(tree)}
    scene = load_scene(SAMPLE)
    rows = []
    for preset in ("demo", "alioscopy-42"):
        times: dict[str, list[float]] = {"draft": [], "normal": []}
        with tempfile.TemporaryDirectory() as folder:
            for _ in range(repeats):
                for level in times:   # interleaved: a change of load hits both
                    command = [sys.executable, "-m", "povh3d.cli", "render", str(SAMPLE), "--preset", preset,
                               "--quality", level, "--no-cache", "-q", "-o", f"{folder}/{level}.png"]
                    start = time.perf_counter()
                    subprocess.run(command, check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    times[level].append(time.perf_counter() - start)
            error = dict(zip(times, probe_errors(scene, Path(f"{folder}/draft.json"), list(times))))
        med = {level: statistics.median(t) for level, t in times.items()}
        rows.append((preset, *(f"{med[level]:.2f} s ({min(t):.2f}-{max(t):.2f})" for level, t in times.items()),
                     f"{med['normal'] / med['draft']:.2f}x", f"{error['draft']:.2f}", f"{error['normal']:.2f}"))
        print(" | ".join(rows[-1]), flush=True)
    return rows


SAMPLE = REPO / "sample_models" / "sample.pov"
#: Candidates for ``normal`` (``--frontier``): today's first, then cheaper antialiasing and footprint samples.
CANDIDATES = {
    "normal (+A0.1 +AM2 +R3)": "Quality(antialias=0.1, aa_method=2, aa_depth=3)",
    "+A0.1 +AM2 +R2": "Quality(antialias=0.1, aa_method=2, aa_depth=2)",
    "+A0.2 +AM2 +R3": "Quality(antialias=0.2, aa_method=2, aa_depth=3)",
    "+A0.3 +AM2 +R3": "Quality(antialias=0.3, aa_method=2, aa_depth=3)",
    "+A0.1 +AM2 +R3 +J": "Quality(antialias=0.1, aa_method=2, aa_depth=3, jitter=True)",
    "+A0.1 +AM1 +R3": "Quality(antialias=0.1, aa_method=1, aa_depth=3)",
    "+A0.1 +AM1 +R2": "Quality(antialias=0.1, aa_method=1, aa_depth=2)",
    "+A0.05 +AM2 +R2": "Quality(antialias=0.05, aa_method=2, aa_depth=2)",
    "4 footprint samples": "Quality(footprint=4)",
}
#: A whole ``povh3d render --quality normal`` with ``normal`` replaced by the candidate (argv: the rest).
WRAPPER = ("import sys; from povh3d.renderer.methods import quality as q; q.QUALITY_LEVELS['normal'] = q.{}; "
           "from povh3d.cli.main import main; sys.exit(main(sys.argv[1:]))")


def frontier(tree: Path, repeats: int, presets: list[str]) -> list[tuple[str, ...]]:
    """Rows ``(preset, setting, seconds, ratio, CPU seconds, ratio, dB)``: every candidate as a whole command,
    interleaved with draft (draft, c1, c2, ... per round), PSNR on the probe of ``default_cost``."""
    import os
    import resource
    import statistics
    import subprocess
    import tempfile

    from povh3d.renderer.methods import quality as q

    env = {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}, "PYTHONPATH": str(tree)}
    scene = load_scene(SAMPLE)
    settings = {"draft": "Quality()", **CANDIDATES}
    rows = []
    for preset in presets:
        times: dict[str, list[float]] = {name: [] for name in settings}
        cpu: dict[str, list[float]] = {name: [] for name in settings}
        with tempfile.TemporaryDirectory() as folder:
            for _ in range(repeats):
                for n, (name, code) in enumerate(settings.items()):
                    command = [sys.executable, "-c", WRAPPER.format(code), "render", str(SAMPLE), "--preset",
                               preset, "--quality", "normal", "--no-cache", "-q", "-o", f"{folder}/{n}.png"]
                    used = resource.getrusage(resource.RUSAGE_CHILDREN)
                    start = time.perf_counter()
                    subprocess.run(command, check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    times[name].append(time.perf_counter() - start)
                    after = resource.getrusage(resource.RUSAGE_CHILDREN)
                    cpu[name].append(after.ru_utime + after.ru_stime - used.ru_utime - used.ru_stime)
                print(preset, {k: (round(v[-1], 2), round(cpu[k][-1], 2)) for k, v in times.items()},
                      f"load {os.getloadavg()[0]:.2f}",
                      file=sys.stderr, flush=True)
            errors = probe_errors(scene, Path(f"{folder}/0.json"), [eval(code, vars(q)) for code in settings.values()])
        draft, draft_cpu = statistics.median(times["draft"]), statistics.median(cpu["draft"])
        for name, db in zip(settings, errors):
            med, med_cpu = statistics.median(times[name]), statistics.median(cpu[name])
            rows.append((preset, name, f"{med:.2f} s ({min(times[name]):.2f}-{max(times[name]):.2f})",
                         f"{med / draft:.2f}x", f"{med_cpu:.2f} s ({min(cpu[name]):.2f}-{max(cpu[name]):.2f})",
                         f"{med_cpu / draft_cpu:.2f}x", f"{db:.2f}"))
            print(" | ".join(rows[-1]), flush=True)
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(REPO / "bench-out"))
    parser.add_argument("--methods", default="multi-ortho,pinhole,single-stage:conic,single-stage:spherical")
    parser.add_argument("--auto-only", action="store_true", help="only --quality auto against high")
    parser.add_argument("--default-cost", action="store_true", help="only normal against draft, whole commands")
    parser.add_argument("--frontier", action="store_true", help="only candidate settings for normal against draft")
    parser.add_argument("--presets", default="demo,alioscopy-42", help="with --frontier: the presets")
    parser.add_argument("--tree", default=str(REPO), help="with --default-cost: the checkout whose code is timed")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    out = Path(args.out)
    if args.frontier:
        load = __import__("os").getloadavg()[0]
        rows = frontier(Path(args.tree), args.repeats, args.presets.split(","))
        print(f"\nload average {load:.2f} before, {__import__('os').getloadavg()[0]:.2f} after (1 min)\n")
        print("| preset | setting | whole command | ratio to draft | CPU | CPU ratio | dB |\n"
              "|---|---|---|---|---|---|---|")
        print("\n".join(f"| {' | '.join(r)} |" for r in rows))
        return 0
    if args.default_cost:
        os_load = __import__("os").getloadavg()
        default_cost(Path(args.tree), args.repeats, out)
        print(f"load average {os_load[0]:.2f} before, {__import__('os').getloadavg()[0]:.2f} after (1 min)")
        return 0
    scene = load_scene(SCENE)
    results: dict = {"auto": []}

    # 1. Every setting on the 240x144 omnidirectional panel (30x18 lenses, 8x8 views).
    if not args.auto_only:
        report = run_bench(scene, omni((30, 18)), default_trials(omni((30, 18)), args.methods.split(",")),
                           on_trial=lambda n, total, what: print(f"  [{n + 1}/{total}] {what}", file=sys.stderr))
        write_report(report, out / "quality")
        print(format_table(report))
        results.update(bench=report.rows(), noise_floor_db=report.noise_floor_db)

    # 2. --quality auto (probe included, cold cache) against --quality high, 480x272 panel.
    la = omni((60, 34))
    results["panel"] = [la.panel.width, la.panel.height]
    base = RenderSettings(quality="draft", use_cache=False)
    t = time.perf_counter()
    render(RenderRequest(SCENE, la, out / "high.png", settings=replace(base, quality="high")))
    high = time.perf_counter() - t
    results["high_seconds"] = high
    print(f"\n480x272, --quality high: {high:.1f} s")
    for target in (25.0, 30.0, 35.0, 38.0):
        t = time.perf_counter()
        record = render(RenderRequest(SCENE, la, out / f"auto-{target:g}.png",
                                      settings=replace(base, quality="auto", max_error_db=target)))
        seconds = time.perf_counter() - t
        chosen = record["quality"]["auto"]["chosen"]
        results["auto"].append({"target_db": target, "seconds": seconds, "chosen": chosen,
                                "speedup_over_high": high / seconds})
        print(f"--quality auto --max-error {target:g}: {seconds:.1f} s = {high / seconds:.1f}x faster "
              f"than high ({chosen})")
    out.mkdir(parents=True, exist_ok=True)
    (out / "quality.json").write_text(json.dumps(results, indent=2, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: the placement on scenes with their own camera (issue 13).

1. Oracle: every sampled view of the H3D image (``demo`` preset, ``--quality
   draft``) against a plain POV-Ray render of the same scene through an oblique
   orthographic camera with that view's direction, placed by the pose in NumPy;
   PSNR per scene (worst and median of the views).
2. Cost of the placement on a re-run: whole ``povh3d render`` commands, all shots
   cached, with the scene's camera (camera evaluation and depth pass read from
   the cache) against ``--placement native``; repeats interleaved, median and
   spread, load average recorded.  Then in the process: the placement on a re-run,
   and on a first render (fresh cache: how many POV-Ray runs, how long).

Scenes: the gallery scenes of ``tests/support/gallery`` and, when Debian's
``povray-examples`` is installed, POV-Ray's sample scenes named in the issue.
Writes its tables between the ``bench_placement`` markers of docs/benchmarks.md.

    .venv/bin/python benchmarks/bench_placement.py [--repeats 7] [--views 4]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from povh3d.renderer.methods.quality import RenderSettings  # noqa: E402
from povh3d.geometry.pose import DisplayPose  # noqa: E402
from povh3d.display.presets import lens_array  # noqa: E402
from povh3d.image.interleave import extract  # noqa: E402
from povh3d.image.io import read_image, read_png  # noqa: E402
from povh3d.image.metrics import psnr  # noqa: E402
from povh3d.scene.format import pov_vector  # noqa: E402
from povh3d.povray.process import PovrayJob, run_jobs  # noqa: E402
from tests.support.render import render  # noqa: E402

EXAMPLES = Path("/usr/share/doc/povray/examples/advanced")
SCENES = [REPO / "tests/support/gallery/tilted.pov", REPO / "tests/support/gallery/inches.pov"] + [
    EXAMPLES / name for name in ("chess2.pov", "woodbox.pov", "teapot/teapot.pov", "glasschess/glasschess.pov",
                                 "pawns.pov", "biscuit.pov")]
BEGIN, END = "<!-- bench_placement -->", "<!-- /bench_placement -->"


def untied_pawns() -> Path | None:
    """pawns.pov with its pine block's top lowered 1e-4 units: in the original the block's top and the
    rosewood squares' tops are one plane (y = 0), so which surface a ray reports is decided by rounding."""
    original = EXAMPLES / "pawns.pov"
    if not original.is_file():
        return None
    text = original.read_text(encoding="latin-1")
    if text.count("translate -0.25*y") != 1:
        return None
    folder = Path(tempfile.mkdtemp())
    path = folder / "pawns-untied.pov"
    path.write_text(text.replace("translate -0.25*y", "translate -0.2501*y"), encoding="latin-1")
    return path


def oracle(scene: Path, views: int) -> tuple[float, float, dict]:
    array = lens_array("demo")
    out = Path(tempfile.mkdtemp()) / "h.png"
    record = render(scene, array, out, settings=RenderSettings(quality="draft"))
    f = record["placement"]
    frame = DisplayPose(tuple(f["centre"]), tuple(f["axis_x"]), tuple(f["axis_y"]), tuple(f["normal"]),
                         f["units_per_mm"], f["source"])
    back = record["quality"]["front_clearance_mm"]
    stack = extract(read_png(out), array.require_views())
    ny, nx = array.require_views()
    s, fl = array.panel.pitch_x, array.focal
    picks = [(0, 0), (ny // 2, nx // 2), (ny - 1, nx - 1), (1, nx - 2), (ny - 2, 1), (0, nx - 1)][:views]
    values = []
    for l, k in picks:
        d = np.array([(k + 0.5 - nx / 2) * s / fl, (ny / 2 - l - 0.5) * s / fl, 1.0])
        script = (f'#include "{scene.name}"\ncamera {{ orthographic location {pov_vector(frame.to_scene(-back * d))} '
                  f'direction {pov_vector(frame.directions_to_scene(d))} '
                  f'right {pov_vector(frame.directions_to_scene([array.lenses_x * array.pitch_x, 0, 0]))} '
                  f'up {pov_vector(frame.directions_to_scene([0, array.lenses_y * array.pitch_y, 0]))} }}\n')
        images = []
        run_jobs([PovrayJob(name="oracle", script=script, width=array.lenses_x, height=array.lenses_y,
                            include_dirs=(str(scene.parent), str(EXAMPLES)), options=("-A",))], processes=1,
                 on_result=lambda r: images.append(read_image(r.images[0])))
        values.append(psnr(stack[l, k], images[0]))
    return min(values), float(np.median(values)), f


def command_seconds(scene: Path, extra: list[str], out: Path, env: dict) -> float:
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "povh3d.cli.main", "render", str(scene), "--preset", "demo",
                    "--quality", "draft", "-q", "-o", str(out), *extra], check=True, env=env,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--views", type=int, default=4)
    args = parser.parse_args()
    scenes = [s for s in SCENES if s.is_file()]
    untied = untied_pawns()
    oracle_scenes = scenes + ([untied] if untied else [])
    load_before = os.getloadavg()
    rows = ["| scene | pose (centre; units per mm) | worst view, dB | median, dB |", "|---|---|---|---|"]
    for scene in oracle_scenes:
        worst, median, f = oracle(scene, args.views)
        centre = ", ".join(f"{v:.3g}" for v in f["centre"])
        rows.append(f"| {scene.name} | {f['source']} ({centre}; {f['units_per_mm']:.4g}) | {worst:.1f} | {median:.1f} |")
        print(rows[-1], flush=True)

    env = {**os.environ, "PYTHONPATH": str(REPO), "POVH3D_CACHE": tempfile.mkdtemp()}
    timing = ["| scene | re-run with the camera placement, s | re-run native, s | difference, s |", "|---|---|---|---|"]
    for scene in scenes[:3]:
        out = Path(tempfile.mkdtemp()) / "o.png"
        command_seconds(scene, [], out, env)
        command_seconds(scene, ["--placement", "native"], out, env)   # warm both caches
        framed, native = [], []
        for _ in range(args.repeats):  # interleaved, so load hits both alike
            framed.append(command_seconds(scene, [], out, env))
            native.append(command_seconds(scene, ["--placement", "native"], out, env))
        diffs = [a - b for a, b in zip(framed, native)]
        timing.append(f"| {scene.name} | {statistics.median(framed):.3f} (spread {max(framed) - min(framed):.3f}) | "
                      f"{statistics.median(native):.3f} (spread {max(native) - min(native):.3f}) | "
                      f"{statistics.median(diffs):+.3f} |")
        print(timing[-1], flush=True)
    # The placement's own cost on a re-run, in process: camera evaluation and depth pass from the cache.
    from povh3d.renderer.placement.place import place_display
    from povh3d.renderer.request import RenderRequest
    from povh3d.scene.scene import load_scene

    os.environ["POVH3D_CACHE"] = env["POVH3D_CACHE"]
    inproc = ["| scene | placement on a re-run (in process), ms: median | max |", "|---|---|---|"]
    for scene in scenes:
        request = RenderRequest(source=scene, lens_array=lens_array("demo"), output=Path("x.png"),
                                settings=RenderSettings(quality="draft"))
        loaded = load_scene(scene)
        place_display(request, loaded)   # fill the cache
        times = []
        for _ in range(args.repeats * 3):
            start = time.perf_counter()
            place_display(request, loaded)
            times.append(1000 * (time.perf_counter() - start))
        inproc.append(f"| {scene.name} | {statistics.median(times):.1f} | {max(times):.1f} |")
        print(inproc[-1], flush=True)
    # The placement's cost on a first render, in process: POV-Ray runs and seconds, fresh cache each time.
    import povh3d.renderer.shots.shots as engine_frames
    import povh3d.povray.process as process

    runs = [0]
    original = process.run_jobs

    def counting(jobs, *a, **k):
        runs[0] += len(jobs)
        return original(jobs, *a, **k)

    process.run_jobs = engine_frames.run_jobs = counting
    cold = ["| scene | POV-Ray runs the placement adds (cold) | seconds: median | spread |", "|---|---|---|---|"]
    for scene in scenes:
        request = RenderRequest(source=scene, lens_array=lens_array("demo"), output=Path("x.png"),
                                settings=RenderSettings(quality="draft"))
        loaded, times = load_scene(scene), []
        for _ in range(max(3, args.repeats // 2)):
            os.environ["POVH3D_CACHE"] = tempfile.mkdtemp()
            runs[0] = 0
            start = time.perf_counter()
            place_display(request, loaded)
            times.append(time.perf_counter() - start)
        cold.append(f"| {scene.name} | {runs[0]} | {statistics.median(times):.3f} | {max(times) - min(times):.3f} |")
        print(cold[-1], flush=True)
    process.run_jobs = engine_frames.run_jobs = original
    load_after = os.getloadavg()
    text = "\n".join([BEGIN, "", f"Load average {load_before[0]:.2f} before, {load_after[0]:.2f} after "
                      f"(2 shared cores); `demo` preset, `--quality draft`.", "",
                      "Views against oblique orthographic renders placed by the pose (PSNR, point-sampled):", "",
                      *rows, "", f"Whole `povh3d render` re-runs (all cached), median of {args.repeats} interleaved:", "",
                      *timing, "", "What the placement adds to a re-run, measured in the process (camera evaluation "
                      "and depth pass, both from the cache):", "", *inproc, "",
                      "What the placement adds to a first render, in the process (fresh cache; the camera's evaluation "
                      "and the depth pass share one POV-Ray run):", "", *cold, "", END])
    doc = REPO / "docs" / "benchmarks.md"
    current = doc.read_text(encoding="utf-8")
    if BEGIN in current and END in current:
        current = current[:current.index(BEGIN)] + text + current[current.index(END) + len(END):]
    else:
        current = current.rstrip("\n") + "\n\n" + text + "\n"
    doc.write_text(current, encoding="utf-8")
    print(f"\nwritten into {doc}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The gallery: every scene of Debian's ``povray-examples`` that has a camera, rendered as a user would.

For each scene and each preset (``demo`` and the lenticular ``ipad-retina``, ``--quality
draft``) one whole ``povh3d render`` command, whose outcome is one of

- ``ok``: exit 0, the scene camera's frame, a finite depth report (or a warning that says why the depth
  pass has none), a non-empty image, and
  every sampled view within ``MIN_DB`` of a plain POV-Ray render of the scene through an
  oblique orthographic camera placed by the pose (point-sampled, as ``bench_placement``);
- ``refused``: a non-zero exit with one line on stderr (the cause and the fix);
- ``timeout``: the command, or the oracle that judges it, ran out of its time;
- ``stochastic``: as ok, but a view below ``MIN_DB`` in a scene whose lighting POV-Ray samples per
  render, within ``STOCHASTIC_MARGIN_DB`` of the gap between two of POV-Ray's own renders (``view_verdict``);
- ``chaotic``: as ok, but a view below ``MIN_DB`` in a scene whose oracle moved by the render's own
  precision (``chaotic_shift_mm``) falls below it too, and within ``CHAOTIC_MARGIN_DB`` of that gap;
- ``wrong``: exit 0 but a frame other than the camera's, no finite depth and no word why, an empty
  image or a view below that bar (the silently wrong image the issue is about);
- ``crash``: a non-zero exit with more than one line (a traceback).

The command's time is set against a plain 2D ``povray`` render of the scene through its own
camera at the preset's panel size.  The table is written between the ``gallery`` markers of
docs/benchmarks.md; rows of scenes not run this time are kept, so runs over subsets add up.

    .venv/bin/python benchmarks/gallery.py [--scenes 'advanced/*'] [--limit N] [--timeout 120]
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from benchmarks._common import write_table  # noqa: E402
from benchmarks.gallery_oracle import (  # noqa: E402, F401  (the judge's oracle, re-exported for the tests)
    CHAOTIC_MARGIN_DB, EXAMPLES, GRID_SHIFTS, MIN_DB, STOCHASTIC_MARGIN_DB, chaotic_floor, chaotic_shift_mm,
    grid_shifts, oracle_view, realizations_psnr, view_psnr, view_verdict)

PRESETS = ("demo", "ipad-retina")
#: features whose lighting POV-Ray samples anew with the camera's pixels (radiosity's pretrace); photons
#: and jittered area lights are checked too: where two realizations agree, the 35 dB rule applies as is
STOCHASTIC = ("radiosity", "photons", "area_light")
NON_EMPTY = 0.01        # share of pixels that must be above black for an image to count as non-empty
#: the depth budget's warnings, which say nothing of whether an image is right
_BUDGET_WARNINGS = ("the framed scene spans", "something beyond the framed subject")
_CAMERA = re.compile(r"\bcamera\s*\{")
_INCLUDE = re.compile(r'#\s*include\s+"([^"]+)"')


@dataclass(frozen=True)
class Outcome:
    scene: str
    preset: str
    kind: str              # ok, stochastic, chaotic, refused, timeout, wrong, crash
    frame: str             # the sidecar's frame source, or ''
    depth: str             # 'near..far mm', the depth pass's reason, or ''
    worst_db: float        # the worst sampled view against its oblique orthographic render (nan: none)
    seconds: float
    seconds_2d: float
    note: str              # why (wrong: what; refused/crash: the first line of stderr)


def _code(text: str) -> str:
    """POV-Ray source without its comments."""
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.DOTALL)
    return re.sub(r"//[^\n]*", " ", text)


def has_camera(scene: Path) -> bool:
    """Whether the scene's text or one of its includes (beside it or POV-Ray's own) writes a camera."""
    from povh3d.scene.scene import system_include_dirs

    folders = [scene.parent, *system_include_dirs()]
    seen, todo = set(), [scene]
    while todo:
        path = todo.pop()
        if path in seen or not path.is_file():
            continue
        seen.add(path)
        text = _code(path.read_text(encoding="latin-1"))
        if _CAMERA.search(text):
            return True
        todo.extend(folder / name for name in _INCLUDE.findall(text) for folder in (path.parent, *folders))
    return False


def gallery_scenes(patterns: list[str] | None = None, limit: int | None = None) -> list[Path]:
    """The example scenes with a camera (paths under EXAMPLES), filtered by glob patterns."""
    scenes = sorted(p for p in EXAMPLES.rglob("*.pov") if has_camera(p))
    if patterns:
        scenes = [p for p in scenes if any(fnmatch.fnmatch(str(p.relative_to(EXAMPLES)), pat) for pat in patterns)]
    # Round robin over the top folders (advanced, animations, ...): a run cut short still covers each.
    folders: dict[str, list[Path]] = {}
    for p in scenes:
        folders.setdefault(p.relative_to(EXAMPLES).parts[0], []).append(p)
    spread = [p for i in range(max(map(len, folders.values()), default=0)) for group in folders.values()
              if i < len(group) for p in [group[i]]]
    return spread[:limit] if limit else spread


def _env(cache: str) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(REPO), "POVH3D_CACHE": cache}


def _two_d_seconds(scene: Path, width: int, height: int, timeout: float) -> float:
    """A plain POV-Ray render of the scene through its own camera at the panel size (nan: timed out)."""
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        try:
            subprocess.run(["povray", f"+I{scene.name}", f"+O{folder}/2d.png", f"+W{width}", f"+H{height}", "-A",
                            "-D", "+WT1", f"+L{EXAMPLES}"], cwd=scene.parent, timeout=timeout,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
        except subprocess.TimeoutExpired:
            return float("nan")
        return time.perf_counter() - start


def is_stochastic(scene: Path) -> bool:
    """Whether the scene (or an include) uses a lighting feature POV-Ray may sample per render."""
    from povh3d.scene.scene import load_scene

    try:
        used = load_scene(scene).features.used
    except Exception:   # an unreadable scene: the render's own outcome says why
        return False
    return bool(used & set(STOCHASTIC))


def judge(scene: Path, preset: str, timeout: float, seconds_2d: float, views: int = 2,
          display: tuple[str, ...] | None = None) -> Outcome:
    """One ``povh3d render`` command on ``scene`` and what came of it; ``display``: the display's options
    (default ``--preset preset``)."""
    name = str(scene.relative_to(EXAMPLES)) if scene.is_relative_to(EXAMPLES) else scene.name
    with tempfile.TemporaryDirectory() as folder:
        out, views_dir = Path(folder) / "h3d.png", Path(folder) / "views"
        command = [sys.executable, "-m", "povh3d.cli", "render", str(scene), *(display or ("--preset", preset)),
                   "--quality", "draft", "-q", "-o", str(out), "--views-dir", str(views_dir), "--jobs", "1",
                   "--threads", "1", "--timeout", str(timeout)]   # one thread, as the 2D render it is set against
        start = time.perf_counter()
        try:
            done = subprocess.run(command, env=_env(str(Path(folder) / "cache")), cwd=scene.parent,
                                  capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return Outcome(name, preset, "timeout", "", "", float("nan"), timeout, seconds_2d, f"over {timeout:g} s")
        seconds = time.perf_counter() - start
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        if done.returncode != 0:
            errors = [line for line in lines if line.startswith("povh3d: error")]
            # povh3d's own bugs come out in one line too ("internal error ..."): a crash, not a refusal
            one_line = (len(errors) == 1 and not any("Traceback" in line for line in lines)
                        and "internal error" not in errors[0])
            note = (errors or lines or ["?"])[-1].removeprefix("povh3d: error: ")[:160]
            return Outcome(name, preset, "refused" if one_line else "crash", "", "", float("nan"), seconds,
                           seconds_2d, note)
        record = json.loads(out.with_suffix(".json").read_text())
        frame = record.get("placement", {})
        depth = frame.get("depth") or {}
        problems = []
        if frame.get("source") != "camera":
            problems.append(f"frame {frame.get('source')}")
        if "near_mm" in depth and np.isfinite([depth["near_mm"], depth["far_mm"]]).all():
            depth_text = f"{depth['near_mm']:.3g}..{depth['far_mm']:.3g}"
        elif not depth and not any("depth" in p.get("name", "") for p in record.get("passes", [])):
            depth_text = "not measured"   # a plain render makes no depth pass (docs/geometry.md); info does
        else:
            depth_text = "blind" if depth.get("blind") else "saturated" if depth.get("saturated") else "none"
            # No depth is a wrong report only where nothing said why (the middle of the field all sky, the
            # viewer inside a solid): the render's warning names the depth pass and the cause.
            if not any(line.startswith("povh3d: warning") and "depth pass" in line for line in lines):
                problems.append(f"depth {depth_text}")
        from povh3d.errors import PovrayTimeout
        from povh3d.image.io import read_png

        image = read_png(out)
        full = 65535 if image.dtype == np.uint16 else 255
        lit = float((image[..., :3].max(axis=-1) > 8 / 255 * full).mean())
        if lit < NON_EMPTY:
            problems.append(f"image {100 * lit:.1f} % lit")
        nx, ny = record["lens_array"]["views"]
        picks = [(ny // 2, nx // 2), (0, 0)][:views]
        stochastic = is_stochastic(scene)
        try:
            worst, realizations = view_psnr(scene, record, views_dir, picks, timeout, stochastic)
        except PovrayTimeout:   # the command was done, but its oracle cannot be rendered in time: not judged
            return Outcome(name, preset, "timeout", frame.get("source", ""), depth_text, float("nan"), seconds,
                           seconds_2d, f"oracle over {timeout:g} s")
        except Exception as error:   # the oracle's own render failed: say so, do not hide the row
            worst, realizations = float("nan"), float("nan")
            problems.append(f"oracle: {str(error).splitlines()[0][:80]}")
        verdict, chaotic = view_verdict(worst, realizations), float("nan")
        if verdict == "wrong" and np.isfinite(worst):   # a pigment that changes within the render's precision?
            try:
                shape = read_png(views_dir / f"v_{picks[0][0]:03d}_{picks[0][1]:03d}.png").shape[:2]
                chaotic = chaotic_floor(scene, record, picks, shape, timeout)
            except Exception:   # not measured: the 35 dB rule as is
                pass
            verdict = view_verdict(worst, realizations, chaotic)
        if verdict == "wrong" and np.isfinite(worst):
            problems.append(f"view {worst:.1f} dB" + (f" (POV-Ray's own realizations: {realizations:.1f} dB)"
                                                      if stochastic else "") + (
                f" (the oracle moved by the precision: {chaotic:.1f} dB)" if chaotic < MIN_DB else "") + _cross_check(
                scene, [*(display or ("--preset", preset))], picks, timeout, record["method"]))
        warnings = [line.removeprefix("povh3d: warning: ") for line in lines if line.startswith("povh3d: warning")]
        if problems:   # wrong; and whether a warning said so (not silent, though exit 0)
            said = [w for w in warnings if not w.startswith(_BUDGET_WARNINGS)]   # not the depth budget's
            note = "; ".join(problems) + (f"; warned: {said[0][:100]}" if said else "")
        elif verdict == "stochastic":
            note = f"stochastic: POV-Ray's own renders of the same rays, the image grid shifted, differ by {realizations:.1f} dB"
        elif verdict == "chaotic":
            note = (f"chaotic: the oracle moved {chaotic_shift_mm(record):.2g} mm or tilted as much (the "
                    f"{record['method']} camera's precision) differs from itself by {chaotic:.1f} dB")
        else:
            said = [w for w in warnings if "depth pass" in w] or warnings
            note = said[0][:120] if said else ""
        kind = "wrong" if problems else verdict
        return Outcome(name, preset, kind, frame.get("source", ""), depth_text, worst,
                       seconds, seconds_2d, note)


def _cross_check(scene: Path, display: list[str], picks: list[tuple[int, int]], timeout: float, method: str) -> str:
    """A hint at why a view is wrong: the same command with ``--method multi-ortho-views`` judged the same
    way; '' where it cannot run.  An orthographic camera a view works out each ray's inside/outside state
    (multi-ortho's mesh camera shares its first ray's) and renders each view at the view's own size (as
    the oracle does, so a scene built from image_width passes it too)."""
    if method != "multi-ortho" or "--method" in display:
        return ""
    with tempfile.TemporaryDirectory() as folder:
        out, views_dir = Path(folder) / "h3d.png", Path(folder) / "views"
        command = [sys.executable, "-m", "povh3d.cli", "render", str(scene), *display, "--method", "multi-ortho-views",
                   "--quality", "draft", "-q", "-o", str(out), "--views-dir", str(views_dir), "--jobs", "1",
                   "--timeout", str(timeout)]
        try:
            done = subprocess.run(command, env=_env(str(Path(folder) / "cache")), cwd=scene.parent,
                                  capture_output=True, text=True, timeout=timeout)
            if done.returncode != 0:
                return ""
            db, _ = view_psnr(scene, json.loads(out.with_suffix(".json").read_text()), views_dir, picks, timeout)
        except Exception:   # a cross-check that cannot run says nothing
            return ""
    return f"; multi-ortho-views {db:.1f} dB"


def run_scene(scene: Path, timeout: float, presets: tuple[str, ...] = PRESETS,
              two_d_timeout: float | None = None) -> list[Outcome]:
    """The presets on one scene (one worker of the pool); the 2D render capped at ``two_d_timeout``
    (default ``timeout``): it times the command, it does not judge it."""
    from povh3d.display.presets import lens_array

    out = []
    for preset in presets:
        panel = lens_array(preset).panel
        two_d = _two_d_seconds(scene, panel.width, panel.height, two_d_timeout or timeout)
        out.append(judge(scene, preset, timeout, two_d))
    return out


def _row(o: Outcome) -> tuple[str, ...]:
    db = f"{o.worst_db:.1f}" if np.isfinite(o.worst_db) else ("inf" if o.worst_db == float("inf") else "")
    ratio = f"{o.seconds / o.seconds_2d:.1f}x" if np.isfinite(o.seconds_2d) and o.kind != "timeout" else ""
    return (o.scene, o.preset, o.kind, o.frame, o.depth, db, f"{o.seconds:.1f}",
            f"{o.seconds_2d:.1f}" if np.isfinite(o.seconds_2d) else "timeout", ratio, o.note.replace("|", "/"))


KINDS = ("ok", "stochastic", "chaotic", "refused", "timeout", "wrong", "crash")
HEADER = ["scene", "preset", "outcome", "frame", "depth, mm", "worst view, dB", "s", "2D s", "vs 2D", "note"]


def _kept_rows(run: set[tuple[str, str]]) -> list[tuple[str, ...]]:
    """Rows of the current table for (scene, preset) pairs not run this time."""
    from benchmarks._common import DOCS, markers

    begin, end = markers("gallery")
    text = DOCS.read_text(encoding="utf-8")
    if begin not in text:
        return []
    body = text[text.index(begin):text.index(end)]
    rows = [tuple(c.strip() for c in line.strip().strip("|").split("|")) for line in body.splitlines()
            if line.startswith("| ") and not line.startswith("| scene")]
    return [r for r in rows if len(r) == len(HEADER) and (r[0], r[1]) not in run]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="*", help="glob patterns under the examples folder, e.g. 'advanced/*'")
    parser.add_argument("--limit", type=int, help="at most this many scenes")
    parser.add_argument("--timeout", type=float, default=120.0, help="seconds allowed to each command")
    parser.add_argument("--workers", type=int, default=1,
                        help="scenes rendered at once (default 1: one POV-Ray at a time on a shared machine)")
    parser.add_argument("--resume", action="store_true", help="skip the scenes the table already holds")
    parser.add_argument("--presets", nargs="+", choices=PRESETS, default=list(PRESETS),
                        help="the displays to render on (default: all of them)")
    parser.add_argument("--two-d-timeout", type=float,
                        help="seconds allowed to the plain 2D render that times a command (default --timeout)")
    args = parser.parse_args()
    if not EXAMPLES.is_dir():
        raise SystemExit(f"no {EXAMPLES}: install POV-Ray's sample scenes (make gallery runs "
                         "apt-get install povray-examples)")
    scenes = gallery_scenes(args.scenes)
    if args.resume:
        done = {row[0] for row in _kept_rows(set())}
        scenes = [p for p in scenes if str(p.relative_to(EXAMPLES)) not in done]
    scenes = scenes[:args.limit] if args.limit else scenes
    total = len(gallery_scenes())
    print(f"{len(scenes)} of {total} scenes with a camera", flush=True)
    load = os.getloadavg()
    presets = tuple(args.presets)
    kept = _kept_rows({(str(p.relative_to(EXAMPLES)), preset) for p in scenes for preset in presets})
    outcomes: list[Outcome] = []
    with ProcessPoolExecutor(args.workers) as pool:
        for result in pool.map(run_scene, scenes, [args.timeout] * len(scenes), [presets] * len(scenes),
                               [args.two_d_timeout] * len(scenes)):
            for o in result:
                outcomes.append(o)
                print(" | ".join(_row(o)), flush=True)
            _write(kept + [_row(o) for o in outcomes], total, args, load)   # after each scene: a stop keeps them
    return 0


def _write(rows: list[tuple[str, ...]], total: int, args: argparse.Namespace, load: tuple[float, ...]) -> None:
    from benchmarks._common import table

    rows = sorted(rows)
    counts = {kind: sum(r[2] == kind for r in rows) for kind in KINDS}
    per_preset = [(preset, *(str(sum(r[1] == preset and r[2] == kind for r in rows)) for kind in KINDS),
                   str(sum(r[1] == preset for r in rows))) for preset in PRESETS]
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    caption = (f"Gallery, {when}: {len({r[0] for r in rows})} of the {total} example scenes with a camera "
               f"({', '.join(f'{v} {k}' for k, v in counts.items())} over {len(rows)} renders); "
               f"`--quality draft`, each command capped at {args.timeout:g} s, {args.workers} at once")
    counts_table = "\n".join([f"| preset | {' | '.join(KINDS)} | renders |", "|" + "---|" * (len(KINDS) + 2)]
                             + [f"| {' | '.join(row)} |" for row in per_preset])
    write_table("gallery", table(caption, HEADER, rows, load).replace("\n\n", f"\n\n{counts_table}\n\n", 1))


if __name__ == "__main__":
    sys.exit(main())

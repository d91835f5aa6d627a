"""``povh3d replay``: an H3D image on its display, seen from an eye (``display/replay.py``), on files.

Reads the image and the lens array its sidecar describes, checks every input, then writes the
replay (or a sweep's frames and GIF) and its sidecar atomically.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..display.display import Display
from ..display.replay import (OPTICS, Replay, default_eye, light_shares, mapped_report, mapped_sheet, psnr, replay, report,
                              sweep_eyes)
from ..errors import ConfigError, InputError, param
from ..image.io import atomic_path, check_writable, read_png, read_sidecar, write_png
from ..renderer.budget import check_memory
from ..renderer.records import base_record, png_output, write_image
from .images import check_against_sidecar

MAX_SWEEP = 240


def read_display(h3d_path: str | Path) -> tuple[np.ndarray, Display]:
    """The H3D image and the display its sidecar describes; one error line when there is none."""
    record = read_sidecar(h3d_path)
    if not Path(h3d_path).is_file():
        raise InputError(f"image {str(h3d_path)!r} does not exist; check the path")
    if not record or not record.get("lens_array"):
        raise InputError(f"{str(h3d_path)!r} has no sidecar with its lens array ({Path(h3d_path).stem}.json); "
                         "replay an image povh3d rendered, with its sidecar beside it")
    display = Display.from_record(record)
    if display.physical_panel is None:
        check_against_sidecar(h3d_path, record["lens_array"])
    return read_png(h3d_path), display


def mapped(display: Display, image: np.ndarray, h3d_path: str | Path) -> tuple[Any, Any, float, np.ndarray] | None:
    """A mapped panel's sheet: ``(mapping, sheet, shift, views)`` (``display/replay.mapped_sheet``), or None for
    an H3D image; one error line for a mapping whose sheet povh3d cannot rebuild."""
    if display.physical_panel is None:
        return None
    from ..display.display import build_display

    panel = display.physical_panel
    if image.shape[:2] != (panel.height, panel.width):
        raise InputError(f"{str(h3d_path)!r} is {image.shape[1]}x{image.shape[0]} but its sidecar describes a "
                         f"{panel.width}x{panel.height} panel; render it again or delete the sidecar")
    if display.preset is None or display.mapping_name is None:
        raise ConfigError(f"{str(h3d_path)!r} is a mapped panel without a preset; replay needs the preset's "
                          f"mapping to rebuild its sheet: render it with {param('preset')}")
    built = build_display(display.preset, mapping=display.mapping_name)
    if built.mapping is None or built.mapped_panel != panel:
        raise ConfigError(f"the sidecar's panel is not preset {display.preset!r}'s with mapping "
                          f"{display.mapping_name!r}; replay needs that preset's own mapping")
    try:
        sheet, shift, views = mapped_sheet(built.mapping, panel, built.lens_array.focal)
    except ConfigError:
        raise ConfigError(f"mapping {display.mapping_name!r} is not a slanted subpixel sheet; replay rebuilds "
                          "those only (alioscopy, philips)") from None
    return built.mapping, sheet, shift, views


def parse_eye(text: str | None) -> tuple[float, float, float] | None:
    if text is None:
        return None
    try:
        x, y, z = (float(v) for v in text.split(","))
    except ValueError:
        raise ConfigError(f"{param('eye')} must be X,Y,Z in mm, got {text!r}; e.g. {param('eye')} 0,0,-300") from None
    return (x, y, z)


def parse_sweep(text: str | None) -> tuple[str, float, float, int] | None:
    """``X0:X1:N`` (eye x) or ``y:Y0:Y1:N`` (eye y)."""
    if text is None:
        return None
    parts = text.split(":")
    axis = "x"
    if parts and parts[0] in ("x", "y"):
        axis, parts = parts[0], parts[1:]
    try:
        start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
        if len(parts) != 3:
            raise ValueError
    except (ValueError, IndexError):
        raise ConfigError(f"{param('sweep')} must be X0:X1:N (or y:Y0:Y1:N), got {text!r}; e.g. {param('sweep')} -60:60:9") from None
    if not 2 <= count <= MAX_SWEEP:
        raise ConfigError(f"{param('sweep')} needs 2 to {MAX_SWEEP} eye positions, got {count}; e.g. {param('sweep')} -60:60:9")
    return axis, start, stop, count


def replay_file(h3d_path: str | Path, output: str | Path, *, eye: tuple[float, float, float] | None = None,
                optics: str = "pinhole", size: str | tuple[int, int] = "lenses",
                sweep: tuple[str, float, float, int] | None = None, json_path: str | Path | None = None,
                quality: str = "draft", ior: float | None = None, lenslet: str = "spherical",
                pupil: float | None = None) -> dict[str, Any]:
    """Replay ``h3d_path`` from ``eye`` (or a sweep of eyes) and write ``output`` with its sidecar.

    With ``sweep``, ``output`` is a ``.gif`` and the frames go beside it as ``stem_NNN.png``."""
    if optics not in OPTICS:
        raise ConfigError(f"{param('optics')} must be one of {', '.join(OPTICS)}, got {optics!r}")
    if pupil is not None and optics != "lens":
        raise ConfigError(f"{param('pupil')} blurs the real lenslets' picture (a POV-Ray focal blur); add {param('optics')} lens")
    output = Path(output)
    if sweep is None:
        out = png_output(output)
    else:
        if output.suffix.lower() not in (".gif", ".mp4"):
            raise ConfigError(f"a sweep's output {str(output)!r} must be a .gif or .mp4 (its frames go beside it "
                              "as PNGs)")
        from ..image.video import check_video_path

        check_video_path(output)
        check_writable(output)
        out = output
    if json_path is not None:
        check_writable(json_path)
    image, display = read_display(h3d_path)
    la = display.lens_array
    if not isinstance(size, str):  # the picture's float geometry, a few arrays of it
        check_memory(f"a {size[0]}x{size[1]} replay", 160.0 * size[0] * size[1] * (1 if sweep is None else 2),
                     f"give a smaller {param('size')}, e.g. {param('size')} 800x600")
    eye = eye if eye is not None else default_eye(la)
    eyes = np.asarray([eye], np.float64) if sweep is None else sweep_eyes(eye, *sweep)
    results: list[Replay] = []
    frames: list[np.ndarray] = []
    timings: dict[str, Any] = {}
    reports: list[dict[str, Any]] = []
    sheet = mapped(display, image, h3d_path)
    if sheet is not None:  # a mapped panel, subpixel by subpixel through the sheet its mapping addresses
        if optics not in ("pinhole", "barrier"):
            raise ConfigError(f"a mapped panel is replayed through its sheet's slits ({param('optics')} pinhole or barrier), "
                              f"not {param('optics')} {optics} (not built yet)")
        _, la, shift, views = sheet
        for e in eyes:
            results.append(replay(image, la, e, optics="barrier", size=size, shift=shift, subpixels=True))
        reports = [mapped_report(r, la, shift, views, e) for r, e in zip(results, eyes)]
        frames = [r.image for r in results]
    elif optics == "lens":
        from ..renderer.replay import REPLAY_IOR, render_replay  # only the renderer starts POV-Ray

        frames, timings = render_replay(image, la, eyes, size=size, quality=quality, coded=json_path is not None,
                                        ior=REPLAY_IOR if ior is None else ior, shape=lenslet, pupil=pupil)
        if json_path is not None:  # the chief rays' report, and where each aperture's light comes from
            codes, frames = frames[len(eyes):], frames[:len(eyes)]
            reports = [report(replay(image, la, e, size=size), la, e) for e in eyes]
            for rep, e, code, frame in zip(reports, eyes, codes, frames):
                rep["light_shares"] = light_shares(code, la, e, size)
                rep["psnr_to_pinhole_db"] = psnr(frame, replay(image, la, e, size=size).image[..., :3])
    else:
        for e in eyes:  # every eye checked before anything is written
            results.append(replay(image, la, e, optics=optics, size=size))
        frames = [r.image for r in results]
        if optics != "none":
            reports = [report(r, la, e) for r, e in zip(results, eyes)]
    record = base_record("replay", la, source=str(Path(h3d_path).resolve()), optics=optics,
                         size=size if isinstance(size, str) else list(size),
                         eyes_mm=eyes.tolist(), output_gamma=(read_sidecar(h3d_path) or {}).get("output_gamma", "sRGB"),
                         **({"timings_s": timings} if timings else {}),
                         **({"reports": [{k: v for k, v in r.items() if k != "view_of_lens"} for r in reports]}
                            if reports else {}))  # the per-lens views: in --json's report only
    if sweep is None:
        write_image(out, frames[0], record)
    else:
        _write_sweep(out, frames, record)
    if json_path is not None:
        with atomic_path(json_path) as tmp:
            tmp.write_text(json.dumps({"eyes": reports, **({"timings_s": timings} if timings else {})}, indent=2)
                           + "\n", encoding="utf-8")
    return record


def _write_sweep(output: Path, frames: list[np.ndarray], record: dict[str, Any]) -> None:
    from ..image.preview import enlarge
    from ..image.video import to_rgb8, write_video

    for n, frame in enumerate(frames):
        write_png(output.with_name(f"{output.stem}_{n:03d}.png"), frame)
    small = [to_rgb8(f) for f in frames]
    scale = max(1, 480 // max(small[0].shape[1], 1))  # lens-sized pixels, about 480 across
    write_video([enlarge(f, (scale, scale)) for f in small], output, fps=8.0)
    with atomic_path(output.with_suffix(".json")) as tmp:
        tmp.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")

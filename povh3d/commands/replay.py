"""``povh3d replay``: an H3D image on its display, seen from an eye (``display/replay.py``), on files.

Reads the image and the lens array its sidecar describes, checks every input, then writes the
replay (or a sweep's frames and GIF) and its sidecar atomically.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..display.display import Display
from ..display.replay import (OPTICS, Replay, aperture_views, default_eye, label_centre_offset, light_shares,
                              mapped_report, mapped_sheet, psnr, replay, report, sheet_slots, sweep_eyes)
from ..errors import ConfigError, InputError, warn, param
from ..image.io import atomic_path, check_output, check_writable, read_png, read_sidecar_record, write_png
from ..image.sidecar import Sidecar
from ..renderer.budget import check_memory
from ..renderer.records import base_record, png_output, write_image
from .images import check_against_sidecar

MAX_SWEEP = 240


def read_display(h3d_path: str | Path) -> tuple[np.ndarray, Display]:
    """The H3D image and the display its sidecar describes; one error line when there is none."""
    record = read_sidecar_record(h3d_path)
    if not Path(h3d_path).is_file():
        raise InputError(f"image {str(h3d_path)!r} does not exist; check the path")
    if record is None or record.lens_array is None:
        raise InputError(f"{str(h3d_path)!r} has no sidecar with its lens array ({Path(h3d_path).stem}.json); "
                         "replay an image povh3d rendered, with its sidecar beside it")
    display = Display.from_record(record.to_json())
    if display.physical_panel is None:
        check_against_sidecar(h3d_path, record.lens_array.to_json())
    return read_png(h3d_path), display


@dataclass(frozen=True)
class DeviceImage:
    """A Looking Glass panel image to replay: the unit's calibration, the device, and the native image
    (given, or made from a quilt with the vendor's shader)."""

    calibration: Any
    device: Any
    image: np.ndarray
    source: str  # "native" or "quilt"


def device_image(h3d_path: str | Path) -> DeviceImage | None:
    """A Looking Glass native image (sidecar ``mapping: looking-glass-shader``) or a device quilt (sidecar
    ``kind: quilt`` whose source render names the device), else None; one error line for a quilt whose
    device is unknown."""
    from ..display.looking_glass import device, device_of, read_visual
    from ..display.quilt import device_calibration

    record = read_sidecar_record(h3d_path)
    if not Path(h3d_path).is_file():
        raise InputError(f"image {str(h3d_path)!r} does not exist; check the path")
    if record is None:
        return None
    calibration, source_path = record.get("calibration"), record.get("source")
    if record.mapping == "looking-glass-shader":
        if not isinstance(calibration, str) or not calibration:
            raise InputError(f"{str(h3d_path)!r} is a Looking Glass native image whose sidecar names no calibration; "
                             f"render it again with {param('calibration')} visual.json")
        cal = read_visual(calibration)
        device_name = record.get("device")
        dev = device(device_name) if isinstance(device_name, str) and device_name else device_of(cal)  # the 27": named, no table entry
        if dev is None:
            raise ConfigError(f"the calibration {calibration!r} is of no Looking Glass model povh3d knows; "
                              "give the unit's own visual.json")
        image = read_png(h3d_path)
        if image.shape[:2] != (cal.screen_h, cal.screen_w):
            raise InputError(f"{str(h3d_path)!r} is {image.shape[1]}x{image.shape[0]}, not the {cal.screen_w}x"
                             f"{cal.screen_h} panel of its calibration; render it again")
        return DeviceImage(cal, dev, image, "native")
    if record.kind != "quilt":
        return None
    source = read_sidecar_record(source_path) if isinstance(source_path, str) and Path(source_path).is_file() else None
    spec: Any = ((source.display if source is not None else None) or {}).get("quilt") or {}
    if not spec.get("device"):
        raise ConfigError(f"{str(h3d_path)!r} is a quilt without its Looking Glass device (its source render's "
                          f"sidecar names none); replay the quilt a render with {param('preset')} looking-glass-... wrote")
    dev = device(spec["device"])
    if dev.calibration is None and not spec.get("calibration"):   # the 27": no factory sheet to replay through
        raise ConfigError(f"{str(h3d_path)!r} is a quilt of the {dev.vendor_name}, which has no public factory "
                          f"calibration, so its replay needs the unit's; render it again with {param('calibration')} visual.json")
    cal = device_calibration(dev, spec.get("calibration"))
    from ..display.mappings.looking_glass_shader import quilt_to_native

    quilt = read_png(h3d_path)
    if quilt.shape[:2] != (dev.quilt_size[1], dev.quilt_size[0]):
        raise InputError(f"{str(h3d_path)!r} is {quilt.shape[1]}x{quilt.shape[0]}, not the {dev.quilt_size[0]}x"
                         f"{dev.quilt_size[1]} quilt of {dev.name}; replay the quilt its render wrote")
    return DeviceImage(cal, dev, quilt_to_native(quilt, dev.grid, cal, views=dev.views), "quilt")


def replay_device(dev_image: DeviceImage, eyes: np.ndarray, optics: str, size: Any, with_report: bool,
                  lens: dict[str, Any] | None = None) -> tuple[list[np.ndarray], list[dict[str, Any]], dict[str, Any]]:
    """Replay a Looking Glass panel image through the device's sheet (``display/replay.device_sheet``,
    converging at the vendor's viewer distance): the frames, the per-eye reports and the sidecar's
    ``device`` entry.  ``optics`` lens: through its real lenticules (``render_replay``'s options ``lens``),
    the panel as its subpixel stripes; with a report, each eye's lenses also compared with the slits'."""
    from ..display import presets
    from ..display.mappings.looking_glass_shader import view_fractions
    from ..display.quilt import default_viewing_distance, sheet_focal
    from ..display.replay import device_report, device_sheet, device_slots_at

    if optics not in ("pinhole", "barrier", "lens"):
        raise ConfigError(f"a Looking Glass panel is replayed through its sheet ({param('optics')} pinhole, barrier or lens), "
                          f"not {param('optics')} {optics}")
    cal, dev = dev_image.calibration, dev_image.device
    focal = presets.lens_array(dev.name).focal if dev.calibration is not None else sheet_focal(cal)
    distance = default_viewing_distance(cal.size_mm[1])
    lens_sheet, lens_shift, _, _ = device_sheet(cal, focal, distance)
    labels = np.minimum((view_fractions(cal) * dev.views).astype(np.int64), dev.views - 1)
    timings: dict[str, Any] = {}
    if optics == "lens":
        frames, timings, compared = _through_lenses(dev_image.image, lens_sheet, lens_shift, eyes, size, lens or {},
                                                    labels, dev.views, lambda p: device_slots_at(cal, p, dev.views),
                                                    7, with_report)
    else:
        frames = [replay(dev_image.image, lens_sheet, e, optics="barrier", size=size, shift=lens_shift,
                         subpixels=True).image for e in eyes]
        compared = []
    reports: list[dict[str, Any]] = []
    if with_report:
        for n, e in enumerate(eyes):
            rep = {"aperture": device_report(cal, labels, e, dev.views, focal, distance, cal.view_cone),
                   "aperture_7_rows": device_report(cal, labels, e, dev.views, focal, distance, cal.view_cone,
                                                    rows=7)}
            if compared:
                rep["lenses_against_slits"] = compared[n]
            reports.append(rep)
    entry = {"device": dev.name, "from": dev_image.source, "focal_mm": focal, "sheet_converges_at_mm": distance,
             "lens_pitch_mm": lens_sheet.pitch_x, "slant_deg": lens_sheet.rotation,
             **({"timings_s": timings} if timings else {})}
    return frames, reports, entry


def _through_lenses(image: np.ndarray, sheet: Any, shift: float, eyes: np.ndarray, size: Any, lens: dict[str, Any],
                    labels: np.ndarray, views: int, slots: Any, rows: int, compare: bool
                    ) -> tuple[list[np.ndarray], dict[str, Any], list[dict[str, Any]]]:
    """A subpixel panel through its real slanted lenticules (``render_replay``, the panel as its R, G, B
    stripes): the frames, the timings, and with ``compare`` per eye the view each lens shows through the
    lenticules against the slits' (``lens_picture_agreement``: a row, and ``rows`` rows), from a second
    picture of the panel whose subpixels code their views (``view_codes(labels)``)."""
    from ..display.replay import decode_views, lens_picture_agreement, view_codes
    from ..renderer.replay import REPLAY_IOR, render_replay  # only the renderer starts POV-Ray

    codes = view_codes(labels)
    ior = lens.get("ior")
    frames, timings = render_replay(image, sheet, eyes, size=size, quality=lens.get("quality", "draft"),
                                    ior=REPLAY_IOR if ior is None else ior, shape=lens.get("shape", "spherical"),
                                    pupil=lens.get("pupil"), shift=shift, subpixels=True, coded=compare, codes=codes)
    compared = []
    if compare:
        pictures, frames = frames[len(eyes):], frames[:len(eyes)]
        for e, picture in zip(eyes, pictures):
            slit = replay(codes, sheet, e, optics="barrier", size=size, shift=shift, subpixels=True)
            seen = decode_views(picture)
            compared.append({"a_row": lens_picture_agreement(seen, slit, views, slots, sheet=(sheet, shift)),
                             "3d_pixel": lens_picture_agreement(seen, slit, views, slots, rows)})
    return frames, timings, compared


def mapped(display: Display, image: np.ndarray, h3d_path: str | Path) -> tuple[Any, Any, float, np.ndarray] | None:
    """A mapped panel's sheet: ``(mapping, sheet, shift, views)`` (``display/replay.mapped_sheet``), or None for
    an H3D image; one error line for a mapping whose sheet povh3d cannot rebuild."""
    if display.physical_panel is None:
        return None
    panel = display.physical_panel
    if image.shape[:2] != (panel.height, panel.width):
        raise InputError(f"{str(h3d_path)!r} is {image.shape[1]}x{image.shape[0]} but its sidecar describes a "
                         f"{panel.width}x{panel.height} panel; render it again or delete the sidecar")
    if display.mapping_name is None:
        raise ConfigError(f"{str(h3d_path)!r} is a mapped panel whose sidecar names no mapping; replay needs it "
                          "to rebuild the sheet: render it again")
    mapping, focal = sidecar_mapping(display, h3d_path)
    try:
        sheet, shift, views = mapped_sheet(mapping, panel, focal)
    except ConfigError:
        raise ConfigError(f"mapping {display.mapping_name!r} is not a slanted subpixel sheet; replay rebuilds "
                          "those only (alioscopy, philips)") from None
    return mapping, sheet, shift, views


def sidecar_mapping(display: Display, h3d_path: str | Path) -> tuple[Any, float]:
    """The mapping the panel was written with and the sheet's focal length: from the sidecar's
    ``mapping_options`` (every parameter), or, for a sidecar older than those, the preset's default
    mapping of that name, with a warning naming it."""
    from ..display.display import build_display
    from ..display.mappings import mapping_from_record

    panel = display.physical_panel
    if display.mapping_options is not None and display.mapping_name is not None and panel is not None:
        mapping = mapping_from_record(display.mapping_name, dict(display.mapping_options))
        if mapping.render_array(panel, display.lens_array.focal) != display.lens_array:
            raise ConfigError(f"the sidecar's mapping options do not read its lens array ({str(h3d_path)!r}); "
                              "render the image again")
        return mapping, display.lens_array.focal
    if display.preset is None:
        raise ConfigError(f"{str(h3d_path)!r} is a mapped panel whose sidecar records neither the mapping's options "
                          "nor a preset; render it again")
    built = build_display(display.preset, mapping=display.mapping_name)
    if built.mapping is None or built.mapped_panel != panel:
        raise ConfigError(f"the sidecar's panel is not preset {display.preset!r}'s with mapping "
                          f"{display.mapping_name!r}; replay needs that preset's own mapping")
    warn(f"{str(h3d_path)!r}'s sidecar records mapping {display.mapping_name!r} without its options (an older "
         f"render): replaying preset {display.preset!r}'s default {built.mapping.name!r} "
         f"({mapping_summary(built.mapping)}); render it again if it used other options")
    return built.mapping, built.lens_array.focal


def mapping_summary(mapping: Any) -> str:
    from ..display.mappings import mapping_parameters

    return ", ".join(f"{k} {v}" for k, v in mapping_parameters(mapping).items() if k not in ("kind", "name"))


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
        check_output(output.with_suffix(".html"), (h3d_path,), what="sweep's viewer page", sidecar=False)
        out = output
    if json_path is not None:
        check_writable(json_path)
    dev_image = device_image(h3d_path)
    if dev_image is not None:  # a Looking Glass native image or quilt, through the device's sheet
        return _replay_device_file(dev_image, h3d_path, out, eye, optics, size, sweep, json_path,
                                   {"quality": quality, "ior": ior, "shape": lenslet, "pupil": pupil})
    image, display = read_display(h3d_path)
    la = display.lens_array
    if not isinstance(size, str):  # the picture's float geometry, a few arrays of it
        check_memory(f"a {size[0]}x{size[1]} replay", 160.0 * size[0] * size[1] * (1 if sweep is None else 2),
                     f"give a smaller {param('size')}, e.g. {param('size')} 800x600")
    eye = eye if eye is not None else default_eye(la, display.viewing_distance_mm)   # where its rows are seen from
    eyes = np.asarray([eye], np.float64) if sweep is None else sweep_eyes(eye, *sweep)
    results: list[Replay] = []
    frames: list[np.ndarray] = []
    timings: dict[str, Any] = {}
    reports: list[dict[str, Any]] = []
    sheet = mapped(display, image, h3d_path)
    if sheet is not None:  # a mapped panel, subpixel by subpixel through the sheet its mapping addresses
        if optics not in ("pinhole", "barrier", "lens"):
            raise ConfigError(f"a mapped panel is replayed through its sheet ({param('optics')} pinhole, barrier or lens), "
                              f"not {param('optics')} {optics}")
        mapping, la, shift, views = sheet
        for e in eyes:
            results.append(replay(image, la, e, optics="barrier", size=size, shift=shift, subpixels=True))
        reports = [mapped_report(r, la, shift, views, e) for r, e in zip(results, eyes)]
        n, offset = mapping.views, label_centre_offset(la, shift, views, mapping.views)
        for rep, e in zip(reports, eyes):  # the view each lens shows over its aperture: a row, a 3D pixel
            rep["aperture"] = aperture_views(la, shift, views, e, n, offset=offset)
            rep["aperture_3d_pixel"] = aperture_views(la, shift, views, e, n, offset=offset,
                                                      rows=mapping.rows_per_view)
        frames = [r.image for r in results]
        if optics == "lens":
            frames, timings, compared = _through_lenses(
                image, la, shift, eyes, size, {"quality": quality, "ior": ior, "shape": lenslet, "pupil": pupil}, views, n,
                sheet_slots(la, shift, offset, n), mapping.rows_per_view, json_path is not None)
            for rep, c in zip(reports, compared):
                rep["lenses_against_slits"] = c
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
                         eyes_mm=eyes.tolist(), output_gamma=_output_gamma(h3d_path),
                         **({"timings_s": timings} if timings else {}),
                         **({"reports": [{k: v for k, v in r.items() if k != "view_of_lens"} for r in reports]}
                            if reports else {}))  # the per-lens views: in --json's report only
    _write_replay(out, frames, record, sweep, json_path,
                  {"eyes": reports, **({"timings_s": timings} if timings else {})})
    return record.to_json()


def _replay_device_file(dev_image: DeviceImage, h3d_path: str | Path, out: Path, eye: Any, optics: str, size: Any,
                        sweep: Any, json_path: str | Path | None, lens: dict[str, Any]) -> dict[str, Any]:
    from ..display.quilt import default_viewing_distance

    if not isinstance(size, str):
        check_memory(f"a {size[0]}x{size[1]} replay", 160.0 * size[0] * size[1], f"give a smaller {param('size')}, e.g. {param('size')} 800x600")
    eye = eye if eye is not None else (0.0, 0.0, -default_viewing_distance(dev_image.calibration.size_mm[1]))
    eyes = np.asarray([eye], np.float64) if sweep is None else sweep_eyes(eye, *sweep)
    frames, reports, entry = replay_device(dev_image, eyes, optics, size, with_report=True, lens=lens)
    record = base_record("replay", source=str(Path(h3d_path).resolve()), optics=optics,
                         size=size if isinstance(size, str) else list(size), eyes_mm=eyes.tolist(),
                         device=entry, reports=reports)
    _write_replay(out, frames, record, sweep, json_path, {"eyes": reports, "device": entry})
    return record.to_json()


def _output_gamma(h3d_path: str | Path) -> str:
    side = read_sidecar_record(h3d_path)
    return side.output_gamma if side is not None and side.output_gamma is not None else "sRGB"


def _write_replay(out: Path, frames: list[np.ndarray], record: Sidecar, sweep: Any,
                  json_path: str | Path | None, report: dict[str, Any]) -> None:
    """The replay (or the sweep's frames, film and page) with its sidecar, and the ``--json`` report."""
    if sweep is None:
        write_image(out, frames[0], record)
    else:
        _write_sweep(out, frames, record.to_json(), sweep[0])
    if json_path is not None:
        with atomic_path(json_path) as tmp:
            tmp.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")


def _write_sweep(output: Path, frames: list[np.ndarray], record: dict[str, Any], axis: str = "x") -> None:
    """The sweep's frames (``stem_NNN.png``), its GIF or MP4, its sidecar, and its viewer page
    (``stem.html``, ``hyper/page.py``'s: frame ``n`` is view column ``n`` of one row for a sweep along
    x, view row ``n`` of one column along y, so the mouse moves the eye the way it moves)."""
    from ..hyper.page import ViewerContent, viewer_html
    from ..image.preview import enlarge
    from ..image.video import to_rgb8, write_video

    for n, frame in enumerate(frames):
        write_png(output.with_name(f"{output.stem}_{n:03d}.png"), frame)
    small = [to_rgb8(f) for f in frames]
    scale = max(1, 480 // max(small[0].shape[1], 1))  # lens-sized pixels, about 480 across
    big = [enlarge(f, (scale, scale)) for f in small]
    write_video(big, output, fps=8.0)
    stack = np.stack(big)[None] if axis == "x" else np.stack(big)[:, None]
    eyes = record["eyes_mm"]
    title = (f"povh3d replay: {Path(record['source']).name}, eye {axis} from {eyes[0][0 if axis == 'x' else 1]:g} "
             f"to {eyes[-1][0 if axis == 'x' else 1]:g} mm at z = {eyes[0][2]:g} mm")
    with atomic_path(output.with_suffix(".html")) as tmp:
        tmp.write_text(viewer_html(ViewerContent((stack,), grid="lenticular" if axis == "x" else "square",
                                                 fps=8.0, title=title)), encoding="utf-8")
    with atomic_path(output.with_suffix(".json")) as tmp:
        tmp.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")

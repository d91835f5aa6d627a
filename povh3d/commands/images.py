"""Display preparation on files: map, refocus, preview (quilts: ``commands/quilt.py``; resample:
``commands/resample.py``).

Each function reads PNGs, calls the pure NumPy modules (``mappings``,
``resample``, ``quilt``, ``refocus``, ``preview``) and writes its outputs
atomically, each image with a JSON sidecar.  Every input is checked before
anything is written.
"""

from __future__ import annotations

from collections.abc import Mapping as MappingABC
from pathlib import Path
from typing import Any, cast

import numpy as np

from PIL import Image

from ..errors import ConfigError, InputError, Povh3dError, param, raw_message
from ..renderer.budget import MAX_PLANES, MAX_PREVIEW_FRAMES, check_count, check_memory
from ..geometry.axes import from_edge, to_edge
from ..geometry.lens_array import _positive as positive_length  # the lens array's own rule
from ..image.io import (atomic_path, check_output, read_png, read_sidecar_record, with_sidecar,
                        write_png,
                        write_sidecar)
from ..renderer.records import base_record, png_output, write_image
from ..image.interleave import extract
from ..display.mappings import Mapping
from ..display.mappings.sampling import Source
from ..image.refocus import bank_steps, contact_sheet, gradient_energy, lens_steps, shift_and_add
from ..image.colour import from_linear, to_linear


# -- lens geometry of an input image -----------------------------------------------------------------
def lens_info(h3d_path: str | Path, ppl: tuple[int, int] | None, focal: float | None,
              pixel_pitch: float | None, *, resampled: bool = False) -> dict[str, Any]:
    """Pixels per lens ``(Ny, Nx)``, focal and pixel pitch (mm): options first, then the sidecar.

    ``resampled``: the caller reads views as ``extract`` does, so a sidecar's array without a
    camera bank (hex, fractional PPL) is taken, as ``lens_array`` with its view grid as ``ppl``;
    otherwise such an array is one error line saying why."""
    side = lens_record(h3d_path)
    check_against_sidecar(h3d_path, side)
    if ppl is not None and side.get("views") and list(side["views"]) != to_edge(ppl):
        raise ConfigError(f"{param('ppl')} {ppl[1]}x{ppl[0]} contradicts the sidecar of {str(h3d_path)!r}, whose lens array "
                          f"has {side['views'][0]}x{side['views'][1]} pixels per lens; leave {param('ppl')} out")
    if ppl is None and side.get("views"):
        ppl = from_edge([int(v) for v in side["views"]])
    if side and not side.get("views"):  # hex, fractional PPL: each lens resampled, as extract does
        if resampled:
            return _resampled_info(h3d_path, side, ppl, focal, pixel_pitch)
        if ppl is None:
            from ..display.display import Display

            Display.from_record({"lens_array": side}).lens_array.require_views()
    if ppl is None:
        raise ConfigError(f"the pixels per lens are unknown (no sidecar); give them with {param('ppl')}, e.g. {param('ppl')} 8")
    for value, name, flag in ((focal, "focal length", f"{param('focal')} 1.5"), (pixel_pitch, "pixel pitch", f"{param('pixel_pitch')} 0.1")):
        if value is not None:  # --focal 0 divided by zero in refocus (an internal error)
            positive_length(f"the {name}", value, f"give it in mm, e.g. {flag}")
    focal = focal if focal is not None else side.get("focal_mm")
    if pixel_pitch is None and side.get("panel"):
        pixel_pitch = side["panel"]["pixel_pitch_mm"][0]
    return {"ppl": ppl, "focal": focal, "pixel_pitch": pixel_pitch,
            "pixel_pitch_y": (side.get("panel") or {}).get("pixel_pitch_mm", [None, pixel_pitch])[1] or pixel_pitch}


def _resampled_info(h3d_path: str | Path, side: dict[str, Any], ppl: tuple[int, int] | None,
                    focal: float | None, pixel_pitch: float | None) -> dict[str, Any]:
    """``lens_info`` of an image whose sidecar's array has no camera bank: the array itself, whose
    views ``extract`` resamples lens by lens; ``--focal`` may replace its focal length."""
    from dataclasses import replace

    from ..image.elemental import view_grid
    from ..display.display import Display

    la = Display.from_record({"lens_array": side}).lens_array
    what = f"{la.grid} lens array" if la.grid != "square" else f"{la.ppl_x:g} x {la.ppl_y:g} pixels per lens"
    if ppl is not None:
        raise ConfigError(f"{param('ppl')} contradicts the sidecar of {str(h3d_path)!r} ({what}, whose views are resampled "
                          f"lens by lens); leave {param('ppl')} out")
    if pixel_pitch is not None and not np.isclose(pixel_pitch, la.panel.pitch_x, rtol=1e-9):
        raise ConfigError(f"{param('pixel_pitch')} {pixel_pitch:g} contradicts the sidecar of {str(h3d_path)!r} "
                          f"({la.panel.pitch_x:g} mm); leave {param('pixel_pitch')} out")
    la = replace(la, focal=focal) if focal is not None else la
    return {"ppl": view_grid(la), "focal": la.focal, "pixel_pitch": la.panel.pitch_x,
            "pixel_pitch_y": la.panel.pitch_y, "lens_array": la}


def lens_record(path: str | Path, key: str = "lens_array") -> dict[str, Any]:
    """The sidecar's lens array entry (``{}`` without one), checked whole by ``Display.from_record``:
    a damaged or forged one is one ``ConfigError`` here, not a crash in the work that reads it."""
    from ..display.display import Display

    record = read_sidecar_record(path)
    side = record.get(key) if record is not None else None
    if side is None or side == {}:
        return {}
    Display.from_record({"lens_array": side})
    return dict(side) if isinstance(side, MappingABC) else {}


def check_against_sidecar(path: str | Path, lens_array: dict[str, Any]) -> None:
    """Refuse an image whose size is not the panel its sidecar's lens array describes."""
    size = (lens_array.get("panel") or {}).get("size_px")
    if not size:
        return
    try:
        Image.MAX_IMAGE_PIXELS = None   # the size only: read_png bounds the memory (image.io.check_png_memory)
        with Image.open(path) as im:
            width, height = im.size
    except Exception:  # noqa: BLE001 - not an image: read_png says so, with its own message
        return
    if [width, height] != list(size):
        raise InputError(f"{str(path)!r} is {width}x{height} but its sidecar describes a {size[0]}x{size[1]} "
                         "panel: the image was changed after its sidecar; render it again or delete the sidecar")


def is_lenticular(path: str | Path) -> bool:
    """Whether the sidecar of ``path`` describes a lenticular (horizontal-only) lens array."""
    try:
        side = lens_record(path)
    except Povh3dError:
        return False
    return side.get("grid") == "lenticular"


def read_whole_lenses(path: str | Path) -> np.ndarray:
    """An H3D PNG cut to the lenses its sidecar's lens array holds: a lenticular array of
    341 lenses of 6 px is centred on a 2048 px panel (``ipad-retina``), so 1 px either side
    is no lens's; ``extract`` reads the same region.  Without a sidecar, the whole image."""
    image = read_png(path)
    record = read_sidecar_record(path)
    if record is None or record.lens_array is None:
        return image
    from ..renderer.outputs.views import sidecar_array

    lens_array = sidecar_array(image, path, record)
    return image[lens_array.bank_region] if lens_array.views is not None else image


def _need(value: Any, what: str, flag: str) -> Any:
    if value is None:
        raise ConfigError(f"the {what} is unknown (no sidecar); give it with {flag}")
    return value


# -- map ---------------------------------------------------------------------------------------------
def infer_panel(mapping: Mapping, shape: tuple[int, int]) -> tuple[int, int] | None:
    """The panel ``(W, H)`` whose mapping reads a view-space image of ``shape`` (rows, cols), if one does."""
    lens_px, _, row_px = mapping.view_pitch((1.0, 1.0))
    rows, cols = shape
    guesses = []
    for views in range(1, cols + 1):
        if cols % views:
            continue
        lenses = cols // views
        w = round(lenses * lens_px)
        h = round(rows * row_px)
        guesses += [(w + dw, h + dh) for dw in (0, 1, -1, 2) for dh in range(0, max(1, round(row_px)))]
    for w, h in guesses:
        if w < 1 or h < 1:
            continue
        try:
            src: Source = mapping.source((w, h))
        except ConfigError:
            continue
        if src.shape[:2] == (rows, cols):
            return (w, h)
    return None


def map_file(input_path: str | Path, mapping: Mapping, output: str | Path,
             panel: tuple[int, int] | None = None) -> dict[str, Any]:
    """Map an unmapped view-space H3D PNG onto a panel and write ``output`` with its sidecar."""
    out = png_output(output, inputs=with_sidecar(input_path))
    image = read_png(input_path)
    side = lens_record(input_path)
    if side.get("grid") not in (None, "lenticular"):
        views = "x".join(map(str, side.get("views") or [])) or "its"
        raise ConfigError(f"{str(input_path)!r} is a {side['grid']} H3D image ({views} views); a mapping reads an "
                          "unmapped lenticular image (one row of views): render with the display's preset or "
                          f"{param('mapping')} instead")
    record = read_sidecar_record(input_path)
    display = record.display if record is not None else None
    recorded: Any = (display.get("physical_panel") if display is not None else None) or {}
    if recorded.get("size_px"):   # the render's own panel: a guess from the image's size may be another
        # cast: the panel's size_px, as povh3d wrote it: W, H
        size = cast(tuple[int, int], tuple(int(v) for v in recorded["size_px"]))
        if panel is not None and tuple(panel) != size:
            raise ConfigError(f"{param('panel_size')} {panel[0]}x{panel[1]} is not the {size[0]}x{size[1]} panel "
                              f"{str(input_path)!r} was rendered for (its sidecar); drop {param('panel_size')}")
        panel = size
    if panel is None:
        panel = infer_panel(mapping, image.shape[:2])
        if panel is None:
            raise ConfigError(f"no panel size fits a {image.shape[1]}x{image.shape[0]} image under mapping "
                              f"{mapping.name!r}; give it with {param('panel_size')} WxH")
    src = mapping.source(panel)
    if side.get("views") and side["views"][0] != src.views:
        raise ConfigError(f"{str(input_path)!r} has {side['views'][0]} views per lens but mapping {mapping.name!r} "
                          f"reads {src.views}; check {param('mapping')} and its options")
    mapped = mapping.apply(image, panel)  # raises before anything is written
    record = base_record("panel", mapping=mapping.name, mapping_parameters=_params(mapping),
                     source=str(Path(input_path).resolve()), size_px=list(panel), output_gamma="sRGB")
    write_image(out, mapped, record)
    return record.to_json()


def _params(mapping: Mapping) -> dict[str, Any]:
    return {k: v for k, v in vars(mapping).items() if isinstance(v, (int, float, str, bool))}


# -- quilts ------------------------------------------------------------------------------------------
def _refocus_views(h3d: np.ndarray, info: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The views, each view's shift in lenses per mm of depth (``refocus.lens_steps``), the views
    to sum and the odd rows' offset: from the sidecar's array when its views are resampled (hex,
    fractional PPL, as ``extract``), else from the pixels per lens of the camera bank."""
    la = info.get("lens_array")
    if la is not None:
        from ..renderer.outputs.views import sidecar_bank

        views = sidecar_bank(h3d[..., :3], la)
        steps, used, row_shift = lens_steps(la, views.shape[:2])
        return views, steps, used, row_shift
    ny, nx = info["ppl"]
    focal = _need(info["focal"], "focal length", param("focal"))
    sx = _need(info["pixel_pitch"], "pixel pitch", param("pixel_pitch"))
    sy = info["pixel_pitch_y"] or sx
    try:
        views = extract(h3d[..., :3], (ny, nx))
    except ValueError as exc:
        raise ConfigError(raw_message(exc)) from None
    u = (np.arange(nx) + 0.5 - nx / 2) * sx
    v = (ny / 2 - np.arange(ny) - 0.5) * sy
    return views, bank_steps((u, v), (nx * sx, ny * sy), focal), np.ones((ny, nx), bool), 0.0


def refocus_file(h3d_path: str | Path, output: str | Path, info: dict[str, Any], *,
                 depth: float | None = None, sweep: tuple[float, float, int] | None = None) -> dict[str, Any]:
    """Refocus at ``depth`` mm, or at ``sweep = (near, far, count)`` depths with a contact sheet.

    A sweep writes ``output`` as the contact sheet and ``stem_NNN.png`` per plane beside it.
    """
    if sweep is not None:
        check_count(f"{param('sweep')} (planes)", int(sweep[2]), MAX_PLANES, "a sweep finds the sharpest depth in far fewer")
    reads = with_sidecar(h3d_path)
    out = png_output(output, inputs=reads)
    count = 1 if sweep is None else int(sweep[2])
    for n in range(count if sweep is not None else 0):   # the planes beside the sheet
        check_output(out.with_name(f"{out.stem}_{n:03d}.png"), reads, sidecar=False)
    image = read_whole_lenses(h3d_path)
    views, steps, used, row_shift = _refocus_views(image, info)
    plane = views.shape[2] * views.shape[3] * views.shape[4]
    check_memory(f"{count} refocused plane(s)", (count * 3 * 4 + 4 * views.shape[0] * views.shape[1]) * plane,
                 f"give fewer planes ({param('sweep')})")
    lin = to_linear(views, np.float32)
    if sweep is not None:
        depths = list(np.linspace(sweep[0], sweep[1], int(sweep[2])))
    elif depth is not None:
        depths = [float(depth)]
    else:  # (was a TypeError from float(None))
        raise ConfigError("refocus needs a depth (mm) or a sweep (near, far, count); give one")
    if not depths or (sweep is not None and int(sweep[2]) < 2):
        raise ConfigError(f"{param('sweep')} needs at least 2 planes")
    planes = [shift_and_add(lin, steps * d, row_shift=row_shift, used=used) for d in depths]
    energy = [gradient_energy(p) for p in planes]
    record = base_record("refocus", source=str(Path(h3d_path).resolve()), depths_mm=depths,
                     gradient_energy=energy, output_gamma="sRGB")
    encoded = [from_linear(p, image.dtype) for p in planes]
    if sweep is None:
        write_image(out, encoded[0], record)
    else:
        for n, img in enumerate(encoded):
            write_png(out.with_name(f"{out.stem}_{n:03d}.png"), img)
        record = record.with_(sharpest_depth_mm=depths[int(np.argmax(energy))])
        write_image(out, contact_sheet(encoded), record)
    return record.to_json()


# -- preview ---------------------------------------------------------------------------------------
def preview_file(h3d_path: str | Path, output: str | Path, info: dict[str, Any], *, frames: int = 12,
                 scale: int | None = None, duration_ms: int = 120) -> dict[str, Any]:
    """Write ``output`` (.gif) sweeping the viewing angle, and ``stem.png``, its contact sheet."""
    from PIL import Image

    from ..image.preview import bank_frames, enlarge, preview_frames, viewer_angles

    output = Path(output)
    if output.suffix.lower() != ".gif":
        raise ConfigError(f"the preview {str(output)!r} must be a .gif file")
    sheet_path = output.with_suffix(".png")
    reads = with_sidecar(h3d_path)
    check_output(output, reads, what="preview", sidecar=False)
    check_output(sheet_path, reads, what="contact sheet")   # and the sidecar both share
    image = read_whole_lenses(h3d_path)
    ny, nx = info["ppl"]
    focal = _need(info["focal"], "focal length", param("focal"))
    sx = _need(info["pixel_pitch"], "pixel pitch", param("pixel_pitch"))
    if info.get("lens_array") is None and (image.shape[0] % ny or image.shape[1] % nx):
        raise ConfigError(f"a {image.shape[1]}x{image.shape[0]} image does not hold whole lenses of "
                          f"{nx}x{ny} pixels; check {param('ppl')}")
    if frames < 2:
        raise ConfigError(f"{param('frames')} must be at least 2")
    check_count(param("frames"), frames, MAX_PREVIEW_FRAMES, "a preview of a few dozen frames shows the parallax")
    # each frame: one pixel a lens, enlarged to about 480 pixels across (or by --scale), and its GIF copy
    side = 480 if scale is None else scale * max(image.shape[1] // nx, image.shape[0] // ny)
    check_memory(f"a preview of {frames} frames", frames * (2 * side * side * 3 + image.size // (nx * ny) * 8)
                 + image.size * 8, f"give fewer {param('frames')} or a smaller {param('scale')}")
    angles = viewer_angles(nx * sx, focal, frames)
    if info.get("lens_array") is not None:  # hex, fractional PPL: the views extract writes
        from ..renderer.outputs.views import sidecar_bank

        shots = bank_frames(sidecar_bank(image[..., :3], info["lens_array"]), sx, focal, angles)
    else:
        shots = preview_frames(image[..., :3], (ny, nx), sx, focal, angles)
    if shots.dtype == np.uint16:
        shots = (shots >> 8).astype(np.uint8)
    aspect = max(1, round(nx / ny)) if ny < nx else 1  # a lenticular lens is nx pixels wide, one row high
    if scale is None:  # lens-sized pixels, about 480 pixels across
        scale = max(1, 480 // max(shots.shape[1], shots.shape[2] * aspect))
    big = [enlarge(f, (scale, scale * aspect)) for f in shots]
    with atomic_path(output) as tmp:
        Image.fromarray(big[0]).save(tmp, format="GIF", save_all=True, append_images=[Image.fromarray(b) for b in big[1:]],
                                     duration=duration_ms, loop=0)
    write_png(sheet_path, contact_sheet(big))
    record = base_record("preview", source=str(Path(h3d_path).resolve()), angles_deg=list(map(float, angles)),
                     frames=frames)
    write_sidecar(sheet_path, record)   # the sheet's sidecar (its SHA-256), which the .gif shares
    return record.to_json()

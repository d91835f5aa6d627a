"""``povh3d resample`` on files (thesis appendix C): every micro-image resized, or views traded
for lenses; on any array its sidecar describes (hex, fractional pixels per lens, turned), each
new pixel's own ray read on the same physical panel (``image.resample.resample_panel``).

Every input is checked before anything is written; the output's sidecar holds its lens array,
so ``extract``, ``refocus`` and ``preview`` read it as they read a render.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import ConfigError, param, raw_message
from ..geometry.axes import to_edge
from ..geometry.lens_array import LensArray, Panel
from ..image.io import read_png, read_sidecar_record, with_sidecar
from ..image.resample import resample_micro_images, resample_panel, resampled_array, trade_views_for_lenses
from ..renderer.budget import check_disk, check_memory
from .images import read_whole_lenses
from ..renderer.records import base_record, png_output, write_image


def _check_budget(out: Path, pixels: float, image_bytes: int, channels: int, itemsize: int,
                  ppl_out: tuple[float, float]) -> None:
    # the output in float64 beside its encoded copy, and the input's float copy: 64 bytes a pixel
    check_memory(f"resampling to {ppl_out[1]:g}x{ppl_out[0]:g} pixels per lens ({pixels:.3g} pixels)",
                 pixels * 64 + image_bytes * 8, f"give a smaller {param('ppl_out')}")
    check_disk(out.parent, f"a {pixels:.3g} pixel image", pixels * channels * itemsize,
               f"give a smaller {param('ppl_out')} or free some space")


def resample_file(input_path: str | Path, output: str | Path, ppl_in: tuple[int, int],
                  ppl_out: tuple[int, int], mode: str = "micro") -> dict[str, Any]:
    """Whole pixels per lens on a camera bank's region: each micro-image resized (``micro``), or
    views traded for lenses (``lenses``)."""
    out = png_output(output, inputs=with_sidecar(input_path))
    image = read_whole_lenses(input_path)
    ny_in, nx_in = ppl_in
    scale = (ppl_out[0] / max(ny_in, 1)) * (ppl_out[1] / max(nx_in, 1))
    _check_budget(out, image.shape[0] * image.shape[1] * scale, image.size, image.shape[2], image.itemsize,
                  ppl_out)
    try:
        if mode == "micro":
            result = resample_micro_images(image, ppl_in, ppl_out)
        elif mode == "lenses":
            result = trade_views_for_lenses(image, ppl_in, ppl_out)
        else:
            raise ConfigError(f"unknown resample mode {mode!r}; choose micro or lenses")
    except ValueError as exc:
        end = f"; check {param('ppl')}"
        raise ConfigError(f"{raw_message(exc).removesuffix(end)}; check {param('ppl')} and {param('ppl_out')}") from None
    record = base_record("h3d", method=f"resample-{mode}", ppl_in=to_edge(ppl_in),
                         ppl_out=to_edge(ppl_out), source=str(Path(input_path).resolve()),
                         size_px=to_edge(result.shape[:2]), output_gamma="sRGB")
    if mode == "lenses":
        record = record.with_(replay={"lens_pitch_scale": [ppl_out[1] / ppl_in[1], ppl_out[0] / ppl_in[0]],
                                      "focal_scale": ppl_out[1] / ppl_in[1]})
    else:
        resampled = _bank_array(input_path, result.shape[:2], ppl_out)
        if resampled is not None:
            record = record.with_(lens_array=resampled.as_record())
    write_image(out, result, record)
    return record.to_json()


def _bank_array(input_path: str | Path, shape: tuple[int, int], ppl_out: tuple[int, int]) -> Any:
    """The input's lens array with ``ppl_out`` pixels under each lens (same lenses, the panel cut
    to them), or None when the input has none or it does not fit ``shape``."""
    from ..display.display import Display

    record = read_sidecar_record(input_path)
    if record is None or record.lens_array is None:
        return None
    side = record.to_json()
    try:
        a = Display.from_record(side).lens_array
        ny, nx = ppl_out
        panel = Panel(a.lenses_x * nx, a.lenses_y * ny if a.grid != "lenticular" else a.panel.height,
                      a.pitch_x / nx, a.pitch_y / ny if a.grid != "lenticular" else a.panel.pitch_y)
        out = LensArray(a.grid, a.lenses_x, a.lenses_y, a.pitch_x, a.pitch_y, a.focal, panel)
    except ConfigError:
        return None
    return out if (out.panel.height, out.panel.width) == tuple(shape) else None


def needs_panel_resample(lens_record: dict[str, Any], ppl_out: tuple[float, float]) -> bool:
    """Whether a resample to ``ppl_out`` goes through ``resample_panel_file``: the input's sidecar
    describes an array with no camera bank (hex, fractional PPL, turned), or the output's
    pixels per lens are not whole."""
    whole = all(float(v).is_integer() for v in ppl_out)
    return bool(lens_record) and (not lens_record.get("views") or not whole)


def _what(la: LensArray) -> str:
    if la.grid in ("hex", "lattice") or la.rotation:
        return f"a {la.grid} lens array{' turned' if la.rotation else ''}"
    return f"{la.ppl_x:g} x {la.ppl_y:g} pixels per lens"


def resample_panel_file(input_path: str | Path, output: str | Path, ppl_out: tuple[float, float],
                        mode: str = "micro") -> dict[str, Any]:
    """Any array its sidecar describes, to ``ppl_out = (My, Mx)`` pixels per lens: the same lenses
    on the same physical panel, each new pixel the light along its own ray
    (``image.resample.resampled_array``, ``resample_panel``)."""
    from ..renderer.outputs.views import sidecar_array

    out = png_output(output, inputs=with_sidecar(input_path))
    image = read_png(input_path)
    lens_in = sidecar_array(image, input_path)
    if mode == "lenses":
        raise ConfigError(f"{param('mode')} lenses cuts each lens's whole-pixel micro-image into smaller lenses, and "
                          f"{str(input_path)!r} has {_what(lens_in)}, whose micro-images are not whole "
                          f"pixels; use {param('mode')} micro (the same lenses, new pixels per lens)")
    if mode != "micro":
        raise ConfigError(f"unknown resample mode {mode!r}; choose micro or lenses")
    my, mx = ppl_out
    if min(mx, my) < 1:
        raise ConfigError(f"{param('ppl_out')} {mx:g}x{my:g} puts a lens under one pixel; give at least 1 pixel per lens")
    if lens_in.grid == "hex" and my != mx:
        raise ConfigError(f"a hex lens's pixels per lens are one number (its pitch over the pixel pitch, pixels "
                          f"keeping their shape), got {param('ppl_out')} {mx:g}x{my:g}; give one, e.g. {param('ppl_out')} {mx:g}")
    if lens_in.grid == "lenticular" and my != 1:
        raise ConfigError(f"a lenticular sheet keeps its rows (1 pixel per lens vertically), got {param('ppl_out')} "
                          f"{mx:g}x{my:g}; give one number, e.g. {param('ppl_out')} {mx:g}")
    # the budget first, from the scale alone (a huge --ppl-out is no panel to build)
    scale_x = mx * lens_in.panel.pitch_x / lens_in.pitch_x
    scale_y = {"lenticular": 1.0, "hex": scale_x}.get(lens_in.grid, my * lens_in.panel.pitch_y / lens_in.pitch_y)
    pixels = image.shape[0] * image.shape[1] * scale_x * scale_y
    _check_budget(out, pixels, image.size, image.shape[2], image.itemsize, ppl_out)
    lens_out = resampled_array(lens_in, ppl_out)   # a new pixel under one pixel: the array's own error line
    result = resample_panel(image, lens_in, lens_out)
    record = base_record("h3d", lens_out, method="resample-micro", ppl_in=[lens_in.ppl_x, lens_in.ppl_y],
                         ppl_out=[lens_out.ppl_x, lens_out.ppl_y], source=str(Path(input_path).resolve()),
                         size_px=to_edge(result.shape[:2]), output_gamma="sRGB")
    write_image(out, result, record)
    return record.to_json()

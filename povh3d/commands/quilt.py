"""Quilts on files: an H3D image's views tiled the Looking Glass way, and a quilt's views
interleaved back into an H3D image.

Each function reads PNGs, calls the pure functions of ``image/quilt.py`` and writes its
outputs atomically, each image with its JSON sidecar; every input is checked first.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import ConfigError, param, raw_message
from ..geometry.axes import to_edge
from ..image.interleave import extract, interleave
from ..image.io import check_output, read_png, read_sidecar_record, with_sidecar
from ..image.quilt import (auto_grid, bank_to_quilt_order, parse_quilt_name, quilt_name, quilt_to_bank_order,
                           quilt_to_views, view_aspect, views_to_quilt)
from .images import lens_record
from ..renderer.records import base_record, png_output, write_image


def export_quilt(h3d_path: str | Path, output_dir: str | Path, grid: tuple[int, int] | str | None,
                 *, ppl: tuple[int, int] | None = None, aspect: float | None = None,
                 rows: str | None = None) -> Path:
    """Write the views of an H3D image as ``stem_qs{c}x{r}a{aspect}.png`` in ``output_dir``.

    The views come from the sidecar's lens array (its camera bank, or each lens resampled on
    a hex array, as ``extract``), else from ``ppl``.  ``grid``: ``(cols, rows)`` or ``"auto"``
    (``image.quilt.auto_grid``: a Looking Glass preset's own layout when the views fill it).
    ``rows``: which rows of a square or hex bank (``centre`` or ``all``).  The aspect in the
    name is the view's physical shape (``quilt_aspect``), unless ``aspect`` is given.
    """
    from ..renderer.outputs.views import sidecar_array, sidecar_bank

    image = read_png(h3d_path)
    record = read_sidecar_record(h3d_path)
    display = None
    if record is not None and record.lens_array is not None:
        from ..display.display import Display

        display = Display.from_record(record.to_json())
        if ppl is not None and display.lens_array.views not in (None, tuple(ppl)):
            raise ConfigError(f"{param('ppl')} contradicts the sidecar of {str(h3d_path)!r}; leave {param('ppl')} out")
        bank = sidecar_bank(image, sidecar_array(image, h3d_path, record))
    else:
        if ppl is None:
            raise ConfigError(f"the pixels per lens are unknown (no sidecar); give them with {param('ppl')}, e.g. {param('ppl')} 8")
        try:
            bank = extract(image, ppl)
        except ValueError as exc:
            raise ConfigError(raw_message(exc)) from None
    views = bank_to_quilt_order(bank, rows)
    n, h, w = views.shape[:3]
    device = _device(display)
    if grid is None or grid == "auto":
        grid = auto_grid(n, (h, w), device.grid if device else None)
    elif isinstance(grid, str):  # (was a TypeError further on)
        raise ConfigError(f"grid is (cols, rows) or 'auto', got {grid!r}")
    if n != grid[0] * grid[1]:
        raise ConfigError(f"{n} views do not fill a {grid[0]}x{grid[1]} quilt exactly; "
                          f"give {param('quilt')} with cols x rows = {n}, or {param('quilt')} auto")
    aspect = aspect or quilt_aspect(display, image.shape[:2])
    folder = Path(output_dir)
    out = folder / quilt_name(Path(h3d_path).stem, grid[0], grid[1], aspect)
    folder.mkdir(parents=True, exist_ok=True)
    check_output(out, with_sidecar(h3d_path))
    out_record = base_record("quilt", grid=list(grid), aspect=aspect, views=int(n), rows=rows or "centre",
                             source=str(Path(h3d_path).resolve()))
    if record is not None and record.lens_array is not None:  # so that importing the quilt gives back the H3D
        out_record = out_record.with_(source_lens_array=record.lens_array.to_json())   # image with its lens array
    write_image(out, views_to_quilt(views, *grid), out_record)
    return out


def _device(display: Any) -> Any:
    """The Looking Glass device a display's preset names, or None."""
    from ..display.looking_glass import DEVICES

    return DEVICES.get(display.preset) if display is not None and display.preset else None


def quilt_aspect(display: Any, shape: tuple[int, int]) -> float:
    """The view's physical aspect: a Looking Glass preset's own (its panel's), else the physical
    panel's extent (a slanted preset's panel, not its view-space image), else, without a
    sidecar, the image's with square pixels."""
    device = _device(display)
    if device is not None:
        return device.aspect
    if display is None:
        return view_aspect(shape[1], shape[0])
    p = display.physical_panel or display.lens_array.panel
    return view_aspect(p.width * p.pitch_x, p.height * p.pitch_y)


def import_quilt(quilt_path: str | Path, output: str | Path, grid: tuple[int, int] | None = None,
                 count: int | None = None) -> dict[str, Any]:
    """Interleave the views of a quilt into a lenticular H3D image (one pixel row per view row)."""
    parsed = parse_quilt_name(Path(quilt_path).name)
    if grid is None:
        if parsed is None:
            raise ConfigError(f"{Path(quilt_path).name!r} does not name its grid (_qs8x6a0.75); give {param('quilt')} 8x6")
        grid = parsed[:2]
    out = png_output(output, inputs=with_sidecar(quilt_path))
    views = quilt_to_views(read_png(quilt_path), grid[0], grid[1], count)
    h3d = interleave(quilt_to_bank_order(views))
    record = base_record("h3d", method="quilt-import", views=[int(views.shape[0]), 1], grid=list(grid),
                     source=str(Path(quilt_path).resolve()), size_px=to_edge(h3d.shape[:2]),
                     output_gamma="sRGB")
    side = lens_record(quilt_path, "source_lens_array")
    if side.get("views") == [int(views.shape[0]), 1] and side.get("panel", {}).get("size_px") == \
            to_edge(h3d.shape[:2]):
        record = record.with_(lens_array=side)
    write_image(out, h3d, record)
    return record.to_json()


# -- refocus ---------------------------------------------------------------------------------------

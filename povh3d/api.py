"""The commands as Python functions on arrays and values: what ``povh3d COMMAND`` does to a file,
done to an array (an H3D image and its lens array in, an array out).  Every one is re-exported
from ``povh3d`` (loaded on first use); docs/api.md shows each with an example.

Arrays are NumPy images ``(H, W, C)`` uint8 or uint16 (sRGB, as the PNG files hold them), rows
first; a view stack is ``(Ny, Nx, Ly, Lx, C)``: view row, view column, lens row, lens column.
Lengths are millimetres.  A lens array comes from ``povh3d.presets.lens_array(...)`` or from
``read_h3d`` (the sidecar's).  The file-level commands (``render``, ``convert_mesh``, ``layout``)
take paths, as their outputs are files for POV-Ray or a picture with its record.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import ConfigError, raw_message

if TYPE_CHECKING:
    from .renderer.content.convert_mesh import ConversionResult
    from .calibration.gridfile import Grid
    from .calibration.lenticular import LenticularFit
    from .display.display import Display
    from .geometry.lens_array import LensArray
    from .geometry.moire import SlantSweep
    from .display.mappings import Mapping

Ppl = tuple[int, int]


def _ppl(lens: LensArray | Ppl) -> Ppl:
    """``(Ny, Nx)`` whole pixels per lens, of a lens array or as given."""
    if isinstance(lens, tuple):
        return (int(lens[0]), int(lens[1]))
    return lens.require_views()


def _display(preset: str, lens_array: LensArray | None) -> Display:
    """The display of ``lens_array``, or of the preset (the command line's builder)."""
    from .display.display import build_display

    return build_display(preset, lens_array=lens_array)


# -- files -------------------------------------------------------------------------------------------
def read_h3d(path: str | Path) -> tuple[np.ndarray, LensArray | None]:
    """An H3D image file and the lens array its sidecar describes (None without a sidecar).

    Returns
    -------
    image : (H, W, C) uint8 or uint16
    lens_array : LensArray or None
    """
    from .display.display import Display
    from .image.io import read_png, read_sidecar_record

    side = read_sidecar_record(path)
    return read_png(path), (Display.from_record(side.to_json()).lens_array if side and side.lens_array else None)


# -- views -------------------------------------------------------------------------------------------
def interleave(views: np.ndarray) -> np.ndarray:
    """``povh3d interleave``: a view stack into an H3D image.

    Parameters
    ----------
    views : (Ny, Nx, Ly, Lx, C) array    view (Ny, Nx) is camera (row, column) of the bank

    Returns
    -------
    (Ly*Ny, Lx*Nx, C) array, pixel (i*Ny + l, j*Nx + k) = views[l, k, i, j]
    """
    from .image.interleave import interleave as _interleave

    return _interleave(np.asarray(views))


def extract(h3d: np.ndarray, lens: LensArray | Ppl) -> np.ndarray:
    """``povh3d extract``: the view stack of an H3D image (the inverse of ``interleave``).

    Parameters
    ----------
    h3d : (H, W, C) array
    lens : LensArray or (Ny, Nx)    a lens array (``read_h3d``'s: hex and fractional PPL resampled
                                    lens by lens, as ``povh3d extract``), or whole pixels per lens

    Returns
    -------
    (Ny, Nx, Ly, Lx, C) array
    """
    from .image.interleave import extract as _extract

    if not isinstance(lens, tuple):
        from .renderer.outputs.views import image_views

        return image_views(np.asarray(h3d), lens)
    try:
        return _extract(np.asarray(h3d), _ppl(lens))
    except ValueError as exc:
        raise ConfigError(raw_message(exc)) from None


# -- the panel ---------------------------------------------------------------------------------------
def map(image: np.ndarray, mapping: str | Mapping, *, preset: str = "demo",  # noqa: A001 - the command's name
        lens_array: LensArray | None = None, panel: tuple[int, int] | None = None,
        **options: Any) -> np.ndarray:
    """``povh3d map``: an unmapped view-space H3D image onto a display's subpixels.

    Parameters
    ----------
    image : (H, W, C) array      one row of views per lens row (a lenticular render)
    mapping : str or Mapping     a mapping name (``alioscopy``, ``slanted``, ``smart:4`` ...) or a built one
    preset, lens_array           the display the name is built for (as ``--preset`` and the lens options)
    panel : (W, H) int           the panel in pixels; default: the one the mapping reads ``image`` from
    **options                    the mapping's options: ``per_lens``, ``views``, ``slope``, ``offset``,
                                 ``rows_per_view``, ``reverse``, ``blend``, ``calibration_path``

    Returns
    -------
    (panel H, panel W, C) array
    """
    if isinstance(mapping, str):
        from .display.display import mapping_for_display

        mapping, _ = mapping_for_display(mapping, _display(preset, lens_array), **options)
    elif options:
        raise ConfigError(f"map() takes mapping options only with a mapping name, got {sorted(options)}")
    image = np.asarray(image)
    if panel is None:
        from .commands.images import infer_panel

        panel = infer_panel(mapping, image.shape[:2])
        if panel is None:
            raise ConfigError(f"no panel size fits a {image.shape[1]}x{image.shape[0]} image under mapping "
                              f"{mapping.name!r}; give it with panel=(W, H)")
    width, height = panel  # a list from a caller, too
    return mapping.apply(image, (width, height))


def resample(h3d: np.ndarray, ppl_in: LensArray | Ppl, ppl_out: tuple[float, float], *,
             mode: str = "micro") -> np.ndarray:
    """``povh3d resample``: every micro-image resampled (``micro``), or views traded for lenses (``lenses``).

    Parameters
    ----------
    h3d : (H, W, C) array             an H3D image
    ppl_in : LensArray or (Ny, Nx)    its lens array (``read_h3d``'s), or whole pixels per lens
    ppl_out : (My, Mx)                pixels per lens after; with a lens array any grid (hex, turned,
                                      fractional) and fractional counts, as the command takes them
    mode : {"micro", "lenses"}

    Returns
    -------
    The resampled image. Whole pixels per lens in and out: ``(Ly*My, Lx*Mx, C)`` for ``micro``, the
    same lenses cut into ``ppl_out`` for ``lenses``. Otherwise the same lenses on the same physical
    panel, each new pixel the light along its own ray; its lens array is
    ``povh3d.image.resample.resampled_array(ppl_in, ppl_out)``.
    """
    from .image.resample import resample_micro_images, resample_panel, resampled_array, trade_views_for_lenses

    functions = {"micro": resample_micro_images, "lenses": trade_views_for_lenses}
    if mode not in functions:
        raise ConfigError(f"unknown resample mode {mode!r}; choose micro or lenses")
    whole_out = all(float(m).is_integer() for m in ppl_out)
    if isinstance(ppl_in, tuple) or (ppl_in.views is not None and whole_out and ppl_in.grid != "hex"):
        try:
            out = tuple(int(m) for m in ppl_out)
            return functions[mode](np.asarray(h3d), _ppl(ppl_in), (out[0], out[1]))
        except ValueError as exc:
            raise ConfigError(f"{raw_message(exc)}; check ppl_in and ppl_out") from None
    if mode != "micro":
        raise ConfigError("mode 'lenses' cuts whole-pixel micro-images; this lens array's are not whole "
                          "pixels: use mode 'micro'")
    panel = ppl_in.panel
    if h3d.shape[:2] != (panel.height, panel.width):
        raise ConfigError(f"the image is {h3d.shape[1]}x{h3d.shape[0]} but its lens array's panel is "
                          f"{panel.width}x{panel.height}; pass the image and lens array read_h3d gives")
    my, mx = (float(m) for m in ppl_out)
    return resample_panel(np.asarray(h3d), ppl_in, resampled_array(ppl_in, (my, mx)))


def quilt(h3d: np.ndarray, lens: LensArray | int, grid: tuple[int, int] | str = "auto", *,
          rows: str | None = None) -> np.ndarray:
    """``povh3d quilt``: the views of an H3D image tiled as a quilt (Looking Glass order).

    Parameters
    ----------
    h3d : (H, W, C) array        an H3D image: one row of views with ``lens`` an int, or any render
                                 with its lens array (square, hex, fractional: views as ``extract``)
    lens : LensArray or int      its lens array, or Nx, the views per lens of a lenticular image
    grid : (cols, rows) or "auto"  cols * rows = the views; ``auto`` as ``--quilt auto``
    rows : {"centre", "all"}     which rows of views of a square or hex array (default: the centre row)

    Returns
    -------
    (rows*h, cols*w, C) array, the leftmost camera bottom left
    """
    from .image.quilt import auto_grid, bank_to_quilt_order, views_to_quilt

    if isinstance(lens, int):
        views = bank_to_quilt_order(extract(h3d, (1, lens)), rows)
    else:
        from .renderer.outputs.views import image_views

        views = bank_to_quilt_order(image_views(np.asarray(h3d), lens), rows)
    n, h, w = views.shape[:3]
    if isinstance(grid, str):
        if grid != "auto":
            raise ConfigError(f"grid must be (cols, rows) or 'auto', got {grid!r}")
        grid = auto_grid(n, (h, w))
    if n != grid[0] * grid[1]:
        raise ConfigError(f"{n} views do not fill a {grid[0]}x{grid[1]} quilt exactly; give a grid with "
                          f"cols x rows = {n}, or 'auto'")
    return views_to_quilt(views, *grid)


def unquilt(quilt_image: np.ndarray, grid: tuple[int, int], count: int | None = None) -> np.ndarray:
    """``povh3d quilt --import``: a quilt's views interleaved into a lenticular H3D image.

    Parameters
    ----------
    quilt_image : (rows*h, cols*w, C) array
    grid : (cols, rows) int
    count : int     views to take (default: every tile)

    Returns
    -------
    (h, w*count, C) array
    """
    from .image.quilt import quilt_to_bank_order, quilt_to_views

    return interleave(quilt_to_bank_order(quilt_to_views(np.asarray(quilt_image), grid[0], grid[1], count)))


# -- what a viewer sees ------------------------------------------------------------------------------
def refocus(h3d: np.ndarray, lens_array: LensArray, depth: float) -> np.ndarray:
    """``povh3d refocus``: the image focused at ``depth`` (shift-and-sum over the views, in linear light).

    Parameters
    ----------
    h3d : (H, W, C) array     an image of ``lens_array`` (any grid, as ``extract``)
    lens_array : LensArray    its views, focal length and pixel pitch
    depth : float, mm         the plane in focus, behind (+) or in front of (-) the screen

    Returns
    -------
    (Ly, Lx, 3) array of ``h3d``'s dtype
    """
    from .image.colour import from_linear, to_linear
    from .image.refocus import bank_steps, lens_steps, shift_and_add

    h3d = np.asarray(h3d)
    views = extract(h3d[..., :3], lens_array)
    ny, nx = views.shape[:2]
    if lens_array.views is None:  # hex, fractional PPL: the odd rows' offset, as the command
        steps, used, row_shift = lens_steps(lens_array, (ny, nx))
    else:
        sx, sy = lens_array.panel.pitch_x, lens_array.panel.pitch_y
        u, v = (np.arange(nx) + 0.5 - nx / 2) * sx, (ny / 2 - np.arange(ny) - 0.5) * sy
        steps, used, row_shift = bank_steps((u, v), (nx * sx, ny * sy), lens_array.focal), None, 0.0
    plane = shift_and_add(to_linear(views, np.float32), steps * float(depth), row_shift=row_shift, used=used)
    return from_linear(plane, h3d.dtype)


def preview(h3d: np.ndarray, lens_array: LensArray, *, frames: int = 12, scale: int | None = None) -> np.ndarray:
    """``povh3d preview``: what a viewer sees walking across the viewing angle, one frame per position.

    Parameters
    ----------
    h3d : (H, W, C) array     an image of ``lens_array`` (any grid, as ``extract``)
    lens_array : LensArray
    frames : int             viewer positions, evenly over the viewing angle
    scale : int              pixels per lens in the frames (default: about 480 pixels across, as the GIF)

    Returns
    -------
    (frames, Ly*scale, Lx*scale*a, 3) uint8 array (``a``: the lens's aspect, ``Nx`` on a lenticular sheet)
    """
    from .image.preview import bank_frames, enlarge, viewer_angles

    if frames < 2:
        raise ConfigError("frames must be at least 2")
    views = extract(np.asarray(h3d)[..., :3], lens_array)
    ny, nx = views.shape[:2]
    sx = lens_array.panel.pitch_x
    shots = bank_frames(views, sx, lens_array.focal, viewer_angles(nx * sx, lens_array.focal, frames))
    if shots.dtype == np.uint16:
        shots = (shots >> 8).astype(np.uint8)
    aspect = max(1, round(nx / ny)) if ny < nx else 1
    if scale is None:
        scale = max(1, 480 // max(shots.shape[1], shots.shape[2] * aspect))
    return np.stack([enlarge(f, (scale, scale * aspect)) for f in shots])


def replay(h3d: np.ndarray, lens_array: LensArray, eye: tuple[float, float, float] | None = None, *,
           optics: str = "pinhole", size: str | tuple[int, int] = "lenses") -> np.ndarray:
    """``povh3d replay``: what an eye sees of ``h3d`` on its display (docs/replay.md).

    Parameters
    ----------
    h3d : (H, W, C) array      an image of ``lens_array``'s panel
    lens_array : LensArray
    eye : (x, y, z) mm         display coordinates, the viewer at ``z < 0`` (default ``(0, 0, -300)``)
    optics : str               ``pinhole`` (a pinhole mask at the lens centres), ``barrier`` (slits, lenticular),
                               ``none`` (no sheet: the panel in the lens plane)
    size : 'lenses' or (W, H)  one pixel a lens, or a perspective picture of the display's area

    Returns
    -------
    (Ly, Lx, C) or (H, W, C) array of ``h3d``'s dtype (black where the ray misses the panel)
    """
    from .display.replay import default_eye, replay as _replay

    return _replay(h3d, lens_array, default_eye(lens_array) if eye is None else eye, optics=optics, size=size).image


# -- the display -------------------------------------------------------------------------------------
def info(preset: str = "demo", *, lens_array: LensArray | None = None) -> dict[str, Any]:
    """``povh3d info --json``: the derived values of a display (viewing angle, 3D resolution ...)."""
    display = _display(preset, lens_array)
    return {**display.as_record()["display"], **display.lens_array.as_record()}


def moire(lens_array: LensArray, slants_deg: np.ndarray | list[float], *, distance: float = 500.0, turn: bool = False,
          blur: float = 1.5, spot: float = 0.0) -> SlantSweep:
    """``povh3d moire``: the moire of two crossed lenticular sheets of the array's pitch over its panel.

    Parameters
    ----------
    lens_array : LensArray          pitch, focal length and panel pixels
    slants_deg : (n,) float, deg    slants of the sheet to sweep
    distance : float, mm            the viewer's distance
    turn : bool                     turn the whole pair (else the horizontal sheet alone is slanted)
    blur : float, lenses            the low-pass of the contrast measure
    spot : float, mm                the focused spot's width

    Returns
    -------
    SlantSweep    ``contrast``, ``row_contrast``, ``period_mm`` ... one value per slant
    """
    import math

    from .geometry.moire import PanelPattern, slant_sweep

    panel = lens_array.panel
    pitch = lens_array.pitch_x
    width, height = panel.size_mm
    least = max(16, 4 * math.ceil(2 * blur) + 8)  # the same sheet size as the command's
    lenses = (max(least, math.ceil(width / pitch)), max(least, math.ceil(height / pitch)))
    return slant_sweep(PanelPattern(panel.pitch_x, panel.pitch_y), pitch, lens_array.focal,
                       np.asarray(slants_deg, dtype=float), (0.0, 0.0, distance), lenses, turn=turn, spot=spot,
                       blur=blur)


# -- captures (the calibration extra: SciPy) ---------------------------------------------------------
def calibrate(white: np.ndarray, *, lattice: str | None = None, distortion: bool = True) -> Grid | LenticularFit:
    """``povh3d calibrate``: the lens grid in a white image taken through the lens array.

    Parameters
    ----------
    white : (H, W[, C]) array
    lattice : {None, "square", "hex", "lenticular"}    None: square or hex, whichever fits
    distortion : bool                                  fit Brown's radial terms

    Returns
    -------
    Grid (``write_grid`` saves it as the command's grid.json), or LenticularFit for ``lenticular``
    """
    if lattice == "lenticular":
        from .calibration.lenticular import calibrate_lenticular

        return calibrate_lenticular(np.asarray(white), distortion=distortion)
    from .calibration.lattice import calibrate as _calibrate

    return _calibrate(np.asarray(white), lattice=lattice, distortion=distortion)


def _grid(grid: Grid | str | Path, image: np.ndarray) -> Grid:
    if isinstance(grid, (str, Path)):
        from .calibration.gridfile import read_grid

        grid = read_grid(grid)
    grid.check_image(np.asarray(image).shape)
    return grid


def undistort(image: np.ndarray, grid: Grid | str | Path) -> np.ndarray:
    """``povh3d undistort``: the capture without the lens distortion ``grid`` measured. Same shape."""
    from .calibration.distortion import undistort_image

    return undistort_image(np.asarray(image), _grid(grid, image).distortion)


def borders(image: np.ndarray, grid: Grid | str | Path, *, threshold: float = 0.5, fill: str = "black") -> np.ndarray:
    """``povh3d borders``: micro-images flat-fielded, the dark borders between them cleaned. Same shape."""
    from .calibration.borders import correct_borders

    return correct_borders(np.asarray(image), _grid(grid, image), threshold=threshold, fill=fill)[0]


def equalise(image: np.ndarray, grid: Grid | str | Path, *, size: int | None = None) -> np.ndarray:
    """``povh3d equalise``: every micro-image resampled to ``size`` x ``size`` pixels (default: the mean).

    Returns
    -------
    (rows*size, cols*size, C) array, one upright square per lens of the grid's table
    """
    from .calibration.equalise import equalise as _equalise

    return _equalise(np.asarray(image), _grid(grid, image), size)[0]


def viewpoints(image: np.ndarray, grid: Grid | str | Path, *, ppl: int) -> np.ndarray:
    """``povh3d viewpoints``: viewpoint images, pixel (a, b) of every micro-image.

    Returns
    -------
    (ppl, ppl, rows, cols, C) array, a view stack as ``extract`` gives
    """
    from .calibration.viewpoints import viewpoints as _viewpoints

    return _viewpoints(np.asarray(image), _grid(grid, image), ppl)


def stitch(a: np.ndarray, b: np.ndarray, grid: Grid | str | Path) -> np.ndarray:
    """``povh3d stitch``: two captures taken a whole number of lenses apart, joined into one image."""
    from .calibration.stitch import stitch as _stitch

    g = _grid(grid, a)
    g.check_image(np.asarray(b).shape)
    return _stitch(np.asarray(a), np.asarray(b), g)[0]


# -- file level --------------------------------------------------------------------------------------
def convert_mesh(model: str | Path, output: str | Path | None = None, **options: Any) -> ConversionResult:
    """``povh3d convert-mesh``: a mesh model to a POV-Ray ``mesh2`` include; see ``renderer.content.convert_mesh``."""
    from .renderer.content.convert_mesh import convert_mesh as _convert

    return _convert(model, output, **options)


def layout(source: str | Path, output: str | Path, *, preset: str = "demo", lens_array: LensArray | None = None,
           **options: Any) -> dict[str, Any]:
    """``povh3d layout``: the set-up picture (content, screen, depth budget, lens array, viewing cone)
    and its record."""
    from .commands.layout import layout as _layout

    if "frame_options" in options:   # its name before "placement" (issue 36)
        import warnings

        warnings.warn("layout(frame_options=...) is deprecated; use placement=", DeprecationWarning, stacklevel=2)
        options.setdefault("placement", options.pop("frame_options"))
    display = _display(preset, lens_array)
    return _layout(source, output, display.lens_array, display=display, **options)

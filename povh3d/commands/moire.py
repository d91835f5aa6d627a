"""``povh3d moire``: the moire of a cross-lenticular sheet against its slant, as a plot
(PNG) whose sidecar holds the numbers (docs/moire.md)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, param
from ..geometry.lens_array import LensArray
from ..geometry.moire import PanelPattern, SlantSweep, slant_sweep
from ..renderer.records import base_record, png_output, write_image


def parse_range(text: str) -> np.ndarray:
    """``START:STOP:STEP`` in degrees (STOP included when on the grid) -> the angles."""
    try:
        start, stop, step = (float(t) for t in text.split(":"))
    except ValueError:
        raise ConfigError(f"{param('slant_range')} takes START:STOP:STEP in degrees, e.g. 0:20:0.25, got {text!r}") from None
    if not all(map(math.isfinite, (start, stop, step))) or step <= 0 or stop < start:
        raise ConfigError(f"{param('slant_range')} needs START <= STOP and a positive STEP, got {text!r}")
    if not (-45 < start and stop <= 45):
        raise ConfigError(f"{param('slant_range')} must stay within (-45, 45] deg, got {text!r}")
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    if n > 2000:
        raise ConfigError(f"{param('slant_range')} asks for {n} angles; use at most 2000 (a larger STEP)")
    return start + step * np.arange(n)


def moire_sweep_file(lens_array: LensArray, slants: np.ndarray, output: str | Path, *, distance: float = 500.0,
                     turn: bool = False, blur: float = 1.5, spot: float = 0.0) -> dict[str, Any]:
    """Sweep two crossed sheets of the array's lens pitch over the panel's pixels; write the plot."""
    path = png_output(output, "plot")
    if not (math.isfinite(distance) and distance > 0):
        raise ConfigError(f"{param('distance')} must be a positive number of mm, got {distance!r}")
    if not (math.isfinite(blur) and blur > 0) or not (math.isfinite(spot) and spot >= 0):
        raise ConfigError(f"{param('blur')} must be positive and {param('spot')} at least 0, got {blur!r}, {spot!r}")
    panel = lens_array.panel
    pattern = PanelPattern(panel.pitch_x, panel.pitch_y)
    pitch = lens_array.pitch_x
    width, height = panel.size_mm
    least = max(16, 4 * math.ceil(2 * blur) + 8)  # room for the edges the low-pass cuts off
    lenses = (max(least, math.ceil(width / pitch)), max(least, math.ceil(height / pitch)))
    sweep = slant_sweep(pattern, pitch, lens_array.focal, slants, (0.0, 0.0, distance), lenses,
                        turn=turn, spot=spot, blur=blur)
    moire = {
        "sheets": "cross-lenticular, whole pair turned" if turn else "cross-lenticular, horizontal sheet slanted",
        "pitch_mm": pitch, "lenses": list(lenses), "viewer_mm": [0.0, 0.0, distance], "blur_lenses": blur,
        "spot_mm": spot, "panel_open": [pattern.open_x, pattern.open_y],
        "slant_deg": sweep.slants_deg.tolist(), "contrast": sweep.contrast.tolist(),
        "row_contrast": sweep.row_contrast.tolist(), "column_contrast": sweep.column_contrast.tolist(),
        "period_mm": sweep.period_mm.tolist(), "direction_deg": sweep.direction_deg.tolist(),
        "row_period_mm": sweep.row_period_mm.tolist(), "row_predicted_mm": sweep.row_predicted_mm.tolist()}
    write_image(path, _plot(sweep, pitch, distance, turn, blur), base_record("moire", lens_array, moire=moire))
    return moire


def _plot(sweep: SlantSweep, pitch: float, distance: float, turn: bool, blur: float) -> np.ndarray:
    """The plot as an RGB image (matplotlib, imported here: only this command needs it)."""
    import matplotlib
    matplotlib.use("Agg")  # no display: render into memory
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 6.5), dpi=110, sharex=True)
    x = sweep.slants_deg
    ax.plot(x, sweep.contrast, "k-", lw=1.4, label="total (luminance)")
    ax.plot(x, sweep.row_contrast, "-", lw=1, label="pixel rows (horizontal sheet)")
    ax.plot(x, sweep.column_contrast, "--", lw=1, label="RGB columns (vertical sheet)")
    for angle in (6.34, 18.43):
        if x[0] <= angle <= x[-1]:
            ax.axvline(angle, color="grey", lw=0.8, ls=":")
    ax.set_ylabel("moire contrast (Michelson)")
    ax.set_ylim(0, 1.05)
    ax.legend(fontsize=7)
    what = "whole pair turned" if turn else "horizontal sheet slanted"
    ax.set_title(f"Cross-lenticular {pitch:g} mm sheets, {what}; viewer {distance:g} mm", fontsize=9)
    bx.semilogy(x, sweep.row_predicted_mm, "-", lw=1, label="rows: predicted (grating formula)")
    bx.semilogy(x, sweep.row_period_mm, "k.", ms=3, label="rows: measured (strongest after the low-pass)")
    # The period whose contrast the low-pass halves: exp(-2 pi^2 sigma^2 / T^2) = 1/2.
    bx.axhline(math.pi * blur * pitch * math.sqrt(2 / math.log(2)), color="grey", lw=0.8, ls=":",
               label="low-pass halves the contrast")
    bx.set_ylabel("moire period, mm")
    bx.legend(fontsize=7)
    bx.set_xlabel("slant, deg")
    fig.tight_layout()
    fig.canvas.draw()
    # Agg's canvas (matplotlib.use above) has buffer_rgba; the stubs type the base canvas
    image = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()  # type: ignore[attr-defined]
    plt.close(fig)
    return image

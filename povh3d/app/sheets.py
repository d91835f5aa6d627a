"""The lens sheet a ``--method subpixel`` render traces, for the command line: the sheet a slanted
mapping describes, or the calibrated sheet a calibration file puts on the panel.

The command line reaches the engine only through ``app/`` (docs/architecture.md); this module is
that step for the two sheets: it reads the calibration file and hands the engine its values.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..geometry.lens_array import LensArray, Panel
from ..mappings.base import Mapping


def mapping_sheet(mapping: Mapping, panel: Panel, focal: float) -> tuple[LensArray, float]:
    """The sheet ``mapping`` describes, centred on ``panel``, and the mapping offset that addresses it."""
    from ..engine.subpixel import slanted_sheet

    return slanted_sheet(mapping, panel, focal)


def calibrated_sheet_from_file(path: str | Path, panel: Panel, focal: float,
                               nominal: LensArray | None) -> tuple[LensArray, dict[str, Any]]:
    """The sheet the calibration file ``path`` puts on ``panel`` and its sidecar record (naming the file)."""
    from ..engine.calibrated_sheet import calibrated_sheet
    from .display import read_calibration

    sheet, _, record = calibrated_sheet(read_calibration(path), panel, focal, nominal)
    return sheet, {**record, "calibration": str(Path(path).resolve())}

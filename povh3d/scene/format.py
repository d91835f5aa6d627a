"""Numbers and vectors written the way POV-Ray reads them, round-tripping exactly.

``repr(float)`` is the shortest text that reads back as the same double and is
locale-independent; POV-Ray parses it (including exponents like ``1e-05``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from ..errors import ConfigError


def pov_number(value: float | int) -> str:
    """One number as POV-Ray text: ``repr`` of the double, never ``nan``/``inf``."""
    x = float(value)
    if not math.isfinite(x):
        raise ConfigError(f"cannot write the non-finite number {x!r} into a POV-Ray script")
    if x == 0.0:
        return "0"  # also turns -0.0 into 0: POV-Ray has no use for the sign
    text = repr(x)
    return text[:-2] if text.endswith(".0") else text


def pov_vector(values: Iterable[float]) -> str:
    """``<a, b, c>`` for any number of components."""
    return "<" + ", ".join(pov_number(v) for v in values) + ">"


def pov_vector_list(array: np.ndarray, per_line: int = 4) -> str:
    """Rows of an ``(n, k)`` array as comma-separated ``<...>`` vectors.

    Integral arrays are written as integers (face indices); floats through
    ``pov_number``.  Lines are wrapped so editors and diffs stay usable.
    """
    array = np.asarray(array)
    if array.ndim != 2:
        raise ValueError(f"pov_vector_list takes an (n, k) array, got shape {array.shape}")
    if not np.issubdtype(array.dtype, np.integer):
        if not np.all(np.isfinite(array)):
            raise ConfigError("cannot write non-finite numbers into a POV-Ray script")
        array = array.astype(np.float64, copy=False)
    # repr of a Python int or float round-trips; mapping it over tolist() is the
    # fast path (a camera mesh has hundreds of thousands of numbers).
    items = ["<" + ", ".join(map(repr, row)) + ">" for row in array.tolist()]
    lines = [", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line)]
    return ",\n    ".join(lines)


def pov_string(value: str) -> str:
    """A POV-Ray string literal (paths in ``#include``)."""
    if '"' in value or "\n" in value:
        raise ConfigError(f"the path {value!r} cannot be written into a POV-Ray script; rename it without quotes")
    return '"' + value.replace("\\", "/") + '"'

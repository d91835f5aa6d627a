"""The optional dependency groups, and the one check that names the group to install.

A plain ``pip install povh3d`` brings what every render needs (NumPy, Jinja2,
Pillow, imagecodecs, trimesh, PyVista, pypng, and Matplotlib, which PyVista
needs anyway).  The packages below serve only some
commands, so they live in extras (``pyproject.toml``); a command that reaches one
that is missing stops with one line saying which extra to install.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from .errors import MissingExtra

#: extra -> the distributions it installs (kept equal to pyproject.toml's groups by a test)
EXTRAS: dict[str, tuple[str, ...]] = {
    "cluster": ("distributed",),
    "volume": ("pydicom", "pynrrd", "scipy"),
    "calibration": ("scipy",),
    "analysis": ("scipy", "scikit-image"),
    "video": ("imageio-ffmpeg",),
    "mesh": ("fast-simplification", "lxml", "networkx", "numba"),
}

#: the import name of a distribution whose two names differ
_DISTRIBUTION = {"nrrd": "pynrrd", "skimage": "scikit-image", "imageio_ffmpeg": "imageio-ffmpeg",
                 "fast_simplification": "fast-simplification"}


def installed(module: str) -> bool:
    """``module`` can be imported (an optional package is there), found without importing it."""
    import importlib.util

    return importlib.util.find_spec(module) is not None


def require(module: str, extra: str, purpose: str) -> ModuleType:
    """Import ``module`` or raise ``MissingExtra`` naming the extra that installs it.

    Parameters
    ----------
    module : str    the module to import (``"scipy.ndimage"``, ``"distributed"``)
    extra : str     the group of ``EXTRAS`` that installs it
    purpose : str   what needs it, as the user asked for it (``param("scheduler")``, ``"a DICOM folder"``)
    """
    if extra not in EXTRAS:
        raise ValueError(f"extra {extra!r} is not one of {sorted(EXTRAS)}")
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as error:
        top = module.split(".")[0]
        if error.name is None or error.name.split(".")[0] != top:
            raise  # the module is there but one of its own imports failed: not ours to rename
        distribution = _DISTRIBUTION.get(top, top)
        raise MissingExtra(f"{purpose} needs {distribution}, which is not installed: "
                           f"pip install 'povh3d[{extra}]'", name=top) from None

"""The sidecar record and the output checks every command shares.

Every image povh3d writes has a JSON sidecar (``name.json`` beside
``name.png``, ``image.sidecar.Sidecar``); its base record is built here and only here, and every output
path is checked here before any work starts: never one of the command's inputs, nor over a
``NAME.json`` that povh3d did not write (``image.io.check_output``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..geometry.lens_array import LensArray
from ..image.io import check_output, write_image_pair
from ..image.sidecar import Sidecar
from ..jsontext import JSONValue



def base_record(kind: str, lens_array: LensArray | None = None, **extra: object) -> Sidecar:
    """``povh3d_version``, ``kind`` (``h3d``, ``panel``, ``views``, ...), the lens array, then ``extra``
    (``image.sidecar.Sidecar.new``: the keys it knows are checked)."""
    return Sidecar.new(kind, lens_array, **extra)


def png_output(path: str | Path, what: str = "output", inputs: Iterable[str | Path] = (), *,
               sidecar: bool = True) -> Path:
    """``path`` as a PNG output: a ``.png`` name in a writable folder, neither it nor its sidecar one of
    ``inputs`` (what the command reads), its ``NAME.json`` absent or a povh3d sidecar
    (``image.io.check_output``); checked before any work."""
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ConfigError(f"the {what} {str(path)!r} must be a .png file")
    return check_output(path, inputs, what=what, sidecar=sidecar)


def write_image(path: str | Path, image: np.ndarray, record: Sidecar | Mapping[str, JSONValue]) -> None:
    """Write ``image`` and its sidecar ``record`` beside it, replaced as a pair
    (``image.io.write_image_pair``: a sidecar always describes the image beside it)."""
    write_image_pair(path, image, record)

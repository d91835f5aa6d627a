"""The one Jinja environment: loads povh3d's POV-Ray templates, registers filters.

Templates hold only loops and formatting; every number passes through the
``pov`` filters so it round-trips (docs/geometry.md, "Numbers").
"""

from __future__ import annotations

from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .format import pov_number, pov_string, pov_vector, pov_vector_list

if TYPE_CHECKING:
    import jinja2


def templates_dir() -> Path:
    """The template folder: inside the installed package, else the source tree's ``templates/``."""
    package = Path(__file__).resolve().parent.parent  # povh3d/
    for candidate in (package / "templates", package.parent / "templates"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError("povh3d's templates folder is missing; reinstall povh3d")


@cache
def environment() -> jinja2.Environment:
    import jinja2  # when a script is written: a render from the cache needs none

    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(templates_dir())),
        undefined=jinja2.StrictUndefined,  # a missing value is a bug, not an empty string
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )
    env.filters["pov"] = pov_number
    env.filters["povvec"] = pov_vector
    env.filters["povvecs"] = pov_vector_list
    env.filters["povvec_rows"] = lambda rows: pov_vector_list(np.asarray(rows, dtype=np.float64))
    env.filters["povstr"] = pov_string
    return env


def render_template(name: str, **context: Any) -> str:
    return environment().get_template(name).render(**context)

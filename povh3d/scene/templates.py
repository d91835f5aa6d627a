"""The one Jinja environment: loads povh3d's POV-Ray templates, registers filters.

Templates hold only loops and formatting; every number passes through the
``pov`` filters so it round-trips (docs/geometry.md, "Numbers").
"""

from __future__ import annotations

from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import Povh3dError
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


def _compiled_templates(jinja2: Any) -> Any:
    """Jinja's code of each template kept in povh3d's cache (``cache.py``, ``templates/``), keyed by the
    template's source and the Python and Jinja versions: parsing and compiling ``multi_ortho.pov.j2`` and
    ``scene.pov.j2`` cost every render 15-25 ms of its start-up.  An unusable cache only costs that again."""
    import sys

    from .. import cache as store

    root = store.cache_root()

    class Compiled(jinja2.BytecodeCache):
        def _entry(self, bucket: Any) -> tuple[Path, str]:
            key = store.content_key(bucket.key, bucket.checksum, jinja2.__version__, sys.version)
            return store.entry_path(root, "templates", key, ".template"), key

        def load_bytecode(self, bucket: Any) -> None:
            path, key = self._entry(bucket)
            try:
                body = store.load(path, key, bytes, again="compiling the template again")
            except OSError:
                return
            if body is not None:
                bucket.bytecode_from_string(body)   # Jinja checks its own header and checksum too

        def dump_bytecode(self, bucket: Any) -> None:
            path, key = self._entry(bucket)
            try:
                store.store(path, key, bucket.bytecode_to_string())
            except (OSError, Povh3dError):
                pass   # read-only or full: the template is compiled again next time

    return Compiled()


@cache
def environment() -> jinja2.Environment:
    import jinja2  # when a script is written: a render from the cache needs none

    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(templates_dir())),
        bytecode_cache=_compiled_templates(jinja2),
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

"""POV-Ray identifiers for converted models: derived from a file name, checked against keywords.

``pov_keywords.txt`` lists every word POV-Ray 3.7 refuses as the name in
``#declare NAME = 1;``: it was made by asking the installed POV-Ray about each
lower-case word in its binary (see the file's header), so it is the parser's
own answer, not a hand-kept list.
"""

from __future__ import annotations

import re
from functools import cache
from importlib import resources
from pathlib import Path

from ..errors import ConfigError, param

_VALID = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
# POV-Ray 3.7 accepts longer names, but keep IDENT_min and friends readable.
MAX_LENGTH = 60


@cache
def pov_keywords() -> frozenset[str]:
    """The reserved words of POV-Ray 3.7."""
    text = resources.files(__package__).joinpath("pov_keywords.txt").read_text(encoding="utf-8")
    return frozenset(w for line in text.splitlines() if (w := line.strip()) and not w.startswith("#"))


def check_identifier(name: str) -> str:
    """``name`` if it can be ``#declare``d, else a ConfigError saying why and what to use."""
    if not _VALID.match(name):
        suggestion = identifier_from_path(name)
        raise ConfigError(f"{param('name')} {name!r} is not a POV-Ray identifier (letters, digits and _, not starting "
                          f"with a digit); use for example {suggestion!r}")
    if len(name) > MAX_LENGTH:
        raise ConfigError(f"{param('name')} {name!r} is longer than {MAX_LENGTH} characters; choose a shorter name")
    if name in pov_keywords():
        raise ConfigError(f"{param('name')} {name!r} is a POV-Ray keyword; choose another name, for example "
                          f"{name.capitalize() + '_model'!r}")
    return name


def identifier_from_path(path: str | Path) -> str:
    """A valid, non-reserved identifier from a file name: ``my-car.obj`` -> ``My_car``.

    The first letter is upper-case: POV-Ray's keywords are all lower-case, and
    its documentation recommends upper-case initials for user names.
    """
    stem = Path(str(path)).stem if "." in str(path) else str(path)
    name = re.sub(r"[^A-Za-z0-9_]+", "_", stem).strip("_") or "Model"
    if name[0].isdigit():
        name = "M_" + name
    name = (name[0].upper() + name[1:])[:MAX_LENGTH]
    return name if name not in pov_keywords() else name + "_model"

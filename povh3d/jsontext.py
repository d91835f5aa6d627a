"""The one JSON reader: every JSON file povh3d reads (sidecars, calibrations, links, cache entries).

Python's decoder recurses once per level, so JSON nested 100,000 deep is a ``RecursionError``,
which no caller expects.  Here it is a ``ValueError`` like any other malformed JSON, and so is a
document deeper than ``MAX_DEPTH`` (no file povh3d reads nests past a handful of levels): each
caller's refusal, or cache miss, holds for it.
"""

from __future__ import annotations

import json
from typing import Any

#: Levels of arrays and objects a JSON document may nest.
MAX_DEPTH = 64


def loads(text: str | bytes, *, max_depth: int = MAX_DEPTH) -> Any:
    """``json.loads(text)``; ``ValueError`` when it is not JSON or nests deeper than ``max_depth``."""
    try:
        value = json.loads(text)
    except RecursionError:
        raise ValueError(f"nested deeper than {max_depth} levels") from None
    if depth(value) > max_depth:
        raise ValueError(f"nested deeper than {max_depth} levels")
    return value


def depth(value: Any) -> int:
    """Levels of lists and dicts in ``value`` (0 for a number or a string); iterative, never recursing."""
    deepest = 0
    stack = [(value, 1)]
    while stack:
        item, level = stack.pop()
        if isinstance(item, dict):
            item = list(item.values())
        if isinstance(item, list):
            deepest = max(deepest, level)
            stack.extend((child, level + 1) for child in item if isinstance(child, (list, dict)))
    return deepest

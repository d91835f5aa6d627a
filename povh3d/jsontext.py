"""The one JSON reader: every JSON file povh3d reads (sidecars, calibrations, links, cache entries), and
the typed records written as JSON (``Record``: the sidecar and its parts, ``image.sidecar``).

Python's decoder recurses once per level, so JSON nested 100,000 deep is a ``RecursionError``,
which no caller expects.  Here it is a ``ValueError`` like any other malformed JSON, and so is a
document deeper than ``MAX_DEPTH`` (no file povh3d reads nests past a handful of levels): each
caller's refusal, or cache miss, holds for it.
"""

from __future__ import annotations

import collections.abc
import dataclasses
import json
import types
import typing
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar, TypeAlias, TypeVar


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


# --- JSON values and typed records -------------------------------------------------------------------
# What a JSON document holds, for the type checker; at run time two markers, so ``Record`` reads a field
# annotated ``JSONValue`` (or ``JSONObject``) as "any JSON, kept as read" without walking a recursive alias.
if TYPE_CHECKING:
    JSONValue: TypeAlias = "None | bool | int | float | str | Sequence[JSONValue] | Mapping[str, JSONValue]"
    JSONObject: TypeAlias = "Mapping[str, JSONValue]"
else:
    class JSONValue:
        """Any JSON value (a marker for ``Record``)."""

    class JSONObject:
        """A JSON object (a marker for ``Record``)."""


R = TypeVar("R", bound="Record")


class Record:
    """A frozen dataclass written to and read from one JSON object: its fields are the object's keys.

    ``to_json`` gives the object; ``from_json`` reads one back and checks every known key's type
    against the field's annotation (``str``, ``int``, ``float``, ``bool``, ``X | None``, ``tuple``,
    another ``Record``, or ``JSONValue`` / ``JSONObject`` for what is open-ended): a wrong type, or a
    field without default that is missing, is one ``InputError`` naming the file, the key and the fix.
    A subclass may declare ``extra: JSONObject`` (keys it does not know, kept as read: a newer povh3d's)
    and ``order: tuple[str, ...]`` (``compare=False``: the keys in the order they were written, so a
    record read and written again is the same bytes).  Without ``order`` the keys follow the fields;
    a field whose default is None is left out while None (unless ``order`` names it: a ``null`` read is
    written back), one without a default is written ``null``.  A value is kept as read: an int where a
    float is typed stays an int, so it is written back as it was.
    """

    def to_json(self) -> dict[str, JSONValue]:
        names = _fields(type(self))
        extra: Mapping[str, JSONValue] = getattr(self, "extra", {}) if "extra" in names else {}
        order: tuple[str, ...] = getattr(self, "order", ()) if "order" in names else ()
        out: dict[str, JSONValue] = {}
        keys = [*order, *(n for n, d in names.items() if n not in _SPECIAL), *extra]
        for key in keys:
            if key in out:
                continue
            if key in names and key not in _SPECIAL:
                value = getattr(self, key)
                if value is None and key not in order and names[key]:   # optional, and not given
                    continue
                out[key] = to_json_value(value)
            elif key in extra:
                out[key] = to_json_value(extra[key])
        return out

    def updated(self: R, **changes: Any) -> R:
        """``dataclasses.replace(self, **changes)``, a key not written before after the others (its ``order``)."""
        names = _fields(type(self))
        if "order" in names:
            order: tuple[str, ...] = getattr(self, "order") or tuple(self.to_json())
            changes["order"] = order + tuple(k for k in changes if k not in order and k != "order")
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    #: The fix a refusal gives (a sidecar's: render the image again).
    FIX: ClassVar[str] = "delete the file or write it again with povh3d"

    @classmethod
    def from_json(cls: type[R], value: object, *, source: object = None, key: str = "", fix: str = "") -> R:
        """``value`` (a parsed JSON object) as this record; ``source``: the file it came from, for the
        error; ``key``: where it sits in that file (``quality``, ``placement.depth``); ``fix``: the
        fix the error gives (the record's ``FIX``)."""
        from .errors import InputError   # here: jsontext stays a leaf of the import graph

        fix = fix or cls.FIX
        where = _where(source, key)
        if not isinstance(value, Mapping):
            raise InputError(f"{where} is {_kind(value)}, not a JSON object; {fix}")
        names = _fields(cls)
        hints = _hints(cls)
        given: dict[str, object] = {}
        for name, optional in names.items():
            if name in _SPECIAL:
                continue
            path = f"{key}.{name}" if key else name
            if name not in value:
                if not optional and not _has_default(cls, name):
                    raise InputError(f"{_where(source, path)} is missing; {fix}")
                continue
            given[name] = _read(hints[name], value[name], source, path, fix)
        if "extra" in names:
            given["extra"] = {k: v for k, v in value.items() if k not in names or k in _SPECIAL}
        if "order" in names:
            given["order"] = tuple(value)
        return cls(**given)


_SPECIAL = ("extra", "order")


def _where(source: object, key: str) -> str:
    name = f"in {str(source)!r}, " if source is not None else ""
    return f"{name}{key or 'the record'}"


def _kind(value: object) -> str:
    """``value`` as the error says it: ``the number 1``, ``the text '8'``, ``a list [...]``."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"{str(value).lower()}"
    what = ("the number" if isinstance(value, (int, float)) else "the text" if isinstance(value, str)
            else "a list" if isinstance(value, (list, tuple)) else "an object" if isinstance(value, Mapping)
            else f"a {type(value).__name__}")
    shown = repr(value)
    return f"{what} {shown[:40]}{'...' if len(shown) > 40 else ''}"


_FIELDS: dict[type, dict[str, bool]] = {}
_HINTS: dict[type, dict[str, object]] = {}


def _fields(cls: type) -> dict[str, bool]:
    """Each field of the dataclass ``cls``: True when its default is None (left out while None)."""
    if cls not in _FIELDS:
        _FIELDS[cls] = {f.name: f.default is None for f in dataclasses.fields(cls)}
    return _FIELDS[cls]


def _has_default(cls: type, name: str) -> bool:
    f = next(f for f in dataclasses.fields(cls) if f.name == name)
    return f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING


def _hints(cls: type) -> dict[str, object]:
    if cls not in _HINTS:
        _HINTS[cls] = typing.get_type_hints(cls)
    return _HINTS[cls]


def to_json_value(value: Any) -> Any:
    """``value`` as JSON: records by their ``to_json``, tuples as lists."""
    if isinstance(value, Record):
        return value.to_json()
    if isinstance(value, (list, tuple)):
        return [to_json_value(v) for v in value]
    if isinstance(value, Mapping):
        return {k: to_json_value(v) for k, v in value.items()}
    return value


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _read(hint: Any, value: object, source: object, key: str, fix: str) -> Any:
    """``value`` checked against ``hint``; a ``Record`` or a tuple built from it."""
    from .errors import InputError

    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1:
            return _read(inner[0], value, source, key, fix)
        for a in inner:   # the first that fits
            try:
                return _read(a, value, source, key, fix)
            except InputError:
                continue
        raise InputError(f"{_where(source, key)} is {_kind(value)}, not {_spelt(hint)}; {fix}")
    if hint is JSONValue or hint is Any:
        return value
    if hint is JSONObject or origin in (Mapping, dict, collections.abc.Mapping):
        if not isinstance(value, Mapping):
            raise InputError(f"{_where(source, key)} is {_kind(value)}, not a JSON object; {fix}")
        return dict(value)
    if isinstance(hint, type) and issubclass(hint, Record):
        return hint.from_json(value, source=source, key=key, fix=fix)
    if origin is tuple:
        if not isinstance(value, list) or (args[-1] is not Ellipsis and len(value) != len(args)):
            raise InputError(f"{_where(source, key)} is {_kind(value)}, not {_spelt(hint)}; {fix}")
        kinds = [args[0]] * len(value) if args[-1] is Ellipsis else list(args)
        return tuple(_read(k, v, source, f"{key}[{i}]", fix) for i, (k, v) in enumerate(zip(kinds, value)))
    fits = {str: lambda v: isinstance(v, str), bool: lambda v: isinstance(v, bool),
            int: lambda v: isinstance(v, int) and not isinstance(v, bool), float: _number}
    if hint in fits:
        if not fits[hint](value):
            raise InputError(f"{_where(source, key)} is {_kind(value)}, not {_spelt(hint)}; {fix}")
        return value
    raise TypeError(f"Record cannot read a field of type {hint!r}")   # a bug in a record's declaration


def _spelt(hint: Any) -> str:
    names = {str: "a string", int: "a whole number", float: "a number", bool: "true or false",
             type(None): "null", JSONObject: "a JSON object", JSONValue: "JSON"}
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_spelt(a) for a in args)
    if origin is tuple:
        return f"a list of {_spelt(args[0])}" if args[-1] is Ellipsis else f"a list of {len(args)} values"
    if isinstance(hint, type) and issubclass(hint, Record):
        return "a JSON object"
    return names.get(hint, str(hint))

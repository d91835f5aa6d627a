"""What each POV-Ray pass around a render cost, for the sidecar's ``passes`` list.

A pass (the scene camera's evaluation, a depth pass, the inside-solid check, the depth maps) says
what it cost with ``note``; ``recording`` collects the notes of one request, in the order the
passes ran.  Outside ``recording`` a note goes nowhere (``povh3d info``, a test calling a pass).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from ...image.sidecar import PassCost   # the sidecar's record of a pass


_NOTES: ContextVar[list[PassCost] | None] = ContextVar("povh3d_pass_notes", default=None)
#: Set in the context of a pass run beside the render (``passes.beside``), whose notes say so.
_BESIDE: ContextVar[bool] = ContextVar("povh3d_pass_beside", default=False)


def mark_beside() -> None:
    """Mark the notes of the current context (a pass's own thread) as made beside the render."""
    _BESIDE.set(True)


@contextmanager
def recording() -> Iterator[list[PassCost]]:
    """Collect the passes run inside the block (a nested block collects its own)."""
    notes: list[PassCost] = []
    token = _NOTES.set(notes)
    try:
        yield notes
    finally:
        _NOTES.reset(token)


def note(name: str, seconds: float, shots: int, runs: int, from_cache: bool = False) -> None:
    """Record a pass in the request being rendered, if any."""
    notes = _NOTES.get()
    if notes is not None:
        notes.append(PassCost(name, seconds, shots, runs, from_cache, True if _BESIDE.get() else None))

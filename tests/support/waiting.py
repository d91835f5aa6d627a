"""Waiting in tests on a condition, never for a fixed time: as short as the machine allows,
and a bound that fails the test loudly instead of hanging it."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def wait_until(condition: Callable[[], T], timeout: float, what: str, step: float = 0.01) -> T:
    """Poll ``condition`` every ``step`` seconds until it is true; its value.

    Raises AssertionError naming ``what`` when ``timeout`` seconds pass first."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        assert time.monotonic() < deadline, f"still not {what} after {timeout} s"
        time.sleep(step)

"""What this machine offers the renderer: the cores this process may use."""

from __future__ import annotations

import os
from functools import cache


@cache
def cpu_count() -> int:
    """Cores this process may run on (its affinity), asked once."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1

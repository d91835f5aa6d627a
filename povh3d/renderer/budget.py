"""What a command will need, estimated before it starts, against what the machine has.

Memory: the memory available (``MemAvailable``) or the user's limit (``--max-memory``, kept in
``POVH3D_MAX_MEMORY`` so that every part of the run and every POV-Ray process sees it), whichever
is smaller.  Disk: the free space of the output's file system.  A command whose estimate is over
either is refused in one line that gives the estimate, before any work; a command whose work
has no use past a count (refocus planes, preview frames) is refused over that count.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from ..errors import ConfigError, param
from ..system import LIMIT_ENV, memory_budget, memory_limit, parse_size

__all__ = ["LIMIT_ENV", "check_count", "check_disk", "check_memory", "memory_budget", "parse_size"]
# Past these the output is of no use to anyone and the work runs for minutes.
MAX_PLANES = 1000
MAX_PREVIEW_FRAMES = 1000


def gib(n: float) -> str:
    return f"{n / 2**30:.3g} GiB"


def check_memory(what: str, need: float, fix: str) -> None:
    """Refuse ``what`` when its estimate ``need`` (bytes) is over the budget."""
    budget = memory_budget()
    if budget is not None and need > budget:
        whose = f"your {param('max_memory')} limit" if memory_limit() is not None and budget == memory_limit() \
            else "the memory available"
        raise ConfigError(f"{what} needs about {gib(need)} of memory, more than {whose} ({gib(budget)}); {fix}")


def check_disk(folder: str | Path, what: str, need: float, fix: str) -> None:
    """Refuse ``what`` when its estimate ``need`` (bytes) is over the free space where it writes."""
    try:
        free = shutil.disk_usage(folder if str(folder) else ".").free
    except OSError:
        return  # the write itself will say what is wrong with the folder
    if need > free:
        raise ConfigError(f"{what} needs about {gib(need)} of disk, more than the {gib(free)} free in "
                          f"{str(folder)!r}; {fix}")


def check_count(what: str, count: int, limit: int, fix: str) -> None:
    if count > limit:
        raise ConfigError(f"{what} is {count}, over {limit}; {fix}")

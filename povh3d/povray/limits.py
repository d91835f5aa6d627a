"""The memory limit of each POV-Ray process (``RLIMIT_AS``), set in the child before exec.

A scene can ask POV-Ray for any amount of memory (``array[150000000]`` twice took 2.4 GB):
each POV-Ray runs under the run's memory budget (``system.memory_budget``: the user's
``--max-memory`` or the memory available), so such a scene fails in POV-Ray
("std::bad_alloc"), not in the machine.
"""

from __future__ import annotations

import os
import resource

from ..system import memory_budget

# Address space POV-Ray 3.7 reserves before a scene asks for anything: measured 400 MB (VmPeak)
# for a small scene with 2 threads, most of it thread stacks and malloc arenas, which grow with
# the threads.  A limit below this would break real renders, so it is never set lower.
BASE_ADDRESS_SPACE = 512 * 2**20
THREAD_ADDRESS_SPACE = 80 * 2**20


def address_space(command: list[str]) -> int | None:
    """The address-space limit of one POV-Ray run of ``command`` (bytes), or None when unknown."""
    budget = memory_budget()
    if budget is None:
        return None
    threads = next((int(a[3:]) for a in command if a.startswith("+WT") and a[3:].isdigit()), os.cpu_count() or 1)
    return max(budget, BASE_ADDRESS_SPACE + threads * THREAD_ADDRESS_SPACE)


def set_address_space(limit: int | None) -> None:
    """In the child, before exec (and before the sandbox): the memory limit."""
    if limit is not None:
        try:
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        except (ValueError, OSError):
            pass  # a hard limit already lower: it holds anyway

"""The mapping of each registry entry built from its example options (shared by the mapping tests)."""

from __future__ import annotations

from povh3d.display.mappings import MAPPINGS


def example(name):
    entry = MAPPINGS[name]
    n = entry.n_range[0] + 1 if entry.n_range else None
    return entry.build(n, entry.example)

"""Benchmark: every pixel mapping of a 3840x2160 panel against a numpy.copy of it.

The index map is built once per mapping and panel (not timed: it is cached);
what is timed is ``Mapping.apply``, one gather, median of several runs, with
the copy measured in the same run.

    .venv/bin/python benchmarks/bench_mapping.py [--repeats 7]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from povh3d.mappings import MAPPINGS, MappingOptions

PANEL = (3840, 2160)
OPTIONS = {"slanted": MappingOptions(per_lens=5.5, views=11, slope=0.75, blend=False),
           "smart": MappingOptions(ppl=6), "distributed-smart": MappingOptions(ppl=6),
           "triangular": MappingOptions(ppl=10), "distributed": MappingOptions(ppl=10)}


def median_seconds(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    panel_image = rng.integers(0, 256, (PANEL[1], PANEL[0], 3), dtype=np.uint8)
    copy = median_seconds(lambda: np.copy(panel_image), args.repeats)
    print(f"numpy.copy of a {PANEL[0]}x{PANEL[1]} RGB image: {copy * 1e3:.2f} ms")
    print(f"{'mapping':22s} {'build (once)':>12s} {'apply':>9s} {'/ copy':>7s}")
    for name, entry in MAPPINGS.items():
        label = f"{name}:4" if entry.n_range else name
        mapping = entry.build(4 if entry.n_range else None, OPTIONS.get(name, MappingOptions()))
        source = rng.integers(0, 256, mapping.source(PANEL).shape, dtype=np.uint8)
        start = time.perf_counter()
        mapping.sample(PANEL)
        build = time.perf_counter() - start
        apply = median_seconds(lambda: mapping.apply(source, PANEL), args.repeats)
        print(f"{label:22s} {build:10.2f} s {apply * 1e3:7.1f} ms {apply / copy:6.1f}x")


if __name__ == "__main__":
    main()

"""Benchmark: every pixel mapping of a 3840x2160 panel against a numpy.copy of it.

The index map and its compressed plan are built once per mapping and panel
(timed separately: they are cached); what is timed is ``Mapping.apply``, the
row gather into a fresh array, against ``numpy.copy`` (also a fresh
array) in the same run.  Hot: the same source again and again (the minimum and
the median: the machine is shared, and a two-thread gather suffers more from a
busy neighbour than a copy does).  Cold: a 64 MB buffer is written between
runs so neither the source nor the index tables start in cache.  ``ref`` is the
old full-index-map fancy-indexing gather (``apply(reference=True)``).

    .venv/bin/python benchmarks/bench_mapping.py [--repeats 15] [--reference]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from povh3d.display.mappings import MAPPINGS, MappingOptions

PANEL = (3840, 2160)
OPTIONS = {"slanted": MappingOptions(per_lens=5.5, views=11, slope=0.75, blend=False),
           "smart": MappingOptions(ppl=6), "distributed-smart": MappingOptions(ppl=6),
           "triangular": MappingOptions(ppl=10), "distributed": MappingOptions(ppl=10)}


def run_times(fn, repeats: int, flush: np.ndarray | None = None) -> list[float]:
    times = []
    for _ in range(repeats):
        if flush is not None:
            flush += 1  # evict caches
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return times


def median_seconds(fn, repeats: int) -> float:
    return statistics.median(run_times(fn, repeats))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--reference", action="store_true", help="also time the old full-index-map gather")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    panel_image = rng.integers(0, 256, (PANEL[1], PANEL[0], 3), dtype=np.uint8)
    flush = np.zeros(64 << 20, np.uint8)
    copy_hot = run_times(lambda: np.copy(panel_image), args.repeats)
    copy_cold = statistics.median(run_times(lambda: np.copy(panel_image), args.repeats, flush))
    c_min, c_med = min(copy_hot), statistics.median(copy_hot)
    print(f"numpy.copy of a {PANEL[0]}x{PANEL[1]} RGB image: hot {c_min * 1e3:.2f} ms min, {c_med * 1e3:.2f} ms "
          f"median; cold {copy_cold * 1e3:.2f} ms median")
    print(f"{'mapping':20s} {'build':>7s} {'apply min':>10s} {'/copy':>6s} {'median':>7s} {'/copy':>6s} "
          f"{'cold':>7s} {'/copy':>6s} {'ref':>6s}")
    for name, entry in MAPPINGS.items():
        label = f"{name}:4" if entry.n_range else name
        mapping = entry.build(4 if entry.n_range else None, OPTIONS.get(name, MappingOptions()))
        source = rng.integers(0, 256, mapping.source(PANEL).shape, dtype=np.uint8)
        start = time.perf_counter()
        mapping.apply(source, PANEL)  # builds and caches the plan
        build = time.perf_counter() - start
        hot = run_times(lambda: mapping.apply(source, PANEL), args.repeats)
        cold = statistics.median(run_times(lambda: mapping.apply(source, PANEL), args.repeats, flush))
        ref = median_seconds(lambda: mapping.apply(source, PANEL, reference=True), 3) if args.reference else 0
        h_min, h_med = min(hot), statistics.median(hot)
        print(f"{label:20s} {build:5.2f} s {h_min * 1e3:7.2f} ms {h_min / c_min:5.1f}x {h_med * 1e3:7.2f} "
              f"{h_med / c_med:5.1f}x {cold * 1e3:7.2f} {cold / copy_cold:5.1f}x"
              + (f" {ref / c_med:5.1f}x" if args.reference else ""))

if __name__ == "__main__":
    main()

"""The compressed mapping plans (display/mappings/plan.py) against the full index maps they replace."""

import numpy as np
import pytest

from povh3d.display.mappings import MAPPINGS, MappingOptions
from povh3d.display.mappings.base import _cached_plan
from povh3d.display.mappings.plan import build_plan
from tests.support.mappings import example
from tests.support.oracles import expand

PANELS = [(360, 216), (131, 77), (97, 12)]  # odd sizes: partial lenses, clipped rows, margins


def reference_map(mapping, panel):
    s = mapping.sample(panel)
    idx = s.index.reshape(panel[1], -1)
    return np.where(s.black.reshape(panel[1], -1), -1, idx) if s.black is not None else idx


@pytest.mark.parametrize("panel", PANELS)
@pytest.mark.parametrize("name", list(MAPPINGS))
def test_plan_encodes_the_index_map_exactly(name, panel):
    m = example(name)
    plan = build_plan(m._sample(panel))
    assert np.array_equal(expand(plan), reference_map(m, panel))


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
@pytest.mark.parametrize("name", list(MAPPINGS))
def test_compiled_apply_matches_the_fancy_indexing_gather(name, dtype):
    m = example(name)
    rng = np.random.default_rng(5)
    for panel in PANELS[:2]:
        src = m.source(panel)
        for channels in (3, 1, 4):
            image = rng.integers(1, 250, (src.rows, src.lenses * src.views, channels)).astype(dtype)
            fast, ref = m.apply(image, panel), m.apply(image, panel, reference=True)
            assert fast.dtype == ref.dtype and np.array_equal(fast, ref), (name, panel, channels)


def test_periodic_mappings_compress_to_a_few_rows():
    # alioscopy repeats every 24 rows (lcm of 3 rows per view row and 8 subpixels of lens for a slope of 1).
    plan = _cached_plan(MAPPINGS["alioscopy"].build(None, MappingOptions()), (384, 240))
    assert plan.unit == 1 and plan.table.shape[0] <= 24 + 6
    smart = _cached_plan(MAPPINGS["smart"].build(3, MappingOptions(ppl=6)), (384, 240))
    assert smart.unit == 3  # whole pixels move together
    # smart:4 / distributed-smart:4 at P 6 repeat every 24 rows; within a view row of 4 rows a
    # one-row shift also holds (3 rows of 4), which a short search window took for the period.
    for name in ("smart", "distributed-smart"):
        plan = _cached_plan(MAPPINGS[name].build(4, MappingOptions(ppl=6)), (640, 400))
        assert plan.table.shape[0] <= 24 + 6, (name, plan.table.shape)


def test_negative_control_a_wrong_table_entry_is_caught():
    m = example("alioscopy")
    panel = (131, 77)
    plan = build_plan(m._sample(panel))
    table = plan.table.copy()
    table[0, 5] += 1
    broken = type(plan)(plan.unit, plan.base, plan.tid, table, plan.black)
    assert not np.array_equal(expand(broken), reference_map(m, panel))


def test_blended_mappings_keep_the_reference_gather():
    m = MAPPINGS["slanted"].build(None, MappingOptions(per_lens=5.5, views=11, slope=0.75, blend=True))
    assert _cached_plan(m, (120, 40)) is None
    src = m.source((120, 40))
    image = np.random.default_rng(0).integers(0, 255, src.shape, dtype=np.uint8)
    assert np.array_equal(m.apply(image, (120, 40)), m.apply(image, (120, 40), reference=True))


@pytest.mark.parametrize("name", ["alioscopy", "philips", "slanted", "smart", "distributed-smart"])
@pytest.mark.parametrize("blend", [False, True])
def test_slanted_maps_built_in_row_blocks_equal_one_block(name, blend, monkeypatch):
    from povh3d.display.mappings.slanted import Slanted

    entry = MAPPINGS[name]
    opts = entry.example if name != "slanted" else MappingOptions(per_lens=5.5, views=11, slope=0.75, blend=blend)
    m = entry.build(entry.n_range[0] if entry.n_range else None, opts)
    panel = (131, 77)
    monkeypatch.setattr(Slanted, "BLOCK_ROWS", 7)
    blocks = m._sample(panel)
    monkeypatch.setattr(Slanted, "BLOCK_ROWS", 10**9)
    whole = m._sample(panel)
    for a, b in [(blocks.index, whole.index), (blocks.black, whole.black), (blocks.index2, whole.index2),
                 (blocks.weight, whole.weight)]:
        assert (a is None and b is None) or np.array_equal(a, b)

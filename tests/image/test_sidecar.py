"""The typed sidecar (``image.sidecar.Sidecar``, ``jsontext.Record``): every key it knows checked on read,
refused in one line naming the file, the key and the fix; unknown keys kept; the bytes of a sidecar read
and written again unchanged; ``from_json(to_json(x)) == x``.  Controls: a valid sidecar reads, and the
same file with the one key damaged does not."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.display.display import build_display
from povh3d.errors import InputError
from povh3d.image.io import read_sidecar, read_sidecar_record, sidecar_path, write_sidecar
from povh3d.image.sidecar import (AnimationRecord, LensArrayRecord, PassCost, PlacementRecord, QualityRecord,
                                  Sidecar, Timings)
from povh3d.renderer.records import base_record, write_image


def _written(tmp_path, **entries):
    """A sidecar as the render path writes it: the display's lens array and entries, then ``entries``."""
    display = build_display("demo")
    record = base_record("h3d", method="multi-ortho", quality=QualityRecord(level="draft", bit_depth=8),
                         timings=Timings(render_seconds=1.5, shots=1, shots_from_cache=0))
    record = record.with_(**display.as_record(), **entries)
    path = tmp_path / "a.png"
    write_image(path, np.zeros((4, 4, 3), np.uint8), record)
    return path


def _damage(path, key, value):
    side = sidecar_path(path)
    document = json.loads(side.read_text())
    target = document
    for part in key[:-1]:
        target = target[part]
    target[key[-1]] = value
    side.write_text(json.dumps(document, indent=2) + "\n")


def test_a_valid_sidecar_reads_typed(tmp_path):
    path = _written(tmp_path, passes=(PassCost("depth", 0.25, 2, 1),), note="kept")
    side = read_sidecar_record(path)
    assert side is not None and side.kind == "h3d" and side.method == "multi-ortho"
    assert side.quality == QualityRecord(level="draft", bit_depth=8)
    assert side.timings is not None and side.timings.render_seconds == 1.5
    assert side.passes == (PassCost("depth", 0.25, 2, 1),)
    assert isinstance(side.lens_array, LensArrayRecord) and side.lens_array.lenses == (40, 30)
    assert side.extra == {"note": "kept"} and side.get("note") == "kept"   # unknown: kept, not typed
    assert side.image_sha256 is not None and len(side.image_sha256) == 64


@pytest.mark.parametrize("key, bad, named", [
    (("quality", "bit_depth"), "8", "quality.bit_depth is the text '8', not a whole number"),
    (("timings", "render_seconds"), [1], "timings.render_seconds is a list [1], not a number;"),
    (("lens_array", "lenses"), [40], "lens_array.lenses is a list [40], not a list of 2 values"),
    (("lens_array", "panel", "size_px"), [320, 2.5], "lens_array.panel.size_px[1] is the number 2.5"),
    (("passes",), [{"name": "depth"}], "passes[0].seconds is missing"),
    (("kind",), 3, "kind is the number 3, not a string"),
    (("method_chosen",), "no", "method_chosen is the text 'no', not true or false;"),
])
def test_a_wrong_type_is_one_line_naming_the_file_the_key_and_the_fix(tmp_path, key, bad, named):
    path = _written(tmp_path)
    assert read_sidecar_record(path) is not None          # control: the same file, undamaged, reads
    _damage(path, key, bad)
    with pytest.raises(InputError) as error:
        read_sidecar_record(path)
    message = str(error.value)
    assert "\n" not in message and str(sidecar_path(path)) in message and named in message
    assert message.endswith("delete the sidecar or render the image again")


def test_a_missing_required_key_is_refused(tmp_path):
    path = _written(tmp_path)
    side = sidecar_path(path)
    document = json.loads(side.read_text())
    del document["povh3d_version"]
    side.write_text(json.dumps(document))
    with pytest.raises(InputError, match=r"povh3d_version is missing; delete the sidecar"):
        read_sidecar_record(path)
    assert read_sidecar(path) is not None   # the plain reader still reads it (a hand-made sidecar)


def test_a_sidecar_read_and_written_again_is_the_same_bytes(tmp_path):
    """Key order, nulls, unknown keys (a newer povh3d's) and floats: all as they were."""
    path = _written(tmp_path, crop=None, placement={"source": "native", "warnings": [], "zz": {"b": 1, "a": 2}},
                    newer={"x": [1.0, 2]}, scheduler=None)
    before = sidecar_path(path).read_bytes()
    side = read_sidecar_record(path)
    assert side is not None and isinstance(side.placement, PlacementRecord)
    assert side.placement.extra == {"zz": {"b": 1, "a": 2}}
    write_sidecar(path, side)
    assert sidecar_path(path).read_bytes() == before
    # control: a changed value is other bytes
    write_sidecar(path, side.with_(method="single-stage"))
    assert sidecar_path(path).read_bytes() != before


def test_with_adds_a_key_after_the_others_and_keeps_a_known_one_in_place():
    side = Sidecar.new("h3d", method="multi-ortho", note="a")
    assert list(side.to_json()) == ["povh3d_version", "kind", "method", "note"]
    changed = side.with_(kind="panel", mapping="m", method="x")
    assert list(changed.to_json()) == ["povh3d_version", "kind", "method", "note", "mapping"]
    assert changed.kind == "panel" and changed.method == "x" and dict(changed)["mapping"] == "m"
    with pytest.raises(InputError, match="timings.shots is the text '1'"):
        side.with_(timings={"shots": "1"})   # a typed key given as JSON is checked as read


_text = st.text(max_size=12)
_number = st.floats(allow_nan=False, allow_infinity=False, width=64)
_json_leaf = st.none() | st.booleans() | st.integers(-10**6, 10**6) | _number | _text
_json = st.recursive(_json_leaf, lambda inner: st.lists(inner, max_size=3)
                     | st.dictionaries(_text, inner, max_size=3), max_leaves=8)


@st.composite
def sidecars(draw):
    quality = draw(st.none() | st.builds(QualityRecord, level=_text, bit_depth=st.none() | st.sampled_from([8, 16]),
                                         front_clearance_mm=st.none() | _number,
                                         povray_options=st.none() | st.lists(_text, max_size=3).map(tuple)))
    timings = draw(st.none() | st.builds(Timings, render_seconds=st.none() | _number,
                                         shots=st.none() | st.integers(0, 999), output_from_cache=st.none() | st.booleans()))
    passes = draw(st.none() | st.lists(st.builds(PassCost, _text, st.floats(0, 1e4).map(lambda s: round(s, 4)),
                                                 st.integers(0, 99), st.integers(0, 99), st.booleans()),
                                       max_size=3).map(tuple))
    animation = draw(st.none() | st.builds(AnimationRecord, frame=st.integers(0, 9999), clock=st.none() | _number))
    extra = draw(st.dictionaries(_text.filter(lambda k: k not in Sidecar.__dataclass_fields__), _json, max_size=3))
    warnings = draw(st.none() | st.lists(_text, max_size=3).map(tuple))
    return Sidecar(povh3d_version=draw(_text), kind=draw(_text), method=draw(st.none() | _text), quality=quality,
                   timings=timings, passes=passes, animation=animation, warnings=warnings, extra=extra,
                   size_px=draw(st.none() | st.tuples(st.integers(1, 9999), st.integers(1, 9999))))


@settings(max_examples=60, deadline=None)
@given(side=sidecars())
def test_from_json_of_to_json_is_the_record(side):
    document = json.loads(json.dumps(side.to_json()))   # through the bytes, as a file holds it
    assert Sidecar.from_json(document) == side
    assert Sidecar.from_json(document).to_json() == document


def test_the_round_trip_can_fail():
    # control of the round trip: a record whose field does not survive JSON (a float where an int is typed
    # reads back refused), so the equality above is a real comparison
    side = Sidecar(povh3d_version="0", kind="h3d", size_px=(4, 4))
    document = side.to_json()
    document["size_px"] = [4.0, 4]
    with pytest.raises(InputError, match=r"size_px\[0\] is the number 4.0, not a whole number"):
        Sidecar.from_json(document)
    assert Sidecar.from_json({**side.to_json(), "size_px": [4, 5]}) != side


@pytest.mark.povray
def test_a_render_s_sidecar_reads_back_typed_and_byte_for_byte(tmp_path):
    """The render path's record (quality, timings, passes, display frame) is the typed sidecar: what
    ``povh3d.render`` returns is its JSON, it reads back as ``Sidecar`` and is written back the same bytes."""
    from pathlib import Path

    import povh3d

    out = tmp_path / "s.png"
    scene = Path(__file__).parents[2] / "sample_models" / "sample.pov"
    record = povh3d.render(scene, out, preset="demo", quality="draft", use_cache=False)
    side = read_sidecar_record(out)
    assert side is not None and side.kind == "h3d" and side.method == "multi-ortho"
    assert isinstance(side.quality, QualityRecord) and side.quality.front_clearance_mm is not None
    assert side.timings is not None and side.timings.total_seconds is not None and side.timings.shots == 1
    assert isinstance(side.placement, PlacementRecord) and side.placement.source == "native"
    assert side.passes is not None and all(isinstance(p, PassCost) for p in side.passes)
    assert {k: v for k, v in side.to_json().items() if k != "image_sha256"} == record
    before = sidecar_path(out).read_bytes()
    write_sidecar(out, side)
    assert sidecar_path(out).read_bytes() == before


def test_a_signal_between_the_two_renames_waits_until_the_pair_is_in_place(tmp_path, monkeypatch):
    """SIGTERM right after the image's rename (as in tests/renderer/test_reliability.py's fault matrix):
    the run stops after the sidecar's rename too, so the new image never sits beside the old sidecar."""
    import os
    import signal

    import numpy as np

    from povh3d.image import io

    path = tmp_path / "out.png"
    io.write_image_pair(path, np.zeros((2, 2, 3), np.uint8), {"povh3d_version": "x", "kind": "h3d", "n": 1})
    real, renames = os.replace, []

    def replace_then_signal(src, dst):
        real(src, dst)
        renames.append(dst)
        if len(renames) == 1:   # the image is in place
            os.kill(os.getpid(), signal.SIGTERM)

    def stop(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, stop)
    monkeypatch.setattr(io.os, "replace", replace_then_signal)
    try:
        with pytest.raises(KeyboardInterrupt):
            io.write_image_pair(path, np.ones((2, 2, 3), np.uint8), {"povh3d_version": "x", "kind": "h3d", "n": 2})
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert len(renames) == 2   # both renamed before the signal was handled
    assert io.read_sidecar(path)["n"] == 2   # the new pair, whole

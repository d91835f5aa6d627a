"""The 3DCDP header: exact round trips through the schema, and what it refuses."""

from __future__ import annotations

import dataclasses

import pytest

from povh3d.errors import InputError
from povh3d.hyper.cdp import Annotation, BoundingBox, CdpHeader, Scene, SearchResultItem, from_xml, to_xml


def _header() -> CdpHeader:
    hits = (SearchResultItem("https://example.org/ball", "video", 87.5, "a <red> ball & more"),
            SearchResultItem("https://example.org/x.png", "image", 0.1 + 0.2, ""))   # http(s) and mailto only
    ball = Annotation(1, "ball", 3, 0, 1, "https://example.org/ball", "the ball", (
        BoundingBox(1, 0, "view", (2, 3, 9, 12), "the ball", "https://example.org/u", hits),
        BoundingBox(2, 0, "h3d", (16, 24, 79, 103)),
        BoundingBox(3, 1, "view", (3, 3, 10, 12))))
    box = Annotation(2, "box é", 1, 1, 1, "", "", (BoundingBox(1, 1, "view", (0, 0, 0, 0)),))
    again = Annotation(3, "ball", 3, 4, 5)
    return CdpHeader("6f1c2b1e-0000-5000-8000-000000000000", "clip", "clip.png", (8, 8), (3, 3), (40, 30),
                     (320, 240), "povh3d render", (Scene(1, 0, 5, "", (ball, box, again)),))


def test_header_round_trips_exactly() -> None:
    header = _header()
    xml = to_xml(header)
    assert from_xml(xml) == header
    assert to_xml(from_xml(xml)) == xml
    assert b'noNamespaceSchemaLocation="THREEDCDP.xsd"' in xml


def test_round_trip_oracle_negative_control() -> None:
    """A header with one box moved by a pixel compares unequal (the equality above could fail)."""
    header = _header()
    scene = header.scenes[0]
    a = scene.annotations[0]
    moved = dataclasses.replace(a, boxes=(dataclasses.replace(a.boxes[0], box=(2, 3, 9, 13)),) + a.boxes[1:])
    other = dataclasses.replace(header, scenes=(dataclasses.replace(scene, annotations=(moved,) + scene.annotations[1:]),))
    assert other != header and to_xml(other) != to_xml(header)


@pytest.mark.parametrize("edit, named", [
    (lambda x: x.replace(b"<UUID>", b"<Colour/><UUID>"), "Element 'Colour'"),
    (lambda x: x.replace(b'<Min X="2"', b'<Min Z="1" X="2"'), "attribute 'Z'"),
    (lambda x: x.replace(b'space="h3d"', b'space="depth"'), "'depth'"),
    (lambda x: x.replace(b'<Max X="9" Y="12"/>', b""), "Element 'SearchResult'"),
])
def test_unknown_or_wrong_parts_are_refused_by_name(edit, named) -> None:
    with pytest.raises(InputError, match=named) as info:
        from_xml(edit(to_xml(_header())), "h.xml")
    assert "\n" not in str(info.value) and "h.xml" in str(info.value)


@pytest.mark.parametrize("data, why", [
    (lambda x: x[: len(x) // 2], "not well-formed"),
    (lambda x: b"<Scene/>", "root is <Scene>"),
    (lambda x: x.replace(b'SearchResultCounter="2"', b'SearchResultCounter="3"'), "says 3 but 2"),
    (lambda x: x.replace(b'wholeDuration="6"', b'wholeDuration="7"'), "wholeDuration"),
    (lambda x: x.replace(b'<BoundingBox ID="3" frame="1"', b'<BoundingBox ID="3" frame="2"'), "box in frame 2"),
    (lambda x: x.replace(b'<!DOCTYPE', b'').replace(b"<?xml version='1.0' encoding='utf-8'?>",
                         b"<?xml version='1.0'?><!DOCTYPE CDP [<!ENTITY e SYSTEM 'file:///etc/passwd'>]>")
     .replace(b"<UUID>", b"<UUID>&e;"), "DOCTYPE"),
])
def test_damaged_headers_are_one_line(data, why) -> None:
    with pytest.raises(InputError, match=why) as info:
        from_xml(data(to_xml(_header())))
    assert "\n" not in str(info.value) and "root:" not in str(info.value)


def test_values_refuse_inverted_boxes() -> None:
    with pytest.raises(ValueError, match="min <= max"):
        BoundingBox(1, 0, "view", (5, 0, 4, 3))

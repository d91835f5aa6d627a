"""``povh3d annotate`` on a synthetic animation: boxes in the centre view and in the H3D image
against their analytic places, merged annotations, links, and bad input as one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from povh3d.commands.annotate import annotate, read_header
from tests.support.cli import run_in_process as run_cli

from tests.support.objects_render import FRAMES, LX, LY, NX, NY, moving_objects_render as _render


def test_boxes_merge_into_annotations_at_their_analytic_places(tmp_path: Path) -> None:
    render = _render(tmp_path)
    (tmp_path / "links.toml").write_text('[ball]\nurl = "https://example.org/ball"\ndescription = "a ball"\n')
    record = annotate(render, tmp_path / "objects", tmp_path / "clip.cdp.xml", links=tmp_path / "links.toml")
    assert record == {"output": str(tmp_path / "clip.cdp.xml"), "objects": 2, "annotations": 3, "frames": [0, 3]}
    header = read_header(tmp_path / "clip.cdp.xml")
    assert header.views == (NX, NY) and header.view_size == (LX, LY) and header.h3d_size == (NX * LX, NY * LY)
    anns = header.scenes[0].annotations
    assert [(a.object_name, a.start, a.end, a.url) for a in anns] == \
        [("ball", 0, 0, "https://example.org/ball"), ("box", 0, 3, ""), ("ball", 3, 3, "https://example.org/ball")]
    box = {(b.frame, b.space): b.box for b in anns[1].boxes}
    for n in FRAMES:
        assert box[(n, "view")] == (3 + n, 2, 7 + n, 5)
        # every view holds the box: whole lenses are covered, NX (NY) pixels per lens
        assert box[(n, "h3d")] == ((3 + n) * NX, 2 * NY, (7 + n) * NX + NX - 1, 5 * NY + NY - 1)


def test_annotate_refuses_a_links_file_naming_an_unknown_object(tmp_path: Path) -> None:
    render = _render(tmp_path)
    (tmp_path / "links.json").write_text('{"cat": {"url": "https://x"}}')
    (tmp_path / "out.xml").write_text("old")
    result = run_cli("annotate", str(render), "--objects", str(tmp_path / "objects"), "-o", str(tmp_path / "out.xml"),
                     "--links", str(tmp_path / "links.json"))
    assert result.code != 0 and "'cat'" in result.err and result.err.count("\n") == 1
    assert (tmp_path / "out.xml").read_text() == "old"


def test_annotate_refuses_masks_that_contradict_the_render(tmp_path: Path) -> None:
    render = _render(tmp_path)
    (tmp_path / "clip_0003.png").unlink()
    (tmp_path / "clip_0003.json").unlink()
    with pytest.raises(Exception, match=r"frames 0..3 \(4\) but the render has 0..2 \(3\)"):
        annotate(render, tmp_path / "objects", tmp_path / "out.xml")
    assert not (tmp_path / "out.xml").exists()


def test_viewer_refuses_a_damaged_header(tmp_path: Path) -> None:
    render = _render(tmp_path)
    annotate(render, tmp_path / "objects", tmp_path / "h.xml")
    (tmp_path / "h.xml").write_bytes((tmp_path / "h.xml").read_bytes().replace(b"<UUID>", b"<Uuid/><UUID>"))
    result = run_cli("viewer", str(render), "--cdp", str(tmp_path / "h.xml"), "-o", str(tmp_path / "v.html"))
    assert result.code != 0 and "Element 'Uuid'" in result.err and result.err.count("\n") == 1
    assert not (tmp_path / "v.html").exists()


def test_viewer_refuses_a_header_of_another_render(tmp_path: Path) -> None:
    render = _render(tmp_path)
    annotate(render, tmp_path / "objects", tmp_path / "h.xml")
    for n in (2, 3):
        for suffix in (".png", ".json"):
            (tmp_path / f"clip_{n:04d}{suffix}").unlink()
    result = run_cli("viewer", str(render), "--cdp", str(tmp_path / "h.xml"), "-o", str(tmp_path / "v.html"))
    assert result.code != 0 and "frame 2" in result.err and result.err.count("\n") == 1
    assert not (tmp_path / "v.html").exists()

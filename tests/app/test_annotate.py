"""``povh3d annotate`` on a synthetic animation: boxes in the centre view and in the H3D image
against their analytic places, merged annotations, links, and bad input as one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from povh3d.app.annotate import annotate, read_header
from povh3d.app.objects import ObjectTable, write_masks
from povh3d.app.records import base_record
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.interleave import interleave
from povh3d.image.io import write_image_pair
from tests.support.cli import run_in_process as run_cli

NY, NX, LY, LX = 4, 4, 12, 16            # 4x4 views of 16x12: a 64x48 panel
FRAMES = [0, 1, 2, 3]


def _render(folder: Path) -> Path:
    """A 4-frame animation: a box (id 1) moving right in every frame, a ball (id 2) in frames 0 and 3."""
    la = LensArray("square", LX, LY, 0.4, 0.4, 1.0, Panel(NX * LX, NY * LY, 0.1, 0.1))
    masks = {}
    for n in FRAMES:
        ids = np.zeros((NY, NX, LY, LX), np.uint16)
        ids[:, :, 2:6, 3 + n:8 + n] = 1               # rows 2..5, columns 3+n..7+n in every view
        if n in (0, 3):
            ids[:, :, 8:11, 1:3] = 2                  # rows 8..10, columns 1..2
        masks[n] = ids
        colour = np.repeat((ids * 100)[..., None], 3, axis=-1).astype(np.uint8)
        record = {**base_record("h3d", la), "animation": {"frame": n, "frames": [0, 3]}}
        write_image_pair(folder / f"clip_{n:04d}.png", interleave(colour), record)
    write_masks(folder / "objects", ObjectTable({1: "box", 2: "ball"}, tuple(FRAMES), (NY, NX), (LY, LX)), masks)
    return folder / "clip.png"


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

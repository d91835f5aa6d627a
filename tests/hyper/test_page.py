"""The viewer page's pure parts: the sprite sheet's tiling and the embedded data."""

from __future__ import annotations

import base64
import json
import re

import numpy as np
import pytest

from povh3d.hyper.page import ViewerContent, page_data, sprite_sheet, viewer_html
from povh3d.image.io import decode_png


def _stack(ny: int, nx: int, ly: int = 3, lx: int = 4) -> np.ndarray:
    rng = np.random.default_rng(7)
    return rng.integers(0, 256, (ny, nx, ly, lx, 3), dtype=np.uint8)


@pytest.mark.parametrize("ny, nx", [(1, 5), (3, 4), (4, 4)])
def test_sprite_sheet_places_view_l_k_at_row_l_column_k(ny: int, nx: int) -> None:
    views = _stack(ny, nx)
    sheet = sprite_sheet(views)
    ly, lx = views.shape[2:4]
    for l in range(ny):
        for k in range(nx):
            assert np.array_equal(sheet[l * ly:(l + 1) * ly, k * lx:(k + 1) * lx], views[l, k])


def test_sprite_sheet_negative_control_transposed_tiling_differs() -> None:
    views = _stack(3, 4)
    wrong = views.transpose(1, 0, 2, 3, 4)  # columns for rows: the oracle must see it
    sheet = sprite_sheet(views)
    assert not np.array_equal(sprite_sheet(wrong)[:3, :4], sheet[:3, :4]) or \
        not np.array_equal(sprite_sheet(wrong)[3:6, :4], sheet[3:6, :4])


def test_embedded_sprite_decodes_to_the_views() -> None:
    views = _stack(2, 3)
    uri = page_data(ViewerContent((views,)))["sprites"][0]
    png = base64.b64decode(uri.split(",", 1)[1])
    assert np.array_equal(decode_png(png, "sprite"), sprite_sheet(views))


def test_sixteen_bit_views_are_rounded_to_eight() -> None:
    views = np.full((1, 2, 2, 2, 3), 65535, np.uint16)
    views[0, 1] = 257 * 100 + 129  # 100.502 in 8 bits rounds up
    png = base64.b64decode(page_data(ViewerContent((views,)))["sprites"][0].split(",", 1)[1])
    sheet = decode_png(png, "sprite")
    assert sheet.dtype == np.uint8 and sheet[0, 0, 0] == 255 and sheet[0, 2, 0] == 101


def test_page_holds_its_data_and_escapes_script_ends() -> None:
    html = viewer_html(ViewerContent((_stack(1, 2),), title="a <b> & c", cdp="</script><x/>"))
    assert "https://" not in html and "http://" not in html   # nothing fetched: it opens from file://
    assert "<title>a &lt;b&gt; &amp; c</title>" in html
    blob = re.search(r'<script id="povh3d-data" type="application/json">(.*?)</script>', html, re.S)[1]
    data = json.loads(blob)
    assert data["cdp"] == "</script><x/>" and data["views"] == [1, 2] and data["view_size"] == [3, 4]


@pytest.mark.parametrize("bad, what", [((), "at least one frame"), ((_stack(1, 2), _stack(1, 3)), "same views")])
def test_content_refuses_bad_frames(bad, what) -> None:
    with pytest.raises(ValueError, match=what):
        ViewerContent(bad)

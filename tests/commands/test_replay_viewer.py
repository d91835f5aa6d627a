"""The viewer page of a replay sweep (`povh3d replay --sweep`, commands/replay.py `_write_sweep`) in a
real headless Chromium: the mouse's place picks the eye, and the picture drawn is that eye's frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

from povh3d.display import presets
from povh3d.image.io import read_png
from povh3d.image.preview import enlarge
from povh3d.image.video import to_rgb8
from povh3d.renderer.records import base_record, write_image
from tests.support.browser import headless_chromium, open_page


@pytest.fixture(scope="module")
def browser():
    with headless_chromium() as b:
        yield b


def _drawn(browser) -> tuple[int, int, tuple[int, int, int], tuple[float, float], int, int]:
    """The view the page shows, the colour at its canvas's centre, the page's scale (x, y: a view pixel
    drawn at its physical aspect, 1 here) and the canvas size."""
    l, k, rgb, scale, w, h = browser.execute_script("""
        const v = window.povh3dViewer, c = v.canvas;
        const px = c.getContext('2d').getImageData(c.width >> 1, c.height >> 1, 1, 1).data;
        return [v.state.l, v.state.k, [px[0], px[1], px[2]], [v.scale.x, v.scale.y], c.width, c.height];""")
    return l, k, tuple(rgb), (scale[0], scale[1]), w, h


@pytest.mark.parametrize("axis, count", [("x", 5), ("y", 4)])
def test_sweep_page_shows_the_eye_under_the_mouse(tmp_path: Path, cli, browser, axis: str, count: int) -> None:
    la = presets.lens_array("demo")
    p = la.panel
    rng = np.random.default_rng(3)
    h3d = tmp_path / "h.png"
    write_image(h3d, rng.integers(0, 256, (p.height, p.width, 3), dtype=np.uint8), base_record("h3d", la))
    sweep = f"-60:60:{count}" if axis == "x" else f"y:-40:40:{count}"
    r = cli("replay", str(h3d), "--sweep", sweep, "-o", str(tmp_path / "s.gif"))
    assert r.code == 0, r.err
    page = tmp_path / "s.html"
    assert page.is_file() and "file://" not in page.read_text()[:200]
    frames = [to_rgb8(read_png(tmp_path / f"s_{n:03d}.png")) for n in range(count)]
    scale = max(1, 480 // frames[0].shape[1])
    big = [enlarge(f, (scale, scale)) for f in frames]
    open_page(browser, page)
    canvas = browser.find_element(By.ID, "view")
    width, height = canvas.size["width"], canvas.size["height"]
    seen = set()
    for n in range(count):
        f = (n + 0.5) / count  # the middle of eye n's stretch of the canvas
        fx, fy = (f, 0.5) if axis == "x" else (0.5, f)
        ActionChains(browser).move_to_element_with_offset(
            canvas, int((fx - 0.5) * width), int((fy - 0.5) * height)).perform()
        l, k, rgb, page_scale, w, h = _drawn(browser)
        assert (k if axis == "x" else l) == n and (l if axis == "x" else k) == 0
        assert page_scale[0] == page_scale[1]   # a replay frame's pixels are square
        centre = int((h >> 1) // page_scale[1]), int((w >> 1) // page_scale[0])
        assert rgb == tuple(int(c) for c in big[n][centre])  # the picture is eye n's frame
        seen.add(rgb)
    # negative control: the frames differ where the page samples them, so a page showing the wrong eye fails
    assert len(seen) >= count - 1

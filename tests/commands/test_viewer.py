"""The viewer page in a real headless Chromium: the view follows the mouse and the arrow
keys, video plays, and the bundled sample's page opens in under a second."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys

from povh3d.commands.viewer import write_viewer
from povh3d.renderer.outputs.views import write_views
from povh3d.errors import InputError
from povh3d.image.io import write_png
from tests.support.browser import headless_chromium, open_page

ROOT = Path(__file__).resolve().parents[2]


def _coded_views(ny: int, nx: int, frame: int = 0) -> np.ndarray:
    """Each view one flat colour that names it: red = 20 l + 10, green = 20 k + 10, blue = 40 frame."""
    views = np.zeros((ny, nx, 6, 8, 3), np.uint8)
    views[..., 0] = (20 * np.arange(ny) + 10)[:, None, None, None]
    views[..., 1] = (20 * np.arange(nx) + 10)[None, :, None, None]
    views[..., 2] = 40 * frame
    return views


def _shown(browser) -> tuple[int, int, int, tuple[int, int, int]]:
    """The view and frame the page says it shows, and the colour at the canvas's centre."""
    l, k, f, rgb = browser.execute_script("""
        const v = window.povh3dViewer, c = v.canvas;
        const px = c.getContext('2d').getImageData(c.width >> 1, c.height >> 1, 1, 1).data;
        return [v.state.l, v.state.k, v.state.frame, [px[0], px[1], px[2]]];""")
    return l, k, f, tuple(rgb)


def _colour_names(rgb: tuple[int, int, int]) -> tuple[int, int, int]:
    return (rgb[0] - 10) // 20, (rgb[1] - 10) // 20, rgb[2] // 40


@pytest.fixture(scope="module")
def browser():
    with headless_chromium() as b:
        yield b


@pytest.mark.parametrize("ny, nx", [(5, 7), (1, 9)])   # a square/hex bank and a lenticular row
def test_view_follows_mouse_and_arrow_keys(tmp_path: Path, browser, ny: int, nx: int) -> None:
    write_views(tmp_path / "views", _coded_views(ny, nx), None)
    page = tmp_path / "view.html"
    write_viewer(tmp_path / "views", page)
    open_page(browser, page)
    canvas = browser.find_element(By.ID, "view")
    width, height = canvas.size["width"], canvas.size["height"]
    seen = set()
    for fx, fy in [(0.05, 0.05), (0.95, 0.95), (0.5, 0.3), (0.33, 0.7)]:  # away from view borders
        ActionChains(browser).move_to_element_with_offset(
            canvas, int((fx - 0.5) * width), int((fy - 0.5) * height)).perform()
        l, k, frame, rgb = _shown(browser)
        # the mouse's place picks the view (column from x; row from y unless one row) ...
        assert (l, k) == ((int(fy * ny) if ny > 1 else 0), int(fx * nx))
        # ... and the pixels drawn are that view's (its colour names it)
        assert _colour_names(rgb) == (l, k, 0)
        seen.add((l, k))
    assert len(seen) == 4 if ny > 1 else len(seen) >= 3
    browser.find_element(By.TAG_NAME, "body").send_keys(Keys.ARROW_LEFT)
    l0, k0 = _shown(browser)[:2]
    browser.find_element(By.TAG_NAME, "body").send_keys(Keys.ARROW_RIGHT, Keys.ARROW_RIGHT)
    l1, k1, _, rgb = _shown(browser)
    assert (l1, k1) == (l0, min(nx - 1, k0 + 2)) and _colour_names(rgb)[:2] == (l1, k1)
    browser.find_element(By.TAG_NAME, "body").send_keys(Keys.ARROW_UP)
    assert _shown(browser)[:2] == (max(0, l1 - 1), k1)


def test_colour_oracle_negative_control() -> None:
    """The colour oracle tells neighbouring views and frames apart (else the test above could not fail)."""
    views = _coded_views(5, 7)
    names = {_colour_names(tuple(int(c) for c in views[l, k, 0, 0])) for l in range(5) for k in range(7)}
    assert len(names) == 35
    assert _colour_names(tuple(int(c) for c in _coded_views(5, 7, 1)[2, 3, 0, 0])) != (2, 3, 0)


def test_play_steps_the_frames_of_an_animation(tmp_path: Path, browser) -> None:
    from povh3d.renderer.records import base_record
    from povh3d.geometry.lens_array import LensArray, Panel
    from povh3d.image.interleave import interleave
    from povh3d.image.io import write_image_pair

    la = LensArray("square", 4, 3, 0.4, 0.4, 1.0, Panel(16, 12, 0.1, 0.1))   # 4x4 views of 4x3
    for n in range(3):
        record = {**base_record("h3d", la), "animation": {"frame": n, "frames": [0, 2]}}
        write_image_pair(tmp_path / f"clip_{n:04d}.png", interleave(_coded_views(4, 4, n)[:, :, :3, :4]), record)
    page = tmp_path / "clip.html"
    assert write_viewer(tmp_path / "clip.png", page, fps=20)["frames"] == 3
    open_page(browser, page)
    assert browser.find_element(By.ID, "play").is_displayed()
    frames = set()
    browser.find_element(By.ID, "play").click()
    for _ in range(12):
        browser.execute_script("return new Promise(r => setTimeout(r, 40))")
        l, k, f, rgb = _shown(browser)
        assert _colour_names(rgb) == (l, k, f)
        frames.add(f)
    browser.find_element(By.ID, "play").click()
    paused = _shown(browser)[2]
    browser.execute_script("return new Promise(r => setTimeout(r, 200))")
    assert frames == {0, 1, 2} and _shown(browser)[2] == paused


@pytest.mark.povray
def test_bundled_sample_page_opens_in_under_a_second(tmp_path: Path, browser) -> None:
    env_cache = {"POVH3D_CACHE": str(tmp_path / "cache")}
    import os
    run = subprocess.run([sys.executable, "-m", "povh3d.cli", "render", str(ROOT / "sample_models" / "sample.pov"),
                          "--preset", "demo", "--quality", "draft", "-o", str(tmp_path / "sample.png")],
                         capture_output=True, text=True, env={**os.environ, **env_cache}, timeout=600)
    assert run.returncode == 0, run.stderr
    page = tmp_path / "sample.html"
    write_viewer(tmp_path / "sample.png", page)
    open_page(browser, page)
    ready_ms = browser.execute_script("return window.povh3dViewer.readyMs")
    nav = browser.execute_script("const n = performance.getEntriesByType('navigation')[0];"
                                 "return [n.domContentLoadedEventEnd, n.loadEventEnd]")
    assert 0 < ready_ms < 1000 and 0 < nav[1] < 1000, (ready_ms, nav)


def test_viewer_refuses_bad_input_and_writes_nothing(tmp_path: Path) -> None:
    write_png(tmp_path / "lone.png", np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(InputError, match="no sidecar"):
        write_viewer(tmp_path / "lone.png", tmp_path / "v.html")
    with pytest.raises(InputError, match="neither an H3D image"):
        write_viewer(tmp_path / "nothing.png", tmp_path / "v.html")
    with pytest.raises(InputError, match=r"\.html"):
        write_viewer(tmp_path / "lone.png", tmp_path / "v.txt")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lone.png"]

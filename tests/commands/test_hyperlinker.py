"""The hyperlinker in headless Chromium: boxes over the views, a click reports the right
object's link, edits come back in the exported XML, and the player's actions are timed
(the thesis's Table 4.3; docs/viewer.md)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

from povh3d.commands.annotate import annotate
from povh3d.commands.viewer import write_viewer
from povh3d.hyper.cdp import from_xml
from tests.support.browser import headless_chromium, open_page
from tests.support.objects_render import LX, LY, moving_objects_render


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hyper")
    render = moving_objects_render(folder)
    (folder / "links.toml").write_text('[ball]\nurl = "https://example.org/ball"\ndescription = "a ball"\n'
                                       '[box]\nurl = "https://example.org/box"\ndescription = "a box"\n')
    annotate(render, folder / "objects", folder / "clip.cdp.xml", links=folder / "links.toml")
    html = folder / "clip.html"
    write_viewer(render, html, cdp=(folder / "clip.cdp.xml").read_text(), objects=folder / "objects")
    with headless_chromium() as browser:
        yield browser, html


def _click_view_pixel(browser, x: float, y: float) -> None:
    """Click at view pixel (x, y) (columns, rows of one view)."""
    canvas = browser.find_element(By.ID, "view")
    w, h = canvas.size["width"], canvas.size["height"]
    ActionChains(browser).move_to_element_with_offset(canvas, int(x / LX * w - w / 2), int(y / LY * h - h / 2)) \
        .click().perform()


def _last_click(browser):
    return browser.execute_script("return window.povh3dViewer.lastClick || null")


def test_click_reports_the_object_under_the_cursor(page) -> None:
    browser, html = page
    open_page(browser, html)
    _click_view_pixel(browser, 0.5, 0.5)            # background: nothing is reported
    assert _last_click(browser) is None
    _click_view_pixel(browser, 2.0, 9.5)            # the ball: columns 1..2, rows 8..10 of frame 0
    assert _last_click(browser)["url"] == "https://example.org/ball"
    assert browser.find_element(By.ID, "r-link").get_attribute("href") == "https://example.org/ball"
    _click_view_pixel(browser, 5.5, 4.0)            # the box: columns 3..7, rows 2..5
    assert _last_click(browser)["object"] == "box"
    assert browser.find_element(By.ID, "view").value_of_css_property("cursor") == "pointer"
    _click_view_pixel(browser, 12.0, 10.0)          # background again: the cursor is the default one
    assert browser.find_element(By.ID, "view").value_of_css_property("cursor") == "default"
    assert _last_click(browser)["object"] == "box"


def test_edits_and_results_come_back_in_the_exported_xml(page) -> None:
    browser, html = page
    open_page(browser, html)
    _click_view_pixel(browser, 2.0, 9.5)            # the ball in frame 0 (its first annotation)
    for field, text in (("e-url", "https://example.org/red-ball"), ("e-desc", "a red ball")):
        browser.find_element(By.ID, field).clear()
        browser.find_element(By.ID, field).send_keys(text)
    browser.find_element(By.ID, "e-save").click()
    browser.find_element(By.ID, "i-url").send_keys("https://example.org/similar")
    browser.find_element(By.ID, "i-desc").send_keys("a similar ball")
    browser.find_element(By.ID, "i-add").click()
    browser.find_element(By.ID, "i-url").clear()
    browser.find_element(By.ID, "i-url").send_keys("https://example.org/other")
    browser.find_element(By.ID, "i-add").click()
    browser.find_elements(By.CSS_SELECTOR, "#items button")[1].click()     # remove the second
    header = from_xml(browser.execute_script("return window.povh3dViewer.exportXml()").encode(), "exported")
    first, box, again = header.scenes[0].annotations
    assert (first.object_name, first.url, first.description) == ("ball", "https://example.org/red-ball", "a red ball")
    assert all(b.url == "https://example.org/red-ball" for b in first.boxes)
    assert all([(r.url, r.description) for r in b.results] == [("https://example.org/similar", "a similar ball")]
               for b in first.boxes)
    # the ball that comes back in frame 3 is another annotation (the thesis's rule): untouched
    assert (again.object_name, again.url, again.boxes[0].results) == ("ball", "https://example.org/ball", ())
    assert box.url == "https://example.org/box"


def test_player_actions_are_timed(page) -> None:
    browser, html = page
    open_page(browser, html)
    _click_view_pixel(browser, 5.5, 4.0)
    browser.find_element(By.ID, "i-url").send_keys("https://example.org/x")
    browser.find_element(By.ID, "i-add").click()
    browser.find_elements(By.CSS_SELECTOR, "#items button")[0].click()
    timings = browser.execute_script("return Object.assign({first_frame_ms: window.povh3dViewer.readyMs},"
                                     " window.povh3dViewer.timings)")
    assert set(timings) == {"first_frame_ms", "box_loading_ms", "highlight_ms", "click_to_result_ms",
                            "add_item_ms", "remove_item_ms"}
    assert all(0 <= v < 1000 for v in timings.values()), timings
    if os.environ.get("POVH3D_VIEWER_TIMINGS"):       # docs/viewer.md's table: where to write them
        Path(os.environ["POVH3D_VIEWER_TIMINGS"]).write_text(json.dumps(timings, indent=2))


def _inside_point(masks: np.ndarray, ident: int) -> tuple[float, float]:
    """A place ``(fx, fy)`` over the page (fractions of the picture) where the view the mouse picks
    there shows object ``ident`` at that pixel and all around it."""
    ny, nx, ly, lx = masks.shape
    for fy in np.linspace(0.02, 0.98, 97):
        for fx in np.linspace(0.02, 0.98, 129):
            l, k = int(fy * ny), int(fx * nx)
            r, c = int(fy * ly), int(fx * lx)
            if 1 <= r < ly - 1 and 1 <= c < lx - 1 and (masks[l, k, r - 1:r + 2, c - 1:c + 2] == ident).all() \
                    and int((fy + 0.01) * ny) == l and int((fx + 0.01) * nx) == k \
                    and int((fy - 0.01) * ny) == l and int((fx - 0.01) * nx) == k:
                return float(fx), float(fy)
    raise AssertionError(f"object {ident} is nowhere under the mouse")


@pytest.mark.povray
def test_click_on_the_bundled_sample_reports_the_torus_link(tmp_path: Path, monkeypatch) -> None:
    """Masks made by POV-Ray (render --objects), their header and page: a click on the torus."""
    from povh3d.renderer.outputs.objects import read_mask, read_table
    from tests.support.cli import run_in_process

    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    sample = Path(__file__).resolve().parents[2] / "sample_models" / "sample.pov"
    assert run_in_process("render", sample, "--preset", "demo", "--quality", "draft", "-o", tmp_path / "s.png",
                          "--objects", tmp_path / "objs").code == 0
    (tmp_path / "links.toml").write_text('[torus_33]\nurl = "https://example.org/torus"\n'
                                         '[box_37]\nurl = "https://example.org/box"\n')
    annotate(tmp_path / "s.png", tmp_path / "objs", tmp_path / "s.xml", links=tmp_path / "links.toml")
    write_viewer(tmp_path / "s.png", tmp_path / "s.html", cdp=(tmp_path / "s.xml").read_text(),
                 objects=tmp_path / "objs")
    table = read_table(tmp_path / "objs")
    masks = np.stack([[read_mask(tmp_path / "objs", table, 0, (l, k)) for k in range(8)] for l in range(8)])
    with headless_chromium() as browser:
        open_page(browser, tmp_path / "s.html")
        canvas = browser.find_element(By.ID, "view")
        w, h = canvas.size["width"], canvas.size["height"]
        for ident, url in ((4, "https://example.org/torus"), (5, "https://example.org/box")):
            fx, fy = _inside_point(masks, ident)
            ActionChains(browser).move_to_element_with_offset(canvas, int((fx - 0.5) * w), int((fy - 0.5) * h)) \
                .click().perform()
            assert _last_click(browser)["url"] == url

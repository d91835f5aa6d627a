"""Hostile or odd content on the viewer page (issue 38 item 6), in a real headless Chromium as the
other viewer tests: links only to http(s) and mailto, a header bounded in size, views at their
physical aspect, the hyperlinker's controls only where there are objects."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from selenium.webdriver.common.by import By

from povh3d.commands.annotate import annotate, read_header
from povh3d.commands.viewer import view_pixel_aspect
from povh3d.errors import InputError
from povh3d.hyper.cdp import MAX_HEADER_BYTES, from_xml
from povh3d.hyper.page import ViewerContent, viewer_html
from tests.commands.test_hyperlinker import _click_view_pixel, _last_click
from tests.support.browser import headless_chromium, open_page
from tests.support.objects_render import moving_objects_render

LINKS = '[ball]\nurl = "{ball}"\ndescription = "a ball"\n[box]\nurl = "https://example.org/box"\n'


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hostile")
    render = moving_objects_render(folder)
    (folder / "links.toml").write_text(LINKS.format(ball="https://example.org/ball"))
    annotate(render, folder / "objects", folder / "clip.cdp.xml", links=folder / "links.toml")
    with headless_chromium() as browser:
        yield folder, render, browser


@pytest.mark.parametrize("url", ["javascript:alert(1)", " JavaScript:alert(1)", "data:text/html,x", "file:///etc/passwd"])
def test_a_links_file_with_another_scheme_is_one_line(made, url) -> None:
    folder, render, _ = made
    (folder / "bad.toml").write_text(LINKS.format(ball=url))
    with pytest.raises(InputError, match="not an http\\(s\\) or mailto address"):
        annotate(render, folder / "objects", folder / "bad.cdp.xml", links=folder / "bad.toml")
    assert not (folder / "bad.cdp.xml").exists()


@pytest.mark.parametrize("url", ["https://example.org/x", "http://example.org", "mailto:a@example.org"])
def test_page_and_mail_links_are_taken(made, url) -> None:   # negative control
    folder, render, _ = made
    (folder / "good.toml").write_text(LINKS.format(ball=url))
    annotate(render, folder / "objects", folder / "good.cdp.xml", links=folder / "good.toml")
    assert url in (folder / "good.cdp.xml").read_text()


def test_a_header_with_a_script_link_is_refused(made) -> None:
    folder, _, _ = made
    text = (folder / "clip.cdp.xml").read_text().replace("https://example.org/ball", "javascript:alert(1)")
    with pytest.raises(InputError, match="not an http\\(s\\) or mailto"):
        from_xml(text.encode())


def test_the_page_makes_no_script_link_of_a_header_it_is_given(made) -> None:
    """Past the reader (a header edited in the page, or given to viewer_html directly), the page
    itself links only http(s) and mailto; the same page with the page link is the control."""
    folder, render, browser = made
    from povh3d.commands.viewer import read_render_views

    rendered = read_render_views(render)
    for url, expected in (("javascript:alert(1)", "#"), ("https://example.org/ball", "https://example.org/ball")):
        text = (folder / "clip.cdp.xml").read_text().replace("https://example.org/ball", url)
        page = folder / "scripted.html"
        page.write_text(viewer_html(ViewerContent(rendered.frames, grid=rendered.grid, cdp=text,
                                                  numbers=rendered.numbers)))
        open_page(browser, page)
        _click_view_pixel(browser, 2.0, 9.5)            # the ball
        assert _last_click(browser)["object"] == "ball"
        href = browser.find_element(By.ID, "r-link").get_attribute("href")
        assert href.endswith("#") if expected == "#" else href == expected


def test_a_header_over_the_bound_is_refused_before_it_is_read(tmp_path: Path) -> None:
    big = tmp_path / "big.cdp.xml"
    with open(big, "wb") as f:
        f.truncate(MAX_HEADER_BYTES + 1)   # sparse: no 16 MB written
    with pytest.raises(InputError, match="over the 16 MB"):
        read_header(big)
    with pytest.raises(InputError, match="over the 16 MB"):
        from_xml(b" " * (MAX_HEADER_BYTES + 1))


def _canvas(browser) -> tuple[int, int]:
    return tuple(browser.execute_script("const c = window.povh3dViewer.canvas; return [c.width, c.height];"))


def test_views_are_drawn_at_their_physical_aspect(tmp_path: Path, made) -> None:
    """A lenticular view's pixel is a lens pitch wide and a panel pixel high: 4.5 to 1 here."""
    browser = made[2]
    views = np.zeros((1, 9, 64, 16, 3), np.uint8)
    sizes = {}
    for aspect in (4.5, 1.0):   # 1: the square pixels the page drew before, the negative control
        page = tmp_path / f"a{aspect}.html"
        page.write_text(viewer_html(ViewerContent((views,), grid="lenticular", pixel_aspect=aspect)))
        open_page(browser, page)
        sizes[aspect] = _canvas(browser)
    w, h = sizes[4.5]
    assert abs(w / h - 16 * 4.5 / 64) < 0.02
    assert sizes[1.0][0] / sizes[1.0][1] == 16 / 64


def test_the_aspect_comes_from_the_sidecars_pitches() -> None:
    assert view_pixel_aspect({"pixel_distance_3d_mm": [0.45, 0.1]}) == pytest.approx(4.5)
    assert view_pixel_aspect({"lens_pitch_mm": [0.8, 0.8]}) == 1.0
    assert view_pixel_aspect(None) == 1.0 and view_pixel_aspect({"pixel_distance_3d_mm": [1, 0]}) == 1.0


def test_the_hyperlinker_shows_only_where_there_are_objects(tmp_path: Path, made) -> None:
    folder, render, browser = made
    from povh3d.commands.viewer import read_render_views

    rendered = read_render_views(render)
    full = (folder / "clip.cdp.xml").read_text()
    header = from_xml(full.encode())
    assert header.scenes[0].annotations   # the control below has objects
    import re
    empty = re.sub(r"<Annotation\b.*?</Annotation>", "", full, flags=re.S)
    for text, shown in ((empty, False), (full, True)):
        page = tmp_path / "h.html"
        page.write_text(viewer_html(ViewerContent(rendered.frames, grid=rendered.grid, cdp=text,
                                                  numbers=rendered.numbers)))
        open_page(browser, page)
        assert browser.find_element(By.ID, "hyper").is_displayed() == shown
        assert browser.find_element(By.ID, "export").is_displayed() == shown

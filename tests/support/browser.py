"""A headless Chromium (Debian's ``chromium`` and ``chromium-driver``, installed by ``make
browser``) driven by Selenium, for the viewer page's tests."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from selenium import webdriver
from selenium.webdriver.chrome.service import Service


@contextmanager
def headless_chromium(downloads: Path | None = None) -> Iterator[webdriver.Chrome]:
    """A headless Chromium; it fails (never skips) when the browser or its driver is missing."""
    binary = shutil.which("chromium")
    driver = shutil.which("chromedriver")
    assert binary and driver, "chromium and chromium-driver are missing: run 'make browser'"
    options = webdriver.ChromeOptions()
    options.binary_location = binary
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1200,900", "--allow-file-access-from-files"):
        options.add_argument(arg)
    if downloads is not None:
        options.add_experimental_option("prefs", {"download.default_directory": str(downloads),
                                                  "download.prompt_for_download": False})
    browser = webdriver.Chrome(service=Service(driver), options=options)
    try:
        yield browser
    finally:
        browser.quit()


def open_page(browser: webdriver.Chrome, page: Path, timeout: float = 20.0) -> None:
    """Load ``page`` from file:// and wait until the viewer has drawn its first view."""
    from selenium.webdriver.support.ui import WebDriverWait

    browser.get(page.resolve().as_uri())
    WebDriverWait(browser, timeout).until(
        lambda b: b.execute_script("return window.povh3dViewer && window.povh3dViewer.readyMs !== null"))

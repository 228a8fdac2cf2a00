"""The page of `vplotter serve` in a real headless browser (Debian's chromium and
chromium-driver, driven by selenium): upload, draw, watch the percent change, stop; no console
errors. Skipped, with the reason, where selenium or the browser is missing (.ci/run installs
them)."""

from __future__ import annotations

import shutil

import pytest

from vplotter.cli import main

from support.web import DRAWING, serve  # noqa: F401 - the server fixture

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed "
                                "(pip install selenium)")
DRIVER = shutil.which("chromedriver")
BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(
    DRIVER is None or BROWSER is None,
    reason="no headless browser: apt-get install chromium chromium-driver")


@pytest.fixture
def browser(tmp_path):
    from selenium.common.exceptions import WebDriverException
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    opts = Options()
    opts.binary_location = BROWSER
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                f"--user-data-dir={tmp_path / 'chromium'}", "--window-size=420,900"):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    try:
        drv = webdriver.Chrome(service=Service(DRIVER), options=opts)
    except WebDriverException as e:
        pytest.skip(f"chromium would not start: {str(e).splitlines()[0]}")
    drv.set_page_load_timeout(30)
    yield drv
    drv.quit()


def wait_for(drv, what, timeout_s: float = 60.0):
    from selenium.webdriver.support.ui import WebDriverWait

    return WebDriverWait(drv, timeout_s, poll_frequency=0.1).until(lambda d: what(d))


def test_page_uploads_draws_shows_progress_and_stops(serve, browser, tmp_path):  # noqa: F811
    from selenium.webdriver.common.by import By

    server = serve()
    assert main(["--config", str(server.config), "calibrate", "--at", "0", "0"]) == 0
    drawing = tmp_path / "page.ngc"
    drawing.write_text(DRAWING)
    browser.get(server.url)
    field = lambda name: browser.find_element(By.CSS_SELECTOR, f'[data-field="{name}"]')  # noqa: E731
    wait_for(browser, lambda d: field("state").text == "idle")
    browser.find_element(By.CSS_SELECTOR, '[data-action="upload"]').send_keys(str(drawing))
    draw = wait_for(browser, lambda d: d.find_elements(
        By.CSS_SELECTOR, '[data-action="draw"][data-file="page.ngc"]'))[0]
    wait_for(browser, lambda d: "plot time" in field("message").text)
    draw.click()
    wait_for(browser, lambda d: field("state").text == "drawing")
    first = wait_for(browser, lambda d: float(field("percent").text) > 0 and
                     float(field("percent").text))
    wait_for(browser, lambda d: field("state").text != "drawing" or
             float(field("percent").text) > first)
    browser.find_element(By.CSS_SELECTOR, '[data-action="stop"]').click()
    wait_for(browser, lambda d: "stopped pid" in field("message").text)     # the answer
    wait_for(browser, lambda d: field("state").text == "paused")
    assert server.status()["resume"]["line"] > 0
    assert browser.find_element(By.CSS_SELECTOR, '[data-action="resume"]').is_enabled()
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert errors == []

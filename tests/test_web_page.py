"""The page of `vplotter serve` in a real headless browser (Debian's chromium and
chromium-driver, driven by selenium) on a phone's screen, 412 x 915 CSS pixels: upload, draw,
watch the percent change, stop; options that change the estimate, the position set and the pen
tuned from the page, a draw without a known position and a backend that cannot start explained
on the page, the pen prompt with its colour; the queue (add, copies, reorder, remove, run with
Continue at the paper change), the history, and the drawing growing on its preview during a
real-time draw, at a phone's size and a desktop's; status in a person's words (no process
ids); every control inside the screen's width; no console errors. Skipped, with the reason, where selenium or the browser is missing (.ci/run
installs them)."""

from __future__ import annotations

import re
import shutil
import tomllib

import pytest

from vplotter.cli import main

from support import REPO
from support.web import DRAWING, Server, events, serve  # noqa: F401 - the server fixture

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed "
                                "(pip install selenium)")
DRIVER = shutil.which("chromedriver")
BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")
W, H = 412, 915                # a common Android phone's screen in CSS pixels
PHOTO = REPO / "tests" / "data" / "images" / "gray16.png"
pytestmark = pytest.mark.skipif(
    DRIVER is None or BROWSER is None,
    reason="no headless browser: apt-get install chromium chromium-driver")


@pytest.fixture(scope="module")
def chromium(tmp_path_factory):
    """One headless chromium for this file's tests (it takes seconds to start)."""
    from selenium.common.exceptions import WebDriverException
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    opts = Options()
    opts.binary_location = BROWSER
    profile = tmp_path_factory.mktemp("chromium")
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                f"--user-data-dir={profile}", f"--window-size={W},{H}"):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    try:
        drv = webdriver.Chrome(service=Service(DRIVER), options=opts)
    except WebDriverException as e:
        pytest.skip(f"chromium would not start: {str(e).splitlines()[0]}")
    drv.set_page_load_timeout(30)
    yield drv
    drv.quit()


@pytest.fixture
def browser(chromium):
    """The browser as a fresh one: a blank page, no cookies, no console lines, a phone's
    screen."""
    drv = chromium
    drv.get("about:blank")
    drv.execute_cdp_cmd("Network.clearBrowserCookies", {})
    drv.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",     # a phone's screen
                        {"width": W, "height": H, "deviceScaleFactor": 1, "mobile": True})
    drv.get_log("browser")                  # read: the next test sees only its own lines
    yield drv
    drv.get("about:blank")                  # the page and its event stream closed


def wait_for(drv, what, timeout_s: float = 60.0):
    from selenium.webdriver.support.ui import WebDriverWait

    return WebDriverWait(drv, timeout_s, poll_frequency=0.1).until(lambda d: what(d))


def console_errors(drv, answered=()) -> list[dict]:
    """The console's errors, but for the network's lines of the HTTP statuses in `answered`
    (a 400 or 503 the page was meant to get and explains)."""
    out = []
    for e in drv.get_log("browser"):
        if e["level"] != "SEVERE":
            continue
        m = re.search(r"status of (\d+)", e["message"])
        if e.get("source") == "network" and m and int(m.group(1)) in answered:
            continue
        out.append(e)
    return out


def fits(drv) -> list[str]:
    """The visible controls that reach past the screen's width (none should)."""
    return drv.execute_script("""
        const w = document.documentElement.clientWidth, out = [];
        if (document.documentElement.scrollWidth > w) out.push('page ' +
            document.documentElement.scrollWidth);
        document.querySelectorAll('button, input, select, label, legend, img').forEach((el) => {
          const r = el.getBoundingClientRect();
          if (r.width && (r.right > w + 0.5 || r.left < -0.5))
            out.push(el.outerHTML.slice(0, 80) + ' ' + r.left + '..' + r.right);
        });
        return out;""")


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
    wait_for(browser, lambda d: field("message").text.startswith("stopped: pen"))  # the answer
    assert "pid" not in field("message").text and "pid" not in field("said").text
    wait_for(browser, lambda d: field("state").text == "paused")
    assert server.status()["resume"]["line"] > 0
    assert browser.find_element(By.CSS_SELECTOR, '[data-action="resume"]').is_enabled()
    assert console_errors(browser) == []


def _field(drv, name: str):
    from selenium.webdriver.common.by import By

    return drv.find_element(By.CSS_SELECTOR, f'[data-field="{name}"]')


def _click(drv, action: str, file: str | None = None):
    from selenium.webdriver.common.by import By

    extra = f'[data-file="{file}"]' if file else ""
    el = wait_for(drv, lambda d: [b for b in d.find_elements(
        By.CSS_SELECTOR, f'[data-action="{action}"]{extra}') if b.is_enabled()])[0]
    drv.execute_script("arguments[0].scrollIntoView({block: 'center'})", el)
    el.click()


def _type(drv, el, text: str):
    el.clear()
    el.send_keys(text)
    drv.execute_script("arguments[0].dispatchEvent(new Event('change', {bubbles: true}))", el)


def test_page_options_change_the_estimate_and_the_preview_shows_beside_the_file(
        serve, browser, tmp_path):  # noqa: F811
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select

    server = serve()
    photo = tmp_path / "photo.png"
    photo.write_bytes(PHOTO.read_bytes())
    browser.get(server.url)
    wait_for(browser, lambda d: _field(d, "state").text == "idle")
    option = lambda name: browser.find_element(By.CSS_SELECTOR, f'[data-option="{name}"]')  # noqa: E731
    wait_for(browser, lambda d: len(Select(option("style")).options) > 1)   # from /api/setup
    # options before the upload: a 3 minute budget, a spiral
    _type(browser, option("max_time"), "3m")
    Select(option("style")).select_by_value("spiral")
    browser.find_element(By.CSS_SELECTOR, '[data-action="upload"]').send_keys(str(photo))
    wait_for(browser, lambda d: "plot time" in _field(d, "message").text)
    first = server.request("GET", "/api/files")[1][0]
    assert first["options"] == {"style": "spiral", "max_time": "3m"}
    assert _field(browser, "estimate").text == f"plot time {clock(first['estimate_s'])}"
    assert _field(browser, "options-for").text == "Options for photo.png"
    assert not browser.find_element(By.CSS_SELECTOR, '[data-takes="fill"]').is_displayed()
    # the notes: a tap away
    _field(browser, "notes-count").click()
    assert any("spiral" in li.text for li in browser.find_elements(
        By.CSS_SELECTOR, '[data-field="notes"] li'))
    # a smaller budget: a new estimate, kept for the file
    _type(browser, option("max_time"), "2m")
    wait_for(browser, lambda d: server.request("GET", "/api/files")[1][0]["options"].get(
        "max_time") == "2m")
    now = server.request("GET", "/api/files")[1][0]
    assert now["estimate_s"] < first["estimate_s"] <= 180
    wait_for(browser, lambda d: _field(d, "estimate").text ==
             f"plot time {clock(now['estimate_s'])}")
    # a bad value: the CLI's line, nothing changed
    _type(browser, option("width"), "-5")
    wait_for(browser, lambda d: _field(d, "message").text ==
             "error: argument --width: width must be above 0 (got '-5')")
    assert server.request("GET", "/api/files")[1][0] == now
    _type(browser, option("width"), "")
    wait_for(browser, lambda d: "plot time" in _field(d, "message").text)
    # the preview: a spinner while it renders, then the picture inside the file's own item
    browser.execute_script("""
        window.spun = false;
        const sp = document.querySelector('[data-field="spinner"]');
        new MutationObserver(() => { if (!sp.hidden) window.spun = true; })
          .observe(sp, {attributes: true});""")
    _click(browser, "preview", "photo.png")
    img = wait_for(browser, lambda d: _field(d, "preview").is_displayed()
                   and _field(d, "preview"))
    assert browser.execute_script("return window.spun")
    assert not _field(browser, "spinner").is_displayed()
    item = browser.find_element(By.CSS_SELECTOR, 'li[data-name="photo.png"]')
    assert browser.execute_script("return arguments[0].contains(arguments[1])", item, img)
    assert browser.execute_script("return arguments[0].naturalWidth", img) > 0
    assert fits(browser) == []
    browser.save_screenshot(str(tmp_path / "options-412x915.png"))
    assert console_errors(browser, answered=(400,)) == []


def clock(s: float) -> str:
    s = round(s)
    h, m, sec = s // 3600, s % 3600 // 60, s % 60
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"


def test_page_sets_the_position_tunes_the_pen_and_explains_an_unknown_position(
        serve, browser, tmp_path):  # noqa: F811
    from selenium.webdriver.common.by import By

    server = serve(speed=4)                 # nothing here watches the pace of a move
    server.upload("walk.ngc", DRAWING.encode())
    browser.get(server.url)
    wait_for(browser, lambda d: _field(d, "where").text == "position unknown: set it under Position")
    # Draw without a known position: what to do, on the page
    _click(browser, "draw", "walk.ngc")
    wait_for(browser, lambda d: "position is unknown" in _field(d, "message").text)
    assert "under Position and press Set" in _field(browser, "message").text
    position = browser.find_element(By.ID, "position")
    assert "need" in position.get_attribute("class").split()
    assert server.status()["busy"] is None and server.status()["calibrated"] is False
    # set it
    _type(browser, _field(browser, "at-x"), "20")
    _type(browser, _field(browser, "at-y"), "-10")
    _click(browser, "set-position")
    wait_for(browser, lambda d: _field(d, "message").text.startswith("pen at X20.000 Y-10.000"))
    wait_for(browser, lambda d: _field(d, "where").text == "pen up at X20.0 Y-10.0")
    assert "need" not in position.get_attribute("class").split()
    st = server.status()
    assert (st["x_mm"], st["y_mm"]) == (20.0, -10.0)
    # jog away, then home
    _click(browser, "jog")                                   # ▲ 10 mm
    wait_for(browser, lambda d: _field(d, "where").text == "pen up at X20.0 Y0.0")
    _click(browser, "home")
    wait_for(browser, lambda d: _field(d, "message").text == "pen at X20.000 Y-10.000")
    wait_for(browser, lambda d: _field(d, "where").text == "pen up at X20.0 Y-10.0")
    # the pen: the widths come from config.toml; try others, then save them
    assert _field(browser, "up-us").get_attribute("value") == "500"
    assert _field(browser, "down-us").get_attribute("value") == "1500"
    _type(browser, _field(browser, "up-us"), "620")
    _type(browser, _field(browser, "down-us"), "1380")
    _click(browser, "pen-try")
    wait_for(browser, lambda d: _field(d, "message").text == "tried up 620 µs, down 1380 µs")
    _click(browser, "pen-save")
    wait_for(browser, lambda d: _field(d, "message").text.startswith(
        "saved [pen] up_us = 620, down_us = 1380 in "))
    text = server.config.read_text()
    assert tomllib.loads(text)["pen"] | {} == {**tomllib.loads(text)["pen"], "up_us": 620,
                                                "down_us": 1380}
    assert re.search(r"(?m)^up_us = 620 +# servo pulse widths", text)
    # now the draw goes
    _click(browser, "draw", "walk.ngc")
    wait_for(browser, lambda d: _field(d, "message").text.startswith("drawing walk.ngc"))
    server.wait_status(lambda s: s["busy"] is None)
    assert fits(browser) == []
    browser.save_screenshot(str(tmp_path / "setup-412x915.png"))
    assert console_errors(browser, answered=(400,)) == []


def test_page_explains_a_backend_that_cannot_start(browser, tmp_path, config_path):
    try:
        import lgpio  # noqa: F401
        pytest.skip("lgpio is installed here: its backend may start")
    except ImportError:
        pass
    cfg = tmp_path / "lgpio.toml"
    cfg.write_text(config_path.read_text())              # [gpio] backend = "lgpio"
    assert main(["--config", str(cfg), "calibrate", "--at", "0", "0"]) == 0
    server = Server(cfg, tmp_path / "uploads")
    try:
        browser.get(server.url)
        wait_for(browser, lambda d: _field(d, "state").text == "idle")
        _click(browser, "pen-down")
        wait_for(browser, lambda d: "backend cannot start" in _field(d, "message").text)
        said = _field(browser, "message").text
        assert "the lgpio backend needs the lgpio module" in said
        assert 'set [gpio] backend = "fake" and realtime = true in config.toml' in said
        assert server.status()["pen"] == "up" and server.status()["busy"] is None
        assert fits(browser) == []
        assert console_errors(browser, answered=(503,)) == []
    finally:
        server.stop()


TWO_PENS = """<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="10mm"
 viewBox="0 0 20 10"><path d="M1 1 L4 1" stroke="red" fill="none"/>
<path d="M1 5 L4 5" stroke="#2050c0" fill="none"/></svg>"""


def test_page_prompts_for_each_pen_with_its_colour(serve, browser, tmp_path):  # noqa: F811
    server = serve(speed=4)                 # the prompts are waits: the pace does not matter
    assert main(["--config", str(server.config), "calibrate", "--at", "0", "0"]) == 0
    assert server.upload("pens.svg", TWO_PENS.encode())[0] == 201
    browser.get(server.url)
    wait_for(browser, lambda d: _field(d, "state").text == "idle")
    assert not _field(browser, "prompt").is_displayed()
    _click(browser, "draw", "pens.svg")
    for colour, rgb in (("red", "rgba(255, 0, 0, 1)"), ("#2050c0", "rgba(32, 80, 192, 1)")):  # light first
        wait_for(browser, lambda d: _field(d, "prompt").is_displayed()
                 and _field(d, "pen-name").text == f"pen: {colour}")
        assert _field(browser, "state").text == "waiting"
        assert f"put in the {colour} pen" in _field(browser, "prompt-text").text
        assert _field(browser, "swatch").value_of_css_property("background-color") == rgb
        assert fits(browser) == []
        if colour == "red":
            browser.save_screenshot(str(tmp_path / "prompt-412x915.png"))
        _click(browser, "continue")
        wait_for(browser, lambda d: not _field(d, "prompt").is_displayed()
                 or _field(d, "pen-name").text != f"pen: {colour}")
    server.wait_status(lambda s: s["busy"] is None)
    assert console_errors(browser) == []


STEP = "G21 G90\nG01 Z-1 F600\nG01 X1 Y0\nG00 Z5\nM2\n"
ZIGZAG = ("G21 G90\nG01 Z-1 F600\nG01 X2.5 Y0.5\nG01 X0.0 Y1.0\nG01 X2.5 Y1.5\n"
          "G01 X0.0 Y2.0\nG01 X2.5 Y2.5\nG01 X0.0 Y3.0\nG01 X2.5 Y3.5\nG01 X0.0 Y4.0\n"
          "G00 Z5\nM2\n")


@pytest.mark.parametrize("size", [(W, H), (1280, 900)], ids=["phone", "desktop"])
def test_page_queue_runs_with_continue_and_the_drawing_grows_on_its_preview(
        serve, browser, tmp_path, size):  # noqa: F811
    from selenium.webdriver.common.by import By

    browser.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                            {"width": size[0], "height": size[1], "deviceScaleFactor": 1,
                             "mobile": size[0] < 600})
    # twice the seed machine's pace: zig.ngc takes 3.5 s, some seven of the events (every
    # 0.5 s) that grow the drawing; walk.ngc, the queue's second drawing, a millimetre
    server = serve(speed=2)
    assert main(["--config", str(server.config), "calibrate", "--at", "0", "0"]) == 0
    assert server.upload("zig.ngc", ZIGZAG.encode())[0] == 201
    assert server.upload("walk.ngc", STEP.encode())[0] == 201
    browser.get(server.url)
    wait_for(browser, lambda d: _field(d, "said").text == "Ready.")
    jobs = lambda: browser.execute_script(  # noqa: E731 - read at once: the list is redrawn
        "return [...document.querySelectorAll('[data-field=\"queue\"] li')]"
        ".map((li) => li.dataset.job)")
    # add: zig.ngc twice, walk.ngc once, walk.ngc again (then removed); reorder
    for name, copies in (("zig.ngc", "2"), ("walk.ngc", "1"), ("walk.ngc", "1")):
        wait_for(browser, lambda d: name in [o.get_attribute("value") for o in
                                             d.find_elements(By.CSS_SELECTOR,
                                                             '[data-field="queue-file"] option')])
        browser.execute_script("arguments[0].value = arguments[1]", _field(browser, "queue-file"),
                               name)
        _type(browser, _field(browser, "queue-copies"), copies)
        n = len(jobs())
        _click(browser, "queue-add")
        wait_for(browser, lambda d: len(jobs()) == n + 1)
    assert jobs() == ["1", "2", "3"]
    assert _field(browser, "said").text == "Ready. 3 drawings in the queue."
    browser.find_element(By.CSS_SELECTOR, '[data-action="queue-remove"][data-job="3"]').click()
    wait_for(browser, lambda d: jobs() == ["1", "2"])
    browser.find_element(By.CSS_SELECTOR, '[data-action="queue-up"][data-job="2"]').click()
    wait_for(browser, lambda d: jobs() == ["2", "1"])
    browser.find_element(By.CSS_SELECTOR, '[data-action="queue-down"][data-job="2"]').click()
    wait_for(browser, lambda d: jobs() == ["1", "2"])
    assert [j["id"] for j in server.request("GET", "/api/queue")[1]["jobs"]] == [1, 2]
    assert "2 drawings" in _field(browser, "queue-total").text
    assert fits(browser) == []
    # run: the drawing grows on its preview as the events come
    _click(browser, "queue-run")
    box = wait_for(browser, lambda d: _field(d, "live-box").is_displayed()
                   and _field(d, "live"))
    said, grown = set(), []
    for _, st in events(server, None, 60.0):           # the page read as each event comes
        said.add(_field(browser, "said").text)
        k = int(box.get_attribute("data-drawn") or 0)
        if not grown or k != grown[-1]:
            grown.append(k)
        waiting = ((st.get("drawing") or {}).get("waiting") or {}).get("prompt")
        if waiting:
            break
        assert st["busy"] is not None, grown
    assert waiting == "put in fresh paper for zig.ngc (2 of 2)"
    total = int(box.get_attribute("data-points"))
    assert len([k for k in grown if 0 < k < total]) >= 2 and grown == sorted(grown), grown
    assert any(t.startswith("Drawing zig.ngc: ") and "% done" in t for t in said)
    assert "of 0.02 m drawn" in _field(browser, "drawn").text
    # a pen-down path on the canvas: dark pixels where it was drawn
    dark = browser.execute_script("""
        const c = arguments[0], d = c.getContext('2d').getImageData(0, 0, c.width, c.height);
        let n = 0;
        for (let i = 0; i < d.data.length; i += 4) if (d.data[i] < 80) n++;
        return n;""", box)
    assert dark > 0
    browser.execute_script("window.scrollTo(0, 0)")
    browser.save_screenshot(str(tmp_path / f"live-{size[0]}x{size[1]}.png"))
    wait_for(browser, lambda d: _field(d, "said").text.startswith("Waiting for you: put in "
                                                                    "fresh paper for zig.ngc"))
    assert fits(browser) == []
    browser.save_screenshot(str(tmp_path / f"queue-{size[0]}x{size[1]}.png"))
    _click(browser, "continue")
    wait_for(browser, lambda d: "walk.ngc" in _field(d, "said").text
             or _field(d, "said").text.startswith("Waiting for you: put in fresh paper for walk"))
    wait_for(browser, lambda d: _field(d, "prompt").is_displayed())
    _click(browser, "continue")
    server.wait_status(lambda s: s["busy"] is None)
    wait_for(browser, lambda d: jobs() == [] and _field(d, "said").text == "Ready.")
    history = wait_for(browser, lambda d: (lambda h: h if len(h) == 3 else None)(
        d.execute_script("return [...document.querySelectorAll('[data-field=\"history\"] li')]"
                         ".map((li) => li.textContent)")))
    assert all(": done; planned " in h for h in history), history
    assert "zig.ngc (1 of 2)" in history[-1] and "walk.ngc" in history[0]
    texts = said | {_field(browser, "message").text}
    assert not [t for t in texts if "pid" in t]
    assert fits(browser) == []
    assert console_errors(browser) == []


def test_page_resumes_a_stopped_queue_job_by_running_the_queue(serve, browser):  # noqa: F811
    server = serve(speed=2)                 # zig.ngc 3.5 s: stopped at a line past 3 of 10
    assert main(["--config", str(server.config), "calibrate", "--at", "0", "0"]) == 0
    assert server.upload("zig.ngc", ZIGZAG.encode())[0] == 201
    assert server.request("POST", "/api/queue", {"file": "zig.ngc"})[0] == 201
    assert server.request("POST", "/api/queue/run")[0] == 202
    server.wait_status(lambda s: (s.get("drawing") or {}).get("line", 0) > 3)
    assert server.request("POST", "/api/stop")[0] == 200
    browser.get(server.url)
    wait_for(browser, lambda d: _field(d, "said").text == (
        "Stopped part-way through zig.ngc (the queue's first drawing): Resume goes on from "
        "where it stopped."))
    _click(browser, "resume")
    wait_for(browser, lambda d: _field(d, "message").text == "going on with the queue")
    server.wait_status(lambda s: s["busy"] is None)
    wait_for(browser, lambda d: _field(d, "said").text == "Ready.")
    assert server.request("GET", "/api/queue")[1]["jobs"] == []
    plots = server.request("GET", "/api/history")[1]
    assert [p["result"] for p in plots] == ["stopped", "done"]
    assert console_errors(browser) == []

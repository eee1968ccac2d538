"""`mpc monitor` in a real browser (issue 17, item 5): headless Chromium from Debian's
`chromium` package, driven by playwright for Python pointed at /usr/bin/chromium. The test
flashes a program into `mpc sim`, starts it from the page, and watches the axis position
change, the run state name it and the path grow on its scaled axes; the screenshot is kept
in build/test-artefacts/monitor.png. The layout keeps every lamp in view from 800 to 2560
px wide, and a page of another origin (another loopback port, or a rebound name) can
neither write nor read the WebSocket.

`make test` installs chromium (`make tools`); without it this test fails, saying so.
"""

from __future__ import annotations

import http.server
import os
import shutil
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from monitorproc import (
    JOB,
    SQUARE_LINE,
    get,
    mpc,
    start_monitor,
    start_sim_monitor,
    state_until,
    stop,
)
from simproc import start_sim

from mplang.cli.common import EXIT_OK

CHROMIUM = Path("/usr/bin/chromium")
ARTEFACTS = Path(__file__).resolve().parents[2] / "build" / "test-artefacts"


def browser_path() -> str:
    if CHROMIUM.exists():
        return str(CHROMIUM)
    found = shutil.which("chromium")
    if found is None:
        pytest.fail("no chromium: the monitor's browser test needs Debian's chromium package "
                    "(`make tools` installs it: apt-get install -y chromium)")
    return found


@contextmanager
def chromium(*args: str) -> Iterator[Any]:
    """A headless Chromium (playwright's Browser) with extra command-line `args`."""
    executable = browser_path()
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.fail("no playwright: install the dev extra (pip install -e '.[dev]')")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=executable,
            args=[*args, *(["--no-sandbox"] if os.geteuid() == 0 else [])])
        try:
            yield browser
        finally:
            browser.close()


def test_manual_12_1_dashboard_in_chromium_shows_a_running_job(tmp_path: Path) -> None:
    executable = browser_path()
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.fail("no playwright: install the dev group (pip install --group dev)")
    work = tmp_path / "w"
    work.mkdir()
    (work / "job.mp").write_text(JOB)
    sim, port = start_sim("--duration", "120")
    try:
        assert mpc(work, "flash", "job.mp", "--tcp", f"127.0.0.1:{port}").returncode == EXIT_OK
        monitor, url = start_monitor(work, "--tcp", f"127.0.0.1:{port}", "job.mp",
                                     "--allow-write")
        try:
            with sync_playwright() as playwright:
                browser = playwright.chromium.launch(
                    executable_path=executable,
                    args=["--no-sandbox"] if os.geteuid() == 0 else [])
                try:
                    page = browser.new_page(viewport={"width": 1300, "height": 1000})
                    page.goto(url)
                    page.wait_for_selector("body[data-connected=true]")
                    assert page.is_visible("#call") and page.is_visible("#estop")
                    x_lp = "#axes tbody tr[data-axis=X] .lp"
                    assert page.inner_text(x_lp) == "0"
                    assert page.inner_text("#run-state") == "idle: no program runs"
                    assert page.get_attribute("#xy", "data-x-title") == "X (pulses)"
                    page.fill("#call-program", "square")
                    page.click("#call")
                    page.wait_for_function("document.querySelector('#write-result')"
                                           ".textContent.includes('called MP41 square')")
                    page.wait_for_function(
                        f"Number(document.querySelector('{x_lp}').textContent) > 0")
                    first = int(page.get_attribute("#xy", "data-points") or "0")
                    page.wait_for_function(
                        f"Number(document.querySelector('#xy').dataset.points) > {first + 5}")
                    assert page.inner_text("#program") == "MP41 square"
                    page.wait_for_function("document.querySelector('#run-state')"
                                           ".textContent === 'running MP41 square'")
                    assert page.inner_text("#state").startswith("(device state ready")
                    assert page.inner_text("#source") == f"job.mp:{SQUARE_LINE}"
                    page.wait_for_function(  # on to the second side: Y moves, X stays
                        "Number(document.querySelector("
                        "'#axes tbody tr[data-axis=Y] .lp').textContent) > 0")
                    assert page.inner_text(x_lp) == "4000"
                    assert page.inner_text("tr[data-name=laps] .value") == "0"
                    xy = page.eval_on_selector("#xy", "c => ({...c.dataset})")
                    assert (xy["xTitle"], xy["yTitle"]) == ("X (pulses)", "Y (pulses)")
                    x_ticks = [int(t) for t in xy["xTicks"].split(",")]
                    y_ticks = [int(t) for t in xy["yTicks"].split(",")]
                    assert x_ticks[0] <= 0 and x_ticks[-1] >= 4000  # the X side is drawn
                    assert x_ticks[1] - x_ticks[0] == y_ticks[1] - y_ticks[0]  # one scale
                    z = page.eval_on_selector("#z", "c => ({...c.dataset})")
                    assert (z["xTitle"], z["yTitle"]) == ("path point", "Z (pulses)")
                    ARTEFACTS.mkdir(parents=True, exist_ok=True)
                    shot = ARTEFACTS / "monitor.png"
                    page.screenshot(path=str(shot), full_page=True)
                    assert shot.stat().st_size > 10_000
                finally:
                    browser.close()
        finally:
            stop(monitor)
    finally:
        stop(sim)


def test_read_only_dashboard_hides_the_write_buttons(tmp_path: Path) -> None:
    executable = browser_path()
    from playwright.sync_api import sync_playwright

    sim, port = start_sim("--duration", "60")
    try:
        monitor, url = start_monitor(tmp_path, "--tcp", f"127.0.0.1:{port}")
        try:
            with sync_playwright() as playwright:
                browser = playwright.chromium.launch(
                    executable_path=executable,
                    args=["--no-sandbox"] if os.geteuid() == 0 else [])
                try:
                    page = browser.new_page()
                    page.goto(url)
                    page.wait_for_selector("body[data-connected=true]")
                    assert page.get_attribute("body", "data-write") == "false"
                    for button in ("#call", "#stop", "#estop", "#clear-estop"):
                        assert not page.is_visible(button)
                    assert page.is_visible("#no-vars")
                    assert not page.is_visible("#error")
                    stop(sim)  # the device goes away: the page says so
                    page.wait_for_selector("body[data-connected=false]")
                    banner = page.inner_text("#error")
                    assert banner.startswith("device unreachable: ") and "reconnecting" in banner
                    assert page.inner_text("#connection") == "not connected"
                finally:
                    browser.close()
        finally:
            stop(monitor)
    finally:
        stop(sim)


WIDTHS = {800: 600, 1280: 720, 1600: 900, 1920: 1080, 2560: 1440}  # width: height, px
LAMP_BOXES = """() => {
  const panel = document.querySelector('#axes-panel').getBoundingClientRect();
  const cells = [...document.querySelectorAll('#axes tbody td')].filter(
    (td) => td.querySelector('.lamp'));
  const heads = [...document.querySelectorAll('#axes thead th')];
  const box = (el) => { const r = el.getBoundingClientRect();
    return [el.textContent || el.querySelector('.lamp').title, r.left, r.top, r.right,
            r.bottom]; };
  return {panel: [panel.left, panel.top, panel.right, panel.bottom],
          cells: cells.map(box), heads: heads.map(box),
          view: [innerWidth, innerHeight],
          scroll: [document.scrollingElement.scrollWidth,
                   document.querySelector('#axes-panel').scrollWidth,
                   document.querySelector('#axes-panel').clientWidth]};
}"""


def test_every_lamp_of_every_axis_in_view_from_800_to_2560_px(tmp_path: Path) -> None:
    """At each width from 800 to 2560 px, with no scrolling: every lamp cell of every axis
    (4 axes x 8 lamps) and every column head lies inside the viewport and inside the axes
    panel, which clips nothing, and the page has no horizontal scroll bar. The favicon is
    served (no 404)."""
    proc, url = start_sim_monitor(tmp_path, "--duration", "120")
    try:
        state_until(url, lambda s: s["connected"])
        with chromium() as browser:
            page = browser.new_page()
            failed: list[str] = []
            page.on("response", lambda r: failed.append(f"{r.status} {r.url}")
                    if r.status >= 400 else None)
            page.goto(url)
            page.wait_for_selector("body[data-connected=true]")
            page.wait_for_selector("#axes tbody tr[data-axis=U]")
            for width, height in WIDTHS.items():
                page.set_viewport_size({"width": width, "height": height})
                seen = page.evaluate(LAMP_BOXES)
                left, top, right, bottom = seen["panel"]
                assert len(seen["cells"]) == 32 and len(seen["heads"]) == 13, seen
                for name, x0, y0, x1, y1 in seen["cells"] + seen["heads"]:
                    where = (width, name, x0, y0, x1, y1, seen["panel"])
                    assert 0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height, where
                    assert left <= x0 and x1 <= right and top <= y0 and y1 <= bottom, where
                page_width, panel_scroll, panel_width = seen["scroll"]
                assert page_width <= width and panel_scroll <= panel_width, (width, seen)
                ARTEFACTS.mkdir(parents=True, exist_ok=True)
                page.screenshot(path=str(ARTEFACTS / f"monitor-{width}.png"))
            icon = page.evaluate("""async () => {
              const r = await fetch(document.querySelector('link[rel=icon]').href);
              return [r.status, r.headers.get('content-type')]; }""")
            assert icon[0] == 200 and icon[1].startswith("image/svg+xml"), icon
            assert failed == []
        assert get(url + "favicon.ico")[0] == 200
    finally:
        stop(proc)


class _Foreign(http.server.BaseHTTPRequestHandler):
    """Another site's page, served from another loopback port."""

    def do_GET(self) -> None:
        body = b"<!doctype html><title>another site</title><p>nothing to see"
        self.send_response(200)
        self.send_header("Content-Type", "text/html")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, format: str, *args: Any) -> None:
        pass


ATTACK = """async (target) => {
  const out = {};
  const attempt = async (name, run) => {
    try { out[name] = await run(); } catch (err) { out[name] = 'blocked: ' + err.name; } };
  await attempt('json_write', async () => (await fetch(target + 'api/emergency-stop', {
    method: 'POST', headers: {'Content-Type': 'application/json'}, body: '{}'})).status);
  await attempt('simple_write', async () => (await fetch(target + 'api/emergency-stop', {
    method: 'POST', mode: 'no-cors', headers: {'Content-Type': 'text/plain'},
    body: '{}'})).type);
  await attempt('read_page', async () => (await (await fetch(target)).text()).length);
  await attempt('read_token', async () => (await (await fetch(target + 'api/session'))
    .json()).token);
  await attempt('read_state', async () => (await (await fetch(target + 'api/state'))
    .json()).seq);
  out.websocket = await new Promise((resolve) => {
    const ws = new WebSocket(target.replace('http', 'ws') + 'ws');
    ws.onmessage = () => { resolve('read a message'); ws.close(); };
    ws.onclose = (event) => resolve('closed ' + event.code);
  });
  return out;
}"""


@contextmanager
def foreign_site() -> Iterator[int]:
    """An HTTP server of another site on a free loopback port, while the block runs."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Foreign)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield int(server.server_address[1])
    finally:
        server.shutdown()
        server.server_close()


def test_a_page_of_another_origin_can_neither_write_nor_read(tmp_path: Path) -> None:
    """Issue 23 in Chromium: a page of another origin (another loopback port, as
    http://127.0.0.1:OTHER/ and http://localhost:OTHER/) cannot write (a JSON write needs a
    preflight never granted; a simple one is refused for its Origin), cannot read the page,
    the token or the state, and its WebSocket is refused without a message. The
    DNS-rebinding page (http://127.attacker.example:PORT/, resolved to 127.0.0.1) is refused
    outright. The dashboard's own page still drives the device."""
    proc, url = start_sim_monitor(tmp_path, "--duration", "120")
    port = int(url.rstrip("/").rsplit(":", 1)[1])
    try:
        state_until(url, lambda s: s["connected"])
        with foreign_site() as other, \
                chromium("--host-resolver-rules=MAP 127.attacker.example 127.0.0.1") \
                as browser:
            page = browser.new_page()
            for site in (f"http://127.0.0.1:{other}/", f"http://localhost:{other}/"):
                page.goto(site)
                for target in (url, url.replace("127.0.0.1", "localhost")):
                    out = page.evaluate(ATTACK, target)
                    assert out["json_write"] == "blocked: TypeError", (site, target, out)
                    assert out["simple_write"] == "opaque", out  # sent, answer unreadable
                    for read in ("read_page", "read_token", "read_state"):
                        assert out[read] == "blocked: TypeError", (site, target, out)
                    assert out["websocket"].startswith("closed "), out
            assert get(url + "api/state")[1]["emergency"] is False  # no write got through
            rebound = page.goto(f"http://127.attacker.example:{port}/")
            assert rebound is not None and rebound.status == 421
            assert "does not answer to the host name" in page.inner_text("body")
            out = page.evaluate(ATTACK, f"http://127.attacker.example:{port}/")
            assert out["json_write"] == 421  # same-origin for the browser, refused by Host
            assert out["read_token"] is None and out["read_state"] is None  # only the refusal
            assert out["websocket"].startswith("closed "), out
            assert get(url + "api/state")[1]["emergency"] is False
            page.goto(url)  # the dashboard's own page: its writes go through
            page.wait_for_selector("body[data-connected=true]")
            page.click("#estop")
            page.wait_for_function("document.querySelector('#emergency').textContent "
                                   "=== 'EMERGENCY STOP'")
            assert page.inner_text("#run-state") == "emergency stop: nothing may run"
            page.click("#clear-estop")
            page.wait_for_function("document.querySelector('#emergency').textContent "
                                   "=== 'off'")
    finally:
        stop(proc)

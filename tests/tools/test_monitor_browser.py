"""`mpc monitor` in a real browser (issue 17, item 5): headless Chromium from Debian's
`chromium` package, driven by playwright for Python pointed at /usr/bin/chromium. The test
flashes a program into `mpc sim`, starts it from the page, and watches the axis position
change and the path grow; the screenshot is kept in build/test-artefacts/monitor.png.

`make test` installs chromium (`make tools`); without it this test fails, saying so.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from monitorproc import JOB, SQUARE_LINE, mpc, start_monitor, stop
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
                    assert page.inner_text("#source") == f"job.mp:{SQUARE_LINE}"
                    page.wait_for_function(  # on to the second side: Y moves, X stays
                        "Number(document.querySelector("
                        "'#axes tbody tr[data-axis=Y] .lp').textContent) > 0")
                    assert page.inner_text(x_lp) == "4000"
                    assert page.inner_text("tr[data-name=laps] .value") == "0"
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

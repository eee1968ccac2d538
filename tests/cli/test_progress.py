"""The flash display: a bar with frames/s on a terminal, plain lines elsewhere."""

from __future__ import annotations

import asyncio
import io
import re

from mplang.cli.progress import FlashDisplay, bar, frames_per_second
from mplang.m8194h.flash import FlashReport


def reports(written: int, planned: int, devices: int = 1) -> list[FlashReport]:
    out = []
    for _ in range(devices):
        report = FlashReport("dev", 0, None, [])
        report.frames_written, report.frames_planned = written, planned
        out.append(report)
    return out


def test_bar_and_rate() -> None:
    assert bar(0, 100, 10) == "[..........]"
    assert bar(50, 100, 10) == "[#####.....]"
    assert bar(150, 100, 10) == "[##########]"  # re-downloads may write more than planned
    assert bar(0, 0, 4) == "[....]"  # nothing planned: an empty bar, never a full one
    assert frames_per_second(500, 0.5) == 1000 and frames_per_second(3, 0) == 0


def test_plain_lines_when_not_a_terminal() -> None:
    out = io.StringIO()
    display = FlashDisplay(lambda: reports(10, 20), out, tty=False)
    display.say("MP1: 10 frames verified")

    async def briefly() -> None:
        await asyncio.wait_for(display.run(), 1)  # returns at once: nothing to redraw

    asyncio.run(briefly())
    display.finish()
    assert out.getvalue() == "mpc flash: MP1: 10 frames verified\n"


def test_terminal_bar_is_redrawn_in_place_below_the_lines() -> None:
    out = io.StringIO()
    state = reports(30, 120, devices=2)
    state[0].seconds = 1.0  # one device finished
    display = FlashDisplay(lambda: state, out, tty=True)
    display.say("first")

    async def a_few_redraws() -> None:
        # wait for three redraws, however long a loaded machine takes (never a real rate)
        task = asyncio.ensure_future(display.run())
        for _ in range(2000):
            if out.getvalue().count("\r\x1b[2K") >= 3:
                break
            await asyncio.sleep(0.01)
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)

    asyncio.run(a_few_redraws())
    display.say("second")
    display.finish()
    text = out.getvalue()
    assert text.count("\r\x1b[2K") >= 3  # every redraw clears the bar line first
    assert "mpc flash: first\n" in text and "mpc flash: second\n" in text
    assert "60/240 frames" in text and "frames/s" in text and "1/2 devices done" in text
    assert text.endswith("\n") and "\r\x1b[2Kmpc flash: second" in text


def test_summary_after_finish_is_not_followed_by_a_bar() -> None:
    out = io.StringIO()
    display = FlashDisplay(lambda: reports(120, 120), out, tty=True)
    display.say("MP1: verified")
    display.finish()
    display.say("1 program(s) written and verified on dev")
    text = out.getvalue()
    # the summary is the last line, and the prompt starts on a line of its own
    assert text.endswith("\nmpc flash: 1 program(s) written and verified on dev\n")
    assert text.count("120/120 frames") == 2  # drawn under the first line, then finished


def test_no_bar_is_left_for_a_flash_that_planned_no_frame() -> None:
    out = io.StringIO()
    display = FlashDisplay(lambda: reports(0, 0), out, tty=True)
    display.say("error: no answer from 10.0.0.9:502")
    display.finish()
    display.say("0 of 0 program(s) written and verified")
    text = out.getvalue()
    assert not re.search(r"0/0 frames +\d+ frames/s\n", text)  # never kept on a line
    # the empty bar is erased before the summary, which ends the output on its own line
    assert text.endswith("frames/s\r\x1b[2Kmpc flash: 0 of 0 program(s) written and verified\n")
    assert "[" + "#" * 24 + "]" not in text


def test_errors_keep_one_prefix_style() -> None:
    from mplang.cli.progress import narration

    assert narration("mpc flash", "error: refused") == "mpc: error: refused"
    assert narration("mpc flash", "job.mp:4: error: MP41: refused") == \
        "job.mp:4: error: MP41: refused"  # gcc-style: problem matchers read it
    assert narration("mpc flash", "MP1: verified") == "mpc flash: MP1: verified"

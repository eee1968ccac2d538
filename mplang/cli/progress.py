"""What `mpc flash` shows while it works: a progress bar with frames/s on a terminal, plain lines
(one per event, nothing redrawn) when standard error is a file or a pipe, as in a CI log.

The display polls the flash reports (`FlashReport.frames_written`, `frames_planned`) instead of
being called for each frame, so flashing never waits for the terminal. The bar itself is
click's (`click.progressbar`, formatted with `format_progress_line`); this module only keeps it
on the bottom line below the narration, which click's bar, drawn for a loop, does not do.
"""

from __future__ import annotations

import asyncio
import re
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol, TextIO

import click

from mplang.cli.style import quiet, redraw

if TYPE_CHECKING:
    from click._termui_impl import ProgressBar


class FlashReport(Protocol):
    """What the display reads of a family's flash reports (the M8194H's
    `mplang.m8194h.flash.FlashReport`)."""

    @property
    def frames_planned(self) -> int: ...

    @property
    def frames_written(self) -> int: ...

    @property
    def seconds(self) -> float: ...


REDRAW_S = 0.1
BAR_WIDTH = 24


def frames_per_second(frames: int, seconds: float) -> float:
    return frames / seconds if seconds > 0 else 0.0


def bar(done: int, total: int, width: int = BAR_WIDTH, info: str = "") -> str:
    """click's bar at `done` of `total`, then `info`. Nothing planned yet (or nothing to write)
    is an empty bar, never a full one; more than planned (re-downloads) a full one."""
    progress: ProgressBar[int] = click.progressbar(length=max(total, 0), width=width, fill_char="#",
                                 empty_char=".", bar_template="[%(bar)s] %(info)s",
                                 show_eta=False, show_percent=False,
                                 item_show_func=lambda _item: info or None)
    progress.pos = 0 if total <= 0 else min(done, total)
    return progress.format_progress_line()


class FlashDisplay:
    """Lines and, on a terminal, one bar line kept at the bottom and redrawn in place."""

    def __init__(self, reports: Callable[[], list[FlashReport]], stream: TextIO | None = None,
                 tty: bool | None = None, prefix: str = "mpc flash") -> None:
        self.reports = reports
        self.stream = stream if stream is not None else sys.stderr
        self.tty = (self.stream.isatty() and not quiet()) if tty is None else tty
        self.prefix = prefix
        self.started = time.monotonic()
        self._bar_shown = False
        self._finished = False

    def say(self, text: str) -> None:
        """An event worth a line of its own (a program verified, a note, an error); after
        `finish` (the summary) the bar is not drawn again."""
        if quiet() and not is_error(text):
            return
        self._clear()
        self.stream.write(narration(self.prefix, text) + "\n")
        if self._finished:
            self.stream.flush()
        else:
            self._draw()

    def status_line(self) -> str:
        reports = self.reports()
        planned = sum(r.frames_planned for r in reports)
        written = sum(r.frames_written for r in reports)
        rate = frames_per_second(written, time.monotonic() - self.started)
        text = bar(written, planned, info=f"{min(written, planned)}/{planned} frames "
                                          f"{rate:7.0f} frames/s")
        if len(reports) > 1:
            finished = sum(1 for r in reports if r.seconds > 0)
            text += f"  {finished}/{len(reports)} devices done"
        return text

    def _clear(self) -> None:
        if self.tty and self._bar_shown:
            redraw(self.stream)
            self._bar_shown = False

    def _draw(self) -> None:
        if self.tty and not self._finished:
            redraw(self.stream, self.status_line())
            self._bar_shown = True

    async def run(self) -> None:
        """Redraw the bar until cancelled (only on a terminal; elsewhere there is no bar)."""
        if not self.tty:
            return
        while True:
            self._draw()
            await asyncio.sleep(REDRAW_S)

    def finish(self) -> None:
        """Leave the final bar on its own line (none if no frame was planned: a device that
        was never reached), the cursor at the start of the next; draw nothing after this."""
        if self.tty and not self._finished:
            if sum(r.frames_planned for r in self.reports()) > 0:
                self._draw()
                self.stream.write("\n")
            else:
                self._clear()
            self._bar_shown = False
            self.stream.flush()
        self._finished = True


_LOCATED = re.compile(r"^[^\s:][^:]*(?::\d+(?::\d+)?)?: error: ")


def is_error(text: str) -> bool:
    """A flash line that reports an error: shown even under `--quiet`."""
    return bool(_LOCATED.match(text)) or text.startswith("error: ")


def narration(prefix: str, text: str) -> str:
    """A flash line as mpc writes it: an error with a place (a source line, a file, a fleet's
    device) keeps the gcc-style `FILE:LINE: error: ...`, one without a place reads
    `mpc: error: ...` as every command's errors do, and the rest is `mpc flash: ...`."""
    if _LOCATED.match(text):
        return text
    if text.startswith("error: "):
        return f"mpc: {text}"
    return f"{prefix}: {text}"

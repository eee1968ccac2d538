"""What `mpc run` and `mpc plot` show while a run goes, and how it ends early.

On a terminal (standard error a TTY) a status line is kept at the bottom and redrawn a few
times a second: simulated time, the running program and its source line, wall time and
`Ctrl-C to stop`; it is erased when the run ends. In a pipe or a file nothing is drawn.

Ctrl-C (SIGINT) during the run does not raise: it asks the run to stop at the next slice
(`mplang.family.watch`), and the command reports the state so far, marked as interrupted,
with exit code 130. A second Ctrl-C ends the command at once (the usual `interrupted`).

`--max-time` (default `DEFAULT_MAX_TIME_S` of simulated time) ends a run that never
finishes with R202 at the line it was at and exit code 18; `0` or `none` is no limit.
"""

from __future__ import annotations

import math
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any, TextIO, TypeVar

import click

from mplang.cli.common import EXIT_RUN_FAILED
from mplang.cli.style import CLEAR_LINE, quiet, redraw
from mplang.family.run_error import SourcePlace
from mplang.family.watch import Where

DEFAULT_MAX_TIME_S = 120.0
"""The default `--max-time`: two minutes of simulated time end a program that loops for ever
in a few seconds of wall time, and fit every documented example but the 10-minute
nameplate job (samples/full_mp156.mp), which says `--max-time 900`; the FATEK manual's jog
example runs 101 s."""

EXIT_OUT_OF_TIME = 18  # 17 is a bad machine file (cli.common.EXIT_BAD_MACHINE)
"""`mpc run`/`mpc plot`: the run reached --max-time without finishing (R202)."""

EXIT_SIGINT = 130
"""`mpc run`/`mpc plot`: stopped with Ctrl-C; the state so far is reported (128 + SIGINT)."""

FIRST_DRAW_S = 0.25
REDRAW_S = 0.2
CLEAR = CLEAR_LINE

F = TypeVar("F", bound=Callable[..., Any])


def parse_max_time(ctx: click.Context | None, param: click.Parameter | None,
                   value: object) -> float:
    """Seconds of simulated time, or `none` (also `0`): no limit (infinity)."""
    text = str(value).strip().lower()
    if text in ("none", "inf", "infinity"):
        return math.inf
    try:
        seconds = float(text)
    except ValueError:
        raise click.BadParameter(f"{value!r} is neither seconds nor 'none'") from None
    if math.isnan(seconds) or seconds < 0:
        raise click.BadParameter(f"{value!r}: give seconds >= 0, or 'none' (0 and none: no "
                                 "limit)")
    return math.inf if seconds == 0 else seconds


def max_time_option(func: F) -> F:
    """The `--max-time` option of `mpc run` and `mpc plot`."""
    return click.option(
        "--max-time", callback=parse_max_time, default=f"{DEFAULT_MAX_TIME_S:g}",
        show_default=True, metavar="SECONDS|none",
        help="Give up after this much simulated time (seconds); 0 or 'none': no limit.")(func)


def place_words(place: SourcePlace) -> str:
    """`MP1 spin at loop.mp:8` (as far as the place is known)."""
    where = f"{place.file}:{place.line}" if place.file and place.line else place.file or ""
    if place.program and where:
        return f"{place.program} at {where}"
    return place.program or where or "no program running"


class RunWatch:
    """The watch `mpc run` and `mpc plot` give a family's run (`mplang.family.watch`):
    draws the status line on a terminal and stops the run after Ctrl-C."""

    def __init__(self, prefix: str, stream: TextIO | None = None,
                 tty: bool | None = None) -> None:
        self.prefix = prefix
        self.stream = stream if stream is not None else sys.stderr
        # `--quiet`: no status line, as in a pipe
        self.tty = (self.stream.isatty() and not quiet()) if tty is None else tty
        self.started = time.monotonic()
        self.next_draw = self.started + FIRST_DRAW_S
        self.interrupted = False
        self.place: SourcePlace | None = None  # where the run was when it stopped
        self.time_s = 0.0
        self.shown = False

    def __call__(self, time_s: float, where: Where) -> bool:
        """Between two slices of the run: draw now and then; True after Ctrl-C."""
        self.time_s = time_s
        if self.interrupted:
            self.place = where()
            return True
        if self.tty:
            now = time.monotonic()
            if now >= self.next_draw:
                self.next_draw = now + REDRAW_S
                self.draw(self.status_line(time_s, where(), now - self.started))
        return False

    def status_line(self, time_s: float, place: SourcePlace, wall_s: float) -> str:
        """One terminal line: the place is shortened (from its start) to fit the width."""
        head = f"{self.prefix}: {time_s:.3f} s simulated, {wall_s:.1f} s wall | "
        tail = " | Ctrl-C to stop"
        middle = place_words(place)
        room = shutil.get_terminal_size((80, 24)).columns - 1 - len(head) - len(tail)
        if len(middle) > room:
            middle = "..." + middle[len(middle) - max(0, room - 3):] if room > 3 else ""
        return head + middle + tail

    def draw(self, text: str) -> None:
        redraw(self.stream, text)
        self.shown = True

    def clear(self) -> None:
        """Erase the status line (the cursor back at the start of the empty line)."""
        if self.shown:
            redraw(self.stream)
            self.shown = False

    def _on_sigint(self, signum: int, frame: FrameType | None) -> None:
        if self.interrupted:  # the second Ctrl-C: stop now
            raise KeyboardInterrupt
        self.interrupted = True

    @contextmanager
    def active(self) -> Iterator[RunWatch]:
        """While the run goes: Ctrl-C asks it to stop (only the main thread has signals);
        afterwards the status line is erased and the usual Ctrl-C comes back."""
        previous = None
        if threading.current_thread() is threading.main_thread():
            previous = signal.signal(signal.SIGINT, self._on_sigint)
        try:
            yield self
        finally:
            if previous is not None:
                signal.signal(signal.SIGINT, previous)
            self.clear()

    def interrupted_json(self) -> dict[str, object] | None:
        """The `"interrupted"` object of `--json`: where and when the run was stopped."""
        if not self.interrupted:
            return None
        place = self.place or SourcePlace(None)
        return {**place.to_json(), "time_ms": round(self.time_s * 1000, 3)}

    def interrupted_note(self) -> str:
        """`loop.mp:8:5: note: interrupted (Ctrl-C) in MP1 spin after 1.234 s simulated`."""
        place = self.place or SourcePlace(None)
        program = f" in {place.program}" if place.program else ""
        return (f"{place.prefix()}note: interrupted (Ctrl-C){program} after "
                f"{self.time_s:.3f} s simulated; the state so far is shown")


def given(ctx: click.Context, name: str) -> bool:
    """Whether the command line (not the default) set the option."""
    source = ctx.get_parameter_source(name)
    return source is not None and source is not click.core.ParameterSource.DEFAULT


def exit_code(interrupted: bool, code: str | None) -> int:
    """An unfinished run's exit code: 130 after Ctrl-C, 18 out of --max-time (R202), else
    5."""
    if interrupted:
        return EXIT_SIGINT
    return EXIT_OUT_OF_TIME if code == "R202" else EXIT_RUN_FAILED


def out_of_time_hint(max_time: float, given: bool) -> str:
    """The hint after an R202: which limit was reached and how to lift it."""
    which = "" if given else " (the default)"
    return (f"    hint: the run reached --max-time {max_time:g} s{which} of simulated time; "
            "give a longer --max-time SECONDS, or --max-time none for no limit")

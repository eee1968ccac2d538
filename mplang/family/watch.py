"""Watching a run while it goes: what every family's `run_build` calls between slices of
simulated time, so that `mpc run` and `mpc plot` can show where a long run is and stop it
on Ctrl-C with the state so far.

A family calls the watch often (many times a second of wall time, never in the middle of a
line or step) with the simulated time and a way to find the running program's source place;
finding the place costs more than a call, so the watch asks only when it draws. When the
watch answers True the family ends the run at once, as it stands: not finished, no error of
its own (the caller knows why it stopped).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from mplang.family.run_error import SourcePlace

Where = Callable[[], SourcePlace]
"""The running program and its current source line (file, line, column, program)."""

Watch = Callable[[float, Where], bool]
"""`watch(time_s, where)` -> True to stop the run now."""

NO_LIMIT = math.inf
"""`max_time` of a run without a limit (`--max-time 0` or `none`)."""


def never_stop(time_s: float, where: Where) -> bool:
    """The watch of a run nobody watches."""
    return False


class Stopped(Exception):
    """Raised inside a family's interpreter loop when its watch asked to stop; the family's
    `run_build` catches it and reports the run as it stands."""


def every(steps: int, watch: Watch | None) -> Callable[[int, float, Where], bool]:
    """A check for interpreter loops that count steps: calls `watch` once every `steps`
    steps (a watch call costs more than a step), False in between and without a watch."""
    if watch is None:
        return lambda count, time_s, where: False

    def check(count: int, time_s: float, where: Where) -> bool:
        return count % steps == 0 and watch(time_s, where)

    return check

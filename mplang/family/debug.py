"""What a source-level debugger (`mpc dap`) asks of a family's virtual controller.

A family that can debug gives, through its face (`Family.debug`), a `Debuggee`: one program
loaded on a fresh virtual controller, stopped before its first line. The debugger sets
breakpoints by source line, resumes it in a `mode` and gets back why it stopped; between
resumes it reads the call stack, the variables, axes and inputs. Everything is in source
terms (the file names of the build's diagnostics, `std:NAME.mp` for library files, 1-based
lines), so the debugger needs to know nothing of slots or slot lines.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from mplang.family.run_error import RunError

MODES = ("continue", "next", "in", "out", "entry")
"""How a debuggee resumes: to the next breakpoint; to the next source line of this program
or its caller (step over); to the next source line anywhere (into a CALL); to the next
source line of the caller (step out); "entry" stops where it is, before the first line
(`stopOnEntry`). Until the first resume nothing has run, so a breakpoint on the first line
(or on the called program's entry) stops a "continue" there."""


class DebugSetupError(ValueError):
    """A launch that cannot start: the message says why (a machine file that cannot be used,
    a program that is not in the build, a build that does not load)."""


@dataclass(frozen=True)
class StackEntry:
    """One frame of the call chain, innermost first: the program and its source line."""

    name: str  # `MP131 std_home_limit`, `ISR2 on_stop (interrupt)`
    file: str | None  # as the build names it: `tour.mp`, `std:home_limit.mp`
    line: int | None
    column: int | None
    kind: str  # "mp" or "isr"


@dataclass(frozen=True)
class Stopped:
    """Why a resume ended: `reason` is "entry", "breakpoint", "function breakpoint", "data
    breakpoint", "step", "pause", "exception" (a run-time finding, in `error`) or "exited"
    (the program finished or failed before)."""

    reason: str
    time_s: float
    error: RunError | None = None
    breakpoints: tuple[int, ...] = ()  # the ids of the breakpoints that stopped it
    finished: bool = False  # "exited": the program came to its end (else it failed)


@dataclass(frozen=True)
class Item:
    """One entry of a scope: a name, its value in words, and its parts (an axis's LP, EP...)."""

    name: str
    value: str
    children: tuple[Item, ...] = ()
    number: str = ""  # the device's name beside a declared one: `VAR400`


@dataclass
class Breakpoint:
    """A breakpoint as the debugger asks for it (on a line, on a program's entry, or on a
    variable's change). Each time it is reached, `condition` (None: always) is asked and may
    raise ValueError (then it stops, to show the problem, kept in `hits`); when it holds,
    `count` goes up and `hit_condition` (None: always) is asked with it. A logpoint (`log`
    set) then calls `log` instead of stopping."""

    id: int
    line: int = 0
    condition: Callable[[], bool] | None = None
    hits: list[str] = field(default_factory=list)  # why a condition failed, once
    hit_condition: Callable[[int], bool] | None = None
    log: Callable[[], None] | None = None
    count: int = 0

    def reached(self) -> bool:
        """Whether it stops the program now (counting the hit, telling a logpoint)."""
        if self.condition is not None:
            try:
                if not self.condition():
                    return False
            except (ValueError, ArithmeticError) as exc:
                self.hits.append(str(exc))
                return True
        self.count += 1
        if self.hit_condition is not None and not self.hit_condition(self.count):
            return False
        if self.log is not None:
            self.log()
            return False
        return True


class Debuggee(Protocol):
    """One program on a family's virtual controller under a debugger's control."""

    @property
    def title(self) -> str:
        """The called program in words: `MP131 home (tour.mp)`."""
        ...

    @property
    def time_s(self) -> float: ...

    @property
    def finished(self) -> bool:
        """True once the program ended (finished or failed): resuming only says so."""
        ...

    @property
    def error(self) -> RunError | None:
        """The run-time finding the program stopped on, once it has (None before)."""
        ...

    def warnings(self) -> Sequence[str]:
        """What the run met that `mpc run` warns about (`file:line:col: warning[Rnnn]: ...`):
        commands not simulated, axis stops that did not end the program."""
        ...

    def files(self) -> Mapping[str, Path]:
        """Every source file of the build, by the name the build gives it, with its place on
        disk (library files too), for the debugger to match the editor's paths."""
        ...

    def stop_lines(self, file: str) -> Sequence[int]:
        """The lines of `file` where the program can stop (a line that has a frame), sorted."""
        ...

    def set_breakpoints(self, file: str, points: Sequence[Breakpoint]) -> None:
        """Replace the breakpoints of `file` (each on a line of `stop_lines`)."""
        ...

    def resume(self, mode: str, interrupted: Callable[[], bool]) -> Stopped:
        """Run in `mode` (one of `MODES`) until a breakpoint, the end of the step, a run-time
        finding or the end of the program; `interrupted()` turning True stops it ("pause")."""
        ...

    def stack(self) -> Sequence[StackEntry]:
        """The call chain where it stopped, innermost first (where a finding was raised,
        after an exception)."""
        ...

    def scopes(self) -> Sequence[tuple[str, Sequence[Item]]]:
        """The named scopes to show: ("Variables", ...), ("Axes", ...), ("Inputs", ...)."""
        ...

    def lookup(self, name: str) -> int | None:
        """The value of a variable by its declared name or device name (`VAR12`), None
        for a name the build does not know."""
        ...

    def column(self, file: str, line: int) -> int:
        """Where the statement on `line` of `file` starts (1-based), for a breakpoint's and
        a stop's column."""
        ...

    def program(self, name: str) -> StackEntry | None:
        """A program of the build by name (`MP60`, `main`, `MP60 main`, `ISR3`): its name as
        the stack shows it and the place of its first line; None if there is none."""
        ...

    def set_function_breakpoints(self, points: Mapping[str, Sequence[Breakpoint]]) -> None:
        """Replace the breakpoints on programs' entries (keyed by `program(...).name`)."""
        ...

    def variable(self, name: str) -> str | None:
        """The device name (`VAR400`, `bVAR3`) of a variable the program can change, by its
        declared or device name; None for another name."""
        ...

    def set_data_breakpoints(self, points: Mapping[str, Sequence[Breakpoint]]) -> None:
        """Replace the breakpoints on variables' changes (keyed by `variable(...)`): a resume
        stops before the first source line that starts after the value changed."""
        ...

    def set_value(self, path: Sequence[str], name: str, value: int) -> Item:
        """Write `value` to entry `name` of the scope (or entry) `path` as a host can
        (`("Variables",)`, `("Axes", "X")`): the entry as it reads now. ValueError when the
        device lets no host write it."""
        ...


DebugStart = Callable[[object, "str | None", "Path | None", float], Debuggee]
"""`Family.debug`: (the build, the program to call or None for the default, a machine
file or None, the simulated seconds after which a program that never ends is stopped) ->
the debuggee, raising `DebugSetupError` with the reason."""

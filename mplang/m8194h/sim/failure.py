"""Why a run on the virtual M8194H stopped, and where: the run-time finding's code (see
`mplang.lang.runtime_rules`), the program, slot line and call chain of the frame that raised it.

The controller knows slots and slot lines only; `mplang.m8194h.run` maps them back to the
source through the build's image, so a finding reads `file:line:col: error[Rnnn]: ...`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from mplang.m8194h.sim.tables import MacroTable

# execution error type (register 119) -> run-time code
EXECUTION_CODES = {0x01: "R101", 0x02: "R102", 0x03: "R103", 0x04: "R104"}


class _Frame(Protocol):
    table: MacroTable
    pc: int


@dataclass(frozen=True)
class Place:
    """One slot line of one program: `MP131 line 49`."""

    kind: str  # "mp" | "isr"
    slot: int
    slot_line: int

    def __str__(self) -> str:
        return f"{self.kind.upper()}{self.slot} line {self.slot_line}"


@dataclass(frozen=True)
class Failure:
    """A run-time finding: `place` is where it was raised, `callers` the frames below it,
    innermost first (the MP_CALL line of each, or the line an ISR interrupted)."""

    code: str
    message: str
    place: Place | None
    callers: tuple[Place, ...] = ()
    time_s: float = 0.0


def _place(frame: _Frame, index: int) -> Place | None:
    lines = frame.table.lines
    if not lines:
        return None
    line = lines[max(0, min(index, len(lines) - 1))]
    return Place(frame.table.kind, frame.table.slot, line.slot_line)


def located(stack: Sequence[_Frame], index: int, code: str, message: str,
            time_s: float) -> Failure:
    """The finding raised by line `index` of the top frame of `stack` (callers: every frame
    below, at the line it last ran, the call or the interrupted line)."""
    if not stack:
        return Failure(code, message, None, (), time_s)
    callers = tuple(p for p in (_place(f, f.pc - 1) for f in reversed(stack[:-1]))
                    if p is not None)
    return Failure(code, message, _place(stack[-1], index), callers, time_s)

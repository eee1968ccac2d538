"""Why a run on the virtual M8194H stopped, and where: the run-time finding's code (see
`mplang.lang.runtime_rules`), the program, slot line and call chain of the frame that raised it.

The controller knows slots and slot lines only; `mplang.m8194h.run` maps them back to the
source through the build's image, so a finding reads `file:line:col: error[Rnnn]: ...`.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from mplang.m8194h.sim.axes import AXES
from mplang.m8194h.sim.io_state import (
    ERR_ALARM,
    ERR_EMERGENCY,
    ERR_HOME,
    ERR_LIMIT_MINUS,
    ERR_LIMIT_PLUS,
    ERR_SOFT_EMG,
    ERR_SOFT_LIMIT_MINUS,
    ERR_SOFT_LIMIT_PLUS,
)
from mplang.m8194h.sim.motion import MotionModel
from mplang.m8194h.sim.tables import MacroTable, StoredLine

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import Frame, VirtualController

# execution error type (register 119) -> run-time code
EXECUTION_CODES = {0x01: "R101", 0x02: "R102", 0x03: "R103", 0x04: "R104"}
NOT_EXECUTABLE = 0x04  # execution error type: the line's values make no sense to the device
LOG = logging.getLogger("mplang.sim")


class ExecutionError(Exception):
    """A line the device refuses to run: `code` is its execution error type (register 119)."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code

# error-code bits of an axis (GET_ERROR_CODE, table 26) -> run-time code and words
STOP_CAUSES = (
    (ERR_LIMIT_PLUS | ERR_LIMIT_MINUS, "R311", "a hardware limit switch (LMT+/LMT-)"),
    (ERR_SOFT_LIMIT_PLUS | ERR_SOFT_LIMIT_MINUS, "R312", "the software limit"),
    (ERR_ALARM, "R313", "the servo ALARM input"),
    (ERR_EMERGENCY | ERR_SOFT_EMG, "R314", "an emergency stop (EMG input or EMERGENCY_STOP)"),
    (ERR_HOME, "R315", "a failed home search"),
)


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


class _Device(Protocol):
    @property
    def stack(self) -> Sequence[_Frame]: ...

    clock: float
    motion: MotionModel
    stops: dict[tuple[str, int], Failure]


def watch_axis_stops(device: _Device) -> None:
    """Record, once per cause and axis, where the program was when an axis stopped on a
    limit, an alarm, an emergency or a failed home search (`device.stops`): the device runs
    on, so these are warnings of the run, not its end."""
    for axis, status in enumerate(device.motion.io.status):
        status.raised = functools.partial(_stopped, device, axis)


def _stopped(device: _Device, axis: int, bits: int) -> None:
    for mask, code, cause in STOP_CAUSES:
        if bits & mask and (code, axis) not in device.stops:
            index = device.stack[-1].pc - 1 if device.stack else 0
            device.stops[(code, axis)] = located(
                device.stack, index, code, f"axis {AXES[axis]} stopped on {cause}",
                device.clock)


def record_error(vc: VirtualController, frame: Frame, line: StoredLine, code: int) -> None:
    """The device's execution error registers (115-119) for `line` of `frame`, and its log."""
    table = frame.table
    mp_no, isr_no = (table.slot, 0) if table.kind == "mp" else (0, table.slot)
    vc.execution_error = (mp_no, isr_no, line.command.code or 0, line.slot_line, code)
    vc.log.append(f"{vc.clock:.4f} s: execution error {code:#04x} in "
                  f"{table.kind.upper()}{table.slot} line {line.slot_line}")


def failed(vc: VirtualController, frame: Frame, pc: int, err: Exception) -> None:
    """Line `pc` of the top frame raised `err` (never out of the device): an execution
    error, the run's error and failure, every program stopped."""
    stack = vc.stack
    line = frame.table.lines[pc]
    code = err.code if isinstance(err, ExecutionError) else NOT_EXECUTABLE
    record_error(vc, frame, line, code)
    vc.error = (str(err) if isinstance(err, ExecutionError) else
                f"{line.command.short_name} at line {line.slot_line}: {err}")
    vc.failure = located(stack, pc, EXECUTION_CODES.get(code, "R104") if
                         isinstance(err, (ExecutionError, ValueError))
                         else "R309", vc.error, vc.clock)
    if not isinstance(err, (ExecutionError, ValueError)):
        LOG.warning("internal fault running %s: %r", vc.error, err, exc_info=err)
    stack.clear()

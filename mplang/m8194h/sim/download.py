"""The download protocol of the virtual M8194H: MP_CREATE / MP_ISR_CREATE, the lines, the
close (9.1-9.2), and what input registers 110-114 then say (9.12, appendix table 13).

Every line is checked as it arrives, whoever sends it: its scope (register-102 causes 5-7),
its parameters (`frame_check`, cause 2), the slot's budget (cause 4) and the block structure
(causes 0xB1-0xBC, RS 11368). A refused line is answered with ILLEGAL FUNCTION and its cause
and fails the download: nothing more is stored, and the close reports the first failure in
110-114 (command and 0-based line of the failing frame) and leaves the slot empty. Where the
manual is silent the profile says what happens ([download] in stdlib/m8194h/device.toml):
the download stays open after a refused line until its close (`refused_line = "fails"`;
"ends" closes it at once), and a failure found only at the close (a block left open, a GOTO
without its LABEL, no line left for the close) is reported in 110-114 and register 102 while
the close itself is acknowledged (`close_failure = "acknowledged"`; "refused" answers it with
the exception).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from mplang.ir.catalogue import Command
from mplang.ir.macro import Operand
from mplang.m8194h.sim import frame_check
from mplang.m8194h.sim.tables import DownloadError, MacroTable, StoredLine, Structure, validate

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import VirtualController

OUT_OF_RANGE = 0x02
NO_SUCH_COMMAND = 0x03
OVER_BUDGET = 0x04
RTC_IN_MACRO = 0x07
NOT_WRITTEN = 0x0F  # download error: "MACRO command not defined ... not written to the FRAM"


@dataclass
class Pending:
    """An open download: the table so far, its next slot line and the first failure."""

    table: MacroTable
    structure: Structure
    budget: int  # the slot's lines (profile), looked up once: every line is checked against it
    line: int = 0
    failure: DownloadError | None = None

    # the table's own view, as clients of `VirtualController.pending` read it
    @property
    def kind(self) -> str:
        return self.table.kind

    @property
    def slot(self) -> int:
        return self.table.slot

    @property
    def lines(self) -> list[StoredLine]:
        return self.table.lines


def create(vc: VirtualController, command: Command, operands: tuple[Operand, ...]) -> int:
    """MP_CREATE / MP_ISR_CREATE in the ready state: open a download of that slot."""
    if vc.stack:
        return 0xC3  # no download while a macro runs (device.toml choice)
    kind = "mp" if command.short_name == "MP_CREATE" else "isr"
    bad = frame_check.check(command, operands, vc.profile)
    if bad is not None:
        vc.log.append(f"{vc.clock:.4f} s: refused: {bad.describe(command)}")
        return OUT_OF_RANGE
    slot = int(operands[0])  # type: ignore[arg-type]
    table = MacroTable(kind, slot)
    vc.pending = Pending(table, Structure(table, vc.profile), vc.profile.budget(kind, slot) or 0)
    vc.state = kind
    vc.chip_state = 6
    return 0


def line(vc: VirtualController, frame: list[int],
         decoded: tuple[Command, tuple[Operand, ...]] | None) -> int:
    """One frame while a download is open: store it, close, or refuse it (and fail the
    download). Returns the register-102 cause, 0 when accepted."""
    pending = vc.pending
    assert pending is not None
    kind = pending.table.kind
    close_name = "MP_CLOSE" if kind == "mp" else "MP_ISR_CLOSE"
    if decoded is not None and decoded[0].short_name == close_name:
        return close(vc)
    cause, error, command = _refusal(vc, pending, frame, decoded)
    if cause:
        if pending.failure is None:
            pending.failure = DownloadError(error, pending.line, command)
            vc.log.append(f"{vc.clock:.4f} s: {kind.upper()}{pending.table.slot} line "
                          f"{pending.line}: frame refused (cause {cause:#04x}): the download "
                          "fails")
            if _setting(vc, "refused_line") == "ends":
                _finish(vc, pending.failure)
        return cause
    assert decoded is not None
    if pending.failure is not None:
        return 0  # accepted, but a failed download stores nothing more
    stored = StoredLine(decoded[0], decoded[1], tuple(frame), pending.line)
    broken = pending.structure.add(len(pending.table.lines), stored)
    if broken is not None:
        pending.failure = DownloadError(broken, pending.line, decoded[0].code or 0)
        if _setting(vc, "refused_line") == "ends":
            _finish(vc, pending.failure)
        return structure_cause(vc, broken)
    pending.table.lines.append(stored)
    pending.line += decoded[0].line_cost
    return 0


def _refusal(vc: VirtualController, pending: Pending, frame: list[int],
             decoded: tuple[Command, tuple[Operand, ...]] | None) -> tuple[int, int, int]:
    """(register-102 cause, download error, command code) of a line refused on its own; cause
    0 when the line is acceptable before the structure is looked at."""
    code = frame[0] if frame else 0
    if decoded is None:
        known = bool(frame) and frame[0] in vc.catalogue.by_code
        return (OUT_OF_RANGE if known else NO_SUCH_COMMAND), NOT_WRITTEN, code
    command, operands = decoded
    kind = pending.table.kind
    if not command.is_macro:
        return RTC_IN_MACRO, NOT_WRITTEN, code
    if kind not in command.scope:
        return (0x05 if kind == "isr" else 0x06), NOT_WRITTEN, code
    bad = frame_check.check(command, operands, vc.profile)
    if bad is not None:
        vc.log.append(f"{vc.clock:.4f} s: refused: {bad.describe(command)}")
        return OUT_OF_RANGE, bad.download_error, code
    cause = vc.initial_table.refusal(command, operands)  # "IT ... not inside MP" RS 990
    if cause:
        return cause, NOT_WRITTEN, code
    if pending.line + command.line_cost > pending.budget:
        return OVER_BUDGET, 0x01, code
    return 0, 0, code


def structure_cause(vc: VirtualController, error: int) -> int:
    """The register-102 cause that goes with a structural download error (0x02 -> 0xB1 ...)."""
    causes = vc.profile.raw["download"]["structure_causes"]
    return int(causes.get(f"{error:#04x}", OUT_OF_RANGE))


def _setting(vc: VirtualController, key: str) -> str:
    """A [download] choice of the profile, checked against the values this module knows."""
    value = str(vc.profile.raw["download"][key])
    known = {"refused_line": ("fails", "ends"), "close_failure": ("acknowledged", "refused"),
             "status_numbers": ("last-download", "since-power-on")}
    if value not in known[key]:
        raise ValueError(f"device profile [download] {key} = {value!r}: expected one of "
                         f"{', '.join(known[key])}")
    return value


def close(vc: VirtualController) -> int:
    """The close: validate what was stored, store it or report why not (110-114). Returns
    the register-102 cause the close is answered with (0: acknowledged)."""
    pending = vc.pending
    assert pending is not None
    failure = pending.failure
    cause = 0
    if failure is None:
        table = pending.table
        failure = validate(table, pending.budget, vc.catalogue, vc.close_counts)
        if failure is not None:  # found at the close: register 102 says why
            cause = OVER_BUDGET if failure.code == 0x01 else structure_cause(vc, failure.code)
    _finish(vc, failure)
    if cause and _setting(vc, "close_failure") == "refused":
        return cause
    vc.illegal_cause = cause  # acknowledged: the cause is there to read all the same
    return 0


def _finish(vc: VirtualController, failure: DownloadError | None) -> None:
    """End the open download: store its table, or report the failure and empty the slot."""
    pending = vc.pending
    assert pending is not None
    table = pending.table
    mp_no, isr_no = (table.slot, 0) if table.kind == "mp" else (0, table.slot)
    if _setting(vc, "status_numbers") == "since-power-on":  # the other kind's number stays
        kept_mp, kept_isr = vc.download_status[:2]
        mp_no, isr_no = mp_no or kept_mp, isr_no or kept_isr
    if failure is None:
        vc.tables[(table.kind, table.slot)] = table
        vc.download_status = (mp_no, isr_no, 0, 0, 0)
        vc.memory_version += 1
    else:
        if vc.tables.pop((table.kind, table.slot), None) is not None:
            vc.memory_version += 1
        vc.download_status = (mp_no, isr_no, failure.command, failure.line, failure.code)
        vc.log.append(f"{vc.clock:.4f} s: {table.kind.upper()}{table.slot} not stored: "
                      f"download error {failure.code:#04x} at line {failure.line}")
    vc.pending = None
    vc.state = "ready"
    vc.chip_state = 7


def stray_close(vc: VirtualController) -> int:
    """MP_CLOSE with no download open: "only used together with RSM_MP_CREATE ...
    Otherwise, it will be ignored" (RS 9886)."""
    vc.log.append(f"{vc.clock:.4f} s: MP_CLOSE outside a download: ignored")
    return 0

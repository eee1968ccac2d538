"""Commands the virtual M8194H accepts but does not simulate. Running one is never silent:
the controller logs a warning (`mpc sim -v` prints it) and records a `Notice` with the
program and slot line, which `mpc run` turns into a warning at the source line.

Which commands these are follows from the catalogue and the handlers: every command with a
sub-function code (so a frame can carry it) that has no handler and is not one the
controller carries out itself. docs/simulator.md lists them; a test keeps the two equal.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from mplang.ir.catalogue import Catalogue
from mplang.ir.macro import Operand

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import Frame, Handler, VirtualController

OWN = frozenset({
    "MP_CREATE", "MP_ISR_CREATE", "MP_CLOSE", "MP_ISR_CLOSE",  # the download protocol
    "MP_CALL", "MP_ISR_CALL", "WRITE_VAR", "WRITE_BVAR", "CLEAR_CARD_BUFFER", "RESET_CARD",
    "LOAD_INITIAL",  # real-time commands `VirtualController._run_rtc` carries out itself
    "WRITE_MD",  # carried out on arrival by `machine_data.MachineData.subfunction`
})
"""Commands without a line handler whose effect the controller gives itself."""


@dataclass(frozen=True)
class Notice:
    """An unmodelled command met at run time: where (the table and its 0-based slot line,
    as registers 118/112 count; kind "rtc" and line -1 for a real-time command)."""

    command: str
    kind: str
    slot: int
    line: int

    def where(self) -> str:
        if self.kind == "rtc":
            return "real-time command"
        return f"{self.kind.upper()}{self.slot} line {self.line}"


def names(catalogue: Catalogue, handlers: dict[str, Handler]) -> list[str]:
    """Short names of the commands a frame can carry that the controller does not simulate."""
    return sorted({c.short_name for c in catalogue.commands
                   if c.code is not None and c.short_name not in handlers
                   and c.short_name not in OWN})


def fill(vc: VirtualController, handlers: dict[str, Handler]) -> None:
    """Give every unmodelled command a handler that warns (and otherwise does nothing)."""
    for name in names(vc.catalogue, handlers):
        handlers[name] = _Warning(vc, name)


def warned(vc: VirtualController) -> list[str]:
    """The commands this controller runs with a warning (what docs/simulator.md lists)."""
    return sorted(name for name, handler in vc.handlers.items()
                  if isinstance(handler, _Warning))


class _Warning:
    """The handler of an unmodelled command: a warning, once per program line."""

    __slots__ = ("name", "vc")

    def __init__(self, vc: VirtualController, name: str) -> None:
        self.vc = vc
        self.name = name

    def __call__(self, frame: Frame, _ops: tuple[Operand, ...]) -> None:
        vc, table = self.vc, frame.table
        line = -1 if table.kind == "rtc" else table.lines[frame.pc - 1].slot_line
        notice = Notice(self.name, table.kind, table.slot, line)
        if notice in vc.notices and table.kind != "rtc":
            return  # once per program line: a loop does not flood the log
        vc.notices[notice] = None
        vc.log.append(f"{vc.clock:.4f} s: warning: {self.name} is not modelled by the virtual "
                      f"controller: accepted with no effect ({notice.where()})")

"""A run-time finding of `mpc run` / `mpc plot` in the user's terms, for every family.

Each family's run maps what its virtual controller knows (a slot line, a step, a CSIM line)
back to the source it can: `FILE:LINE:COL: error[Rnnn]: message`, with the call chain as notes.
The `--json` shape is the same for every family; what a family does not know is null.
"""

from __future__ import annotations

from mplang.lang.record import FrozenRecord
from mplang.lang.runtime_rules import RUNTIME_RULES


class SourcePlace(FrozenRecord):
    """A source position (1-based line and column), with the program it belongs to."""

    file: str | None
    line: int | None
    column: int | None
    program: str  # `MP100 home_z`
    via: str  # how the frame above came from here: "call", or "interrupt" (an ISR)
    _fields = __match_args__ = ("file", "line", "column", "program", "via")

    def __init__(self, file: str | None, line: int | None = None, column: int | None = None,
                 program: str = "", via: str = "call") -> None:
        self.__dict__.update(file=file, line=line, column=column, program=program, via=via)

    def prefix(self) -> str:
        """`file:line:col: `, as far as it is known ("" when nothing is)."""
        parts = [str(p) for p in (self.file, self.line, self.column) if p is not None]
        return ":".join(parts) + ": " if self.file is not None else ""

    def to_json(self) -> dict[str, object]:
        return {"file": self.file, "line": self.line, "column": self.column,
                "program": self.program or None, "via": self.via}


class RunError(FrozenRecord):
    """Why a run failed (`code` from `mplang.lang.runtime_rules`), where, and when."""

    code: str
    message: str
    where: SourcePlace
    slot: str | None  # the device's program: `MP131`, a FATEK table, a CSIM program
    slot_line: int | None  # the device's own line (0-based slot line, step, line)
    time_ms: float
    called_from: tuple[SourcePlace, ...]  # innermost caller first
    line_unit: str  # what `slot_line` counts: FATEK "step", CSIM "line"
    _fields = __match_args__ = ("code", "message", "where", "slot", "slot_line", "time_ms",
                                "called_from", "line_unit")

    def __init__(self, code: str, message: str, where: SourcePlace | None = None,
                 slot: str | None = None, slot_line: int | None = None, time_ms: float = 0.0,
                 called_from: tuple[SourcePlace, ...] = (),
                 line_unit: str = "slot line") -> None:
        self.__dict__.update(code=code, message=message,
                             where=SourcePlace(None) if where is None else where, slot=slot,
                             slot_line=slot_line, time_ms=time_ms, called_from=called_from,
                             line_unit=line_unit)

    @property
    def severity(self) -> str:
        return RUNTIME_RULES[self.code].severity.value

    def render(self) -> str:
        """gcc-style: the finding at its line, then one note per caller."""
        device = f", {self.line_unit} {self.slot_line}" if self.slot_line is not None else ""
        in_program = f" in {self.where.program or self.slot}" \
            if self.where.program or self.slot else ""
        text = (f"{self.where.prefix()}{self.severity}[{self.code}]: {self.message}"
                f"{in_program}{device}")
        for caller in self.called_from:
            where = f"{caller.file}:{caller.line}" if caller.line is not None else caller.file
            program = f" ({caller.program})" if caller.program else ""
            how = "interrupted at" if caller.via == "interrupt" else "called from"
            text += f"\n{caller.prefix()}note: {how} {where}{program}"
        return text

    def to_json(self) -> dict[str, object]:
        """The `"error"` object of `mpc run --json` (docs/cli.md)."""
        return {"code": self.code, "message": self.message, "file": self.where.file,
                "line": self.where.line, "column": self.where.column, "slot": self.slot,
                "slot_line": self.slot_line, "time_ms": self.time_ms,
                "called_from": [c.to_json() for c in self.called_from]}

"""The host's view of a build: what a host program (C, C#, Python, an HMI, a SCADA) needs to
speak the source's names to a controller. The build id the device's build manifest must
hold, each program with how to call it, each declared variable with where it lives, the
CONSTs, and the source line of each (`mpc export`, `mpc call`, `mpc var`, `mplang.host`).

Family-neutral data: a family fills it from its build (`Family.host`), `to_json` and
`from_json` carry it across processes (`mpc export --format json` is this object), and the
errors a host meets are the same for every family.
"""

from __future__ import annotations

import math
import re
from typing import Any

from mplang.lang.record import FrozenRecord, Record

VIEW_FORMAT = "mplang-host/1"
TYPE_RANGES = {"int32": (-2**31, 2**31 - 1), "uint8": (0, 255), "uint16": (0, 0xFFFF)}
FLOAT32_MAX = 3.4028234663852886e38
REAL_TYPES = frozenset({"float32"})
HostValue = int | float
"""A variable's value as a host reads it: an int, or a float where the device's variable is
real (a CSIM's R variables)."""
PROGRAM_NUMBER = re.compile(r"(?:MP)?(\d+)", re.IGNORECASE)


class HostError(Exception):
    """What a host program meets at the device boundary; the message says what and where."""


class BuildMismatch(HostError):
    """The device holds another build than the host's (or none, or one it cannot vouch
    for): nothing was written to it."""

    def __init__(self, device_build: str | None, expected: str, reason: str = "",
                 held: str = "") -> None:
        self.device_build = device_build
        self.expected = expected
        self.reason = reason
        held = held or (f"build {device_build}" if device_build else "no build manifest")
        why = f" ({reason})" if reason else ""
        super().__init__(f"the device holds {held}{why}, the host expects build {expected}: "
                         "flash the build first (mpc flash), or skip the check (--no-check, "
                         "check=False)")


class ExecutionError(HostError):
    """A program the host called stopped on an execution error; `file` and `line` are its
    source line (None where the build does not say), `code` the run-time code (`R103`),
    `device_code` what the device's error register holds."""

    def __init__(self, code: str, message: str, file: str | None, line: int | None,
                 device_code: int = 0, slot: str | None = None,
                 slot_line: int | None = None, column: int | None = None) -> None:
        self.code = code
        self.file = file
        self.line = line
        self.column = column
        self.device_code = device_code
        self.slot = slot
        self.slot_line = slot_line
        self.message = message
        where = f"{file}:{line}: " if file is not None and line is not None else ""
        at = f" in {slot}" if slot else ""
        at += f", slot line {slot_line}" if slot_line is not None else ""
        super().__init__(f"{where}error[{code}]: {message}{at}")

    def to_json(self) -> dict[str, object]:
        """The `"error"` object of `mpc call --json` (the keys of `mpc run --json`'s)."""
        return {"code": self.code, "message": self.message, "file": self.file,
                "line": self.line, "column": self.column, "slot": self.slot,
                "slot_line": self.slot_line, "device_code": self.device_code}


class ProgramRunning(HostError):
    """A program runs already: the device takes no call until it ends."""


class WaitTimeout(HostError, TimeoutError):
    """A program did not end within the time the host gave it (`mpc call` exit 20)."""


class HostLinkError(HostError):
    """The device could not be reached (`reached` False), a request to it failed on the way,
    or the device refused it (`refused`); the message says which and where."""

    def __init__(self, message: str, reached: bool = True, refused: bool = False) -> None:
        super().__init__(message)
        self.reached = reached
        self.refused = refused


class BadValue(HostError, ValueError):
    """A value the variable cannot hold (its type's range); nothing was written."""


class UnknownName(HostError, KeyError):
    """A name the build does not declare (with the names it does)."""

    def __str__(self) -> str:
        return str(self.args[0])


class HostLine(FrozenRecord):
    """Where a device line of a program came from: `first`..`first + cost - 1` (0-based
    device lines) were compiled from `file:line:column`."""

    first: int
    cost: int
    file: str
    line: int
    column: int
    _fields = __match_args__ = ("first", "cost", "file", "line", "column")

    def __init__(self, first: int, cost: int, file: str, line: int, column: int) -> None:
        self.__dict__.update(first=first, cost=cost, file=file, line=line, column=column)


class HostProgram(FrozenRecord):
    """A program as the host calls it: `register` takes `number` (FC16) to start it."""

    name: str
    kind: str  # "mp" or "isr"
    slot: int
    source: str  # file:line
    register: int | None  # None: the host cannot start it (an ISR)
    function: str
    writes: tuple[str, ...]  # the declared variables it (or what it calls) writes
    lines: tuple[HostLine, ...]
    end: tuple[str, int, int] | None  # its END line: where it returns
    device: str  # the device's own name for it where it is no `MPn` (a CSIM's `$LABEL`)
    _fields = __match_args__ = ("name", "kind", "slot", "source", "register", "function",
                                "writes", "lines", "end", "device")

    def __init__(self, name: str, kind: str, slot: int, source: str,
                 register: int | None = None, function: str = "", writes: tuple[str, ...] = (),
                 lines: tuple[HostLine, ...] = (), end: tuple[str, int, int] | None = None,
                 device: str = "") -> None:
        self.__dict__.update(name=name, kind=kind, slot=slot, source=source, register=register,
                             function=function, writes=writes, lines=lines, end=end,
                             device=device)

    @property
    def device_name(self) -> str:
        return self.device or f"{self.kind.upper()}{self.slot}"


class HostVariable(FrozenRecord):
    """A declared variable as the host reads and writes it: `words` registers from
    `register` (0-based, `function` names the Modbus functions), in `word_order`."""

    name: str
    kind: str  # "var" (VAR name), "alias" (ALIAS name = VARn), "bvar", "md"
    device_name: str  # VAR400
    index: int
    register: int
    function: str  # "3/16": read with FC3, write with FC16
    words: int
    type: str  # "int32", "uint8"
    word_order: str  # "msw-first", "lsw-first", "" for one register
    access: str  # "read-write"
    source: str
    _fields = __match_args__ = ("name", "kind", "device_name", "index", "register", "function",
                                "words", "type", "word_order", "access", "source")

    def __init__(self, name: str, kind: str, device_name: str, index: int, register: int,
                 function: str, words: int, type: str, word_order: str, access: str,
                 source: str) -> None:
        self.__dict__.update(name=name, kind=kind, device_name=device_name, index=index,
                             register=register, function=function, words=words, type=type,
                             word_order=word_order, access=access, source=source)

    def check(self, value: HostValue) -> HostValue:
        """`value` if the variable's type holds it, else BadValue naming the range: a real
        type takes any finite number in its range, an integer type a whole number."""
        if self.type in REAL_TYPES:
            if not math.isfinite(value) or abs(value) > FLOAT32_MAX:
                raise BadValue(f"{self.name} ({self.device_name}) is {self.type}: a finite "
                               f"number within +-{FLOAT32_MAX:.7g}, not {value}")
            return value
        if isinstance(value, float):
            if not value.is_integer():
                raise BadValue(f"{self.name} ({self.device_name}) is {self.type}: a whole "
                               f"number, not {value}")
            value = int(value)
        low, high = TYPE_RANGES.get(self.type, (-2**31, 2**31 - 1))
        if not low <= value <= high:
            raise BadValue(f"{self.name} ({self.device_name}) is {self.type}: {low}..{high}, "
                           f"not {value}")
        return value


class HostConst(FrozenRecord):
    name: str
    value: int
    source: str
    _fields = __match_args__ = ("name", "value", "source")

    def __init__(self, name: str, value: int, source: str) -> None:
        self.__dict__.update(name=name, value=value, source=source)


class HostView(Record):
    """Everything `mpc export` writes, and what `mpc call` / `mpc var` / `mplang.host` work
    from."""

    family: str
    build_id: str
    word_order: int
    programs: list[HostProgram]
    variables: list[HostVariable]
    consts: list[HostConst]
    protocol: str  # how a host reaches it: "modbus", or "rs232-ascii" (a CSIM)
    listing: list[str]  # a CSIM: the program lines it holds
    _fields = __match_args__ = ("family", "build_id", "word_order", "programs", "variables",
                                "consts", "protocol", "listing")

    def __init__(self, family: str, build_id: str, word_order: int,
                 programs: list[HostProgram] | None = None,
                 variables: list[HostVariable] | None = None,
                 consts: list[HostConst] | None = None, protocol: str = "modbus",
                 listing: list[str] | None = None) -> None:
        self.family = family
        self.build_id = build_id
        self.word_order = word_order
        self.programs = [] if programs is None else programs
        self.variables = [] if variables is None else variables
        self.consts = [] if consts is None else consts
        self.protocol = protocol
        self.listing = [] if listing is None else listing

    def program(self, name: str) -> HostProgram:
        """A program by declared name, `MPn` or `n`, or by its device name (a CSIM's
        `$LABEL`); UnknownName lists the callable ones."""
        callable_programs = [p for p in self.programs if p.kind != "isr"]
        wanted = name.strip().upper()
        number = PROGRAM_NUMBER.fullmatch(name.strip())
        for p in callable_programs:
            if (number and p.kind == "mp" and p.slot == int(number.group(1))) or \
                    (p.name and p.name.upper() in (wanted, wanted.lstrip("$"))) or \
                    (p.device and p.device.upper() == wanted):
                return p
        known = ", ".join(p.device_name if p.name == p.device.lstrip("$")
                          else f"{p.device_name} {p.name}".rstrip()
                          for p in callable_programs) or "none"
        raise UnknownName(f"no program named {name!r} in build {self.build_id} (callable: "
                          f"{known})")

    def running_name(self, number: int) -> str:
        """What `running()`'s number names: `MPn` where programs are started by number,
        else "a program" (a CSIM does not say which of its labels runs)."""
        if any(p.kind == "mp" and p.register is not None for p in self.programs):
            return f"MP{number}"
        return "a program"

    def variable(self, name: str) -> HostVariable:
        """A declared variable by name (UnknownName lists the declared ones)."""
        for v in self.variables:
            if v.name.upper() == name.strip().upper():
                return v
        known = ", ".join(v.name for v in self.variables) or "none"
        raise UnknownName(f"no declared variable {name!r} in build {self.build_id} "
                          f"(declared: {known})")

    def to_json(self) -> dict[str, Any]:
        """The view as JSON; `protocol`, a program's `device` and the `listing` are written
        only where they are not a Modbus device's (an M8194H's export is as it was)."""
        data = self._json()
        if self.protocol != "modbus":
            data["protocol"] = self.protocol
            data["listing"] = list(self.listing)
            for entry, p in zip(data["programs"], self.programs, strict=True):
                entry["device"] = p.device
        return data

    def _json(self) -> dict[str, Any]:
        return {
            "format": VIEW_FORMAT, "family": self.family, "build_id": self.build_id,
            "word_order": self.word_order,
            "programs": [{"name": p.name, "kind": p.kind, "slot": p.slot,
                          "device_name": p.device_name, "register": p.register,
                          "function": p.function, "source": p.source,
                          "writes": list(p.writes),
                          "lines": [[x.first, x.cost, x.file, x.line, x.column]
                                    for x in p.lines],
                          "end": list(p.end) if p.end else None} for p in self.programs],
            "variables": [{"name": v.name, "kind": v.kind, "device_name": v.device_name,
                           "index": v.index, "register": v.register, "function": v.function,
                           "words": v.words, "type": v.type, "word_order": v.word_order,
                           "access": v.access, "source": v.source} for v in self.variables],
            "consts": [{"name": c.name, "value": c.value, "source": c.source}
                       for c in self.consts],
        }

    @classmethod
    def from_json(cls, data: Any) -> HostView:
        """The view `to_json` wrote; ValueError says what does not fit."""
        if not isinstance(data, dict) or data.get("format") != VIEW_FORMAT:
            raise ValueError(f"not a host view (\"format\": \"{VIEW_FORMAT}\")")
        try:
            programs = [HostProgram(
                str(p["name"]), str(p["kind"]), int(p["slot"]), str(p["source"]),
                None if p["register"] is None else int(p["register"]), str(p["function"]),
                tuple(str(w) for w in p["writes"]),
                tuple(HostLine(int(a), int(b), str(c), int(d), int(e))
                      for a, b, c, d, e in p["lines"]),
                None if p["end"] is None else (str(p["end"][0]), int(p["end"][1]),
                                               int(p["end"][2])), str(p.get("device", "")))
                for p in data["programs"]]
            variables = [HostVariable(
                str(v["name"]), str(v["kind"]), str(v["device_name"]), int(v["index"]),
                int(v["register"]), str(v["function"]), int(v["words"]), str(v["type"]),
                str(v["word_order"]), str(v["access"]), str(v["source"]))
                for v in data["variables"]]
            consts = [HostConst(str(c["name"]), int(c["value"]), str(c["source"]))
                      for c in data["consts"]]
            return cls(str(data["family"]), str(data["build_id"]), int(data["word_order"]),
                       programs, variables, consts, str(data.get("protocol", "modbus")),
                       [str(line) for line in data.get("listing", [])])
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"a host view with a missing or malformed entry ({exc!r})"
                             ) from None

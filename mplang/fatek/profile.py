"""The FATEK FBs-PLC device knowledge, loaded once from `stdlib/fatek/`.

Limits, register layouts, error codes, the FUN141 parameter table and the readings taken where
the manual is silent all live in TOML data (`device.toml`, `mpara.toml`, `mp_commands.toml`);
this module only gives them types.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any


@dataclass(frozen=True)
class FunLimits:
    """The fixed facts of one positioning instruction (FUN140 or FUN147)."""

    fun: int
    flag: int
    header_words: int
    words_per_step: int
    max_steps: int
    work_registers: int
    unit_max: int  # Ps 0..3 or Gp 0..1
    speed_min: int
    speed_max: int
    stroke_min: int
    stroke_max: int
    instructions: frozenset[str]


@dataclass(frozen=True)
class ParamSpec:
    """One FUN141 parameter: where it sits in the 24-register table and what it accepts."""

    number: int
    name: str
    offset: int
    words: int
    min: int
    max: int
    default: int
    error: int | None
    lines: str
    doc: str
    mechanical_min: int | None = None
    mechanical_max: int | None = None
    bytes_0_or_1: bool = False
    hex: bool = False

    def text(self, value: int) -> str:
        """A value as a listing writes it: bit fields in WinProladder hex (0100H)."""
        if self.hex and 0 <= value < 1 << (16 * self.words):
            return f"{value:0{4 * self.words}X}H"
        return str(value)


@dataclass(frozen=True)
class Area:
    """A range of PLC registers: `R` 0..3839, `D` 0..3999, ..."""

    kind: str
    first: int
    last: int

    def holds(self, kind: str, number: int, words: int = 1) -> bool:
        return kind == self.kind and self.first <= number and number + words - 1 <= self.last

    def __str__(self) -> str:
        return f"{self.kind}{self.first}-{self.kind}{self.last}"


@dataclass(frozen=True)
class Profile:
    raw: dict[str, Any]
    fun140: FunLimits
    fun147: FunLimits
    params: tuple[ParamSpec, ...]
    errors: dict[int, str]
    table_areas: tuple[Area, ...]
    variable_areas: tuple[Area, ...]
    contacts: dict[str, int]
    mp_translated: dict[str, str]
    mp_ignored: dict[str, str]
    mp_unsupported: dict[str, str]
    drvz: dict[str, int]

    def limits(self, fun: int) -> FunLimits:
        return self.fun140 if fun == 140 else self.fun147

    @property
    def axis_names(self) -> tuple[str, ...]:
        return tuple(self.raw["family"]["axis_names"])

    @property
    def time_range(self) -> tuple[int, int]:
        ops = self.raw["operands"]
        return int(ops["time_min"]), int(ops["time_max"])

    @property
    def axis_frequency_max(self) -> int:
        return int(self.raw["fun147"]["axis_frequency_max"])

    @property
    def drvc_max_segments(self) -> int:
        return int(self.raw["fun140"]["drvc_max_segments"])

    @property
    def fun141_words(self) -> int:
        return int(self.raw["fun141"]["words"])

    def register(self, key: str) -> int:
        return int(self.raw["registers"][key])

    def semantics(self, key: str) -> str:
        return str(self.raw["semantics"][key])

    def zero_runs_on(self, coord: str) -> bool:
        """Whether a DRV/DRVC stroke of 0 with these coordinates is a continuous run rather
        than a position: always for ADR, for ABS only with the literal reading of FB 955-957
        (`semantics.abs_zero`)."""
        return coord != "ABS" or self.semantics("abs_zero") == "continuous"

    @property
    def motor_ut_scaling(self) -> str:
        return str(self.raw["units"]["motor_ut_scaling"])

    def param(self, number: int) -> ParamSpec | None:
        for spec in self.params:
            if spec.number == number:
                return spec
        return None

    def error_text(self, code: int) -> str:
        return self.errors.get(code, "unknown error")


def _read(filename: str) -> dict[str, Any]:
    text = resources.files("mplang.stdlib").joinpath("fatek", filename).read_text("utf-8")
    return tomllib.loads(text)


def _limits(raw: dict[str, Any], fun: int) -> FunLimits:
    table = raw[f"fun{fun}"]
    return FunLimits(
        fun=fun, flag=int(table["flag"]), header_words=int(table["header_words"]),
        words_per_step=int(table["words_per_step"]), max_steps=int(table["max_steps"]),
        work_registers=int(table["work_registers"]),
        unit_max=int(table["axis_max"] if fun == 140 else table["group_max"]),
        speed_min=int(table["speed_min"]), speed_max=int(table["speed_max"]),
        stroke_min=int(table["stroke_min"]), stroke_max=int(table["stroke_max"]),
        instructions=frozenset(table["instructions"]))


def _areas(rows: list[list[Any]]) -> tuple[Area, ...]:
    return tuple(Area(str(kind), int(first), int(last)) for kind, first, last in rows)


def _param(row: dict[str, Any]) -> ParamSpec:
    return ParamSpec(
        number=int(row["number"]), name=row["name"], offset=int(row["offset"]),
        words=int(row["words"]), min=int(row["min"]), max=int(row["max"]),
        default=int(row["default"]), error=row.get("error"), lines=row["lines"],
        doc=row["doc"], mechanical_min=row.get("mechanical_min"),
        mechanical_max=row.get("mechanical_max"),
        bytes_0_or_1=bool(row.get("bytes_0_or_1", False)), hex=bool(row.get("hex", False)))


@cache
def load() -> Profile:
    """The profile, read once per process."""
    raw = _read("device.toml")
    mpara = _read("mpara.toml")
    commands = _read("mp_commands.toml")
    operands = raw["operands"]
    return Profile(
        raw=raw,
        fun140=_limits(raw, 140),
        fun147=_limits(raw, 147),
        params=tuple(_param(row) for row in mpara["param"]),
        errors={int(code): text for code, text in raw["errors"].items()},
        table_areas=_areas(operands["table_areas"]),
        variable_areas=_areas(operands["variable_areas"]),
        contacts={kind: int(last) for kind, last in operands["contacts"].items()},
        mp_translated=dict(commands["translated"]),
        mp_ignored=dict(commands["ignored"]),
        mp_unsupported=dict(commands["unsupported"]),
        drvz={key: int(value) for key, value in mpara["drvz"].items()},
    )

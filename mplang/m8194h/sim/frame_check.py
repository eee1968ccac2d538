"""The device's own check of a sub-function's parameters, from the catalogue alone.

The virtual controller must refuse what the device refuses whoever sends it (the vendor DLL,
an HMI, a PLC, a fuzzer), so this reads the decoded frame against the catalogue's parameter
kinds and ranges (`stdlib/m8194h/commands.toml`, FORMAT.md) and the profile's limits, and
never asks the compiler. A refused parameter is ILLEGAL FUNCTION cause 2 "parameter value is
not within defined range" (appendix 12.1.12, RS 11366-11368); inside a download it also fails
the download with the manual's download error (0x06 wrong IF operator, 0x10 wrong
VAR_CALCULATE operator, otherwise 0x0F "not written to the FRAM", RS 10974).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mplang.ir.catalogue import Command, Param, Profile
from mplang.ir.macro import BVarRef, Operand, ProgramRef, VarRef

OUT_OF_RANGE = 0x02  # register-102 cause (appendix table 12)
WRONG_IF_OPERATOR = 0x06  # download errors (9.12)
NOT_WRITTEN = 0x0F
WRONG_CALC_OPERATOR = 0x10


@dataclass(frozen=True)
class BadParameter:
    """Why a frame's parameter is refused, and the download error it makes in a download."""

    param: str
    reason: str
    download_error: int

    def describe(self, command: Command) -> str:
        return f"{command.short_name} {self.param}: {self.reason}"


def check(command: Command, operands: tuple[Operand, ...], profile: Profile) -> BadParameter | None:
    """The first parameter of a decoded frame the device refuses, or None."""
    for param, operand in zip(command.params, operands, strict=True):
        # the common cases first, without the reasons' work: a variable that exists, an
        # integer in its set or range
        if type(operand) is VarRef:
            if 0 <= operand.index < _var_count(profile):
                continue
        elif type(operand) is int and param.kind not in ("var", "bvar"):
            allowed, low, high = _values(param, profile)
            if operand in allowed if allowed is not None else \
                    (low is None or operand >= low) and (high is None or operand <= high):
                continue
        reason = _refusal(param, operand, profile)
        if reason is not None:
            error = {"cmp_op": WRONG_IF_OPERATOR, "calc_op": WRONG_CALC_OPERATOR}.get(
                param.kind, NOT_WRITTEN)
            return BadParameter(param.name, reason, error)
    return None


def _refusal(param: Param, operand: Operand, profile: Profile) -> str | None:
    """Why `operand` is not a value `param` takes (None: it is)."""
    if isinstance(operand, VarRef):
        count = profile.var("count")  # VAR0..VAR511 (RS 2394, 10144)
        if not 0 <= operand.index < count:
            return f"VAR{operand.index} does not exist (VAR0..VAR{count - 1})"
        return None
    if isinstance(operand, BVarRef):
        count = profile.var("byte_count")
        if param.kind != "bvar" or not 0 <= operand.index < count:
            return f"bVAR{operand.index} is not allowed here"
        return None
    if param.kind == "var":
        return f"{operand} is not a variable (VARn is sent as {profile.var('macro_base'):#x} + n)"
    if isinstance(operand, ProgramRef):  # a compiler-side name: never on the wire
        return "a program name is not a device value"
    if isinstance(operand, float):
        if not math.isfinite(operand):
            return f"{operand} is not a number"
        return _outside(operand, param.min, param.max)
    value = int(operand)
    allowed, low, high = _values(param, profile)
    if allowed is not None:
        return None if value in allowed else f"{value:#x} is not one of the values it takes"
    if param.kind == "bvar" and low is None and high is None:
        return f"{value} is not a byte variable (bVARn is sent as 0x80 + n)"
    if (low is not None and value < low) or (high is not None and value > high):
        return _outside(value, low, high)
    return None


def _outside(value: float, low: float | None, high: float | None) -> str | None:
    if (low is not None and value < low) or (high is not None and value > high):
        return (f"{value} is outside {low if low is not None else '-inf'}.."
                f"{high if high is not None else 'inf'}")
    return None


Values = tuple[frozenset[int] | None, float | None, float | None]
"""The integers a parameter takes: a closed set of them (None: a range), and the range's
bounds (None: open on that side)."""
_ALLOWED: dict[tuple[int, int], tuple[Param, Profile, Values]] = {}


def _values(param: Param, profile: Profile) -> Values:
    """What `_refusal` checks an integer against, worked out once per parameter and profile:
    every downloaded line asks, and the device's per-line cost is a flash's floor."""
    key = (id(param), id(profile))
    known = _ALLOWED.get(key)
    if known is not None and known[0] is param and known[1] is profile:
        return known[2]
    values = _allowed_now(param, profile)
    low, high = param.min, param.max
    if param.wire == 2 and param.kind == "int":
        # a 32-bit data value the manual bounds by +-2,000,000,000 (e.g. RS 2451, 2705)
        low = profile.var("immediate_min") if low is None else low
        high = profile.var("immediate_max") if high is None else high
    worked_out: Values = (None if values is None else frozenset(values), low, high)
    _ALLOWED[key] = (param, profile, worked_out)
    return worked_out


_VAR_COUNT: dict[int, tuple[Profile, int]] = {}


def _var_count(profile: Profile) -> int:
    """VAR0..VARn-1 (RS 2394, 10144): n, looked up once per profile."""
    known = _VAR_COUNT.get(id(profile))
    if known is None or known[0] is not profile:
        known = _VAR_COUNT[id(profile)] = (profile, profile.var("count"))
    return known[1]


def _allowed(param: Param, profile: Profile) -> frozenset[int] | None:
    """The only values of a parameter that has a closed set of them (None: a range)."""
    return _values(param, profile)[0]


def _allowed_now(param: Param, profile: Profile) -> set[int] | None:
    kind = param.kind
    singles = set(profile.axes.values())
    offset = int(profile.raw["axes"]["initial_table_offset"])
    sets: dict[str, set[int]] = {
        "axis": set(range(1, 16)),  # Table 4 (RS 970-979)
        "axis1": singles,
        "axis1_or_none": singles | {0},
        "axis_it": set(range(1, 16)) | {c + offset for c in range(1, 16)},  # + Table 5
        "mp": set(profile.slot_numbers("mp")),
        "isr": set(profile.slot_numbers("isr")),
        "isr_or_none": set(profile.slot_numbers("isr")) | {0},
        "label": set(range(profile.limit("label_max") + 1)),  # labels 0..3 (RS 10719)
        "calc_op": set(profile.calc_ops.values()),
        # the constant table's codes and the worked example's byte order (compare_order)
        "cmp_op": {code for c in profile.cmp_ops.values()
                   for code in (c, ((c & 0xFF) << 8) | (c >> 8) if c > 0xFF else c)},
    }
    allowed = sets.get(kind)
    if param.values and kind != "cmp_op":
        allowed = set(param.values) if allowed is None else allowed & set(param.values)
    return allowed

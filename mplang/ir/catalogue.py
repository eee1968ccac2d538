"""The device knowledge: command catalogue and device profile, loaded once from `stdlib/`.

Everything device-specific (codes, register layouts, limits, budgets) lives in the TOML data
files described in `stdlib/m8194h/FORMAT.md`; this module only gives them types and indexes.
"""

from __future__ import annotations

import re
import sys
from functools import cache, cached_property
from typing import Any

from mplang.lang import caches, packagedata
from mplang.lang.record import FrozenRecord

WIRE_BY_TYPE = {"BYTE": 1, "WORD": 1, "short": 1, "DWORD": 2, "long": 2, "float": 2}
VENDOR_PREFIXES = ("RSM_", "ETM_")


class Param(FrozenRecord):
    name: str
    type: str
    wire: int
    kind: str
    var: bool
    min: int | float | None
    max: int | float | None
    values: tuple[int, ...]
    symbols: dict[str, int]
    encoding: str | None
    doc: str
    _fields = __match_args__ = ("name", "type", "wire", "kind", "var", "min", "max", "values",
                                "symbols", "encoding", "doc")

    def __init__(self, name: str, type: str, wire: int, kind: str, var: bool = False,
                 min: int | float | None = None, max: int | float | None = None,
                 values: tuple[int, ...] = (), symbols: dict[str, int] | None = None,
                 encoding: str | None = None, doc: str = "") -> None:
        self.__dict__.update(name=name, type=type, wire=wire, kind=kind, var=var, min=min,
                             max=max, values=values,
                             symbols={} if symbols is None else symbols, encoding=encoding,
                             doc=doc)


class Command(FrozenRecord):
    name: str  # RS vendor name, e.g. RSM_MACRO_FIXED_MOVE
    section: str
    code: int | None
    registers: int | None
    scope: frozenset[str]
    line_cost: int
    returns: bool
    targets: frozenset[str]
    params: tuple[Param, ...]
    summary: str
    lines: dict[str, int]
    choice: str
    _fields = __match_args__ = ("name", "section", "code", "registers", "scope", "line_cost",
                                "returns", "targets", "params", "summary", "lines", "choice")

    def __init__(self, name: str, section: str, code: int | None, registers: int | None,
                 scope: frozenset[str], line_cost: int, returns: bool, targets: frozenset[str],
                 params: tuple[Param, ...], summary: str = "",
                 lines: dict[str, int] | None = None, choice: str = "") -> None:
        self.__dict__.update(name=name, section=section, code=code, registers=registers,
                             scope=scope, line_cost=line_cost, returns=returns,
                             targets=targets, params=params, summary=summary,
                             lines={} if lines is None else lines, choice=choice)

    @cached_property
    def is_macro(self) -> bool:
        """Stored in a macro table (MP and/or ISR), as opposed to sent in real time."""
        return bool(self.scope & {"mp", "isr"})

    @cached_property
    def short_name(self) -> str:
        """The mplang name: vendor prefix and the MACRO marker removed (computed once: the
        assembler, the device's validation and the interpreter all look it up); interned, so
        the catalogue's cache entry holds it once however many commands share it."""
        return sys.intern(short_name(self.name))


def short_name(vendor: str) -> str:
    """`RSM_MACRO_FIXED_MOVE` -> `FIXED_MOVE`, `RSM_ABS_MACRO_FIXED_MOVE` -> `ABS_FIXED_MOVE`."""
    name = vendor.upper()
    for prefix in VENDOR_PREFIXES:
        if name.startswith(prefix):
            name = name[len(prefix) :]
            break
    if name.startswith("MACRO_"):
        return name[len("MACRO_") :]
    return name.replace("_MACRO_", "_", 1)


class SlotRange(FrozenRecord):
    kind: str  # "mp" or "isr"
    first: int
    last: int
    lines: int
    _fields = __match_args__ = ("kind", "first", "last", "lines")

    def __init__(self, kind: str, first: int, last: int, lines: int) -> None:
        self.__dict__.update(kind=kind, first=first, last=last, lines=lines)


class Profile(FrozenRecord):
    """The device profile: budgets, limits and codes (stdlib/m8194h/device.toml). Its dict
    fields make it unhashable, as the frozen dataclass it was."""

    raw: dict[str, Any]
    slots: tuple[SlotRange, ...]
    axes: dict[str, int]
    calc_ops: dict[str, int]
    cmp_ops: dict[str, int]
    cmp_symbols: dict[str, str]
    download_errors: dict[int, str]
    illegal_function_causes: dict[int, str]
    _fields = __match_args__ = ("raw", "slots", "axes", "calc_ops", "cmp_ops", "cmp_symbols",
                                "download_errors", "illegal_function_causes")

    def __init__(self, raw: dict[str, Any], slots: tuple[SlotRange, ...], axes: dict[str, int],
                 calc_ops: dict[str, int], cmp_ops: dict[str, int], cmp_symbols: dict[str, str],
                 download_errors: dict[int, str],
                 illegal_function_causes: dict[int, str]) -> None:
        self.__dict__.update(raw=raw, slots=slots, axes=axes, calc_ops=calc_ops,
                             cmp_ops=cmp_ops, cmp_symbols=cmp_symbols,
                             download_errors=download_errors,
                             illegal_function_causes=illegal_function_causes)

    @property
    def word_order_default(self) -> int:
        return int(self.raw["device"]["word_order_default"])

    @property
    def close_counts_as_line(self) -> bool:
        return bool(self.raw["download"]["close_counts_as_line"])

    def limit(self, key: str) -> int:
        return int(self.raw["limits"][key])

    def var(self, key: str) -> int:
        return int(self.raw["variables"][key])

    def budget(self, kind: str, slot: int) -> int | None:
        """Lines of MP/ISR slot `slot`, or None when the slot does not exist."""
        for rng in self.slots:
            if rng.kind == kind and rng.first <= slot <= rng.last:
                return rng.lines
        return None

    def slot_numbers(self, kind: str) -> list[int]:
        return [n for rng in self.slots if rng.kind == kind for n in range(rng.first, rng.last + 1)]

    def axis_code(self, name: str) -> int | None:
        """`XZ` or `AXIS_XZ` -> 0x5; `INITIAL_XZ` -> 0x15; None if not an axis name."""
        return self._axis_codes.get(name.upper())

    def allowed_axes(self, kind: str, values: tuple[int, ...] = ()) -> frozenset[int]:
        """The axis codes a parameter of `kind` (axis, axis1, axis1_or_none, axis_it) takes,
        narrowed to its catalogue `values`: worked out once per kind and values, as every
        axis argument of a build asks."""
        key = (kind, values)
        found = self._allowed_axes.get(key)
        if found is None:
            singles = set(self.axes.values())
            offset = int(self.raw["axes"]["initial_table_offset"])
            allowed = {
                "axis": set(range(1, 16)),
                "axis1": singles,
                "axis1_or_none": singles | {0},
                "axis_it": set(range(1, 16)) | {c + offset for c in range(1, 16)},
            }[kind]
            found = self._allowed_axes[key] = frozenset(allowed & set(values) if values
                                                        else allowed)
        return found

    @cached_property
    def _allowed_axes(self) -> dict[tuple[str, tuple[int, ...]], frozenset[int]]:
        return {}

    @cached_property
    def _axis_codes(self) -> dict[str, int | None]:
        """Every spelling `_axis_code` reads, worked out once (every axis argument of a
        build asks)."""
        letters = "XYZU"  # the order `_axis_code` accepts
        names = ["".join(c for i, c in enumerate(letters) if mask >> i & 1)
                 for mask in range(1 << len(letters))]
        spellings = [prefix + n for prefix in ("", "AXIS_", "INITIAL_") for n in names]
        return {s: self._axis_code(s) for s in spellings}

    def _axis_code(self, name: str) -> int | None:
        upper = name.upper()
        offset = 0
        if upper.startswith("AXIS_"):
            upper = upper[5:]
        elif upper.startswith("INITIAL_"):
            upper = upper[8:]
            offset = int(self.raw["axes"]["initial_table_offset"])
        if not upper or not re.fullmatch(r"X?Y?Z?U?", upper):
            return None
        return sum(self.axes[letter] for letter in upper) + offset

    def axis_name(self, code: int) -> str:
        letters = "".join(a for a, bit in self.axes.items() if code & bit)
        return letters or "0"


class Catalogue(FrozenRecord):
    """The commands of a family, indexed, with its device profile."""

    commands: tuple[Command, ...]
    profile: Profile
    by_vendor: dict[str, Command]
    macro_by_short: dict[str, Command]
    rtc_by_short: dict[str, Command]
    by_code: dict[int, Command]
    _fields = __match_args__ = ("commands", "profile", "by_vendor", "macro_by_short",
                                "rtc_by_short", "by_code")

    def __init__(self, commands: tuple[Command, ...], profile: Profile,
                 by_vendor: dict[str, Command], macro_by_short: dict[str, Command],
                 rtc_by_short: dict[str, Command], by_code: dict[int, Command]) -> None:
        self.__dict__.update(commands=commands, profile=profile, by_vendor=by_vendor,
                             macro_by_short=macro_by_short, rtc_by_short=rtc_by_short,
                             by_code=by_code)

    def lookup(self, name: str) -> Command | None:
        """Find a command by mplang name or by full RS/ET vendor name (macro forms first)."""
        upper = name.upper()
        for prefix in VENDOR_PREFIXES:
            if upper.startswith(prefix):
                return self.by_vendor.get("RSM_" + upper[len(prefix) :])
        return self.macro_by_short.get(upper) or self.rtc_by_short.get(upper)

    def macro(self, short: str) -> Command:
        """A macro command the compiler itself emits (MP_CLOSE, SET_VAR, ...)."""
        return self.macro_by_short[short]

    def all_names(self) -> list[str]:
        return sorted(set(self.macro_by_short) | set(self.rtc_by_short))


def _param(raw: dict[str, Any]) -> Param:
    return Param(
        name=raw["name"],
        type=raw["type"],
        wire=int(raw.get("wire", WIRE_BY_TYPE[raw["type"]])),
        kind=raw["kind"],
        var=bool(raw.get("var", False)),
        min=raw.get("min"),
        max=raw.get("max"),
        values=tuple(raw.get("values", ())),
        symbols={sys.intern(k.upper()): int(v) for k, v in raw.get("symbols", {}).items()},
        encoding=raw.get("encoding"),
        doc=raw.get("doc", ""),
    )


def _frozen(items: Any, sets: dict[frozenset[str], frozenset[str]] | None) -> frozenset[str]:
    """`frozenset(items)`, one object for equal sets when `sets` is given (`_share`)."""
    made = frozenset(items)
    return made if sets is None else sets.setdefault(made, made)


def _share(value: Any) -> Any:
    """`value` (what tomllib gives) with each string that occurs more than once one object
    (interned): tomllib makes a new one at each occurrence ("BYTE" 331 times, "axis" 199,
    the same doc line dozens), and the pickle the cache holds writes, and a run unpickles,
    one object per distinct object; this halves the objects of the catalogue's entry."""
    if isinstance(value, str):
        return sys.intern(value)  # one with the field names too (the entry's state keys)
    if isinstance(value, dict):
        return {sys.intern(k): _share(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_share(item) for item in value]
    return value


def _command(raw: dict[str, Any],
             sets: dict[frozenset[str], frozenset[str]] | None = None) -> Command:
    return Command(
        name=raw["name"],
        section=str(raw["section"]),
        code=raw.get("code"),
        registers=raw.get("registers"),
        scope=_frozen(raw.get("scope", ()), sets),
        line_cost=int(raw.get("line_cost", 1)),
        returns=bool(raw.get("returns", False)),
        targets=_frozen(raw.get("targets", ("rs", "et")), sets),
        params=tuple(_param(p) for p in raw.get("param", ())),
        summary=raw.get("summary", ""),
        lines=dict(raw.get("lines", {})),
        choice=raw.get("choice", ""),
    )


def _int_keys(table: dict[str, str]) -> dict[int, str]:
    return {int(k, 0): v for k, v in table.items()}


def _profile(raw: dict[str, Any]) -> Profile:
    axes = {k: int(v) for k, v in raw["axes"].items() if len(k) == 1}
    ops = raw["operators"]
    return Profile(
        raw=raw,
        slots=tuple(SlotRange(s["kind"], s["first"], s["last"], s["lines"]) for s in raw["slots"]),
        axes=axes,
        calc_ops={k: int(v) for k, v in ops["calculate"].items()},
        cmp_ops={k: int(v) for k, v in ops["compare"].items()},
        cmp_symbols=dict(ops["compare_symbols"]),
        download_errors=_int_keys(raw["download_errors"]),
        illegal_function_causes=_int_keys(raw["illegal_function"]["causes"]),
    )


def _read_text(family: str, filename: str) -> str:
    return packagedata.read_text("mplang.stdlib", family, filename)


CACHE_FORMAT = "catalogue 3"
"""Part of the cache key: change it when the classes of this module change shape."""

BUILDS: list[str] = []
"""The families whose catalogue was built from the TOML in this process (tests read it)."""


@cache
def load(family: str = "m8194h") -> Catalogue:
    """Load and index the catalogue and profile of a controller family (once per process).

    The TOML files stay the one source: the indexed result is kept in the user cache
    (`mplang.lang.caches`) under a hash of their text, so it is rebuilt whenever they
    change, and parsing them (most of the start-up of a short run) is skipped otherwise."""
    commands_text = _read_text(family, "commands.toml")
    device_text = _read_text(family, "device.toml")
    directory = caches.user_cache_dir()
    if directory is None:
        return _build(family, commands_text, device_text)
    key = caches.digest(CACHE_FORMAT, family, commands_text, device_text)
    path = directory / f"catalogue-{family}.pickle"
    found = caches.load(path, key)
    if isinstance(found, Catalogue):
        return found
    built = _build(family, commands_text, device_text)
    caches.store(path, key, built)
    return built


def _build(family: str, commands_text: str, device_text: str) -> Catalogue:
    """The catalogue from the text of its two TOML files."""
    BUILDS.append(family)
    import tomllib  # only when the cache misses: a run that hits never loads it

    sets: dict[frozenset[str], frozenset[str]] = {}
    commands = tuple(_command(_share(c), sets) for c in tomllib.loads(commands_text)["command"])
    profile = _profile(_share(tomllib.loads(device_text)))
    by_vendor = {sys.intern(c.name.upper()): c for c in commands}
    macro_by_short: dict[str, Command] = {}
    rtc_by_short: dict[str, Command] = {}
    for cmd in commands:
        table = macro_by_short if cmd.is_macro else rtc_by_short
        table.setdefault(cmd.short_name, cmd)
    by_code = {c.code: c for c in commands if c.code is not None}
    return Catalogue(commands, profile, by_vendor, macro_by_short, rtc_by_short, by_code)

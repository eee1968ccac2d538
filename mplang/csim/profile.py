"""The CSIM device knowledge: command catalogue and device profile, loaded once from
`stdlib/csim/` (commands.toml, device.toml, from_mp.toml).

Everything device-specific (commands, operand kinds and ranges, where a command may be used,
the protocol and the readings of what the manual leaves open) is data; this module only
gives it types and indexes, so the checker, the interpreter, the virtual device and the
downloader agree on one set of facts.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from typing import Any


@dataclass(frozen=True)
class OperandSpec:
    name: str
    kinds: tuple[str, ...]
    min: float | None = None
    max: float | None = None
    words: tuple[str, ...] = ()
    optional: bool = False


@dataclass(frozen=True)
class CommandSpec:
    name: str
    summary: str
    lines: str
    operands: tuple[OperandSpec, ...]
    prefix: bool
    use: frozenset[str]
    var_use: frozenset[str]
    modelled: bool


@dataclass(frozen=True)
class ParameterSpec:
    name: str
    summary: str
    lines: str
    kinds: tuple[str, ...]
    min: float | None
    max: float | None
    exclusive_min: bool
    values: tuple[int, ...]
    prefix: bool
    use: frozenset[str]
    modelled: bool


@dataclass(frozen=True)
class QuerySpec:
    name: str
    lines: str
    operand: str | None
    prefix: bool


@dataclass(frozen=True)
class MpRule:
    """How one M8194H macro command lowers to CSIM (`from_mp.toml`)."""

    name: str
    how: str
    note: str = ""


@dataclass(frozen=True)
class Profile:
    raw: dict[str, Any]
    commands: dict[str, CommandSpec]
    parameters: dict[str, ParameterSpec]
    queries: dict[str, QuerySpec]
    mp_rules: dict[str, MpRule] = field(default_factory=dict)

    def section(self, name: str) -> dict[str, Any]:
        value = self.raw[name]
        assert isinstance(value, dict)
        return value

    def fact(self, section: str, key: str) -> Any:
        return self.section(section)[key]

    @property
    def modules(self) -> int:
        return int(self.fact("device", "modules"))

    @property
    def inputs(self) -> int:
        return int(self.fact("device", "inputs"))

    @property
    def outputs(self) -> int:
        return int(self.fact("device", "outputs"))

    @property
    def events(self) -> int:
        return int(self.fact("program", "events"))

    @property
    def n_count(self) -> int:
        return int(self.fact("variables", "n_count"))

    @property
    def r_count(self) -> int:
        return int(self.fact("variables", "r_count"))

    @property
    def array_size(self) -> int:
        return int(self.fact("variables", "array_size"))

    @property
    def n_min(self) -> int:
        return int(self.fact("variables", "n_min"))

    @property
    def n_max(self) -> int:
        return int(self.fact("variables", "n_max"))

    @property
    def error_texts(self) -> dict[int, str]:
        return {int(k): str(v) for k, v in self.section("protocol")["errors"].items()}


def _operand(raw: dict[str, Any]) -> OperandSpec:
    return OperandSpec(name=raw["name"], kinds=tuple(raw["kind"].split("|")),
                       min=raw.get("min"), max=raw.get("max"),
                       words=tuple(raw.get("words", ())), optional=bool(raw.get("optional")))


def _command(raw: dict[str, Any]) -> CommandSpec:
    use = frozenset(raw["use"])
    return CommandSpec(name=raw["name"], summary=raw.get("summary", ""),
                       lines=raw.get("lines", ""),
                       operands=tuple(_operand(o) for o in raw.get("operands", ())),
                       prefix=bool(raw.get("prefix", False)), use=use,
                       var_use=frozenset(raw.get("var_use", use)),
                       modelled=bool(raw.get("modelled", True)))


def _parameter(raw: dict[str, Any]) -> ParameterSpec:
    return ParameterSpec(name=raw["name"], summary=raw.get("summary", ""),
                         lines=raw.get("lines", ""), kinds=tuple(raw["kind"].split("|")),
                         min=raw.get("min"), max=raw.get("max"),
                         exclusive_min=bool(raw.get("exclusive_min", False)),
                         values=tuple(raw.get("values", ())),
                         prefix=bool(raw.get("prefix", False)),
                         use=frozenset(raw.get("use", ("program", "immediate"))),
                         modelled=bool(raw.get("modelled", True)))


def _read(filename: str) -> dict[str, Any]:
    text = resources.files("mplang.stdlib").joinpath("csim", filename).read_text("utf-8")
    return tomllib.loads(text)


@cache
def load() -> Profile:
    """The CSIM profile and catalogue (read once per process)."""
    catalogue = _read("commands.toml")
    device = _read("device.toml")
    mapping = _read("from_mp.toml")
    commands = {c["name"]: _command(c) for c in catalogue["command"]}
    parameters = {p["name"]: _parameter(p) for p in catalogue["parameter"]}
    queries = {q["name"]: QuerySpec(q["name"], q.get("lines", ""), q.get("operand"),
                                    bool(q.get("prefix", False)))
               for q in catalogue["query"]}
    mp_rules = {name: MpRule(name, row["how"], row.get("note", ""))
                for name, row in mapping["command"].items()}
    device["catalogue"] = {"use": "inferred", "use_choice": catalogue.get("inferred_use", "")}
    device["from_mp"] = {key: value for key, value in mapping.items() if key.endswith("_choice")}
    return Profile(device, commands, parameters, queries, mp_rules)

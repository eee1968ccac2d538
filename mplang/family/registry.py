"""The controller families mplang knows, one line each, and how a target name or a source
file finds its family.

A line names the package and repeats its targets and native suffixes, so that `--help`,
`--target` checking and `mpc.toml` validation need not import any family; a test keeps the
repeated names equal to the packages' own `TARGETS` and `SUFFIXES`. Adding a family is one
new package that satisfies `mplang.family.face.Family` and one line in `FAMILIES`.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import TYPE_CHECKING, cast

from mplang.lang.record import FrozenRecord

if TYPE_CHECKING:
    from mplang.family.face import Family


class Registered(FrozenRecord):
    """One family: its package, its `--target` names (the first is its default) with what
    each means in words, and the suffixes of its own listings."""

    package: str
    targets: tuple[str, ...]
    suffixes: tuple[str, ...]
    target_titles: dict[str, str]
    _fields = __match_args__ = ("package", "targets", "suffixes", "target_titles")

    def __init__(self, package: str, targets: tuple[str, ...], suffixes: tuple[str, ...] = (),
                 target_titles: dict[str, str] | None = None) -> None:
        self.__dict__.update(package=package, targets=targets, suffixes=suffixes,
                             target_titles={} if target_titles is None else target_titles)

    def load(self) -> Family:
        return cast("Family", importlib.import_module(self.package))


FAMILIES = (
    Registered("mplang.m8194h", ("et", "rs"), (),
               {"et": "ET-M8194H, Modbus TCP", "rs": "RS-M8194H, Modbus RTU"}),
    Registered("mplang.fatek", ("fbs-fun140", "fbs-fun147"), (".fbs",)),
    Registered("mplang.csim", ("csim",), (".csim",)),
)
DEFAULT_TARGET = FAMILIES[0].targets[0]


def families() -> list[Family]:
    """Every family package, in registry order."""
    return [entry.load() for entry in FAMILIES]


def known_targets() -> tuple[str, ...]:
    """Every `--target` / `target =` value, in registry order."""
    return tuple(name for entry in FAMILIES for name in entry.targets)


def target_title(target: str) -> str:
    """What a target name means in words ("" where its name says it)."""
    return next((entry.target_titles.get(target, "") for entry in FAMILIES
                 if target in entry.targets), "")


def family_of_target(target: str) -> Family | None:
    """The family answering to a `--target` value; None for an unknown name."""
    entry = next((e for e in FAMILIES if target in e.targets), None)
    return None if entry is None else entry.load()


def family_of_path(path: Path) -> Family | None:
    """The family whose native suffix the file has; None for `.mp` (every family compiles
    it) and anything else."""
    suffix = path.suffix.lower()
    entry = next((e for e in FAMILIES if suffix in e.suffixes), None)
    return None if entry is None else entry.load()


def family_of_title(title: str) -> Family | None:
    """The family an image names (`"target": {"family": TITLE}`); None for no such name."""
    return next((f for f in families() if title == f.TITLE), None)

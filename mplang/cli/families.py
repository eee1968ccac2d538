"""The controller families beside the M8194H (issue 7) as `mpc` sees them.

Which family a command works for follows from the sources and `--target`: native listings
(`.fbs`, `.csim`: each family package names its `SUFFIXES`) belong to their family, `.mp`
sources to the target's. Everything the commands refuse for that reason (mixed families,
native files with `.mp` sources, a contradicting `--target`, options that only an M8194H
has) is decided here, once, as click usage errors (exit 2) naming the files. The family
packages are reached through one typed face, `Family`, which every package satisfies as a
module (mypy checks that below).
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import click

from mplang.cli.common import EXIT_RUN_FAILED, BuildSetup, report
from mplang.lang.diagnostics import Diagnostic
from mplang.m8194h.compiler import Options
from mplang.tools import project as project_module

M8194H_TITLE = "M8194H"
M8194H_FORMATS = ("json", "listing", "hex", "map", "vars", "vars-h", "vars-py", "triggers")
"""`mpc build --format` values of an M8194H build (the image and its views)."""


class FamilyBuild(Protocol):
    """What `check_native` and `compile_mp` return (the family contract)."""

    @property
    def diagnostics(self) -> list[Diagnostic]: ...

    @property
    def ok(self) -> bool: ...

    @property
    def programs(self) -> Sequence[object]: ...

    def render(self, fmt: str) -> str: ...

    def to_json(self) -> Mapping[str, object]: ...


class FamilyRun(Protocol):
    """What `run_build` returns: the `mpc run --json` summary and the sampled motion."""

    @property
    def called(self) -> str: ...

    @property
    def finished(self) -> bool: ...

    @property
    def error(self) -> str | None: ...

    @property
    def time_s(self) -> float: ...

    @property
    def samples(self) -> Sequence[tuple[float, Mapping[str, float]]]: ...

    def to_json(self) -> Mapping[str, object]: ...


class Family(Protocol):
    """A family package (`mplang.fatek`, `mplang.csim`) as a module: its constants read as
    properties (upper-case names, as the packages spell them)."""

    @property
    def TITLE(self) -> str: ...

    @property
    def TARGETS(self) -> tuple[str, ...]: ...

    @property
    def SUFFIXES(self) -> tuple[str, ...]: ...

    @property
    def FORMATS(self) -> tuple[str, ...]: ...

    @property
    def DEFAULT_FORMAT(self) -> str: ...

    @property
    def POSITION_UNIT(self) -> str: ...

    @property
    def TRANSPORTS(self) -> tuple[str, ...]: ...

    @property
    def NO_TRANSPORT(self) -> str: ...

    @property
    def NoSuchProgram(self) -> type[Exception]: ...

    @property
    def RunSetupError(self) -> type[Exception]: ...

    def check_native(self, paths: list[Path], target: str | None = None) -> FamilyBuild: ...

    def compile_mp(self, paths: list[Path], options: Options, target: str) -> FamilyBuild: ...

    def run_build(self, build: Any, call: str | None, max_time: float, *,
                  sample_period: float | None = ...) -> FamilyRun: ...


if TYPE_CHECKING:  # every family package has the face the CLI uses
    import mplang.csim
    import mplang.fatek

    _FATEK: Family = mplang.fatek
    _CSIM: Family = mplang.csim


def families() -> list[Family]:
    """Every family package, in the order of `mplang.tools.project.FAMILY_PACKAGES`."""
    found: list[Family] = [importlib.import_module(name)
                           for name in project_module.FAMILY_PACKAGES]
    return found


def family_of_target(target: str) -> Family | None:
    """The family of a `--target` value; None for the M8194H's et and rs."""
    package: Family | None = project_module.family_package(target)
    return package


def family_of_path(path: Path) -> Family | None:
    """The family whose native suffix the file has; None for `.mp` (and anything else)."""
    suffix = path.suffix.lower()
    if suffix == ".mp":
        return None
    return next((f for f in families() if suffix in f.SUFFIXES), None)


def title(family: Family | None) -> str:
    return M8194H_TITLE if family is None else family.TITLE


def _names(paths: Sequence[Path], limit: int = 4) -> str:
    shown = ", ".join(str(p) for p in paths[:limit])
    return shown + (f" and {len(paths) - limit} more" if len(paths) > limit else "")


@dataclass(frozen=True)
class Selection:
    """The family of one build and how to build it: native listings checked with the
    family's `check_native` (`target` narrows it, or None), or `.mp` sources compiled with
    its `compile_mp` for `target`. `family` None is the M8194H."""

    family: Family | None
    target: str | None
    native: bool
    paths: list[Path]

    def build(self, options: Options) -> FamilyBuild:
        family = self.family
        assert family is not None, "the M8194H builds through mplang.m8194h.compiler"
        if self.native:
            return family.check_native(self.paths, self.target)
        assert self.target is not None
        return family.compile_mp(self.paths, options, self.target)

    @property
    def describe(self) -> str:
        """`FATEK FBs-PLC (fbs-fun140)`, `CSIM`, for messages."""
        name = title(self.family)
        return f"{name} ({self.target})" if self.target and self.family is not None \
            and len(self.family.TARGETS) > 1 else name


def select(paths: list[Path], target: str, target_given: bool) -> Selection:
    """The family the sources and target ask for; a usage error if they disagree."""
    native: dict[int, tuple[Family, list[Path]]] = {}
    others: list[Path] = []
    for path in paths:
        family = family_of_path(path)
        if family is None:
            others.append(path)
        else:
            native.setdefault(id(family), (family, []))[1].append(path)
    if len(native) > 1:
        groups = "; ".join(f"{f.TITLE}: {_names(files)}" for f, files in native.values())
        raise click.UsageError(f"one build is for one controller family, and these sources "
                               f"are for several ({groups}); build them separately")
    if native:
        ((family, files),) = native.values()
        if others:
            raise click.UsageError(
                f"{family.TITLE} listings and .mp sources do not build together "
                f"({_names(files)} with {_names(others)}): build the listings on their own, "
                f"and the .mp sources with --target {family.TARGETS[0]}")
        if target_given and target not in family.TARGETS:
            raise click.UsageError(
                f"{_names(files)}: {family.TITLE} source(s), but the target is {target}; "
                f"use --target {' or '.join(family.TARGETS)}, or leave --target out")
        return Selection(family, target if target_given else None, True, paths)
    return Selection(family_of_target(target), target, False, paths)


def refuse_m8194h_options(selection: Selection, given: Mapping[str, bool]) -> None:
    """Options that only an M8194H build has, given for another family: a usage error."""
    if selection.family is None:
        return
    wrong = [name for name, was_given in given.items() if was_given]
    if wrong:
        raise click.UsageError(f"{', '.join(wrong)}: M8194H option(s); {selection.describe} "
                               "builds have no such setting")


def project_notes(selection: Selection, project: project_module.Project | None) -> list[str]:
    """What an mpc.toml sets that a family build does not use, said instead of dropped."""
    if selection.family is None or project is None:
        return []
    notes = []
    if project.pins:
        notes.append(f"mpc: note: {project.path}: [slots] pins place M8194H programs; "
                     f"{selection.describe} builds have no slots, so they do not apply")
    if project.word_order is not None:
        notes.append(f"mpc: note: {project.path}: word-order is an M8194H setting; "
                     f"{selection.describe} builds do not use it")
    return notes


def check_format(selection: Selection, fmt: str | None) -> str:
    """The `mpc build --format` of this build: the family's default if not given; a usage
    error for a format of another family."""
    family = selection.family
    if family is None:
        if fmt is None:
            return "json"
        if fmt not in M8194H_FORMATS:
            owners = [f for f in families() if fmt in f.FORMATS]
            raise click.UsageError(
                f"--format {fmt} is for {' and '.join(f.TITLE for f in owners)} builds; "
                f"an M8194H build writes {', '.join(M8194H_FORMATS)}")
        return fmt
    if fmt is None:
        return family.DEFAULT_FORMAT
    if fmt not in family.FORMATS:
        raise click.UsageError(f"--format {fmt} is not a format of {selection.describe} "
                               f"builds: use {', '.join(family.FORMATS)} "
                               f"(default {family.DEFAULT_FORMAT})")
    return fmt


def all_formats() -> tuple[str, ...]:
    """Every `mpc build --format` value: the M8194H's, then each family's own."""
    formats = list(M8194H_FORMATS)
    for family in families():
        formats += [f for f in family.FORMATS if f not in formats]
    return tuple(formats)


def choose(setup: BuildSetup) -> Selection:
    """The selection of a command's build (`select`), with the M8194H-only options refused
    and the project file's unused settings noted on standard error."""
    selection = select(setup.paths, setup.options.target, setup.target_given)
    refuse_m8194h_options(selection, {"--word-order": setup.word_order_given})
    for note in project_notes(selection, setup.project):
        click.echo(note, err=True)
    return selection


def build_and_run(selection: Selection, setup: BuildSetup, call: str | None, max_time: float,
                  sample_period: float | None) -> FamilyRun:
    """`mpc run` / `mpc plot` for a family: build (diagnostics to standard error, exit 1 on
    errors), then run on the family's virtual controller. An unknown --call is a usage
    error, a build that cannot run exits 5, as for the M8194H."""
    family = selection.family
    assert family is not None
    build = selection.build(setup.options)
    code = report(build, setup.werror)
    if code:
        sys.exit(code)
    try:
        run = family.run_build(build, call, max_time, sample_period=sample_period)
    except family.NoSuchProgram as exc:
        raise click.BadParameter(str(exc), param_hint="--call") from None
    except family.RunSetupError as exc:
        click.echo(f"mpc: {exc}", err=True)
        sys.exit(EXIT_RUN_FAILED)
    return run

"""Which controller family a command works for, as `mpc` decides it.

The family follows from the sources and `--target`: native listings (`.fbs`, `.csim`: each
registered family names its `SUFFIXES`) belong to their family, `.mp` sources to the
target's. Everything the commands refuse for that reason (mixed families, native files with
`.mp` sources, a contradicting `--target`, options the family has no use for) is decided
here, once, as click usage errors (exit 2) naming the files. Every family, the M8194H
included, is reached through one face (`mplang.family.face.Family`) found in one registry
(`mplang.family.registry`); nothing here asks which family it is.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import click

from mplang.cli import style
from mplang.cli.common import EXIT_RUN_FAILED, BuildSetup, report
from mplang.family.face import CommandError, Family, FamilyBuild, FamilyRun
from mplang.family.registry import families, family_of_path, family_of_target
from mplang.ir.unit import Options
from mplang.lang.record import FrozenRecord
from mplang.tools import project as project_module

if TYPE_CHECKING:  # every family package has the face the CLI uses
    import mplang.csim
    import mplang.fatek
    import mplang.m8194h
    from mplang.cli.runwatch import RunWatch
    from mplang.family.watch import Watch  # a run's only

    _M8194H: Family = mplang.m8194h
    _FATEK: Family = mplang.fatek
    _CSIM: Family = mplang.csim

__all__ = [
    "Family",
    "FamilyBuild",
    "FamilyRun",
    "Selection",
    "all_formats",
    "build_and_run",
    "check_format",
    "choose",
    "click_error",
    "identity_choice",
    "machine_for",
    "refuse_options",
    "select",
]


def _names(paths: Sequence[Path], limit: int = 4) -> str:
    shown = ", ".join(str(p) for p in paths[:limit])
    return shown + (f" and {len(paths) - limit} more" if len(paths) > limit else "")


class Selection(FrozenRecord):
    """The family of one build and how to build it: native listings checked with the
    family's `check_native` (`target` narrows it, or None), or `.mp` sources compiled with
    its `compile_mp` for `target`."""

    family: Family
    target: str | None
    native: bool
    paths: list[Path]
    _fields = __match_args__ = ("family", "target", "native", "paths")

    def __init__(self, family: Family, target: str | None, native: bool,
                 paths: list[Path]) -> None:
        self.__dict__.update(family=family, target=target, native=native, paths=paths)

    def build(self, options: Options, texts: dict[Path, str] | None = None) -> FamilyBuild:
        """The build; `texts` (by resolved path) stand for files (`mpc lint -`): only
        `.mp` sources can be read so, a native listing is refused."""
        if self.native:
            if texts:
                raise click.UsageError(f"{_names(self.paths)}: {self.family.TITLE} listings "
                                       "are not read from standard input; name the file")
            return self.family.check_native(self.paths, self.target)
        assert self.target is not None
        return self.family.compile_mp(self.paths, options, self.target, texts=texts)

    @property
    def describe(self) -> str:
        """`FATEK FBs-PLC (fbs-fun140)`, `CSIM`, `M8194H`, for messages."""
        name = self.family.TITLE
        return f"{name} ({self.target})" if self.target and len(self.family.TARGETS) > 1 \
            else name


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
    chosen = family_of_target(target)
    if chosen is None:
        raise click.UsageError(f"unknown target {target!r}")
    return Selection(chosen, target, False, paths)


def device_selection(setup: BuildSetup, device: project_module.Target) -> Selection:
    """The family and sources of one device of `mpc flash`, `status` or `monitor`: its own
    target (mpc.toml [targets.NAME]), else --target or the project's; its image or sources,
    else the command's FILEs (`select`)."""
    paths = [device.image] if device.image is not None else list(device.sources) or setup.paths
    return select(paths, device.target or setup.options.target,
                  setup.target_given or device.target is not None)


def _owners(option: str, attribute: str) -> str:
    """The families that take `option` (their `BUILD_OPTIONS` or `SERVE_OPTIONS`)."""
    return " and ".join(f.TITLE for f in families() if option in getattr(f, attribute))


def refuse_options(selection: Selection, given: Mapping[str, bool],
                   attribute: str = "BUILD_OPTIONS") -> None:
    """Options given on the command line that the selected family has no use for (they are
    not in its `attribute`, `BUILD_OPTIONS` or `SERVE_OPTIONS`): a usage error."""
    taken = getattr(selection.family, attribute)
    wrong = [name for name, was_given in given.items() if was_given and name not in taken]
    if wrong:
        owners = sorted({_owners(name, attribute) for name in wrong})
        raise click.UsageError(f"{', '.join(wrong)}: {' and '.join(owners)} option(s); "
                               f"{selection.describe} builds have no such setting")


def project_notes(selection: Selection, project: project_module.Project | None) -> list[str]:
    """What an mpc.toml sets that this family's build does not use, said instead of
    dropped."""
    if project is None:
        return []
    notes = []
    if project.pins and "--pins" not in selection.family.BUILD_OPTIONS:
        notes.append(f"mpc: note: {project.path}: [slots] pins place M8194H programs; "
                     f"{selection.describe} builds have no slots, so they do not apply")
    if project.word_order is not None and "--word-order" not in selection.family.BUILD_OPTIONS:
        notes.append(f"mpc: note: {project.path}: word-order is an M8194H setting; "
                     f"{selection.describe} builds do not use it")
    return notes


def check_format(selection: Selection, fmt: str | None) -> str:
    """The `mpc build --format` of this build: the family's default if not given; a usage
    error for a format of another family."""
    family = selection.family
    if fmt is None:
        return family.DEFAULT_FORMAT
    if fmt not in family.FORMATS:
        owners = " and ".join(f.TITLE for f in families() if fmt in f.FORMATS)
        raise click.UsageError(f"--format {fmt} is not a format of {selection.describe} "
                               f"builds (it is for {owners} builds): use "
                               f"{', '.join(family.FORMATS)} (default {family.DEFAULT_FORMAT})")
    return fmt


def all_formats() -> tuple[str, ...]:
    """Every `mpc build --format` value, family by family in registry order."""
    formats: list[str] = []
    for family in families():
        formats += [f for f in family.FORMATS if f not in formats]
    return tuple(formats)


def choose(setup: BuildSetup) -> Selection:
    """The selection of a command's build (`select`), with the options the family does not
    take refused and the project file's unused settings noted on standard error."""
    selection = select(setup.paths, setup.options.target, setup.target_given)
    refuse_options(selection, {"--word-order": setup.word_order_given})
    for note in project_notes(selection, setup.project):
        click.echo(note, err=True)
    return selection


def build_checked(selection: Selection, setup: BuildSetup) -> FamilyBuild:
    """Build; diagnostics to standard error, and exit 1 on errors (or warnings with
    --werror)."""
    build = selection.build(setup.options)
    code = report(build, setup.werror, setup.ignore)
    if code:
        sys.exit(code)
    return build


def machine_for(selection: Selection, machine_file: Path | None,
                project: project_module.Project | None) -> object | None:
    """The simulated machine of a run or a `mpc sim`: `--machine FILE`, else the project's
    `[machine]` table, read by the family (docs/machine.md). A bad file exits 17 at its
    line; `--machine` for a family without one is a usage error with the family's reason,
    a project's `[machine]` a note."""
    from mplang.cli.common import BadMachine
    from mplang.family.face import MachineError

    family = selection.family
    if machine_file is None and (project is None or not project.machine):
        return None
    load = family.load_machine
    if load is None:
        reason = family.NO_MACHINE or "its virtual device has no machine"
        if machine_file is not None:
            raise click.UsageError(f"--machine: {selection.describe} runs take no machine "
                                   f"file: {reason}")
        assert project is not None
        click.echo(f"mpc: note: {project.path}: [machine] does not apply: {reason}", err=True)
        return None
    try:
        if machine_file is not None:
            return load(machine_file, False)
        assert project is not None
        return load(project.path, True)
    except MachineError as exc:
        raise BadMachine(str(exc)) from None


def watched_run(command: str, selection: Selection, setup: BuildSetup, call: str | None,
                max_time: float, sample_period: float | None,
                machine_file: Path | None) -> tuple[FamilyRun, RunWatch]:
    """`mpc run` / `mpc plot`: build and run on the machine of `machine_for`, with the
    status line on a terminal and Ctrl-C stopping the run (`mplang.cli.runwatch`); the run,
    and the watch that saw it (whether and where Ctrl-C ended it)."""
    from mplang.cli.runwatch import RunWatch

    machine = machine_for(selection, machine_file, setup.project)
    watch = RunWatch(command)
    with watch.active():
        run = build_and_run(selection, setup, call, max_time, sample_period, machine=machine,
                            watch=watch)
    return run, watch


def build_and_run(selection: Selection, setup: BuildSetup, call: str | None, max_time: float,
                  sample_period: float | None, machine: object | None = None,
                  watch: Watch | None = None) -> FamilyRun:
    """`mpc run` / `mpc plot`: build, then run on the family's virtual controller (on
    `machine`, from `machine_for`; `watch` sees it go, `mplang.cli.runwatch`). An unknown
    --call is a usage error, a build that cannot run exits 5."""
    family = selection.family
    build = build_checked(selection, setup)
    try:
        run = family.run_build(build, call, max_time, sample_period=sample_period,
                               machine=machine, watch=watch)
    except family.NoSuchProgram as exc:
        raise click.BadParameter(str(exc), param_hint="--call") from None
    except family.RunSetupError as exc:
        style.error(str(exc))
        sys.exit(EXIT_RUN_FAILED)
    return run


def click_error(exc: CommandError) -> click.ClickException:
    """What a family's `CommandError` is on the command line: exit 3 for bad input, a usage
    error (naming the option to blame, if any) otherwise."""
    from mplang.cli.common import InputError

    if exc.kind == "input":
        return InputError(str(exc))
    if exc.param is not None:
        return click.BadParameter(str(exc), param_hint=exc.param)
    return click.UsageError(str(exc))


def identity_choice(identity: str | None, no_identity: bool,
                    settings: project_module.FlashSettings | None
                    ) -> tuple[str | bool | None, str | None]:
    """The build manifest's machine-data range for `mpc flash` and `mpc status`: --identity,
    none with --no-identity, else `[flash] identity`, else the family's default (None); and
    where the project file set it, for messages about it."""
    if identity is not None and no_identity:
        raise click.UsageError("give --identity RANGE or --no-identity, not both")
    if no_identity:
        return False, None
    if identity is not None or settings is None:
        return identity, None
    return settings.identity, settings.identity_where

"""What every `mpc` command shares: exit codes, the never-a-traceback guard, input
expansion, and the compiler and serial-line options."""


from __future__ import annotations

import errno
import os
import sys
from collections.abc import Callable, Sequence
from functools import wraps
from pathlib import Path
from typing import Any, Protocol, TypeVar

import click

from mplang.cli import style
from mplang.cli.shell import complete_targets
from mplang.family.registry import DEFAULT_TARGET, known_targets
from mplang.ir.unit import DEFAULT_TEMPS, Options
from mplang.lang import caches
from mplang.lang.diagnostics import (
    Diagnostic,
    DiagnosticSink,
    Severity,
    Span,
    without_ignored,
)
from mplang.lang.record import FrozenRecord
from mplang.tools import project as project_module

EXIT_OK = 0
EXIT_SOURCE_ERRORS = 1
EXIT_USAGE = 2
EXIT_NO_INPUT = 3
EXIT_OUTPUT = 4
EXIT_RUN_FAILED = 5
EXIT_TRANSPORT = 6
EXIT_NO_DEVICE = 7
EXIT_REJECTED = 8
EXIT_UNVERIFIED = 9
EXIT_INTERRUPTED = 10
EXIT_FLEET_MIXED = 11
EXIT_WOULD_REFORMAT = 12
EXIT_OMISSIONS = 13
EXIT_NOT_EXACT = 14
EXIT_MISSING_EXTRA = 15
EXIT_OUT_OF_SYNC = 16
EXIT_BAD_MACHINE = 17
EXIT_LEASED = 19
EXIT_WAIT_TIMEOUT = 20
"""`mpc call --wait`: the program did not end within --timeout."""
EXIT_INTERNAL = 70
SERVER_PORT = 1502
"""`mpc sim --tcp HOST`'s port (502 needs privileges; 1502 is the usual unprivileged one)."""
FLASH_EXIT = {"verified": EXIT_OK, "no-port": EXIT_TRANSPORT, "no-device": EXIT_NO_DEVICE,
              "rejected": EXIT_REJECTED, "unverified": EXIT_UNVERIFIED,
              "interrupted": EXIT_INTERRUPTED, "mixed": EXIT_FLEET_MIXED,
              "leased": EXIT_LEASED}
"""A flash's outcome (`mplang.family.face.FLASH_OUTCOMES`) -> the exit code."""

F = TypeVar("F", bound=Callable[..., Any])


class InputError(click.ClickException):
    exit_code = EXIT_NO_INPUT


class OutputError(click.ClickException):
    exit_code = EXIT_OUTPUT


class MissingExtra(click.ClickException):
    """An optional dependency of a command (one of mplang's extras) is not installed."""

    exit_code = EXIT_MISSING_EXTRA


def require_extra(command: str, extra: str, *modules: str) -> None:
    """Import `modules` (mplang's `extra`) or end `command` saying how to get them: the extra
    by name and the form that works in a source folder (`pip install '.[plot]'`), since on
    a public index `mplang[plot]` may name another project's package."""
    import importlib

    for module in modules:
        try:
            importlib.import_module(module)
        except ImportError as exc:
            raise MissingExtra(
                f"{command} needs {modules[0]}, which cannot be imported ({exc}); install the "
                f"{extra} extra of mplang (in its source folder: pip install '.[{extra}]')"
            ) from None


class BadMachine(click.ClickException):
    """A machine file (`--machine`, an mpc.toml's `[machine]`) that cannot be used."""

    exit_code = EXIT_BAD_MACHINE


def near_path(path: str | os.PathLike[str]) -> str:
    """`path` relative to the working directory, for messages and project sources; as it is
    when it has no such form (on Windows, a path on another drive: relpath raises there)."""
    try:
        return os.path.relpath(path)
    except ValueError:
        return os.fspath(path)


def guarded(func: F) -> F:
    """Turn any unexpected exception into one line and exit 70: never a traceback."""

    @wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except (click.ClickException, click.exceptions.Exit, click.Abort, SystemExit,
                BrokenPipeError):
            raise  # BrokenPipeError: the group ends quietly (mplang.cli.CommandPackage)
        except KeyboardInterrupt:
            style.error("interrupted")
            sys.exit(130)
        except Exception as exc:
            style.error(f"internal error: {type(exc).__name__}: {exc}\n"
                        "This is a bug in mpc; please report it with the input that caused it.")
            sys.exit(EXIT_INTERNAL)

    return wrapper  # type: ignore[return-value]


def expand_inputs(patterns: tuple[str, ...], skip_projects: bool = False) -> list[Path]:
    """Files, directories (every .mp below) and glob patterns, in a stable order. With
    `skip_projects` (one build), a directory's sub-folders that are projects of their own
    (an mpc.toml of their own) are left out, with a note: they are other builds."""
    paths: list[Path] = []
    for pattern in patterns:
        path = Path(pattern)
        try:  # a name the system refuses (too long, a loop of links) is the user's input
            path.stat()
        except OSError as exc:
            if exc.errno not in (errno.ENOENT, errno.ENOTDIR):
                raise InputError(f"{_shown(pattern)}: {exc.strerror or exc}") from None
        if path.is_dir():
            found = sorted(p for p in path.rglob("*.mp") if p.is_file())  # no FIFOs
            if skip_projects:
                found = _own_project(path, found)
            if not found:
                raise InputError(f"no .mp files in directory {pattern}")
            paths += found
        elif path.exists():
            paths.append(path)
        elif any(ch in pattern for ch in "*?["):
            import glob  # for a file pattern only

            matches = sorted(Path(m) for m in glob.glob(pattern, recursive=True))
            if not matches:
                raise InputError(f"no files match {pattern}")
            paths += matches
        else:
            raise InputError(f"{pattern}: no such file")
    from mplang.lang.sources import not_regular

    for p in paths:
        special = not_regular(p)
        if special is not None:  # a FIFO or a device would block, or never end
            raise InputError(f"{_shown(str(p))}: it is {special}, not a regular file")
    unique: list[Path] = []
    seen: set[Path] = set()
    for p in paths:
        if p.resolve() not in seen:
            seen.add(p.resolve())
            unique.append(p)
    return unique


def _own_project(directory: Path, found: list[Path]) -> list[Path]:
    """The files of `found` (below `directory`) under the directory's own project file
    (or none), noting on standard error each sub-folder left out for its own mpc.toml."""
    own = project_module.find_project(directory)
    kept: list[Path] = []
    skipped: dict[Path, int] = {}
    for path in found:
        nearest = project_module.find_project(path.parent)
        if nearest == own:
            kept.append(path)
        elif nearest is not None:
            skipped[nearest] = skipped.get(nearest, 0) + 1
    for project, count in skipped.items():
        click.echo(f"mpc: note: {near_path(project.parent)}: left out ({count} .mp "
                   f"file{'s' if count != 1 else ''}), a project of its own "
                   f"({near_path(project)}): build it on its own", err=True)
    return kept


def _shown(name: str) -> str:
    """A file name as messages show it: at most 80 characters."""
    return name if len(name) <= 80 else f"{name[:40]}...{name[-20:]}"


def parse_temps(_ctx: click.Context, _param: click.Parameter, value: str | None) -> range:
    if value is None:
        return DEFAULT_TEMPS
    try:
        return project_module.parse_temps(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


def write_output(text: str, output: str | None) -> None:
    if output is None or output == "-":
        click.echo(text, nl=False)
        return
    try:
        Path(output).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise OutputError(f"cannot write {output}: {exc.strerror or exc}") from None


STDIN = "-"
"""A FILE argument that means standard input (`mpc lint -`, `mpc fmt -`)."""
STDIN_NAME = "<stdin>"
"""What messages call standard input without `--stdin-filename`."""

stdin_filename_option = click.option(
    "--stdin-filename", default=None, metavar="PATH",
    help="With '-': the file standard input stands for; messages name it, its INCLUDEs are "
    "relative to it, and the mpc.toml nearest it applies (as editors lint unsaved buffers).")


def decode_source(data: bytes, display: str) -> str | None:
    """UTF-8 text, or None after the compiler's E105 diagnostic for anything else."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        sink = DiagnosticSink()
        sink.add("E105", Span(display, 1), f"{display} is not UTF-8 text ({exc.reason})")
        style.report_diagnostics(sink.items)
        return None


def stdin_project(ctx: click.Context, name: str | None, project_file: Path | None
                  ) -> project_module.Project | None:
    """The project file standard input is read under: `--project FILE`, none with
    `--isolated`, else the mpc.toml nearest `--stdin-filename` (without it: nearest here)."""
    if project_file is not None and isolated(ctx):
        raise click.UsageError("give --project FILE or --isolated, not both")
    if project_file is not None:
        return load_project_file(project_file)
    if isolated(ctx):
        return None
    folder = Path(name).parent if name else Path.cwd()
    found = project_module.find_project(folder.resolve())
    return None if found is None else load_project_file(Path(os.path.relpath(found)))


def stdin_setup(ctx: click.Context, name: str, project_file: Path | None, target: str,
                word_order: str | None, temp_vars: range, allow_outside_includes: bool,
                werror: bool) -> BuildSetup:
    """The build standard input is checked in as if it were the file `name`: with the other
    sources of its project when the project lists it (as the language server checks a
    buffer), else alone; the project's settings apply either way."""
    path = Path(name)
    project = stdin_project(ctx, name, project_file)
    paths = [path]
    if project is not None and path.resolve() in {p.resolve() for p in project.sources}:
        paths = [path if p.resolve() == path.resolve() else Path(os.path.relpath(p))
                 for p in project.sources]
    return _setup(ctx, paths, project, target, word_order, temp_vars, allow_outside_includes,
                  werror, keep_pins=False)


class HasDiagnostics(Protocol):
    """A build of any controller family: the M8194H's BuildResult or a FamilyBuild."""

    @property
    def diagnostics(self) -> list[Diagnostic]: ...


def report(result: HasDiagnostics, werror: bool, ignore: frozenset[str] = frozenset()) -> int:
    """Every diagnostic (but the warnings a project's `[lint] ignore` names) with its source
    excerpt, then `2 errors, 1 warning in 3 files` when there was any; exit 1 on an error,
    or a warning with --werror."""
    diagnostics = without_ignored(result.diagnostics, ignore)
    style.report_diagnostics(diagnostics)
    if diagnostics:
        style.echo_summary(diagnostics, werror)
    errors = sum(1 for d in diagnostics if d.severity is Severity.ERROR)
    warnings = len(diagnostics) - errors
    if errors or (werror and warnings):
        return EXIT_SOURCE_ERRORS
    return EXIT_OK


class DeviceUI:
    """How a command that talks to a device (`mpc flash`, `mpc status`) shows what the
    family's work says: its lines on standard error (an error as `mpc: error: ...`, as every
    command's), its output on standard output, and the build's diagnostics, which end the
    command when they fail it."""

    def __init__(self, command: str, werror: bool) -> None:
        self.command = command
        self.werror = werror

    def say(self, text: str) -> None:
        from mplang.cli.progress import is_error, narration

        if style.quiet() and not is_error(text):
            return  # `--quiet`: errors only
        click.echo(narration(self.command, text), err=True)

    def out(self, text: str) -> None:
        click.echo(text, nl=False)

    def checked(self, build: HasDiagnostics) -> None:
        code = report(build, self.werror)
        if code:
            sys.exit(code)


class LazyChoice(click.Choice[str]):
    """A choice whose values beyond `first` come from `rest()` only when they are needed
    (an unknown value, help, completion): `--target` lists the family packages' targets
    without importing them for `mpc --help` or an M8194H build."""

    def __init__(self, first: Sequence[str], rest: Callable[[], Sequence[str]]) -> None:
        super().__init__(first)
        self._first = tuple(first)
        self._rest = rest
        self._all: tuple[str, ...] | None = None

    @property  # click stores a tuple; this computes it once
    def choices(self) -> tuple[str, ...]:
        if self._all is None:
            self._all = (*self._first, *(c for c in self._rest() if c not in self._first))
        return self._all

    @choices.setter
    def choices(self, value: Sequence[str]) -> None:
        self._first = tuple(value)
        self._all = None

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> str:
        if value in self._first:
            return str(value)
        return super().convert(value, param, ctx)


TARGET_HELP = ("Controller: et (ET-M8194H, Modbus TCP), rs (RS-M8194H, Modbus RTU), or the "
               "target of another controller family (FATEK FBs-PLC positioning tables, CSIM "
               "RS232 programs: docs/cli.md); native listings imply their family's.")

common_options = [
    click.option("--target", type=click.Choice(known_targets()), default=DEFAULT_TARGET,
                 show_default=True, help=TARGET_HELP),
    click.option("--word-order", type=click.Choice(["0", "1"]), default=None,
                 help="Device word order (holding register 14). Default: the device's, 0."),
    click.option("--temp-vars", callback=parse_temps, default=None, metavar="FIRST-LAST",
                 help="VAR pool for expression temporaries [default: 500-511]."),
    click.option("--allow-outside-includes", is_flag=True,
                 help="Let INCLUDE reach files outside the project directory."),
    click.option("--werror", is_flag=True, help="Treat warnings as errors."),
    click.option("--no-cache", is_flag=True, expose_value=False, is_eager=True,
                 callback=lambda _ctx, _param, off: caches.turn_off(bool(off)),
                 help="Parse every source again: neither read nor write mpc's cache "
                      "(docs/cli.md, \"Caches\")."),
]


def with_common(func: F) -> F:
    for option in reversed(common_options):
        func = option(func)
    return func


serial_line_options = [
    click.option("--baud", type=click.IntRange(min=50), default=115200, show_default=True,
                 help="Serial line speed."),
    click.option("--parity", type=click.Choice(["N", "E", "O"]), default="N",
                 show_default=True, help="Serial line parity."),
    click.option("--stopbits", type=click.Choice(["1", "2"]), default="1", show_default=True,
                 help="Serial line stop bits."),
]


def with_serial_line(func: F) -> F:
    """The RTU line settings `mpc sim` and `mpc flash` share."""
    for option in reversed(serial_line_options):
        func = option(func)
    return func


def device_options(serial_help: str, to_help: str) -> Callable[[F], F]:
    """The options that name one device (`mpc flash`, `status`, `monitor`): --tcp, --serial,
    --unit, the RTU line settings and --to; `chosen_device` reads them."""
    options = [
        click.option("--tcp", callback=parse_device_address, default=None,
                     metavar="HOST[:PORT]", help="The device's Modbus TCP address (ET-M8194H) "
                     "[default port: 502]."),
        click.option("--serial", default=None, metavar="PORT", help=serial_help),
        click.option("--unit", type=click.IntRange(1, 247), default=1, show_default=True,
                     help="Modbus unit id: the RTU slave address (the ET-M8194H answers as "
                     "1)."),
        with_serial_line,
        click.option("--to", "to", default=None, metavar="NAME", help=to_help,
                     shell_complete=complete_targets),
    ]

    def decorate(func: F) -> F:
        for option in reversed(options):
            func = option(func)
        return func

    return decorate


def chosen_device(tcp: tuple[str, int] | None, serial: str | None, unit: int, baud: int,
                  parity: str, stopbits: str, to: str | None,
                  project: project_module.Project | None) -> project_module.Target:
    """The device `device_options` name: --tcp, --serial, or --to NAME of the project (a
    usage error naming the file when it has no such [targets.NAME])."""
    if tcp is not None:
        return project_module.Target(f"{tcp[0]}:{tcp[1]}", host=tcp[0], port=tcp[1],
                                     unit=unit, baud=baud, parity=parity,
                                     stopbits=int(stopbits))
    if serial is not None:
        return project_module.Target(serial, serial=serial, unit=unit, baud=baud,
                                     parity=parity, stopbits=int(stopbits))
    if project is None:
        raise click.UsageError("--to names a [targets] device of mpc.toml, and there is no "
                               "mpc.toml here or above (or give --project)")
    if to not in project.targets:
        known = ", ".join(project.targets) or "none"
        raise click.BadParameter(f"{project.path} has no [targets.{to}] (targets: {known})",
                                 param_hint="--to")
    return project.targets[to]


def build_options(target: str, word_order: str | None, temp_vars: range,
                  allow_outside_includes: bool) -> Options:
    return Options(word_order=None if word_order is None else int(word_order), target=target,
                   temps=temp_vars, allow_outside_includes=allow_outside_includes)


def parse_host_port(_ctx: click.Context, _param: click.Parameter,
                    value: str | None) -> tuple[str, int] | None:
    """Where a server listens (`mpc sim --tcp`): the one `--tcp` convention of
    `project.parse_address` (PORT alone is a port on 127.0.0.1), port 1502 by default and port
    0 for any free one."""
    if value is None:
        return None
    try:
        return project_module.parse_address(value, SERVER_PORT, any_port=True)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


def parse_device_address(_ctx: click.Context, _param: click.Parameter,
                         value: str | None) -> tuple[str, int] | None:
    """A device to reach (`mpc flash --tcp`): the same convention, with the Modbus TCP port
    502 by default; a bare number is a port on 127.0.0.1 (a local `mpc sim`)."""
    if value is None:
        return None
    try:
        return project_module.parse_address(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


def parse_listen_port(_ctx: click.Context, _param: click.Parameter,
                      value: str | None) -> tuple[str, int] | None:
    """Where a server without a usual port listens (`mpc lsp --tcp`): PORT (on 127.0.0.1)
    or HOST:PORT, the same convention with the port always given."""
    if value is None:
        return None
    try:
        return project_module.parse_address(value, None)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


ISOLATED = "mpc.isolated"
"""ctx.meta key: `--isolated` was given (no project file is read)."""


def _note_isolated(ctx: click.Context, _param: click.Parameter, value: bool) -> bool:
    ctx.meta[ISOLATED] = value
    return value


_project_file_option = click.option(
    "--project", "--config", "project_file",
    type=click.Path(dir_okay=False, path_type=Path), default=None,
    help="Project file to use for every FILE [default: for each FILE the nearest mpc.toml "
    "above it; without FILE, mpc.toml here or in a parent directory].")
_isolated_option = click.option(
    "--isolated", is_flag=True, expose_value=False, callback=_note_isolated,
    help="Read no project file: only the command line's options apply.")


def project_option(func: F) -> F:
    """`--project/--config FILE` and `--isolated`: which project file applies."""
    return _project_file_option(_isolated_option(func))


def isolated(ctx: click.Context | None = None) -> bool:
    """Whether `--isolated` was given to the current command."""
    ctx = ctx or click.get_current_context(silent=True)
    return bool(ctx is not None and ctx.meta.get(ISOLATED))
machine_option = click.option(
    "--machine", "machine_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
    help="The simulated machine: a TOML file with a [machine] table (switches, start "
    "positions, inputs over time; docs/machine.md) [default: the project's [machine]].")


class BuildSetup(FrozenRecord):
    """What to compile and how: the command line merged over the project file."""

    paths: list[Path]
    options: Options
    werror: bool
    project: project_module.Project | None
    target_given: bool  # --target on the command line, or the project file's
    word_order_given: bool  # --word-order on the command line (M8194H only)
    _fields = __match_args__ = ("paths", "options", "werror", "project", "target_given",
                                "word_order_given")

    def __init__(self, paths: list[Path], options: Options, werror: bool,
                 project: project_module.Project | None, target_given: bool = False,
                 word_order_given: bool = False) -> None:
        self.__dict__.update(paths=paths, options=options, werror=werror, project=project,
                             target_given=target_given, word_order_given=word_order_given)

    def settings(self) -> tuple[object, ...]:
        """What this build takes from its project file: builds that agree in it can be
        one."""
        return (self.options, self.werror, self.ignore, self.target_given,
                self.word_order_given)

    @property
    def ignore(self) -> frozenset[str]:
        """The project's `[lint] ignore` codes (none without a project file)."""
        return self.project.ignore if self.project is not None else frozenset()


def load_project_file(path: Path) -> project_module.Project:
    try:
        return project_module.load_project(path)
    except project_module.ProjectError as exc:
        raise InputError(str(exc)) from None


def _given(ctx: click.Context, name: str) -> bool:
    source = ctx.get_parameter_source(name)
    return source is not None and source is not click.core.ParameterSource.DEFAULT


def refuse_images(paths: Sequence[Path]) -> None:
    """A built image given where sources belong (`mpc build image.json`): one message
    saying what it is and what to do with it, instead of a syntax error per line. What
    `mpc build` writes as JSON is an object with "format" and "target"; no .mp source or
    native listing starts with `{`, so nothing else is read whole."""
    from mplang.lang.limits import read_json_file

    for path in paths:
        try:
            if not path.is_file():
                continue  # the build says what it is (a FIFO is never opened here)
            with path.open("rb") as stream:
                if not stream.read(256).lstrip().startswith(b"{"):
                    continue
            data = read_json_file(path, errors="strict")
        except (OSError, ValueError):
            continue  # the build reports what is wrong with the file itself
        if isinstance(data, dict) and "format" in data and "target" in data:
            raise InputError(f"{path}: a built image (the JSON `mpc build` writes), not a "
                             f"source: flash it with `mpc flash {path} --tcp HOST` (or "
                             f"--serial PORT), compare it with a device with `mpc status`, or "
                             f"turn it back into .mp source with `mpc disasm {path}`; build "
                             "and run take .mp sources (or .fbs / .csim listings)")


def nearest_projects(paths: Sequence[Path]) -> list[tuple[Path | None, list[Path]]]:
    """`paths` grouped by the nearest mpc.toml above each (None: no project file), in the
    order the groups first appear: each FILE is checked with its own project's settings,
    as ruff finds its configuration."""
    found: dict[Path, Path | None] = {}
    groups: dict[Path | None, list[Path]] = {}
    for path in paths:
        folder = path.parent.resolve()
        if folder not in found:
            found[folder] = project_module.find_project(folder)
        groups.setdefault(found[folder], []).append(path)
    return list(groups.items())


def _shown_project(setup: BuildSetup) -> str:
    """`FILE (its mpc.toml)` of a build's first file, for messages."""
    where = near_path(setup.project.path) if setup.project is not None else "no mpc.toml"
    return f"{setup.paths[0]} ({where})"


def build_setups(ctx: click.Context, files: tuple[str, ...], project_file: Path | None,
                 target: str, word_order: str | None, temp_vars: range,
                 allow_outside_includes: bool, werror: bool,
                 need_sources: bool = True, one_build: bool = False) -> list[BuildSetup]:
    """The builds FILE... makes, one per project: each FILE is built with the settings of
    the nearest mpc.toml above it (`--project FILE` names one for all, `--isolated` none).
    Without FILE, the project file found from here up gives the sources. Options given on
    the command line win over a project file's. `mpc flash` and `mpc status`
    (`need_sources=False`) read the project only without FILE or with --project: their
    devices and flash record come from it. For `one_build`, a folder's sub-folders with an
    mpc.toml of their own are left out (`expand_inputs`)."""
    if project_file is not None and isolated(ctx):
        raise click.UsageError("give --project FILE or --isolated, not both")
    if not files:
        project = None
        if project_file is not None:
            project = load_project_file(project_file)
        elif not isolated(ctx):
            found = project_module.find_project(Path.cwd())
            if found is not None:  # named as seen from here, in messages and images
                project = load_project_file(Path(near_path(found)))
        if project is not None and project.sources:
            paths = [Path(near_path(p)) for p in project.sources]
        elif project is not None and need_sources:
            raise click.UsageError(f"{project.path}: [project] lists no sources; give FILE...")
        elif need_sources:
            raise click.UsageError("give FILE... (.mp sources), or run where an mpc.toml lists "
                                   "them (docs/project.md)")
        else:
            paths = []
        return [_setup(ctx, paths, project, target, word_order, temp_vars,
                       allow_outside_includes, werror)]
    paths = expand_inputs(files, skip_projects=one_build and need_sources
                          and project_file is None and not isolated(ctx))
    if need_sources:
        refuse_images(paths)
    if project_file is not None:
        return [_setup(ctx, paths, load_project_file(project_file), target, word_order,
                       temp_vars, allow_outside_includes, werror)]
    if isolated(ctx) or not need_sources:
        return [_setup(ctx, paths, None, target, word_order, temp_vars,
                       allow_outside_includes, werror)]
    setups = []
    for found, group in nearest_projects(paths):
        project = None if found is None else load_project_file(Path(near_path(found)))
        setups.append(_setup(ctx, group, project, target, word_order, temp_vars,
                             allow_outside_includes, werror, keep_pins=False))
    return setups


def build_setup(ctx: click.Context, files: tuple[str, ...], project_file: Path | None,
                target: str, word_order: str | None, temp_vars: range,
                allow_outside_includes: bool, werror: bool,
                need_sources: bool = True) -> BuildSetup:
    """The one build of `mpc build`, `run` and `plot` (`build_setups`): FILE... under
    projects whose settings agree are one build; under projects that set different options
    they cannot be, and the command is refused naming a file of each."""
    setups = build_setups(ctx, files, project_file, target, word_order, temp_vars,
                          allow_outside_includes, werror, need_sources, one_build=True)
    first = setups[0]
    for other in setups[1:]:
        if other.settings() != first.settings():
            raise click.UsageError(
                "these files are one build but belong to projects with different settings: "
                f"{_shown_project(first)} and {_shown_project(other)}; build each project on "
                "its own, or name one for all with --project FILE (or --isolated for none)")
    return first.replace(paths=[p for setup in setups for p in setup.paths])


def _setup(ctx: click.Context, paths: list[Path], project: project_module.Project | None,
           target: str, word_order: str | None, temp_vars: range,
           allow_outside_includes: bool, werror: bool, keep_pins: bool = True) -> BuildSetup:
    """One build's options: the command line's over the project file's (its slot pins only
    when named with --project, or when the build holds every source it lists)."""
    options = build_options(target, word_order, temp_vars, allow_outside_includes)
    if project is None:
        return BuildSetup(paths, options, werror, None, _given(ctx, "target"),
                          _given(ctx, "word_order"))
    listed = {p.resolve() for p in project.sources}
    # Pins name programs of the project's sources: a build of only some of them keeps none.
    pins = project.pins if keep_pins or listed <= {p.resolve() for p in paths} else ()
    options = options.replace(
        target=target if _given(ctx, "target") or project.target is None else project.target,
        word_order=options.word_order if _given(ctx, "word_order") else project.word_order,
        temps=temp_vars if _given(ctx, "temp_vars") or project.temp_vars is None
        else project.temp_vars,
        allow_outside_includes=allow_outside_includes
        if _given(ctx, "allow_outside_includes") or project.allow_outside_includes is None
        else project.allow_outside_includes,
        pins=pins,
        var_pool=options.var_pool if project.var_pool is None else project.var_pool)
    werror = werror if _given(ctx, "werror") or project.werror is None else project.werror
    return BuildSetup(paths, options, werror, project,
                      _given(ctx, "target") or project.target is not None,
                      _given(ctx, "word_order"))

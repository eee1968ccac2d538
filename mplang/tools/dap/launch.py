"""The `launch` request of `mpc dap`: its arguments, the build, the debuggee.

`program` is a `.mp` file, a list of them, or an `mpc.toml` (its sources and build options,
as `mpc run` reads them); `call` the program to run (`MPn` or a name; default: the first MP
of the first file); `stopOnEntry`; `machine` a machine file; `target` (default: the
project's, else et); `cwd` the directory relative paths start from; `maxTime` the simulated
seconds after which a program that never ends is stopped (R202), 3600 by default (longer
than `mpc run`'s 120: a session spent stepping through a long job should not run out).
Every problem is a `LaunchError` whose message is the editor's error text.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mplang.family.debug import Debuggee, DebugSetupError
from mplang.family.registry import DEFAULT_TARGET, family_of_path, family_of_target
from mplang.ir.unit import Options
from mplang.tools import project as project_module
from mplang.tools.report import render_text

ARGUMENTS = ("program", "call", "stopOnEntry", "machine", "target", "cwd", "maxTime")
"""The launch arguments `mpc dap` reads (others, such as `type` and `name`, are the editor's)."""
MAX_SHOWN_DIAGNOSTICS = 10


class LaunchError(ValueError):
    """A launch that cannot start; the message says why, with the file and line if any."""


@dataclass(frozen=True)
class Launch:
    """A launch's arguments, checked."""

    paths: list[Path]
    options: Options
    call: str | None
    stop_on_entry: bool
    machine: Path | None
    max_time: float


def _string(args: Mapping[str, Any], key: str) -> str | None:
    value = args.get(key)
    if value is None:
        return None
    if not isinstance(value, str) or not value.strip():
        raise LaunchError(f"launch argument {key!r} must be a non-empty string, not "
                          f"{json_kind(value)}")
    return value


def json_kind(value: object) -> str:
    """What a JSON value is, in words, for messages."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, str):
        return "a string"
    return "a list" if isinstance(value, list) else "an object"


def read_arguments(args: Mapping[str, Any]) -> Launch:
    """Check the launch arguments and find the sources and options of the build."""
    base = Path(_string(args, "cwd") or ".")
    if not base.is_dir():
        raise LaunchError(f"launch argument 'cwd': {base} is not a directory")
    program = args.get("program")
    if isinstance(program, str) and program.strip():
        names = [program]
    elif isinstance(program, list) and program and all(isinstance(p, str) and p.strip()
                                                       for p in program):
        names = list(program)
    elif program is None:
        raise LaunchError("launch argument 'program' is missing: give a .mp file, a list of "
                          "them, or an mpc.toml")
    else:
        raise LaunchError("launch argument 'program' must be a path or a non-empty list of "
                          f"paths, not {json_kind(program)}")
    paths = [base / name for name in names]
    target = _string(args, "target")
    options = Options(target=target or DEFAULT_TARGET)
    if len(paths) == 1 and paths[0].suffix == ".toml":
        project_file = paths[0]
        paths, options = _project(project_file, target)
        if "machine" not in args and _has_machine(project_file):
            args = {**args, "machine": str(project_file.resolve())}  # its [machine] table
    for path in paths:
        if not path.is_file():
            raise LaunchError(f"{path}: no such file" if not path.exists()
                              else f"{path}: not a regular file")
    stop = args.get("stopOnEntry", False)
    if not isinstance(stop, bool):
        raise LaunchError(f"launch argument 'stopOnEntry' must be true or false, not "
                          f"{json_kind(stop)}")
    machine = _string(args, "machine")
    max_time = args.get("maxTime", 3600.0)
    if isinstance(max_time, bool) or not isinstance(max_time, (int, float)) \
            or not math.isfinite(max_time) or max_time <= 0:
        raise LaunchError("launch argument 'maxTime' must be a number of seconds above 0")
    call = args.get("call")
    if isinstance(call, str) and not call.strip():
        call = None  # an empty answer to an editor's prompt: the default program
    return Launch(paths, options, _string({"call": call}, "call"), stop,
                  None if machine is None else base / machine, float(max_time))


def _has_machine(path: Path) -> bool:
    """Whether an mpc.toml (already read by `_project`) has a `[machine]` table."""
    return project_module.load_project(path).machine


def _project(path: Path, target: str | None) -> tuple[list[Path], Options]:
    """The sources and build options of an mpc.toml (a given `target` wins)."""
    try:
        project = project_module.load_project(path)
    except project_module.ProjectError as exc:
        raise LaunchError(str(exc)) from None
    except OSError as exc:
        raise LaunchError(f"{path}: {exc.strerror or exc}") from None
    if not project.sources:
        raise LaunchError(f"{path}: [project] lists no sources to debug")
    options = Options(target=target or project.target or DEFAULT_TARGET,
                      word_order=project.word_order, pins=project.pins,
                      allow_outside_includes=bool(project.allow_outside_includes))
    if project.temp_vars is not None:
        options = options.replace(temps=project.temp_vars)
    if project.var_pool is not None:
        options = options.replace(var_pool=project.var_pool)
    return list(project.sources), options


def start(launch: Launch) -> Debuggee:
    """Build the sources and load the program on its family's virtual controller, stopped
    before its first line."""
    native = {id(f): f for f in (family_of_path(p) for p in launch.paths) if f is not None}
    family = next(iter(native.values())) if native else family_of_target(launch.options.target)
    if family is None:
        raise LaunchError(f"unknown target {launch.options.target!r}")
    if family.debug is None:
        raise LaunchError(f"{family.TITLE} programs cannot be debugged: {family.NO_DEBUG}")
    if native:
        raise LaunchError(f"{family.TITLE} listings cannot be debugged")
    build = family.compile_mp(launch.paths, launch.options, launch.options.target)
    if not build.ok:
        errors = [d for d in build.diagnostics if d.severity.value == "error"]
        shown = render_text(errors[:MAX_SHOWN_DIAGNOSTICS])
        more = len(errors) - MAX_SHOWN_DIAGNOSTICS
        raise LaunchError(f"the build has errors:\n{shown}"
                          + (f"\n... and {more} more" if more > 0 else ""))
    try:
        return family.debug(build, launch.call, launch.machine, launch.max_time)
    except DebugSetupError as exc:
        raise LaunchError(str(exc)) from None

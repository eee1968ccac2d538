"""What `mpc call` and `mpc var` share: the device and build options, the plan they open
(`mplang.host.session.Plan`), and the mapping of the host's errors to exit codes. The work is
`mplang.host`'s; the family's part is its `host` side, reached through the registry."""

from __future__ import annotations

import asyncio
import logging
import math
import sys
from collections.abc import Callable, Coroutine
from typing import TYPE_CHECKING, Any, TypeVar

import click

from mplang.cli import style
from mplang.cli.common import (
    EXIT_INTERRUPTED,
    EXIT_NO_DEVICE,
    EXIT_NO_INPUT,
    EXIT_OUT_OF_SYNC,
    EXIT_REJECTED,
    EXIT_SOURCE_ERRORS,
    EXIT_WAIT_TIMEOUT,
    build_setup,
    chosen_device,
    device_options,
    project_option,
    report,
    with_common,
)
from mplang.cli.families import device_selection, identity_choice
from mplang.cli.shell import complete_paths
from mplang.family.hostview import HostValue

if TYPE_CHECKING:
    from mplang.host.session import AsyncController, Plan

F = TypeVar("F", bound=Callable[..., Any])
T = TypeVar("T")


def host_options(func: F) -> F:
    """FILE..., the device, the build manifest's place, the check, the link's patience,
    --json and the common build options."""
    options = [
        click.argument("files", nargs=-1, shell_complete=complete_paths),
        device_options("The serial port of a Modbus RTU device (RS-M8194H), or of a CSIM's "
                       "RS232 line.",
                       "The device [targets.NAME] of mpc.toml."),
        click.option("--identity", default=None, metavar="MDa-MDb",
                     help="The machine data holding the build manifest [default: [flash] "
                     "identity of mpc.toml, else MD768-MD1023]. Not for a CSIM: it holds no "
                     "manifest, its program listing is compared."),
        click.option("--no-check", is_flag=True,
                     help="Do not compare the device's build with FILE's: write anyway."),
        click.option("--answer-timeout", type=click.FloatRange(min=0.01, max=60), default=1.0,
                     show_default=True, help="Seconds to wait for each answer (Modbus, or a "
                     "CSIM's line)."),
        click.option("--retries", type=click.IntRange(0, 100), default=3, show_default=True,
                     help="Repeats of a Modbus read after a timeout or a lost connection (a "
                     "CSIM's line asks once)."),
        click.option("--json", "as_json", is_flag=True, help="Print the outcome as JSON."),
        project_option,
        with_common,
    ]
    for option in reversed(options):
        func = option(func)
    return func


def make_plan(ctx: click.Context, kw: dict[str, Any]) -> Plan:
    """The device and build the options name (usage errors as click's, exit 2); a family
    without a host side is refused with its reason (exit 2)."""
    from mplang.host.session import Plan

    if sum(kw[k] is not None for k in ("tcp", "serial", "to")) != 1:
        raise click.UsageError("give one device: --tcp HOST[:PORT], --serial PORT or --to NAME")
    setup = build_setup(ctx, kw["files"], kw["project_file"], kw["target"], kw["word_order"],
                        kw["temp_vars"], kw["allow_outside_includes"], kw["werror"],
                        need_sources=False)
    device = chosen_device(kw["tcp"], kw["serial"], kw["unit"], kw["baud"], kw["parity"],
                           kw["stopbits"], kw["to"], setup.project)
    selection = device_selection(setup, device)
    family = selection.family
    if family.host is None:
        raise click.UsageError(f"{family.TITLE}: {family.NO_HOST}")
    if device.serial is None and "tcp" not in family.TRANSPORTS:
        raise click.UsageError(f"a {family.TITLE} is reached over its RS232 line: give "
                               "--serial PORT (--tcp is Modbus TCP, for the ET-M8194H)")
    if family.PROTOCOL != "modbus" and kw["identity"] is not None:
        raise click.UsageError(f"--identity names the machine data of an M8194H's build "
                               f"manifest; a {family.TITLE} holds none (its program listing "
                               "is compared with the build's)")
    if family.PROTOCOL != "modbus":
        _refuse_modbus_only(ctx, family.TITLE)
    paths = selection.paths
    if not paths:
        raise click.UsageError("give FILE... (the .mp sources of the build the device holds, "
                               "or its image or export JSON), or run where an mpc.toml lists "
                               "them")
    images = [p for p in paths if p.suffix.lower() == ".json"]
    if images and len(paths) != 1:
        raise click.UsageError("give one image or export JSON, or .mp sources, not both")
    identity, _where = identity_choice(kw["identity"], False, setup.project.flash
                                       if setup.project is not None else None)
    fixed = kw["word_order"] is not None or (setup.project is not None
                                             and setup.project.word_order is not None)
    return Plan(family, device, tuple(paths), images[0] if images else None, setup.options,
                fixed, identity, kw["answer_timeout"], kw["retries"])


def _refuse_modbus_only(ctx: click.Context, title: str) -> None:
    """--unit and --retries given for a device that does not speak Modbus: refused rather
    than silently ignored (a CSIM's line has no unit number and asks each question once)."""
    from click.core import ParameterSource

    for name, flag in (("unit", "--unit"), ("retries", "--retries")):
        if ctx.get_parameter_source(name) in (ParameterSource.COMMANDLINE,
                                              ParameterSource.ENVIRONMENT):
            raise click.UsageError(f"{flag} is for a Modbus device; a {title}'s RS232 line "
                                   "has no unit number and asks each question once")


def run_host(plan: Plan, check: bool, werror: bool,
             work: Callable[[AsyncController], Coroutine[Any, Any, T]]) -> T:
    """Open the controller (checking its build unless told not to), do `work`, close; the
    host's errors as `mpc: error: ...` and their exit codes."""
    from mplang.family.hostview import (
        BadValue,
        BuildMismatch,
        HostError,
        HostLinkError,
        ProgramRunning,
        UnknownName,
        WaitTimeout,
    )
    from mplang.host.session import AsyncController, BuildFailed

    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)

    try:
        opened = AsyncController(plan, check=check)
    except ValueError as exc:  # the build manifest's range, from --identity or [flash]
        raise click.BadParameter(str(exc), param_hint="--identity") from None

    async def session() -> T:
        async with opened as controller:
            if controller.build is not None:
                _diagnostics(controller, werror)
            return await work(controller)

    try:
        return asyncio.run(session())
    except BuildFailed as exc:
        report(exc.build, werror)
        sys.exit(EXIT_SOURCE_ERRORS)
    except BuildMismatch as exc:
        _fail(EXIT_OUT_OF_SYNC, f"{plan.device.name}: {exc}")
    except (UnknownName, BadValue) as exc:
        raise click.UsageError(str(exc)) from None
    except ProgramRunning as exc:
        _fail(EXIT_REJECTED, str(exc))
    except WaitTimeout as exc:
        _fail(EXIT_WAIT_TIMEOUT, str(exc))
    except HostLinkError as exc:
        _fail(EXIT_NO_DEVICE if not exc.reached else EXIT_REJECTED if exc.refused
              else EXIT_INTERRUPTED, str(exc))
    except HostError as exc:
        _fail(EXIT_NO_INPUT, str(exc))
    raise AssertionError("unreachable")


def _diagnostics(controller: AsyncController, werror: bool) -> None:
    """The build's warnings on standard error (its errors end the command earlier)."""
    assert controller.build is not None
    if report(controller.build, werror):
        sys.exit(EXIT_SOURCE_ERRORS)


def _fail(code: int, message: str) -> None:
    style.error(message)
    sys.exit(code)


def parse_value(text: str, what: str) -> HostValue:
    """An integer as the sources write one (decimal or 0x hex, optional sign), or a finite
    decimal number (2.5, -1e3) for a real variable; whether the variable takes it is the
    variable's check."""
    cleaned = text.strip().replace("_", "")
    try:
        return int(cleaned, 0)
    except ValueError:
        pass
    try:
        value = float(cleaned)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or cleaned.lower().startswith(("inf", "+inf", "-inf", "nan")):
        raise click.BadParameter(f"{text!r} is not a number (write 120, -5, 0x7F, or 2.5 for "
                                 "a real variable)", param_hint=what)
    return value


def name_values(pairs: tuple[str, ...], what: str) -> dict[str, HostValue]:
    """NAME=VALUE pairs, in order (a later one of the same name wins)."""
    values: dict[str, HostValue] = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep or not name.strip():
            raise click.BadParameter(f"{pair!r}: write NAME=VALUE", param_hint=what)
        values[name.strip()] = parse_value(value, what)
    return values


def json_out(data: object) -> None:
    import json

    click.echo(json.dumps(data, indent=1))


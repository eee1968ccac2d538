"""`mpc monitor`: a live dashboard of one controller in the browser (docs/monitor.md). The
family reads the device (`Family.watch`); `mplang.tools.monitor.server` serves the page;
this module resolves the device and the build and maps failures to exit codes.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import AsyncIterator
from pathlib import Path

import click

from mplang.cli import style
from mplang.cli.common import (
    EXIT_TRANSPORT,
    build_setup,
    chosen_device,
    device_options,
    guarded,
    project_option,
    require_extra,
    with_common,
)
from mplang.cli.families import build_checked, device_selection
from mplang.cli.shell import complete_paths
from mplang.family.face import (
    Companion,
    Family,
    FamilyBuild,
    LiveDevice,
    ServiceError,
    WatchJob,
)
from mplang.tools.monitor import DEFAULT_PORT as DEFAULT_PORT
from mplang.tools.project import Target


def require_aiohttp(command: str) -> None:
    """aiohttp is the optional `monitor` extra (no other command serves HTTP): say how to get
    it, instead of an import error."""
    require_extra(command, "monitor", "aiohttp")


def refuse_family(family: Family, command: str) -> None:
    """A usage error naming why a family has no live view."""
    reason = family.NO_TRANSPORT or f"{family.TITLE} devices are not read over Modbus"
    raise click.UsageError(f"{command} watches M8194H controllers over Modbus; there is no "
                           f"live view of a {family.TITLE} device: {reason} "
                           "(docs/monitor.md)")


def watcher(family: Family, device: Target, build: FamilyBuild | None, timeout: float,
            retries: int) -> LiveDevice:
    """The family's live view of `device` (its `watch`, which must not be None)."""
    assert family.watch is not None
    return family.watch(WatchJob(device=device, build=build, timeout=timeout,
                                 retries=retries))


def dashboard(family: Family, build: FamilyBuild | None, port: int) -> Companion:
    """`mpc sim --monitor`: the dashboard beside the virtual device, on 127.0.0.1:`port`,
    watching it over its own Modbus TCP service like any client, writes allowed (nothing
    real moves)."""

    @contextlib.asynccontextmanager
    async def serve(host: str, bound: int) -> AsyncIterator[None]:
        from mplang.tools.monitor.server import MonitorError, serving

        address = "127.0.0.1" if host in ("0.0.0.0", "", "::") else host
        device = Target(f"{address}:{bound}", host=address, port=bound)
        try:
            async with serving(watcher(family, device, build, 0.5, 0), "127.0.0.1", port,
                               allow_write=True, title="mpc sim") as (_monitor, url):
                click.echo(f"mpc sim: dashboard on {url}")
                yield
        except MonitorError as exc:
            raise ServiceError("transport", str(exc)) from None

    return serve


def _open(url: str) -> None:
    import webbrowser

    if not webbrowser.open(url):
        click.echo(f"mpc monitor: no browser to open; open {url} yourself", err=True)


@click.command("monitor", short_help="Watch a device live in the browser.")
@click.argument("files", nargs=-1, shell_complete=complete_paths)
@device_options("The serial port of a Modbus RTU device (RS-M8194H).",
                "The device [targets.NAME] of mpc.toml.")
@click.option("--port", "http_port", type=click.IntRange(0, 65535), default=DEFAULT_PORT,
              show_default=True, help="The dashboard's HTTP port (0: any free one).")
@click.option("--bind", default="127.0.0.1", show_default=True, metavar="ADDR",
              help="The address the dashboard listens on. Anything but loopback lets "
              "other machines watch (and, with --allow-write, drive) the device.")
@click.option("--open", "open_browser", is_flag=True, help="Open the page in a browser.")
@click.option("--allow-write", is_flag=True,
              help="Offer the writes: call a program, set a VAR, stop, emergency stop "
              "(each with this session's token, which the page carries; docs/monitor.md).")
@click.option("--timeout", type=click.FloatRange(min=0.01, max=60), default=0.5,
              show_default=True, help="Seconds to wait for each answer.")
@click.option("--retries", type=click.IntRange(0, 100), default=0, show_default=True,
              help="Repeats of a read after a timeout (the next poll tries again anyway).")
@click.option("--duration", type=click.FloatRange(min=0), default=None,
              help="Stop after this many seconds [default: run until interrupted].")
@project_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], tcp: tuple[str, int] | None,
            serial: str | None, unit: int, baud: int, parity: str, stopbits: str,
            to: str | None, http_port: int, bind: str, open_browser: bool, allow_write: bool,
            timeout: float, retries: int, duration: float | None, project_file: Path | None,
            target: str, word_order: str | None, temp_vars: range,
            allow_outside_includes: bool, werror: bool) -> None:
    """Serve a live dashboard of one device on http://127.0.0.1:PORT/: axes (LP, EP, CV,
    state), input lamps, FRnet DI, the running program, execution errors, variables by
    declared name and the tool path, updated 20 times a second; GET /api/state gives the
    same as JSON. FILE... (.mp sources, or the project's) name the variables and place the
    programs in the sources. Writes only with --allow-write."""
    if sum(x is not None for x in (tcp, serial, to)) != 1:
        raise click.UsageError("give the device: --tcp HOST[:PORT], --serial PORT or --to NAME")
    setup = build_setup(ctx, files, project_file, target, word_order, temp_vars,
                        allow_outside_includes, werror, need_sources=False)
    project = setup.project
    device = chosen_device(tcp, serial, unit, baud, parity, stopbits, to, project)
    selection = device_selection(setup, device)
    paths, family = selection.paths, selection.family
    if family.watch is None:
        refuse_family(family, "mpc monitor")
    require_aiohttp("mpc monitor")
    build = None
    if paths and not any(p.suffix.lower() == ".json" for p in paths):
        build = build_checked(selection, setup)
    from mplang.tools.monitor.server import MonitorError, is_loopback, run

    if not is_loopback(bind):
        click.echo(f"mpc monitor: warning: listening on {bind}: other machines can reach the "
                   "dashboard" + (" and drive the device (--allow-write)" if allow_write
                                  else ""), err=True)
    try:
        run(watcher(family, device, build, timeout, retries), bind, http_port,
            allow_write=allow_write, title=device.name,
            say=lambda text: click.echo(f"mpc monitor: {text}"),
            opened=_open if open_browser else None, duration=duration)
    except MonitorError as exc:
        style.error(str(exc))
        sys.exit(EXIT_TRANSPORT)
    click.echo("mpc monitor: stopped")

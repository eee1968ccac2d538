"""`mpc flash`: download an image into one device, or a fleet, and verify every program.

What is flashed where comes from the command line first, then from the project file: FILE...
(sources or one image JSON) or `[project] sources`; `--tcp`/`--serial`, `--to NAME` (one of
mpc.toml's `[targets]`), or `--fleet FILE` (every `[targets.NAME]` of FILE, concurrently).
The work itself is the family's (`Family.flash_devices`: the M8194H's
`mplang.m8194h.flashing`, the CSIM's `mplang.csim.flashing`); this module only resolves those
choices and reports.
"""

from __future__ import annotations

import sys
from collections.abc import Awaitable, Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click

from mplang.cli.common import (
    FLASH_EXIT,
    BuildSetup,
    DeviceUI,
    InputError,
    build_setup,
    chosen_device,
    device_options,
    guarded,
    project_option,
    with_common,
)
from mplang.cli.families import (
    Selection,
    click_error,
    device_selection,
    identity_choice,
    refuse_options,
    select,
)
from mplang.cli.shell import complete_paths
from mplang.cli.style import quiet_option
from mplang.family.registry import families
from mplang.tools.project import FlashSettings, Project, ProjectError, Target, load_fleet

if TYPE_CHECKING:
    from mplang.cli.progress import FlashDisplay

T = TypeVar("T")

DEFAULT_TIMEOUT, DEFAULT_RETRIES = 1.0, 3


@click.command("flash", short_help="Download and verify programs in a device or a fleet.")
@click.argument("files", nargs=-1, shell_complete=complete_paths)
@device_options("The serial port of a Modbus RTU device (RS-M8194H), or of a CSIM.",
                "Flash the device [targets.NAME] of mpc.toml.")
@click.option("--fleet", type=click.Path(dir_okay=False, path_type=Path), default=None,
              metavar="FILE", help="Flash every [targets.NAME] device of FILE concurrently "
              "(mpc.toml itself is a fleet file).")
@click.option("--timeout", type=click.FloatRange(min=0.01, max=60), default=DEFAULT_TIMEOUT,
              show_default=True, help="Seconds to wait for each answer.")
@click.option("--retries", type=click.IntRange(0, 100), default=DEFAULT_RETRIES,
              show_default=True, help="Repeats after a timeout or a lost connection (reads, "
              "reconnections, re-downloads of a program).")
@click.option("--set-word-order", is_flag=True,
              help="If the device's word order (holding register 14) differs from the "
              "image's, set it instead of refusing.")
@click.option("--stop-running", is_flag=True,
              help="If a program is running, stop it (MP_TERMINATE) before writing, instead "
              "of refusing to flash.")
@click.option("--force", is_flag=True,
              help="Write every program, even those the flash record says the device holds.")
@click.option("--record", "record_file", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="The flash record for incremental flashing [default: "
              "[flash] record of mpc.toml, else mpc/flash-record.json in the user's state "
              "directory ($XDG_STATE_HOME, ~/.local/state, %LOCALAPPDATA%)].")
@click.option("--identity", default=None, metavar="MDa-MDb",
              help="The machine data that hold the build manifest [default: [flash] identity "
              "of mpc.toml, else MD768-MD1023].")
@click.option("--no-identity", is_flag=True,
              help="Write no build manifest: leave every machine data (MD) as it is.")
@click.option("--wait-lease", type=click.FloatRange(min=0, max=3600), default=0.0,
              metavar="SECONDS", help="If another client holds the device's download lease, "
              "wait up to SECONDS for it to end [default: refuse at once, exit 19].")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary on standard output.")
@click.option("--dry-run", is_flag=True,
              help="Print every frame that would be sent; connect to nothing.")
@project_option
@quiet_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], tcp: tuple[str, int] | None,
            serial: str | None, unit: int, baud: int, parity: str, stopbits: str,
            to: str | None, fleet: Path | None, timeout: float, retries: int,
            set_word_order: bool, stop_running: bool, force: bool, record_file: Path | None,
            identity: str | None, no_identity: bool, wait_lease: float, as_json: bool,
            dry_run: bool,
            project_file: Path | None, target: str,
            word_order: str | None, temp_vars: range, allow_outside_includes: bool,
            werror: bool) -> None:
    """Download FILE... (.mp sources built together, or one image JSON; without FILE, the
    sources of mpc.toml) into a device over Modbus TCP or RTU, and verify every program
    through its download-status registers. Programs the flash record says the device already
    holds are not written again (--force writes them).

    A CSIM (--target csim, or a .csim FILE) takes its one program over --serial PORT: sent
    with DLP, listed back with ULP and compared, then saved with SAVE P. FATEK FBs-PLC
    tables cannot be flashed (the manual documents no transport): see mpc build --format
    table."""
    from mplang.family.face import CommandError, FlashJob

    def given(name: str) -> bool:
        source = ctx.get_parameter_source(name)
        return source is not None and source is not click.core.ParameterSource.DEFAULT

    if fleet is not None and (tcp is not None or serial is not None or to is not None):
        raise click.UsageError("--fleet flashes the devices of its file: leave out --tcp, "
                               "--serial and --to")
    if tcp is not None and serial is not None:
        raise click.UsageError("give one device: --tcp HOST[:PORT] or --serial PORT")
    setup = build_setup(ctx, files, project_file, target, word_order, temp_vars,
                        allow_outside_includes, werror, need_sources=False)
    if fleet is None and to is None:  # what cannot be flashed is refused before the device
        _refuse_early(select(setup.paths, setup.options.target, setup.target_given),
                      tcp is not None)
    targets = _targets(setup.project, tcp, serial, unit, baud, parity, int(stopbits), to,
                       fleet, dry_run)
    seen: dict[str, str] = {}
    for device in targets:
        if device.address() in seen:  # two downloads into one device would interleave
            raise click.UsageError(f"targets {seen[device.address()]} and {device.name} are "
                                   f"the same device ({device.address()})")
        seen[device.address()] = device.name
    chosen = [(device, _selection(setup, device, given("target"))) for device in targets]
    if fleet is not None:
        _check_fleet(fleet, chosen)
    else:
        refuse_transport(chosen[0][1], tcp is not None)
        refuse_options(chosen[0][1], {option: given(name) for option, name in FLASH_OPTIONS},
                       "FLASH_OPTIONS")
    family = chosen[0][1].family
    assert family.flash_devices is not None  # refused above otherwise
    settings = setup.project.flash if setup.project is not None else None
    manifest_range, manifest_where = identity_choice(identity, no_identity, settings)
    job = FlashJob(
        devices=targets, paths=setup.paths, options=setup.options, werror=setup.werror,
        word_order_fixed=word_order is not None
        or (setup.project is not None and setup.project.word_order is not None),
        dry_run=dry_run, as_json=as_json, force=force, set_word_order=set_word_order,
        record=record_file or (_project_record(settings) if settings else None),
        timeout=timeout if given("timeout") else None,
        retries=retries if given("retries") else None,
        settings_timeout=settings.timeout if settings else None,
        settings_retries=settings.retries if settings else None,
        settings_set_word_order=bool(settings and settings.set_word_order),
        fleet=fleet is not None, stop_running=stop_running,
        identity=manifest_range, identity_where=manifest_where, wait_lease=wait_lease)
    try:
        outcome = family.flash_devices(job, _FlashUI("mpc flash", setup.werror))
    except CommandError as exc:
        raise click_error(exc) from None
    sys.exit(FLASH_EXIT[outcome])


def _project_record(settings: FlashSettings) -> Path:
    """The project's flash record, or InputError (exit 3) at its line if the project file
    names a place mpc may not write (checked only here: lint and build never write it)."""
    try:
        return settings.writable_record()
    except ProjectError as exc:
        raise InputError(str(exc)) from None


FLASH_OPTIONS = (("--unit", "unit"), ("--word-order", "word_order"),
                 ("--set-word-order", "set_word_order"), ("--record", "record_file"),
                 ("--retries", "retries"), ("--stop-running", "stop_running"),
                 ("--identity", "identity"), ("--no-identity", "no_identity"),
                 ("--wait-lease", "wait_lease"))
"""Options of `mpc flash` beyond the common ones: refused for a family whose
`FLASH_OPTIONS` does not take them."""


def _refuse_early(selection: Selection, tcp_given: bool) -> None:
    """A family without a transport (FATEK), or asked for over --tcp when it has no TCP:
    refused at once, whatever the device options."""
    family = selection.family
    if family.flash_devices is None or (tcp_given and "tcp" not in family.TRANSPORTS):
        refuse_transport(selection, tcp_given)


def refuse_transport(selection: Selection, tcp_given: bool) -> None:
    """A usage error if the family cannot be flashed at all (why, and what to do instead),
    or not over TCP."""
    family = selection.family
    if family.flash_devices is None or not family.TRANSPORTS:
        target = selection.target or family.TARGETS[0]
        instead = family.FLASH_INSTEAD.format(target=target)
        raise click.UsageError(f"{selection.describe} programs cannot be flashed: "
                               f"{family.NO_TRANSPORT}. {instead}")
    if tcp_given and "tcp" not in family.TRANSPORTS:
        raise click.UsageError(f"a {family.TITLE} is reached over RS232: give --serial PORT "
                               "(--tcp is Modbus TCP, for the ET-M8194H)")


def _check_fleet(fleet: Path, chosen: list[tuple[Target, Selection]]) -> None:
    """A fleet is flashed at once by one family that flashes fleets: the others are named."""
    for _, selection in chosen:
        refuse_transport(selection, False)  # a family nothing can flash: say why
    fleets = [f for f in families() if f.FLASHES_FLEETS]
    kinds = {id(selection.family) for _, selection in chosen}
    others = [(device, selection) for device, selection in chosen
              if not selection.family.FLASHES_FLEETS or (len(kinds) > 1
              and selection.family is not chosen[0][1].family)]
    if others:
        names = ", ".join(f"{device.name} ({selection.describe})" for device, selection in others)
        raise click.UsageError(f"--fleet flashes {' or '.join(f.TITLE for f in fleets)} "
                               f"devices, and {fleet} also lists {names}: flash each of those "
                               "on its own (--to NAME, or --serial PORT --target TARGET)")


def _selection(setup: BuildSetup, device: Target, cli_target: bool) -> Selection:
    """The controller family flashed into `device`: its own `target` (mpc.toml), else
    --target or the project's; native listings imply theirs (`families.select`)."""
    own = device.target
    if own is not None and cli_target and setup.options.target != own:
        raise click.UsageError(f"--target {setup.options.target} contradicts target = "
                               f"\"{own}\" of [targets.{device.name}]")
    return device_selection(setup, device)


def _targets(project: Project | None, tcp: tuple[str, int] | None, serial: str | None,
             unit: int, baud: int, parity: str, stopbits: int, to: str | None,
             fleet: Path | None, dry_run: bool) -> list[Target]:
    """The devices to flash, as project-file targets (the command line makes one)."""
    if fleet is not None:
        try:
            return load_fleet(fleet)
        except ProjectError as exc:
            raise InputError(str(exc)) from None
    if tcp is not None or serial is not None or to is not None:
        return [chosen_device(tcp, serial, unit, baud, parity, str(stopbits), to, project)]
    if project is not None and len(project.targets) == 1:
        return list(project.targets.values())
    if project is not None and project.targets:
        raise click.UsageError(f"{project.path} lists {len(project.targets)} targets: choose "
                               f"one with --to NAME ({', '.join(project.targets)}), or flash "
                               f"them all with --fleet {project.path}")
    if dry_run:
        return [Target("dry run", host="-")]
    raise click.UsageError("give the device: --tcp HOST[:PORT], --serial PORT, --to NAME "
                           "(mpc.toml) or --fleet FILE")


class _FlashUI(DeviceUI):
    """The family's flash, as the terminal shows it: `DeviceUI` and a progress bar."""

    def progress(self, reports: Callable[[], Sequence[Any]]) -> _Progress:
        from mplang.cli.progress import FlashDisplay

        return _Progress(FlashDisplay(lambda: list(reports())))


class _Progress:
    """A progress bar (on a terminal) with the flash's lines above it."""

    def __init__(self, display: FlashDisplay) -> None:
        self.display = display

    def say(self, text: str) -> None:
        self.display.say(text)

    def drive(self, work: Callable[[], Awaitable[T]], fallback: Callable[[], T]) -> T:
        """Run `work()` with the display's redraw task beside it; Ctrl-C and SIGTERM cancel
        the work, and `fallback()` gives what it left (the reports)."""
        import asyncio
        import logging

        from mplang.family.stopsignals import on_stop_signals

        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
        display = self.display

        async def main_task() -> T:
            task = asyncio.ensure_future(work())
            redraw = asyncio.ensure_future(display.run())
            try:
                with on_stop_signals(task.cancel):
                    return await task
            except asyncio.CancelledError:
                return fallback()
            finally:
                redraw.cancel()
                await asyncio.gather(redraw, return_exceptions=True)
                display.finish()

        return asyncio.run(main_task())

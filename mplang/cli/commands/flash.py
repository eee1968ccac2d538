"""`mpc flash`: download an image into one device, or a fleet, and verify every program.

What is flashed where comes from the command line first, then from the project file: FILE...
(sources or one image JSON) or `[project] sources`; `--tcp`/`--serial`, `--to NAME` (one of
mpc.toml's `[targets]`), or `--fleet FILE` (every `[targets.NAME]` of FILE, concurrently).
The work itself is `mplang.m8194h.flash`; this module only resolves those choices and reports.
A device of another controller family (a CSIM) goes to `mplang.cli.family_flash`.
"""

from __future__ import annotations

import sys
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import click

from mplang.cli.common import (
    EXIT_FLEET_MIXED,
    EXIT_SOURCE_ERRORS,
    FLASH_EXIT,
    BuildSetup,
    InputError,
    build_setup,
    guarded,
    parse_device_address,
    project_option,
    report,
    with_common,
    with_serial_line,
)
from mplang.cli.families import Selection, select
from mplang.m8194h.compiler import Options, compile_paths
from mplang.tools.project import Project, ProjectError, Target, load_fleet

if TYPE_CHECKING:
    from mplang.cli.progress import FlashDisplay
    from mplang.m8194h import flash as flashing

T = TypeVar("T")

DEFAULT_TIMEOUT, DEFAULT_RETRIES = 1.0, 3


@click.command("flash", short_help="Download and verify programs in a device or a fleet.")
@click.argument("files", nargs=-1)
@click.option("--tcp", callback=parse_device_address, default=None, metavar="HOST[:PORT]",
              help="The device's Modbus TCP address (ET-M8194H) [default port: 502].")
@click.option("--serial", default=None, metavar="PORT",
              help="The serial port of a Modbus RTU device (RS-M8194H), or of a CSIM.")
@click.option("--unit", type=click.IntRange(1, 247), default=1, show_default=True,
              help="Modbus unit id: the RTU slave address (the ET-M8194H answers as 1).")
@with_serial_line
@click.option("--to", "to", default=None, metavar="NAME",
              help="Flash the device [targets.NAME] of mpc.toml.")
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
@click.option("--force", is_flag=True,
              help="Write every program, even those the flash record says the device holds.")
@click.option("--record", "record_file", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="The flash record for incremental flashing [default: "
              "[flash] record of mpc.toml, else $XDG_STATE_HOME/mpc/flash-record.json].")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary on standard output.")
@click.option("--dry-run", is_flag=True,
              help="Print every frame that would be sent; connect to nothing.")
@project_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], tcp: tuple[str, int] | None,
            serial: str | None, unit: int, baud: int, parity: str, stopbits: str,
            to: str | None, fleet: Path | None, timeout: float, retries: int,
            set_word_order: bool, force: bool, record_file: Path | None, as_json: bool,
            dry_run: bool, project_file: Path | None, target: str, word_order: str | None,
            temp_vars: range, allow_outside_includes: bool, werror: bool) -> None:
    """Download FILE... (.mp sources built together, or one image JSON; without FILE, the
    sources of mpc.toml) into a device over Modbus TCP or RTU, and verify every program
    through its download-status registers. Programs the flash record says the device already
    holds are not written again (--force writes them).

    A CSIM (--target csim, or a .csim FILE) takes its one program over --serial PORT: sent
    with DLP, listed back with ULP and compared, then saved with SAVE P. FATEK FBs-PLC
    tables cannot be flashed (the manual documents no transport): see mpc build --format
    table."""
    from mplang.m8194h import flash as flashing
    from mplang.m8194h.modbus import Endpoint

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
    others = [(device, selection) for device, selection in chosen
              if selection.family.PROTOCOL != "modbus"]
    if others and fleet is not None:
        from mplang.cli.family_flash import refuse_transport

        for _, selection in others:
            refuse_transport(selection, False)  # a family nothing can flash: say why
        names = ", ".join(f"{device.name} ({selection.describe})" for device, selection in others)
        raise click.UsageError(f"--fleet flashes M8194H devices, and {fleet} also lists {names}: "
                               "flash each of those on its own (--to NAME, or --serial PORT "
                               "--target TARGET)")
    if others:
        from mplang.cli.family_flash import FlashRequest, flash_family

        device, selection = others[0]
        settings = setup.project.flash if setup.project is not None else None
        flash_family(selection, setup, device, FlashRequest(
            tcp_given=tcp is not None, dry_run=dry_run, as_json=as_json,
            timeout=timeout if given("timeout") else device.timeout
            or (settings.timeout if settings else None) or DEFAULT_TIMEOUT,
            m8194h_options={option: given(name) for option, name in M8194H_FLASH_OPTIONS}))
        return
    images = _Images(setup.paths, setup.options, setup.werror, word_order is not None
                     or (setup.project is not None and setup.project.word_order is not None))
    settings = setup.project.flash if setup.project is not None else None
    record_path = record_file or (settings.record if settings else None) \
        or flashing.default_record_path()
    devices: list[flashing.FleetDevice] = []
    for device in targets:
        image, rebuild = images.for_target(device)
        endpoint = Endpoint(
            host=device.host, port=device.port, serial=device.serial, baudrate=device.baud,
            parity=device.parity, stopbits=device.stopbits, unit=device.unit,
            timeout=timeout if given("timeout") else
            device.timeout or (settings.timeout if settings else None) or DEFAULT_TIMEOUT,
            retries=retries if given("retries") else _first_int(
                device.retries, settings.retries if settings else None, DEFAULT_RETRIES))
        devices.append(flashing.FleetDevice(device.name, image, endpoint, flashing.FlashOptions(
            set_word_order=set_word_order or bool(settings and settings.set_word_order),
            rebuild=rebuild, address=device.address(), force=force)))
    record = flashing.FlashRecord(record_path)
    if dry_run:
        _dry_run(devices, record, as_json)
        return
    for job in devices:
        job.options = replace(job.options, record=record)
    if fleet is None:
        _flash_one(devices[0], as_json)
    else:
        _flash_fleet(devices, as_json)


M8194H_FLASH_OPTIONS = (("--unit", "unit"), ("--word-order", "word_order"),
                        ("--set-word-order", "set_word_order"), ("--record", "record_file"),
                        ("--retries", "retries"))
"""Options of `mpc flash` that only an M8194H (Modbus, image frames, flash record) has."""


def _refuse_early(selection: Selection, tcp_given: bool) -> None:
    """A family without a transport (FATEK), or a CSIM asked for over --tcp: refused at once,
    whatever the device options."""
    family = selection.family
    if not family.TRANSPORTS or (tcp_given and "tcp" not in family.TRANSPORTS):
        from mplang.cli.family_flash import refuse_transport

        refuse_transport(selection, tcp_given)


def _selection(setup: BuildSetup, device: Target, cli_target: bool) -> Selection:
    """The controller family flashed into `device`: its own `target` (mpc.toml), else
    --target or the project's; native listings imply theirs (`families.select`)."""
    own = device.target
    if own is not None and cli_target and setup.options.target != own:
        raise click.UsageError(f"--target {setup.options.target} contradicts target = "
                               f"\"{own}\" of [targets.{device.name}]")
    target = own if own is not None else setup.options.target
    paths = [device.image] if device.image is not None else list(device.sources) or setup.paths
    return select(paths, target, setup.target_given or own is not None)


def _first_int(*values: int | None) -> int:
    return next(v for v in values if v is not None)


def _targets(project: Project | None, tcp: tuple[str, int] | None, serial: str | None,
             unit: int, baud: int, parity: str, stopbits: int, to: str | None,
             fleet: Path | None, dry_run: bool) -> list[Target]:
    """The devices to flash, as project-file targets (the command line makes one)."""
    if fleet is not None:
        try:
            return load_fleet(fleet)
        except ProjectError as exc:
            raise InputError(str(exc)) from None
    if tcp is not None:
        return [Target(f"{tcp[0]}:{tcp[1]}", host=tcp[0], port=tcp[1], unit=unit, baud=baud,
                       parity=parity, stopbits=stopbits)]
    if serial is not None:
        return [Target(serial, serial=serial, unit=unit, baud=baud, parity=parity,
                       stopbits=stopbits)]
    if to is not None:
        if project is None:
            raise click.UsageError("--to names a [targets] device of mpc.toml, and there is "
                                   "no mpc.toml here or above (or give --project)")
        if to not in project.targets:
            known = ", ".join(project.targets) or "none"
            raise click.BadParameter(f"{project.path} has no [targets.{to}] (targets: "
                                     f"{known})", param_hint="--to")
        return [project.targets[to]]
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


@dataclass
class _Images:
    """Builds each distinct set of sources once (per word order), or loads an image JSON."""

    paths: list[Path]
    options: Options
    werror: bool
    fixed_order: bool

    def __post_init__(self) -> None:
        self._cache: dict[tuple[tuple[Path, ...], int | None, str],
                          tuple[flashing.FlashImage,
                                Callable[[int], flashing.FlashImage] | None]] = {}

    def for_target(self, device: Target) -> tuple[flashing.FlashImage,
                                                  Callable[[int], flashing.FlashImage] | None]:
        if device.image is not None:
            return self._load(device.image, device.word_order), None
        paths = list(device.sources) or self.paths
        if not paths:
            raise click.UsageError("nothing to flash: give FILE..., or list sources in "
                                   "mpc.toml ([project] sources or the target's own)")
        options = self.options if device.word_order is None \
            else replace(self.options, word_order=device.word_order)
        if device.target is not None:  # an M8194H here: families are flashed elsewhere
            options = replace(options, target=device.target)
        key = (tuple(paths), options.word_order, options.target)
        if key not in self._cache:
            self._cache[key] = self._build(paths, options, device.word_order is not None)
        return self._cache[key]

    def _load(self, path: Path, word_order: int | None) -> flashing.FlashImage:
        from mplang.m8194h import flash as flashing

        try:
            image = flashing.load_image(path)
        except OSError as exc:
            raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None
        except flashing.ImageError as exc:
            raise InputError(f"{exc}") from None
        if word_order is not None and word_order != image.word_order:
            raise InputError(f"{path}: the image is built for word order {image.word_order}, "
                             f"its target asks for {word_order}")
        return image

    def _build(self, paths: list[Path], options: Options, target_fixes_order: bool
               ) -> tuple[flashing.FlashImage, Callable[[int], flashing.FlashImage] | None]:
        from mplang.m8194h import flash as flashing

        images = [p for p in paths if p.suffix.lower() == ".json"]
        if images:
            if len(paths) != 1:
                raise click.UsageError("give one image JSON, or .mp sources, not both")
            if self.fixed_order and options.word_order is not None:
                raise click.BadParameter("an image JSON carries its own word order; "
                                         "--word-order is for building .mp sources",
                                         param_hint="--word-order")
            return self._load(images[0], None), None
        result = compile_paths(paths, options)
        code = report(result, self.werror)
        if code:
            sys.exit(EXIT_SOURCE_ERRORS)
        image = flashing.image_from_build(result)
        if self.fixed_order or target_fixes_order:
            return image, None

        def build_for(order: int) -> flashing.FlashImage:
            """Sources without a chosen word order follow the device's: the same build."""
            return flashing.image_from_build(compile_paths(paths, replace(options,
                                                                          word_order=order)))
        return image, build_for


def _dry_run(devices: list[flashing.FleetDevice],
             record: flashing.FlashRecord, as_json: bool) -> None:
    import json

    from mplang.m8194h import flash as flashing

    plans = []
    for device in devices:
        recorded = record.recorded_slots(device.options.address or "")
        if as_json:
            plan = flashing.plan_json(device.image, recorded)
            plans.append({"device": device.name, **plan} if len(devices) > 1 else plan)
            continue
        if len(devices) > 1:
            click.echo(f"; device {device.name} ({device.endpoint.describe()})")
        click.echo(flashing.render_plan(device.image, recorded=recorded), nl=False)
    if as_json:
        click.echo(json.dumps(plans[0] if len(plans) == 1 else {"devices": plans}))


def _flash_one(device: flashing.FleetDevice, as_json: bool) -> None:
    import json

    from mplang.cli.progress import FlashDisplay
    from mplang.m8194h import flash as flashing
    from mplang.m8194h.modbus import DeviceLink

    flasher: flashing.Flasher | None = None
    display = FlashDisplay(lambda: [flasher.report] if flasher else [])
    flasher = flashing.Flasher(device.image, DeviceLink(device.endpoint), device.options,
                               display.say)
    report_ = _drive(flasher.run, display, lambda: flasher.report)
    written, unchanged = report_.count("verified"), report_.count("unchanged")
    if report_.ok:
        kept = f", {unchanged} unchanged" if unchanged else ""
        steps = "".join(text for step, text in ((report_.init, ", initial table loaded"),
                                                (report_.triggers, ", DI triggering set"))
                        if step is not None)
        display.say(f"{written} program(s) written and verified{kept}{steps} on "
                    f"{report_.device}"
                    + (f" (build {report_.build_id})" if report_.build_id else ""))
    else:
        where = f"{report_.where}: " if report_.where else ""
        display.say(f"{where}error: {report_.error}")
        display.say(f"{written} of {len(report_.programs)} program(s) written and verified"
                    + (f", {unchanged} unchanged" if unchanged else ""))
    if as_json:
        click.echo(json.dumps(report_.to_json(), indent=1))
    sys.exit(FLASH_EXIT[report_.outcome])


def _drive(work: Callable[[], Awaitable[T]], display: FlashDisplay,
           fallback: Callable[[], T]) -> T:
    """Run `work()` (a coroutine function) with the display's redraw task beside it; Ctrl-C
    and SIGTERM cancel the work, and `fallback()` gives what it left (the reports)."""
    import asyncio
    import logging
    import signal

    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)

    async def main_task() -> T:
        task = asyncio.ensure_future(work())
        redraw = asyncio.ensure_future(display.run())
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, task.cancel)
        try:
            return await task
        except asyncio.CancelledError:
            return fallback()
        finally:
            redraw.cancel()
            await asyncio.gather(redraw, return_exceptions=True)
            display.finish()

    return asyncio.run(main_task())


def _flash_fleet(devices: list[flashing.FleetDevice], as_json: bool) -> None:
    import json

    from mplang.cli.progress import FlashDisplay
    from mplang.m8194h import flash as flashing

    fleet: flashing.Fleet | None = None
    display = FlashDisplay(lambda: fleet.reports if fleet else [])
    fleet = flashing.Fleet(devices, lambda name, text: display.say(f"{name}: {text}"))
    _drive(fleet.run, display, lambda: fleet.reports)
    reports = fleet.reports
    for line in fleet_table(devices, reports):
        display.say(line)
    if as_json:
        click.echo(json.dumps({"ok": all(r.ok for r in reports), "devices": [
            {"name": d.name, **r.to_json()} for d, r in zip(devices, reports, strict=True)]},
            indent=1))
    failed = {r.outcome for r in reports if not r.ok}
    if not failed:
        sys.exit(0)
    sys.exit(FLASH_EXIT[failed.pop()] if len(failed) == 1 else EXIT_FLEET_MIXED)


def fleet_table(devices: list[flashing.FleetDevice],
                reports: list[flashing.FlashReport]) -> list[str]:
    """One row per device: name, address, outcome, programs written / unchanged, time, and
    the error where there is one."""
    rows = [("DEVICE", "ADDRESS", "RESULT", "WRITTEN", "UNCHANGED", "SECONDS")]
    for device, result in zip(devices, reports, strict=True):
        outcome = "ok" if result.ok else result.outcome
        rows.append((device.name, device.endpoint.describe(), outcome,
                     str(result.count("verified")), str(result.count("unchanged")),
                     f"{result.seconds:.2f}"))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True))
             .rstrip() for row in rows]
    for device, result in zip(devices, reports, strict=True):
        if not result.ok:
            where = f"{result.where}: " if result.where else ""
            lines.append(f"{device.name}: {where}{result.error}")
    return lines


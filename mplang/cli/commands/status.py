"""`mpc status`: what one controller holds and does, read without writing anything, and (given
sources, an image or a project) each slot compared with what `mpc flash` would write. The
work is the family's (`Family.status_device`: the M8194H's `mplang.m8194h.status`); this
module resolves the device and the build and maps the outcome to an exit code.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mplang.cli.common import (
    EXIT_NO_DEVICE,
    EXIT_OK,
    EXIT_OUT_OF_SYNC,
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
from mplang.cli.families import Family, click_error, device_selection, identity_choice
from mplang.cli.shell import complete_paths
from mplang.tools.project import ProjectError, Target, load_fleet

STATUS_EXIT = {"in-sync": EXIT_OK, "out-of-sync": EXIT_OUT_OF_SYNC, "no-device": EXIT_NO_DEVICE}


@click.command("status", short_help="Show what a device holds and does, and compare it.")
@click.argument("files", nargs=-1)
@device_options("The serial port of a Modbus RTU device (RS-M8194H), or of a CSIM.",
                "The device [targets.NAME] of mpc.toml.")
@click.option("--fleet", type=click.Path(dir_okay=False, path_type=Path), default=None,
              metavar="FILE", shell_complete=complete_paths,
              help="Read every [targets.NAME] device of FILE (mpc.toml is a fleet file too) "
              "and print one table.")
@click.option("--jobs", type=click.IntRange(1, 256), default=8, show_default=True,
              help="With --fleet: devices read at once.")
@click.option("--timeout", type=click.FloatRange(min=0.01, max=60), default=1.0,
              show_default=True, help="Seconds to wait for each answer.")
@click.option("--retries", type=click.IntRange(0, 100), default=3, show_default=True,
              help="Repeats of a read after a timeout or a lost connection.")
@click.option("--identity", default=None, metavar="MDa-MDb",
              help="The machine data holding the build manifest [default: [flash] identity "
              "of mpc.toml, else MD768-MD1023].")
@click.option("--no-identity", is_flag=True, help="Do not read the build manifest.")
@click.option("--json", "as_json", is_flag=True, help="Print the status as JSON.")
@project_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], tcp: tuple[str, int] | None,
            serial: str | None, unit: int, baud: int, parity: str, stopbits: str,
            to: str | None, fleet: Path | None, jobs: int, timeout: float, retries: int,
            identity: str | None,
            no_identity: bool, as_json: bool, project_file: Path | None, target: str,
            word_order: str | None, temp_vars: range, allow_outside_includes: bool,
            werror: bool) -> None:
    """Read a device over Modbus TCP or RTU: identity and firmware, word order, state,
    download status, the running program, execution errors, the build manifest `mpc flash`
    stored in its machine data, the axes and their input lamps; given FILE... (.mp sources
    or one image JSON) or a project, every slot compared with what would be flashed (in
    sync, differs, missing, extra) and the build's variables by name. With --fleet FILE,
    every device of FILE, concurrently, in one table.

    A CSIM (--target csim, or a .csim FILE) is read over --serial PORT with its query
    commands, and its program listed back (ULP) and compared. Exit 0 in sync (or nothing to
    compare), 16 out of sync, 7 no device (with --fleet: 7 if any device is unreachable,
    else 16 if any is out of sync)."""
    from mplang.family.face import CommandError, StatusJob

    if sum(x is not None for x in (tcp, serial, to, fleet)) != 1:
        raise click.UsageError("give one device: --tcp HOST[:PORT], --serial PORT or --to "
                               "NAME, or a fleet: --fleet FILE")
    setup = build_setup(ctx, files, project_file, target, word_order, temp_vars,
                        allow_outside_includes, werror, need_sources=False)
    project = setup.project
    devices: list[Target] = []
    if fleet is not None:
        try:
            devices = load_fleet(fleet)
        except ProjectError as exc:
            raise InputError(str(exc)) from None
        device = devices[0]
    else:
        device = chosen_device(tcp, serial, unit, baud, parity, stopbits, to, project)
    family = _family(setup, device)
    if fleet is not None:
        others = [d.name for d in devices[1:] if _family(setup, d) is not family]
        if others:
            raise click.UsageError(f"--fleet reads devices of one controller family, and "
                                   f"{fleet} lists {family.TITLE} ({device.name}) with others "
                                   f"({', '.join(others)}): read those with --to NAME")
    if family.status_device is None:
        raise click.UsageError(f"there is no {family.TITLE} device to read: "
                               f"{family.NO_TRANSPORT}")
    wrong = [option for option, name in STATUS_OPTIONS
             if option not in family.FLASH_OPTIONS and ctx.get_parameter_source(name)
             not in (None, click.core.ParameterSource.DEFAULT)]
    if wrong:
        raise click.UsageError(f"{', '.join(wrong)}: M8194H option(s); a {family.TITLE} "
                               "device has no such setting")
    settings = project.flash if project is not None else None
    manifest_range, manifest_where = identity_choice(identity, no_identity, settings)
    job = StatusJob(
        device=device, paths=setup.paths, options=setup.options,
        word_order_fixed=word_order is not None
        or (project is not None and project.word_order is not None),
        as_json=as_json, timeout=timeout, retries=retries,
        identity=manifest_range, identity_where=manifest_where,
        fleet=fleet is not None, devices=devices or [device], jobs=jobs)
    try:
        outcome = family.status_device(job, DeviceUI("mpc status", setup.werror))
    except CommandError as exc:
        raise click_error(exc) from None
    sys.exit(STATUS_EXIT[outcome])


STATUS_OPTIONS = (("--unit", "unit"), ("--word-order", "word_order"), ("--retries", "retries"),
                  ("--identity", "identity"), ("--no-identity", "no_identity"))
"""Options of `mpc status` that only families taking them in `mpc flash` (their
`FLASH_OPTIONS`) accept: Modbus, the image's word order, the build manifest."""


def _family(setup: BuildSetup, device: Target) -> Family:
    """The controller family of one device: its own target, else the sources' or
    --target's (`families.select`)."""
    return device_selection(setup, device).family

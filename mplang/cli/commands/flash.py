"""`mpc flash`: download an image into a device and verify every program."""

from __future__ import annotations

import sys
from collections.abc import Callable

import click

from mplang.cli.common import (
    FLASH_EXIT,
    InputError,
    build_options,
    expand_inputs,
    guarded,
    parse_device_address,
    report,
    with_common,
    with_serial_line,
)
from mplang.compiler import compile_paths


@click.command("flash",
               short_help="Download and verify programs in one device (Modbus TCP or RTU).")
@click.argument("files", nargs=-1, required=True)
@click.option("--tcp", callback=parse_device_address, default=None, metavar="HOST[:PORT]",
              help="The device's Modbus TCP address (ET-M8194H) [default port: 502].")
@click.option("--serial", default=None, metavar="PORT",
              help="The serial port of a Modbus RTU device (RS-M8194H).")
@click.option("--unit", type=click.IntRange(1, 247), default=1, show_default=True,
              help="Modbus unit id: the RTU slave address (the ET-M8194H answers as 1).")
@with_serial_line
@click.option("--timeout", type=click.FloatRange(min=0.01, max=60), default=1.0,
              show_default=True, help="Seconds to wait for each answer.")
@click.option("--retries", type=click.IntRange(0, 100), default=3, show_default=True,
              help="Repeats after a timeout or a lost connection (reads, reconnections, "
              "re-downloads of a program).")
@click.option("--set-word-order", is_flag=True,
              help="If the device's word order (holding register 14) differs from the "
              "image's, set it instead of refusing.")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON summary on standard output.")
@click.option("--dry-run", is_flag=True,
              help="Print every frame that would be sent; connect to nothing.")
@with_common
@guarded
def command(files: tuple[str, ...], tcp: tuple[str, int] | None, serial: str | None, unit: int,
          baud: int, parity: str, stopbits: str, timeout: float, retries: int,
          set_word_order: bool, as_json: bool, dry_run: bool, target: str,
          word_order: str | None, temp_vars: range, allow_outside_includes: bool,
          werror: bool) -> None:
    """Download FILE... (.mp sources built together, or one image JSON) into one device over
    Modbus TCP or RTU, and verify every program through its download-status registers."""
    import asyncio
    import json
    import logging
    import signal
    from dataclasses import replace

    from mplang import flash as flashing
    from mplang.modbus import DeviceLink, Endpoint

    if (tcp is None) == (serial is None) and not dry_run:
        raise click.UsageError("give the device: --tcp HOST[:PORT] or --serial PORT")
    paths = expand_inputs(files)
    rebuild: Callable[[int], flashing.FlashImage] | None = None
    if any(p.suffix.lower() == ".json" for p in paths):
        if len(paths) != 1:
            raise click.UsageError("give one image JSON, or .mp sources, not both")
        if word_order is not None:
            raise click.BadParameter("an image JSON carries its own word order; --word-order "
                                     "is for building .mp sources", param_hint="--word-order")
        try:
            image = flashing.load_image(paths[0])
        except OSError as exc:
            raise InputError(f"cannot read {paths[0]}: {exc.strerror or exc}") from None
        except flashing.ImageError as exc:
            raise InputError(f"{exc}") from None
    else:
        options = build_options(target, word_order, temp_vars, allow_outside_includes)
        result = compile_paths(paths, options)
        code = report(result, werror)
        if code:
            sys.exit(code)
        image = flashing.image_from_build(result)
        if word_order is None:  # follow the device's word order: the build is the same
            def build_for(order: int) -> flashing.FlashImage:
                return flashing.image_from_build(
                    compile_paths(paths, replace(options, word_order=order)))
            rebuild = build_for
    if dry_run:
        click.echo(json.dumps(flashing.plan_json(image)) + "\n" if as_json
                   else flashing.render_plan(image), nl=False)
        return
    endpoint = Endpoint(host=tcp[0] if tcp else None, port=tcp[1] if tcp else 502,
                        serial=serial, baudrate=baud, parity=parity, stopbits=int(stopbits),
                        unit=unit, timeout=timeout, retries=retries)
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    flasher = flashing.Flasher(image, DeviceLink(endpoint), flashing.FlashOptions(
        set_word_order=set_word_order, rebuild=rebuild),
        lambda text: click.echo(f"mpc flash: {text}", err=True))

    async def main_task() -> flashing.FlashReport:
        task = asyncio.ensure_future(flasher.run())
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, task.cancel)
        try:
            return await task
        except asyncio.CancelledError:
            return flasher.report

    outcome = asyncio.run(main_task())
    verified = sum(1 for p in outcome.programs if p.status == "verified")
    if outcome.ok:
        click.echo(f"mpc flash: {verified} program(s) verified on {outcome.device}"
                   + (f" (build {outcome.build_id})" if outcome.build_id else ""), err=True)
    else:
        where = f"{outcome.where}: " if outcome.where else ""
        click.echo(f"mpc flash: {where}error: {outcome.error}", err=True)
        click.echo(f"mpc flash: {verified} of {len(outcome.programs)} program(s) verified",
                   err=True)
    if as_json:
        click.echo(json.dumps(outcome.to_json(), indent=1))
    sys.exit(FLASH_EXIT[outcome.outcome])

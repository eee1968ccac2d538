"""`mpc`: the command line, a thin shell over `mplang.compiler`.

Exit codes (also in docs/cli.md):
  0 success            1 errors in the sources     2 bad command-line usage
  3 input files missing or unreadable               4 output cannot be written
  5 the program failed or did not finish on the virtual controller
  6 a Modbus endpoint cannot be opened (port in use, no such serial device)
  7 mpc flash: the device cannot be reached (refused, no answer, no such serial port)
  8 mpc flash: the device refused a program, or cannot take the image (word order)
  9 mpc flash: the device did not confirm a download (download-status registers)
  10 mpc flash: interrupted: the link failed beyond --retries, the device stayed busy, or
     Ctrl-C / SIGTERM; programs after the last verified one may be missing
  70 internal error (a bug in mpc: please report it with the input)
"""

from __future__ import annotations

import glob
import sys
from collections.abc import Callable
from functools import wraps
from pathlib import Path
from typing import Any, TypeVar

import click

from mplang import __version__
from mplang.compiler import DEFAULT_TEMPS, BuildResult, Options, compile_paths
from mplang.diagnostics import Severity

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
EXIT_INTERNAL = 70
FLASH_EXIT = {"verified": EXIT_OK, "no-device": EXIT_NO_DEVICE, "rejected": EXIT_REJECTED,
              "unverified": EXIT_UNVERIFIED, "interrupted": EXIT_INTERRUPTED}

F = TypeVar("F", bound=Callable[..., Any])


class InputError(click.ClickException):
    exit_code = EXIT_NO_INPUT


class OutputError(click.ClickException):
    exit_code = EXIT_OUTPUT


def guarded(func: F) -> F:
    """Turn any unexpected exception into one line and exit 70: never a traceback."""

    @wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except (click.ClickException, click.exceptions.Exit, click.Abort, SystemExit):
            raise
        except KeyboardInterrupt:
            click.echo("mpc: interrupted", err=True)
            sys.exit(130)
        except Exception as exc:
            click.echo(f"mpc: internal error: {type(exc).__name__}: {exc}\n"
                       "This is a bug in mpc; please report it with the input that caused it.",
                       err=True)
            sys.exit(EXIT_INTERNAL)

    return wrapper  # type: ignore[return-value]


def expand_inputs(patterns: tuple[str, ...]) -> list[Path]:
    """Files, directories (every .mp below) and glob patterns, in a stable order."""
    paths: list[Path] = []
    for pattern in patterns:
        path = Path(pattern)
        if path.is_dir():
            found = sorted(path.rglob("*.mp"))
            if not found:
                raise InputError(f"no .mp files in directory {pattern}")
            paths += found
        elif path.exists():
            paths.append(path)
        elif any(ch in pattern for ch in "*?["):
            matches = sorted(Path(m) for m in glob.glob(pattern, recursive=True))
            if not matches:
                raise InputError(f"no files match {pattern}")
            paths += matches
        else:
            raise InputError(f"{pattern}: no such file")
    unique: list[Path] = []
    seen: set[Path] = set()
    for p in paths:
        if p.resolve() not in seen:
            seen.add(p.resolve())
            unique.append(p)
    return unique


def parse_temps(_ctx: click.Context, _param: click.Parameter, value: str | None) -> range:
    if value is None:
        return DEFAULT_TEMPS
    try:
        low_text, high_text = value.replace("VAR", "").replace("var", "").split("-")
        low, high = int(low_text), int(high_text)
    except ValueError:
        raise click.BadParameter("write the pool as FIRST-LAST, e.g. 496-511") from None
    if not 0 <= low <= high <= 511:
        raise click.BadParameter("the pool must lie within VAR0..VAR511")
    return range(low, high + 1)


def write_output(text: str, output: str | None) -> None:
    if output is None or output == "-":
        click.echo(text, nl=False)
        return
    try:
        Path(output).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise OutputError(f"cannot write {output}: {exc.strerror or exc}") from None


def report(result: BuildResult, werror: bool) -> int:
    for diagnostic in result.diagnostics:
        click.echo(diagnostic.render(), err=True)
    errors = sum(1 for d in result.diagnostics if d.severity is Severity.ERROR)
    warnings = len(result.diagnostics) - errors
    if errors or (werror and warnings):
        click.echo(f"mpc: {errors} error(s), {warnings} warning(s)", err=True)
        return EXIT_SOURCE_ERRORS
    return EXIT_OK


common_options = [
    click.option("--target", type=click.Choice(["et", "rs"]), default="et", show_default=True,
                 help="Controller: ET-M8194H (Modbus TCP) or RS-M8194H (Modbus RTU)."),
    click.option("--word-order", type=click.Choice(["0", "1"]), default=None,
                 help="Device word order (holding register 14). Default: the device's, 0."),
    click.option("--temp-vars", callback=parse_temps, default=None, metavar="FIRST-LAST",
                 help="VAR pool for expression temporaries [default: 500-511]."),
    click.option("--allow-outside-includes", is_flag=True,
                 help="Let INCLUDE reach files outside the project directory."),
    click.option("--werror", is_flag=True, help="Treat warnings as errors."),
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


def build_options(target: str, word_order: str | None, temp_vars: range,
                  allow_outside_includes: bool) -> Options:
    return Options(word_order=None if word_order is None else int(word_order), target=target,
                   temps=temp_vars, allow_outside_includes=allow_outside_includes)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="mpc")
def main() -> None:
    """mpc: compile, check, run and download M8194H macro programs (.mp)."""


@main.command()
@click.argument("files", nargs=-1, required=True)
@click.option("-o", "--output", default=None, metavar="OUT",
              help="Write the result here ('-' or absent: standard output).")
@click.option("--format", "fmt", type=click.Choice(["json", "listing", "hex", "map"]),
              default="json", show_default=True, help="Image JSON, human listing, hex "
              "frames, or the link map.")
@with_common
@guarded
def build(files: tuple[str, ...], output: str | None, fmt: str, target: str,
          word_order: str | None, temp_vars: range, allow_outside_includes: bool,
          werror: bool) -> None:
    """Compile FILE... (files, directories or globs) together into one download image."""
    from mplang import output as render

    result = compile_paths(expand_inputs(files),
                           build_options(target, word_order, temp_vars, allow_outside_includes))
    code = report(result, werror)
    if code:
        sys.exit(code)
    text = {
        "json": lambda: render.render_json(result),
        "listing": lambda: render.render_listing(result, result.sources),
        "hex": lambda: render.render_hex(result),
        "map": lambda: render.render_link_map(result),
    }[fmt]()
    write_output(text, output)


@main.command()
@click.argument("files", nargs=-1, required=True)
@click.option("--format", "fmt", type=click.Choice(["text", "json", "sarif"]), default="text",
              show_default=True, help="gcc-style lines, a JSON list, or SARIF 2.1.0.")
@click.option("-o", "--output", default=None, metavar="OUT", help="Write the report here.")
@with_common
@guarded
def lint(files: tuple[str, ...], fmt: str, output: str | None, target: str,
         word_order: str | None, temp_vars: range, allow_outside_includes: bool,
         werror: bool) -> None:
    """Check FILE... without producing an image. Exit 1 if any error is found."""
    from mplang import output as render

    result = compile_paths(expand_inputs(files),
                           build_options(target, word_order, temp_vars, allow_outside_includes))
    diagnostics = result.diagnostics
    if fmt == "text":
        text = render.render_text(diagnostics)
        if output is None:
            click.echo(text, nl=False, err=False)
        else:
            write_output(text, output)
    else:
        write_output(render.render_sarif(diagnostics) if fmt == "sarif"
                     else render.render_diagnostics_json(diagnostics), output)
    errors = sum(1 for d in diagnostics if d.severity is Severity.ERROR)
    if errors or (werror and diagnostics):
        sys.exit(EXIT_SOURCE_ERRORS)


@main.command()
@click.argument("files", nargs=-1, required=True)
@click.option("--call", "call", default=None, metavar="MPn|NAME",
              help="Program to call [default: the first MP of the first file].")
@click.option("--json", "as_json", is_flag=True, help="Print variables, axes, time and error "
              "as JSON.")
@click.option("--max-time", type=click.FloatRange(min=0.001), default=3600.0, show_default=True,
              help="Give up after this much simulated time (seconds).")
@with_common
@guarded
def run(files: tuple[str, ...], call: str | None, as_json: bool, max_time: float, target: str,
        word_order: str | None, temp_vars: range, allow_outside_includes: bool,
        werror: bool) -> None:
    """Build FILE..., load every program into a fresh virtual controller and run one."""
    import json

    from mplang.run import NoSuchProgram, RunSetupError, run_build

    paths = expand_inputs(files)
    result = compile_paths(paths, build_options(target, word_order, temp_vars,
                                                allow_outside_includes))
    code = report(result, werror)
    if code:
        sys.exit(code)
    first = next((s for s in result.sources if Path(s).resolve() == paths[0].resolve()), None)
    try:
        outcome = run_build(result, call, first, max_time=max_time)
    except NoSuchProgram as exc:
        raise click.BadParameter(str(exc), param_hint="--call") from None
    except RunSetupError as exc:
        click.echo(f"mpc: {exc}", err=True)
        sys.exit(EXIT_RUN_FAILED)
    summary = outcome.to_json()
    if as_json:
        click.echo(json.dumps(summary, indent=1))
    else:
        click.echo(f"{outcome.called}: {'finished' if outcome.result.finished else 'FAILED'} "
                   f"after {summary['time_ms']} ms simulated, {outcome.result.steps} lines")
        for name, value in summary["vars"].items():  # type: ignore[attr-defined]
            click.echo(f"  {name} = {value}")
        for name, pos in summary["axes"].items():  # type: ignore[attr-defined]
            click.echo(f"  {name}: lp {pos['lp']}, ep {pos['ep']}")
        if outcome.result.error:
            click.echo(f"error: {outcome.result.error}", err=True)
    if not outcome.result.finished:
        sys.exit(EXIT_RUN_FAILED)


def parse_host_port(_ctx: click.Context, _param: click.Parameter,
                    value: str | None) -> tuple[str, int] | None:
    if value is None:
        return None
    host, sep, port_text = value.rpartition(":")
    if not sep:
        host, port_text = value, "1502"
    try:
        port = int(port_text)
    except ValueError:
        raise click.BadParameter(f"{value!r}: write HOST:PORT, e.g. 127.0.0.1:1502") from None
    if not 0 <= port <= 65535:
        raise click.BadParameter(f"port {port} is not in 0..65535")
    return host.strip("[]") or "127.0.0.1", port


@main.command()
@click.argument("files", nargs=-1)
@click.option("--tcp", callback=parse_host_port, default=None, metavar="HOST:PORT",
              help="Serve Modbus TCP here (port 0: any free port) [default without --serial: "
              "127.0.0.1:1502].")
@click.option("--serial", default=None, metavar="PORT|pty",
              help="Serve Modbus RTU on this serial device; 'pty' makes a linked pseudo-"
              "terminal pair and prints the end to open.")
@click.option("--unit", type=click.IntRange(1, 247), default=1, show_default=True,
              help="RTU slave address.")
@with_serial_line
@click.option("--speed", type=click.FloatRange(min=0.0001, max=10000), default=1.0,
              show_default=True, help="Simulated seconds per wall second.")
@click.option("--memory", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Macro memory file: loaded at start, written after every download.")
@click.option("--duration", type=click.FloatRange(min=0), default=None,
              help="Stop after this many seconds [default: run until interrupted].")
@click.option("-v", "--verbose", is_flag=True, help="Print what the device does.")
@with_common
@guarded
def sim(files: tuple[str, ...], tcp: tuple[str, int] | None, serial: str | None, unit: int,
        baud: int, parity: str, stopbits: str, speed: float, memory: Path | None,
        duration: float | None, verbose: bool, target: str, word_order: str | None,
        temp_vars: range, allow_outside_includes: bool, werror: bool) -> None:
    """Serve a virtual M8194H over Modbus TCP and/or RTU (FILE...: programs to preload)."""
    import asyncio
    import signal

    from mplang.sim.controller import VirtualController
    from mplang.sim.service import (
        ServiceError,
        SimOptions,
        load_memory,
        preload,
        save_memory,
        serve,
    )

    controller = VirtualController(word_order=int(word_order or 0))
    try:
        if memory is not None and memory.exists():
            load_memory(controller, memory)
            click.echo(f"mpc sim: macro memory {memory}: {len(controller.tables)} program(s)")
        if files:
            result = compile_paths(expand_inputs(files), build_options(
                target, word_order, temp_vars, allow_outside_includes))
            code = report(result, werror)
            if code:
                sys.exit(code)
            preload(controller, result)
            click.echo(f"mpc sim: {len(result.programs)} program(s) downloaded")
            if memory is not None:
                save_memory(controller, memory)
    except ServiceError as exc:
        click.echo(f"mpc sim: {exc}", err=True)
        sys.exit(EXIT_NO_INPUT if exc.kind == "memory" else EXIT_RUN_FAILED)
    options = SimOptions(tcp=tcp if tcp is not None or serial is not None
                         else ("127.0.0.1", 1502),
                         serial=serial, unit=unit, baudrate=baud, parity=parity,
                         stopbits=int(stopbits), speed=speed, memory=memory,
                         duration=duration, verbose=verbose)

    async def main_task() -> None:
        stop_event = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop_event.set)
        await serve(options, controller, lambda text: click.echo(f"mpc sim: {text}"),
                    stop_event)

    try:
        asyncio.run(main_task())
    except ServiceError as exc:
        click.echo(f"mpc sim: {exc}", err=True)
        sys.exit(EXIT_NO_INPUT if exc.kind == "memory" else EXIT_TRANSPORT)
    click.echo("mpc sim: stopped")


def parse_device_address(_ctx: click.Context, _param: click.Parameter,
                         value: str | None) -> tuple[str, int] | None:
    """HOST[:PORT] with the Modbus TCP port 502 by default; IPv6 as [ADDR]:PORT or bare."""
    if value is None:
        return None
    host, port_text = value, "502"
    if value.startswith("["):
        host, _, rest = value[1:].partition("]")
        if rest:
            port_text = rest.removeprefix(":")
    elif value.count(":") == 1:
        host, port_text = value.split(":")
    try:
        port = int(port_text)
    except ValueError:
        raise click.BadParameter(f"{value!r}: write HOST or HOST:PORT, e.g. 192.168.0.16:502"
                                 ) from None
    if not host or not 1 <= port <= 65535:
        raise click.BadParameter(f"{value!r}: write HOST or HOST:PORT with a port in 1..65535")
    return host, port


@main.command(short_help="Download and verify programs in one device (Modbus TCP or RTU).")
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
def flash(files: tuple[str, ...], tcp: tuple[str, int] | None, serial: str | None, unit: int,
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

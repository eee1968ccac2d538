"""What every `mpc` command shares: exit codes, the never-a-traceback guard, input
expansion, and the compiler and serial-line options."""


from __future__ import annotations

import glob
import sys
from collections.abc import Callable
from functools import wraps
from pathlib import Path
from typing import Any, TypeVar

import click

from mplang.compiler import DEFAULT_TEMPS, BuildResult, Options
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
EXIT_FLEET_MIXED = 11
EXIT_WOULD_REFORMAT = 12
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

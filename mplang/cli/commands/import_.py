"""`mpc import`: a C program written against the vendor API (RSM_/ETM_) turned into `.mp`."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mplang.cli import style
from mplang.cli.common import (
    EXIT_NO_INPUT,
    EXIT_OMISSIONS,
    EXIT_SOURCE_ERRORS,
    guarded,
    write_output,
)
from mplang.cli.shell import complete_paths


@click.command("import", short_help="Convert a vendor-API C program into .mp source.")
@click.argument("file", metavar="FILE.c", shell_complete=complete_paths)
@click.option("-o", "--output", default=None, metavar="OUT", shell_complete=complete_paths,
              help="Write the .mp source here ('-' or absent: standard output).")
@click.option("--encoding", default=None, metavar="CODEC",
              help="Text encoding of FILE [default: UTF-8, else cp950, else Latin-1].")
@click.option("--check", is_flag=True,
              help="Also compile the result and report its errors and warnings at the C "
              "lines they come from (exit 1 on errors).")
@guarded
def command(file: str, output: str | None, encoding: str | None, check: bool) -> None:
    """Convert FILE.c, which downloads macro programs with RSM_MP_CREATE ... RSM_MACRO_* ...
    RSM_MACRO_MP_CLOSE (or the ETM_ names), into .mp source.

    Comments and blank lines are kept; host code around the programs is kept as `# C:`
    comments. Whatever cannot be converted is named on standard error as
    `FILE.c:LINE: cannot convert ...` and the exit code is 13. A file that calls no
    vendor function is not such a program: exit 3.
    """
    import codecs

    from mplang.lang.sources import read_regular_bytes
    from mplang.m8194h.importc import convert, read_c_file

    if encoding is not None:
        try:
            codecs.lookup(encoding)
        except LookupError:
            raise click.BadParameter(f"unknown encoding {encoding!r}",
                                     param_hint="--encoding") from None
    path = Path(file)
    try:
        data = read_regular_bytes(path)
    except OSError as exc:
        style.error(f"{file}: cannot read: {exc.strerror or exc}")
        sys.exit(EXIT_NO_INPUT)
    try:
        text, used = read_c_file(data, encoding)
    except UnicodeDecodeError as exc:
        style.error(f"{file}: not {encoding} text (byte {exc.start})")
        sys.exit(EXIT_NO_INPUT)
    if encoding is None and used != "utf-8":
        click.echo(f"{file}: note: not UTF-8; read as {used} (use --encoding to choose)",
                   err=True)
    if not _has_vendor_calls(text):
        style.error(f"{file}: no call of the vendor API (RSM_... or ETM_... functions): "
                    "nothing to convert; mpc import reads C programs that download macro "
                    "programs with RSM_MP_CREATE, RSM_MACRO_... and RSM_MACRO_MP_CLOSE (or "
                    "the ETM_ names)")
        sys.exit(EXIT_NO_INPUT)
    result = convert(text, source_name=path.name)
    write_output(result.text, output)
    for warning in result.warnings:
        click.echo(f"{file}:{warning.line}: {warning.message}", err=True)
    code = 0
    if check:
        code = _check(result.text, result.line_map, result.target, file, output)
    if code:
        sys.exit(code)
    if result.warnings:
        style.error(f"{len(result.warnings)} construct(s) not converted")
        sys.exit(EXIT_OMISSIONS)


def _has_vendor_calls(text: str) -> bool:
    """Whether the C text calls an RSM_/ETM_ function outside comments and strings."""
    import re

    code = re.sub(r'/\*.*?\*/|//[^\n]*|"(?:\\.|[^"\\\n])*"', " ", text, flags=re.DOTALL)
    return re.search(r"\b(?:RSM|ETM)_\w+\s*\(", code) is not None


def _check(text: str, line_map: list[int | None], target: str, file: str,
           output: str | None) -> int:
    """Compile the converted text; report each diagnostic at its C line (and .mp line)."""
    from mplang.lang.diagnostics import Severity
    from mplang.m8194h.compiler import Options, compile_source

    name = output if output not in (None, "-") else Path(file).with_suffix(".mp").name
    result = compile_source(text, str(name), Options(target=target))
    for diagnostic in result.diagnostics:
        row = diagnostic.span.line - 1
        c_line = line_map[row] if 0 <= row < len(line_map) else None
        where = f"{file}:{c_line}" if c_line is not None else file
        click.echo(f"{where}: {diagnostic.severity.value}[{diagnostic.code}]: "
                   f"{diagnostic.message} ({diagnostic.span})", err=True)
        if diagnostic.hint:
            click.echo(f"    hint: {diagnostic.hint}", err=True)
    errors = sum(1 for d in result.diagnostics if d.severity is Severity.ERROR)
    return EXIT_SOURCE_ERRORS if errors else 0

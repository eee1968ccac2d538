"""How `mpc` writes to a person: colour only on a terminal (or `--color always`), never with
`NO_COLOR`; one error prefix (`mpc: error: ...`); diagnostics with the source line and a caret
range under them, and a one-line summary.

The first line of a diagnostic stays the gcc-style `file:line:col: error[CODE]: message`
whatever the colour, so greps and editors' problem matchers keep reading it.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

import click

from mplang.lang.severity import Severity

if TYPE_CHECKING:  # not at run time: `mpc --version` and `--help` need no rule registry
    from mplang.lang.diagnostics import Diagnostic

COLOR_CHOICES = ("auto", "always", "never")
_META_KEY = "mpc.color"
_MAX_SOURCE_BYTES = 4 * 1024 * 1024  # an excerpt is worth no more than this much reading


def set_color(ctx: click.Context, mode: str) -> None:
    """Remember `--color` for every command of this invocation."""
    ctx.meta[_META_KEY] = mode


def color_enabled(stream: TextIO | None = None, err: bool = True) -> bool:
    """`--color always` colours even a pipe; `never` never; under `auto`, the conventions
    other tools keep: `NO_COLOR` (any value but empty, no-color.org) never, then
    `FORCE_COLOR` (any value but empty or `0`, force-color.org) always, as a CI log wants,
    then `TERM=dumb` never (a terminal without escape sequences), else only a terminal."""
    ctx = click.get_current_context(silent=True)
    mode = ctx.meta.get(_META_KEY, "auto") if ctx is not None else "auto"
    if mode == "never":
        return False
    if mode == "always":
        return True
    if os.environ.get("NO_COLOR"):
        return False
    if os.environ.get("FORCE_COLOR", "0") not in ("", "0"):
        return True
    if os.environ.get("TERM") == "dumb":
        return False
    return is_terminal(stream if stream is not None else
                       (sys.stderr if err else sys.stdout))


def is_terminal(stream: TextIO) -> bool:
    """A terminal, as far as a stream can tell (a closed or fake one is not)."""
    try:
        return bool(stream.isatty())
    except (ValueError, OSError):  # a closed stream
        return False


def echo(text: str, err: bool = True, nl: bool = True) -> None:
    """`click.echo` that keeps or strips the colour as `color_enabled` says."""
    click.echo(text, err=err, nl=nl, color=color_enabled(err=err))


CLEAR_LINE = "\r\x1b[2K"
"""Back to the start of the terminal line, and erase it: what a status line is redrawn over."""


def redraw(stream: TextIO, text: str = "") -> None:
    """Erase the terminal line `stream` is on and write `text` (no newline) through click,
    which on Windows consoles turns the escape into console calls (colorama) instead of
    printing it; only called for a terminal, so the escape is kept (`color=True`)."""
    click.echo(CLEAR_LINE + text, file=stream, nl=False, color=True)
    stream.flush()


def _paint(text: str, color: bool, fg: str | None = None, bold: bool = False) -> str:
    return click.style(text, fg=fg, bold=bold) if color else text


def error_line(message: str, color: bool) -> str:
    """The one prefix of every error mpc itself reports (not a diagnostic of a source)."""
    return f"{_paint('mpc', color, bold=True)}: {_paint('error', color, 'red', True)}: " \
           f"{message}"


def error(message: str) -> None:
    """Report an error of mpc itself on standard error."""
    echo(error_line(message, color_enabled()))


class SourceLines:
    """The lines of the files diagnostics point into, read once each; a file that cannot be
    read (standard input, a vanished or binary file) gives no excerpt rather than an error."""

    def __init__(self, known: dict[str, Sequence[str]] | None = None) -> None:
        self._lines: dict[str, Sequence[str] | None] = dict(known or {})

    def line(self, file: str, number: int) -> str | None:
        if file not in self._lines:
            self._lines[file] = self._read(file)
        lines = self._lines[file]
        if lines is None or not 0 < number <= len(lines):
            return None
        return lines[number - 1]

    @staticmethod
    def _read(file: str) -> list[str] | None:
        path = Path(file)
        try:
            if not path.is_file() or path.stat().st_size > _MAX_SOURCE_BYTES:
                return None
            return path.read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError, ValueError):
            return None


_SEVERITY_COLOR = {Severity.ERROR: "red", Severity.WARNING: "yellow"}
_SEVERITY_WORD = {severity: severity.value for severity in Severity}  # not through the enum


def render_diagnostic(diagnostic: Diagnostic, sources: SourceLines, color: bool) -> str:
    """The gcc-style first line, then (rustc/ruff style) the source line with a caret range
    under the span, related notes and the hint. Built as one string, painted only with
    `color`: a whole device's check renders thousands, so the plain text is made without
    a call per part."""
    span = diagnostic.span
    tint = _SEVERITY_COLOR.get(diagnostic.severity, "cyan")
    where = f"{span.file}:{span.line}:{span.col}"  # str(span), without the call
    label = f"{_SEVERITY_WORD[diagnostic.severity]}[{diagnostic.code}]"
    if color:
        where, label = _paint(where, color, bold=True), _paint(label, color, tint, True)
    out = f"{where}: {label}: {diagnostic.message}" + _excerpt(
        span.file, span.line, span.col, span.end_col, sources, color, tint)
    for related, note in diagnostic.related:
        out += (f"\n{_paint(str(related), color, bold=True)}: "
                f"{_paint('note', color, 'cyan', True)}: {note}")
        out += _excerpt(related.file, related.line, related.col, related.end_col, sources,
                        color, "cyan")
    if diagnostic.hint:
        hint = _paint("hint", color, "cyan", True) if color else "hint"
        out += f"\n    {hint}: {diagnostic.hint}"
    return out


def _excerpt(file: str, number: int, col: int, end_col: int | None, sources: SourceLines,
             color: bool, tint: str) -> str:
    """The three lines under a diagnostic's first one (each after a line break): the source
    line and carets under the span; "" without a line to show."""
    text = sources.line(file, number)
    if text is None:
        return ""
    if "\t" in text:
        text = text.expandtabs(1)  # one column a character, as spans count them
    text = text.rstrip()
    if len(text) > 200:
        return ""  # a generated line: the excerpt would help no one
    start = col if col > 1 else 1
    end = end_col if end_col is not None and end_col > start else start + 1
    end = min(end, max(len(text) + 1, start + 1))
    shown = str(number)
    gutter = " " * len(shown)
    if color:
        bar, shown = _paint("|", color, "blue", True), _paint(shown, color, "blue", True)
        carets = _paint("^" * (end - start), color, tint, True)
        return f"\n {gutter} {bar}\n {shown} {bar} {text}\n {gutter} {bar} " \
               f"{' ' * (start - 1)}{carets}"
    return f"\n {gutter} |\n {shown} | {text}\n {gutter} | {' ' * (start - 1)}{'^' * (end - start)}"


WERROR_REASON = "failed: warnings are errors here (--werror, or werror = true in mpc.toml)"
"""Why a check with warnings alone fails: said, not left to the exit code."""


def summary(diagnostics: Sequence[Diagnostic], werror: bool = False) -> str:
    """`2 errors, 1 warning in 3 files`: the files are those with a finding. With `werror`
    and warnings but no error, the line ends saying why the check fails."""
    errors = sum(1 for d in diagnostics if d.severity is Severity.ERROR)
    warnings = len(diagnostics) - errors
    files = len({d.span.file for d in diagnostics})

    def count(n: int, word: str) -> str:
        return f"{n} {word}{'' if n == 1 else 's'}"

    line = f"{count(errors, 'error')}, {count(warnings, 'warning')} in {count(files, 'file')}"
    return f"{line}; {WERROR_REASON}" if werror and warnings and not errors else line


def echo_summary(diagnostics: Sequence[Diagnostic], werror: bool = False) -> None:
    """The summary on standard error, bold (red when it fails) on a terminal; nothing
    under `--quiet`."""
    if quiet():
        return
    failed = any(d.severity is Severity.ERROR for d in diagnostics) or (
        werror and bool(diagnostics))
    echo(_paint(summary(diagnostics, werror), color_enabled(), "red" if failed else None,
                True))


_QUIET_KEY = "mpc.quiet"


def _note_quiet(ctx: click.Context, _param: click.Parameter, value: bool) -> bool:
    if value:
        ctx.meta[_QUIET_KEY] = True
    return value


quiet_option = click.option(
    "-q", "--quiet", is_flag=True, expose_value=False, callback=_note_quiet,
    help="Print no progress and no summary: only the report, the output and errors.")
"""`-q/--quiet` of every command that prints progress or a summary (`quiet()` reads it)."""


def quiet() -> bool:
    """Whether `-q/--quiet` was given (to the command, or to `mpc` before it)."""
    ctx = click.get_current_context(silent=True)
    return bool(ctx is not None and ctx.meta.get(_QUIET_KEY))


def all_checks_passed() -> None:
    if quiet():
        return
    echo(_paint("All checks passed", color_enabled(), "green", True))


def report_diagnostics(diagnostics: Sequence[Diagnostic],
                       known: dict[str, Sequence[str]] | None = None) -> None:
    """Every diagnostic on standard error, rendered for a person: in one write, the colour
    decided once (a whole device can have thousands of warnings)."""
    if not diagnostics:
        return
    color = color_enabled()
    sources = SourceLines(known)
    click.echo("\n".join(render_diagnostic(diagnostic, sources, color)
                         for diagnostic in diagnostics), err=True, color=color)

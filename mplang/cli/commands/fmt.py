"""`mpc fmt`: rewrite `.mp` sources in the canonical layout, or check / show what would change.

Files are replaced atomically (a temporary file beside them, then a rename), and only when
their text changes. A file with syntax errors is never touched: the compiler's diagnostics
say why. Exit codes, first that applies: 3 a file cannot be read, 4 a file cannot be written,
1 syntax errors, 12 `--check` found files that would change, else 0.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, cast

import click

from mplang.cli import style
from mplang.cli.common import (
    EXIT_NO_INPUT,
    EXIT_OK,
    EXIT_OUTPUT,
    EXIT_SOURCE_ERRORS,
    EXIT_WOULD_REFORMAT,
    STDIN,
    STDIN_NAME,
    InputError,
    decode_source,
    expand_inputs,
    guarded,
    isolated,
    load_project_file,
    near_path,
    nearest_projects,
    project_option,
    stdin_filename_option,
    stdin_project,
)
from mplang.cli.rewrite import unified_diff, write_atomically
from mplang.cli.shell import complete_paths
from mplang.cli.style import quiet_option
from mplang.tools.project import find_project

if TYPE_CHECKING:
    from mplang.tools.fmt import FormatOptions
    from mplang.tools.project import Project


@dataclass
class _Tally:
    """What happened to the files of one run, for the summary line and the exit code."""

    changed: list[str] = field(default_factory=list)
    unchanged: int = 0
    unreadable: int = 0
    unwritable: int = 0
    with_errors: int = 0

    def exit_code(self, check: bool) -> int:
        if self.unreadable:
            return EXIT_NO_INPUT
        if self.unwritable:
            return EXIT_OUTPUT
        if self.with_errors:
            return EXIT_SOURCE_ERRORS
        if check and self.changed:
            return EXIT_WOULD_REFORMAT
        return EXIT_OK


def _plural(count: int, word: str) -> str:
    return f"{count} {word}{'' if count == 1 else 's'}"


def _options(indent: int | None, keyword_case: str | None,
             base: FormatOptions | None = None) -> FormatOptions:
    """The command line's settings over `base`: the defaults, or the options a project's
    [fmt] table gives (`FormatOptions.from_mapping`)."""
    from mplang.tools.fmt import FormatOptions, FormatOptionsError, KeywordCase

    options = base or FormatOptions()
    try:
        if indent is not None:
            options = replace(options, indent=indent)
        if keyword_case is not None:
            options = replace(options, keyword_case=cast(KeywordCase, keyword_case))
    except FormatOptionsError as exc:
        raise click.UsageError(f"mpc fmt: {exc}") from None
    return options


def _formatted(text: str, display: str, options: FormatOptions) -> str | None:
    """The canonical text, or None after printing the syntax errors that prevent it."""
    from mplang.tools.fmt import SourceNotFormattable, format_source

    try:
        return format_source(text, options, name=display)
    except SourceNotFormattable as exc:
        style.report_diagnostics(exc.diagnostics, {display: text.splitlines()})
        style.error(f"{display} has syntax errors; left as it is")
        return None


def _format_file(path: Path, options: FormatOptions, check: bool, show_diff: bool,
                 tally: _Tally) -> None:
    display = str(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        style.error(f"cannot read {display}: {exc.strerror or exc}")
        tally.unreadable += 1
        return
    text = decode_source(data, display)
    formatted = None if text is None else _formatted(text, display, options)
    if text is None or formatted is None:
        tally.with_errors += 1
        return
    if formatted == text:
        tally.unchanged += 1
        return
    if show_diff:
        click.echo(unified_diff(text, formatted, display), nl=False)
    if check or show_diff:
        tally.changed.append(display)
        if check:
            click.echo(f"would reformat {display}", err=True)
        return
    try:
        write_atomically(path, formatted.encode("utf-8"))
    except OSError as exc:
        style.error(f"cannot write {display}: {exc.strerror or exc}")
        tally.unwritable += 1
        return
    tally.changed.append(display)
    if not style.quiet():
        click.echo(f"reformatted {display}", err=True)


def _format_stdin(options: FormatOptions, check: bool, show_diff: bool,
                  display: str = STDIN_NAME) -> int:
    """`mpc fmt -`: standard input to standard output (nothing on stdout on errors);
    messages call it `display` (`--stdin-filename`)."""
    text = decode_source(sys.stdin.buffer.read(), display)
    formatted = None if text is None else _formatted(text, display, options)
    if text is None or formatted is None:
        return EXIT_SOURCE_ERRORS
    if show_diff:
        click.echo(unified_diff(text, formatted, display), nl=False)
    elif not check:
        sys.stdout.flush()
        sys.stdout.buffer.write(formatted.encode("utf-8"))
        sys.stdout.buffer.flush()
    if check and formatted != text:
        click.echo(f"would reformat {display}", err=True)
        return EXIT_WOULD_REFORMAT
    return EXIT_OK


def _fmt_table(project: Project | None) -> FormatOptions | None:
    """The project file's [fmt] settings, or None for the formatter's defaults."""
    from mplang.tools.fmt import FormatOptions, FormatOptionsError

    if project is None:
        return None
    try:
        return FormatOptions.from_mapping(project.fmt, where=f"{project.path} [fmt]")
    except FormatOptionsError as exc:
        raise InputError(str(exc)) from None


@click.command("fmt", short_help="Lay out .mp sources in the canonical format.")
@click.argument("files", nargs=-1, shell_complete=complete_paths)
@click.option("--check", is_flag=True,
              help="Write nothing; list the files that would change and exit 12 if any.")
@click.option("--diff", "show_diff", is_flag=True,
              help="Print unified diffs of the changes instead of writing the files.")
@click.option("--indent", type=int, default=None, metavar="N",
              help="Spaces per block level, 1-16 [default: 4].")
@click.option("--keyword-case", type=click.Choice(["upper", "lower"]), default=None,
              help="Case of keywords and command names [default: upper].")
@stdin_filename_option
@project_option
@quiet_option
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], check: bool, show_diff: bool,
            indent: int | None, keyword_case: str | None, stdin_filename: str | None,
            project_file: Path | None) -> None:
    """Format FILE... (files, directories or globs; without them, the sources of mpc.toml)
    in place; '-' formats standard input to standard output. Comments, blank-line groups and
    every token are kept; files with syntax errors are left untouched (exit 1). The [fmt]
    table of the nearest mpc.toml above each FILE (above here for standard input) sets its
    defaults; with --stdin-filename PATH, the one nearest PATH for standard input."""
    if stdin_filename is not None and files != (STDIN,):
        raise click.UsageError("--stdin-filename names what '-' (standard input) stands for: "
                               "give it with '-' as the only FILE")
    if files == (STDIN,):
        project = stdin_project(ctx, stdin_filename, project_file)
        sys.exit(_format_stdin(_options(indent, keyword_case, _fmt_table(project)), check,
                               show_diff, stdin_filename or STDIN_NAME))
    if project_file is not None and isolated():
        raise click.UsageError("give --project FILE or --isolated, not both")
    here = not isolated() and not files  # FILEs find their own
    found = project_file or (find_project(Path.cwd()) if here else None)
    project = load_project_file(found) if found is not None else None
    if not files:
        if project is None or not project.sources:
            raise click.UsageError("give FILE... (.mp sources), or run where an mpc.toml "
                                   "lists them (docs/project.md)")
        if not (check or show_diff):  # rewriting in place on the project file's word
            outside = [p for p in project.sources if not project.may_write(p)]
            if outside:
                raise InputError(
                    f"{project.path}:{project.sources_line}: [project] sources: "
                    f"{near_path(outside[0])} is outside the project "
                    f"({near_path(project.root)}), and mpc fmt rewrites only files "
                    "inside it: name the file on the command line to format it")
        files = tuple(near_path(p) for p in project.sources)
    if STDIN in files:
        raise click.UsageError("'-' (standard input) cannot be combined with files")
    tally = _Tally()
    paths = expand_inputs(files)
    if project_file is not None or isolated():
        groups = [(project, paths)]
    else:  # each file laid out by the [fmt] table of the nearest mpc.toml above it
        groups = [(None if near is None else load_project_file(Path(near_path(near))),
                   group) for near, group in nearest_projects(paths)]
    for owner, group in groups:
        options = _options(indent, keyword_case, _fmt_table(owner))
        for path in group:
            _format_file(path, options, check, show_diff, tally)
    verb = "would be reformatted" if check or show_diff else "reformatted"
    summary = [f"{_plural(len(tally.changed), 'file')} {verb}", f"{tally.unchanged} unchanged"]
    if tally.with_errors:
        summary.append(f"{tally.with_errors} with errors left as they are")
    if tally.unreadable or tally.unwritable:
        summary.append(f"{tally.unreadable + tally.unwritable} unreadable or unwritable")
    if not style.quiet():
        click.echo(f"mpc fmt: {', '.join(summary)}", err=True)
    sys.exit(tally.exit_code(check))

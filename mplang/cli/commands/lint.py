"""`mpc lint`: the compiler's checks alone, as text, JSON, SARIF, GitHub workflow commands or
GitLab Code Quality JSON; for the other controller
families (`.fbs`/`.csim` listings, `.mp` with their `--target`) their checks, reported the
same way."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import click

from mplang.cli import style
from mplang.cli.common import (
    EXIT_OK,
    EXIT_SOURCE_ERRORS,
    STDIN,
    STDIN_NAME,
    BuildSetup,
    OutputError,
    build_setups,
    decode_source,
    guarded,
    project_option,
    stdin_filename_option,
    stdin_setup,
    with_common,
    write_output,
)
from mplang.cli.families import choose
from mplang.cli.shell import complete_paths
from mplang.cli.style import quiet_option
from mplang.lang.diagnostics import Diagnostic, Severity, without_ignored


@click.command("lint", short_help="Run every check without producing an image.")
@click.argument("files", nargs=-1, shell_complete=complete_paths)
@click.option("--format", "fmt",
              type=click.Choice(["text", "json", "sarif", "github", "gitlab"]), default="text",
              show_default=True, help="gcc-style lines, a JSON list, SARIF 2.1.0, GitHub "
              "workflow commands (annotations) or GitLab Code Quality JSON.")
@click.option("-o", "--output", default=None, metavar="OUT", shell_complete=complete_paths,
              help="Write the report here.")
@click.option("--fix", is_flag=True, help="Apply the preferred fix of every diagnostic that "
              "has one (did-you-mean and the like) in place, then report what remains; with "
              "'-', print the fixed text on standard output.")
@click.option("--diff", "show_diff", is_flag=True, help="Print the fixes --fix would apply "
              "as unified diffs and change nothing (exit 1 if there is any).")
@stdin_filename_option
@project_option
@quiet_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], fmt: str, output: str | None,
            fix: bool, show_diff: bool, stdin_filename: str | None,
            project_file: Path | None, target: str, word_order: str | None, temp_vars: range,
            allow_outside_includes: bool, werror: bool) -> None:
    """Check FILE... (without them, the sources of mpc.toml) without producing an image:
    .mp sources for --target, or FATEK .fbs / CSIM .csim listings. Each FILE is checked with
    the nearest mpc.toml above it (files of one project together, as one build); '-' checks
    standard input (--stdin-filename PATH: as the file PATH). Exit 1 if any error is found
    (or a warning, where werror is set)."""
    if stdin_filename is not None and files != (STDIN,):
        raise click.UsageError("--stdin-filename names what '-' (standard input) stands for: "
                               "give it with '-' as the only FILE")
    if STDIN in files and len(files) > 1:
        raise click.UsageError("'-' (standard input) cannot be combined with files")
    diagnostics: list[Diagnostic] = []
    failed = werror_failed = False
    known: dict[str, Sequence[str]] = {}
    setups: list[tuple[BuildSetup, dict[Path, str] | None]]
    if files == (STDIN,):
        setup, texts = _stdin_build(ctx, stdin_filename, project_file, target, word_order,
                                    temp_vars, allow_outside_includes, werror,
                                    fix or show_diff)
        if texts is None:
            sys.exit(EXIT_SOURCE_ERRORS)
        setups = [(setup, texts)]
    else:
        setups = [(setup, None) for setup in build_setups(
            ctx, files, project_file, target, word_order, temp_vars, allow_outside_includes,
            werror)]
        if fix or show_diff:
            if _fix_files([p for setup, _ in setups for p in setup.paths], show_diff):
                if show_diff:
                    sys.exit(EXIT_SOURCE_ERRORS)
            elif show_diff:
                return
    for setup, texts in setups:
        selection = choose(setup)
        found = without_ignored(selection.build(setup.options, texts).diagnostics,
                                setup.ignore)
        if texts is not None:  # standard input: its own findings, not its project's others
            found = [d for d in found if Path(d.span.file).resolve() in texts]
            known.update((d.span.file, texts[Path(d.span.file).resolve()].splitlines())
                         for d in found)
        diagnostics += found
        failed = failed or any(d.severity is Severity.ERROR for d in found) \
            or (setup.werror and bool(found))
        werror_failed = werror_failed or (setup.werror and bool(found))
    if fix and files == (STDIN,):
        style.report_diagnostics(diagnostics, known)  # standard output holds the text
        if diagnostics:
            style.echo_summary(diagnostics, werror_failed)
    elif fmt == "text":
        _report_text(diagnostics, output, werror_failed, known)
    else:
        from mplang.tools import report as render  # the machine-read formats only

        renderer = {"sarif": render.render_sarif, "github": render.render_github,
                    "gitlab": render.render_gitlab}.get(fmt)
        write_output(render.render_diagnostics_json(diagnostics) if renderer is None
                     else renderer(diagnostics), output)
    if failed:
        sys.exit(EXIT_SOURCE_ERRORS)


def _stdin_build(ctx: click.Context, name: str | None, project_file: Path | None,
                 target: str, word_order: str | None, temp_vars: range,
                 allow_outside_includes: bool, werror: bool, fix: bool
                 ) -> tuple[BuildSetup, dict[Path, str] | None]:
    """`mpc lint -`: the build standard input is checked in (as the file `name`), and the
    text standing for that file (None when it is no UTF-8: E105 reported). With
    `fix`, the fixed text is what is checked, and it is printed (or its diff)."""
    display = name or STDIN_NAME
    setup = stdin_setup(ctx, display, project_file, target, word_order, temp_vars,
                        allow_outside_includes, werror)
    text = decode_source(sys.stdin.buffer.read(), display)
    if text is None:
        return setup, None
    if fix:
        from mplang.tools.fix import fix_text

        fixed = fix_text(Path(display), text).text
        if ctx.params.get("show_diff"):
            from mplang.cli.rewrite import unified_diff

            click.echo(unified_diff(text, fixed, display, "fixed"), nl=False)
            sys.exit(EXIT_SOURCE_ERRORS if fixed != text else EXIT_OK)
        sys.stdout.flush()
        sys.stdout.buffer.write(fixed.encode("utf-8"))
        sys.stdout.buffer.flush()
        text = fixed
    # the loader looks a file up by the path as given; the filter below by resolved path
    return setup, {Path(display): text, Path(display).resolve(): text}


def _fix_files(paths: list[Path], show_diff: bool) -> bool:
    """Apply (or, with `show_diff`, print as diffs) the preferred fixes of every `.mp` file
    of `paths`; whether any file has a fix. A file that cannot be read or written is
    reported and left for the check that follows to report too."""
    from mplang.cli.rewrite import unified_diff, write_atomically
    from mplang.tools.fix import fix_text

    any_fixed = False
    for path in paths:
        if path.suffix.lower() != ".mp":
            continue  # native listings have no fixes
        try:
            text = path.read_bytes().decode("utf-8")  # line endings as they are
        except (OSError, UnicodeDecodeError):
            continue  # the check reports it (E102 / E105)
        fixed = fix_text(path, text)
        if fixed.text == text:
            continue
        any_fixed = True
        if show_diff:
            click.echo(unified_diff(text, fixed.text, str(path), "fixed"), nl=False)
            continue
        try:
            write_atomically(path, fixed.text.encode("utf-8"))
        except OSError as exc:
            raise OutputError(f"cannot write {path}: {exc.strerror or exc}") from None
        if not style.quiet():
            count = f"{fixed.applied} fix{'es' if fixed.applied != 1 else ''}"
            click.echo(f"mpc lint: fixed {path} ({count})", err=True)
    return any_fixed


def _report_text(diagnostics: list[Diagnostic], output: str | None, werror: bool,
                 known: dict[str, Sequence[str]]) -> None:
    """The text report: each diagnostic's gcc-style line with its source excerpt (coloured
    only on a terminal) on standard output or OUT, then the summary on standard error:
    `2 errors, 1 warning in 3 files`, or for a clean check `All checks passed` on a terminal
    and nothing in a pipe (a CI log or a script sees silence, as before)."""
    sources = style.SourceLines(dict(known))
    color = output is None and style.color_enabled(err=False)
    text = "".join(style.render_diagnostic(d, sources, color) + "\n" for d in diagnostics)
    if output is None:
        click.echo(text, nl=False, color=color)
    else:
        write_output(text, output)
    sys.stdout.flush()  # the report before the summary, where both reach one terminal
    if diagnostics:
        style.echo_summary(diagnostics, werror)
    elif style.is_terminal(sys.stderr):
        style.all_checks_passed()

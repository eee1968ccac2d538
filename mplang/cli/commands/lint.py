"""`mpc lint`: the compiler's checks alone, as text, JSON, SARIF, GitHub workflow commands or
GitLab Code Quality JSON; for the other controller
families (`.fbs`/`.csim` listings, `.mp` with their `--target`) their checks, reported the
same way."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mplang.cli import style
from mplang.cli.common import (
    EXIT_SOURCE_ERRORS,
    build_setups,
    guarded,
    project_option,
    with_common,
    write_output,
)
from mplang.cli.families import choose
from mplang.cli.shell import complete_paths
from mplang.lang.diagnostics import Diagnostic, Severity, without_ignored


@click.command("lint", short_help="Run every check without producing an image.")
@click.argument("files", nargs=-1, shell_complete=complete_paths)
@click.option("--format", "fmt",
              type=click.Choice(["text", "json", "sarif", "github", "gitlab"]), default="text",
              show_default=True, help="gcc-style lines, a JSON list, SARIF 2.1.0, GitHub "
              "workflow commands (annotations) or GitLab Code Quality JSON.")
@click.option("-o", "--output", default=None, metavar="OUT", shell_complete=complete_paths,
              help="Write the report here.")
@project_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], fmt: str, output: str | None,
            project_file: Path | None, target: str, word_order: str | None, temp_vars: range,
            allow_outside_includes: bool, werror: bool) -> None:
    """Check FILE... (without them, the sources of mpc.toml) without producing an image:
    .mp sources for --target, or FATEK .fbs / CSIM .csim listings. Each FILE is checked with
    the nearest mpc.toml above it (files of one project together, as one build). Exit 1 if
    any error is found (or a warning, where werror is set)."""
    from mplang.tools import report as render

    diagnostics: list[Diagnostic] = []
    failed = False
    for setup in build_setups(ctx, files, project_file, target, word_order, temp_vars,
                              allow_outside_includes, werror):
        selection = choose(setup)
        found = without_ignored(selection.build(setup.options).diagnostics, setup.ignore)
        diagnostics += found
        failed = failed or any(d.severity is Severity.ERROR for d in found) \
            or (setup.werror and bool(found))
    if fmt == "text":
        _report_text(diagnostics, output)
    else:
        renderer = {"sarif": render.render_sarif, "github": render.render_github,
                    "gitlab": render.render_gitlab}.get(fmt)
        write_output(render.render_diagnostics_json(diagnostics) if renderer is None
                     else renderer(diagnostics), output)
    if failed:
        sys.exit(EXIT_SOURCE_ERRORS)


def _report_text(diagnostics: list[Diagnostic], output: str | None) -> None:
    """The text report: each diagnostic's gcc-style line with its source excerpt (coloured
    only on a terminal) on standard output or OUT, then the summary on standard error:
    `2 errors, 1 warning in 3 files`, or for a clean check `All checks passed` on a terminal
    and nothing in a pipe (a CI log or a script sees silence, as before)."""
    sources = style.SourceLines()
    color = output is None and style.color_enabled(err=False)
    text = "".join(style.render_diagnostic(d, sources, color) + "\n" for d in diagnostics)
    if output is None:
        click.echo(text, nl=False, color=color)
    else:
        write_output(text, output)
    sys.stdout.flush()  # the report before the summary, where both reach one terminal
    if diagnostics:
        style.echo_summary(diagnostics)
    elif style.is_terminal(sys.stderr):
        style.all_checks_passed()

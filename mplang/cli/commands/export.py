"""`mpc export`: the host's view of a build (build id, programs, declared variables with
their registers, CONSTs, source lines) for host programs, HMIs and SCADA tag lists."""

from __future__ import annotations

from pathlib import Path

import click

from mplang.cli.common import (
    EXIT_SOURCE_ERRORS,
    InputError,
    build_setup,
    guarded,
    project_option,
    report,
    with_common,
    write_output,
)
from mplang.cli.families import choose
from mplang.cli.shell import complete_paths
from mplang.family.hostexport import EXPORT_FORMATS


@click.command("export", short_help="Write the host's view of a build (JSON, CSV, C, ...).")
@click.argument("files", nargs=-1, shell_complete=complete_paths)
@click.option("--format", "fmt", type=click.Choice(EXPORT_FORMATS), default="json",
              show_default=True, help="json: everything; csv: one row per tag (HMI/SCADA "
              "import); c: a header of #defines; python / csharp: constants.")
@click.option("-o", "--output", default=None, metavar="OUT", shell_complete=complete_paths,
              help="Write to OUT instead of standard output.")
@project_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], fmt: str, output: str | None,
            project_file: Path | None, target: str, word_order: str | None, temp_vars: range,
            allow_outside_includes: bool, werror: bool) -> None:
    """Write the host's view of the build of FILE... (.mp sources; default: the project's):
    its build id, each program's name, kind, slot and how to call it (write its number to
    holding register 8), each declared variable's name, device name, 0-based holding
    register (VARn: 300 + 2n), words, type, word order and access, the CONSTs, and the
    source line of each. Every format carries the build id, which `mpc flash` stores in the
    device: a host compares them at start (`mpc call`, `mpc var` and mplang.host do)."""
    import sys

    setup = build_setup(ctx, files, project_file, target, word_order, temp_vars,
                        allow_outside_includes, werror)
    selection = choose(setup)
    family = selection.family
    if family.host is None:
        raise click.UsageError(f"{family.TITLE}: {family.NO_HOST}")
    from mplang.family.hostview import HostError

    try:
        build, view = family.host.build_view(setup.paths, setup.options)
    except HostError as exc:
        raise InputError(str(exc)) from None
    code = report(build, setup.werror, setup.ignore)
    if code:
        sys.exit(EXIT_SOURCE_ERRORS)
    if not view.build_id:
        raise InputError("the build has no id")
    from mplang.family.hostexport import render

    write_output(render(view, fmt), output)

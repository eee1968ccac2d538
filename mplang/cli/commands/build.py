"""`mpc build`: compile sources into an image JSON, a listing, hex frames or a link map; for
the other controller families (`--target fbs-fun140|fbs-fun147|csim`, `.fbs`/`.csim` sources)
their checked programs in the family's own formats."""

from __future__ import annotations

from pathlib import Path

import click

from mplang.cli.common import (
    LazyChoice,
    build_setup,
    guarded,
    project_option,
    with_common,
    write_output,
)
from mplang.cli.families import all_formats, build_checked, check_format, choose
from mplang.cli.shell import complete_paths
from mplang.cli.style import quiet_option


@click.command("build", short_help="Compile sources into one download image.")
@click.argument("files", nargs=-1, shell_complete=complete_paths)
@click.option("-o", "--output", default=None, metavar="OUT", shell_complete=complete_paths,
              help="Write the result here ('-' or absent: standard output).")
@click.option("--format", "fmt", type=LazyChoice((), all_formats), default=None,
              help="M8194H: image JSON (the default), human listing, hex frames, the link "
              "map, or the map of declared variables (JSON, C header, Python module). FATEK: "
              "fbs (the default: the listing), listing, table (register table), json. CSIM: "
              "csim (the default: the script), listing, json.")
@project_option
@quiet_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], output: str | None, fmt: str | None,
            project_file: Path | None, target: str, word_order: str | None, temp_vars: range,
            allow_outside_includes: bool, werror: bool) -> None:
    """Compile FILE... (files, directories or globs; without them, the sources of mpc.toml)
    together into one download image, or, for a FATEK or CSIM target (or .fbs / .csim
    listings), into that controller's checked programs."""
    setup = build_setup(ctx, files, project_file, target, word_order, temp_vars,
                        allow_outside_includes, werror)
    selection = choose(setup)
    fmt = check_format(selection, fmt)
    build = build_checked(selection, setup)
    write_output(build.render(fmt), output)

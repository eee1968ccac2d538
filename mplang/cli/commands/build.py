"""`mpc build`: compile sources into an image JSON, a listing, hex frames or a link map."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mplang.cli.common import (
    build_setup,
    guarded,
    project_option,
    report,
    with_common,
    write_output,
)
from mplang.compiler import compile_paths


@click.command("build", short_help="Compile sources into one download image.")
@click.argument("files", nargs=-1)
@click.option("-o", "--output", default=None, metavar="OUT",
              help="Write the result here ('-' or absent: standard output).")
@click.option("--format", "fmt", type=click.Choice(["json", "listing", "hex", "map", "vars",
                                                   "vars-h", "vars-py"]),
              default="json", show_default=True, help="Image JSON, human listing, hex "
              "frames, the link map, or the map of declared variables (JSON, C header, "
              "Python module).")
@project_option
@with_common
@click.pass_context
@guarded
def command(ctx: click.Context, files: tuple[str, ...], output: str | None, fmt: str,
            project_file: Path | None, target: str, word_order: str | None, temp_vars: range,
            allow_outside_includes: bool, werror: bool) -> None:
    """Compile FILE... (files, directories or globs; without them, the sources of mpc.toml)
    together into one download image."""
    from mplang import output as render

    setup = build_setup(ctx, files, project_file, target, word_order, temp_vars,
                        allow_outside_includes, werror)
    result = compile_paths(setup.paths, setup.options)
    code = report(result, setup.werror)
    if code:
        sys.exit(code)
    text = {
        "json": lambda: render.render_json(result),
        "listing": lambda: render.render_listing(result, result.sources),
        "hex": lambda: render.render_hex(result),
        "map": lambda: render.render_link_map(result),
        "vars": lambda: render.render_variables_json(result),
        "vars-h": lambda: render.render_variables_c(result),
        "vars-py": lambda: render.render_variables_python(result),
    }[fmt]()
    write_output(text, output)

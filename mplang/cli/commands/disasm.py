"""`mpc disasm`: an image JSON back to `.mp` source that rebuilds to the same frames."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mplang.cli import style
from mplang.cli.common import (
    EXIT_NO_INPUT,
    EXIT_NOT_EXACT,
    guarded,
    parse_temps,
    write_output,
)
from mplang.cli.shell import complete_paths
from mplang.family.face import Family


@click.command("disasm", short_help="Turn an image JSON back into .mp source.")
@click.argument("image", metavar="IMAGE", shell_complete=complete_paths)
@click.option("-o", "--output", default=None, metavar="OUT", shell_complete=complete_paths,
              help="Write the source here ('-' or absent: standard output).")
@click.option("--temp-vars", callback=parse_temps, default=None, metavar="FIRST-LAST",
              help="VAR pool the image was built with [default: 500-511]; lines computed "
              "through it are folded back into expressions.")
@guarded
def command(image: str, output: str | None, temp_vars: range) -> None:
    """Disassemble IMAGE (as `mpc build` writes it) into .mp source.

    Every program is rebuilt from the text and compared frame for frame with the image;
    frames that cannot be carried over exactly are named on standard error (exit 14).
    """
    from mplang.family.face import BadImage

    path = Path(image)
    family = _image_family(path)
    if family.disassemble is None:
        raise click.UsageError(f"{image}: {family.TITLE} images cannot be disassembled: the "
                               "build's own listing is its source")
    try:
        result = family.disassemble(path, temp_vars)
    except BadImage as exc:
        style.error(str(exc))
        sys.exit(EXIT_NO_INPUT)
    except OSError as exc:
        style.error(f"{image}: cannot read: {exc.strerror or exc}")
        sys.exit(EXIT_NO_INPUT)
    write_output(result.text, output)
    for problem in result.problems:
        click.echo(f"{image}: warning: {problem}", err=True)
    if result.problems:
        style.error(f"{len(result.problems)} frame(s) or program(s) not carried over "
                    "exactly")
        sys.exit(EXIT_NOT_EXACT)


def _image_family(path: Path) -> Family:
    """The family an image names (`"target": {"family": TITLE}`, or a target's name); the
    first registered family when it names none or cannot be read (whose loader then says
    what is wrong)."""
    from mplang.family.registry import families, family_of_target, family_of_title
    from mplang.lang.limits import read_json_file

    try:
        data = read_json_file(path)
    except (OSError, ValueError):  # bad syntax or nested too deep: the loader says so
        data = None
    target = data.get("target") if isinstance(data, dict) else None
    found = None
    if isinstance(target, dict) and isinstance(target.get("family"), str):
        found = family_of_title(target["family"])
    elif isinstance(target, str):  # the other families write their target's name
        found = family_of_target(target)
    return found if found is not None else families()[0]

"""`mpc init [DIR]`: a new project, ready for `mpc build`, `mpc lint`, `mpc run` and
pre-commit with no further arguments, as `cargo new` and `uv init` start one.

Nothing is overwritten: when any of the files it would write is there already, the command
names them and writes none (exit 4, the output cannot be written), so running it twice, or in
a folder that holds a project, never loses work.
"""

from __future__ import annotations

import os
from pathlib import Path

import click

from mplang.cli.common import OutputError, guarded
from mplang.cli.shell import complete_paths
from mplang.cli.style import quiet, quiet_option

PROJECT_FILE = """\
# mpc.toml: the project file of mpc (docs/project.md has every key).
# `mpc build`, `mpc lint`, `mpc fmt`, `mpc run` and `mpc flash` run here without FILE
# arguments take their sources and settings from this file.

[project]
sources = ["src"]                    # files, directories (every .mp below) or globs
target = "et"                        # "et" (ET-M8194H, Modbus TCP) or "rs" (RS-M8194H)
# word-order = 0                     # leave out to follow the device when flashing
# temp-vars = "500-511"              # VAR pool for expression temporaries
# var-pool = "400-499"               # where unpinned `VAR name` declarations go
werror = false                       # true: warnings fail build and lint too

# [slots]                            # pin a program to a slot: name = slot
# main = "MP50"

# [targets.cell1]                    # a device for `mpc flash --to cell1`
# tcp = "192.168.0.16"               # HOST[:PORT], port 502 by default

[fmt]                                # options of `mpc fmt` (docs/fmt.md)
indent = 4

[lint]
ignore = []                          # warning codes silenced in every file (W102, ...)
"""

SAMPLE = """\
# main.mp: a first macro program. Try:
#   mpc build            the download image (JSON) on standard output
#   mpc run              run it on the virtual controller
#   mpc lint             every check, without an image
VAR cycles  # a declared variable: mpc places it in the project's VAR pool

MP main  # no number: the linker places it in the smallest slot that holds it
    SET_V X, 20000
    SET_A X, 100000
    cycles = 0
    FOR 3
        FIXED_MOVE X, 5000
        STOP_WAIT X
        FIXED_MOVE X, -5000
        STOP_WAIT X
        cycles = cycles + 1
    NEXT
END MP
"""

GITIGNORE = """\
# mpc's incremental-flash record and build output
.mpc/
*.image.json
"""

PRE_COMMIT = """\
# pre-commit (https://pre-commit.com): `pip install pre-commit && pre-commit install`.
# docs/editors.md of mplang explains the hooks; point `repo` at your copy of mplang.
repos:
  - repo: local
    hooks:
      - id: mpc-lint
        name: mpc lint
        entry: mpc lint
        language: system
        files: \\.mp$
        require_serial: true
      - id: mpc-fmt
        name: mpc fmt
        entry: mpc fmt
        language: system
        files: \\.mp$
"""

FILES = {"mpc.toml": PROJECT_FILE, "src/main.mp": SAMPLE, ".gitignore": GITIGNORE,
         ".pre-commit-config.yaml": PRE_COMMIT}
"""What a new project holds, by path inside DIR."""


@click.command("init", short_help="Start a new project (mpc.toml, a sample, pre-commit).")
@click.argument("directory", default=".", required=False, shell_complete=complete_paths)
@quiet_option
@guarded
def command(directory: str) -> None:
    """Start a project in DIRECTORY (created if missing; default: here): an mpc.toml with
    comments, src/main.mp, a .gitignore and a .pre-commit-config.yaml running mpc lint and
    mpc fmt. Existing files are never overwritten: if any is there, nothing is written
    (exit 4)."""
    root = Path(directory)
    if root.exists() and not root.is_dir():
        raise OutputError(f"{directory}: not a directory")
    present = [name for name in FILES if (root / name).exists() or (root / name).is_symlink()]
    if present:
        shown = ", ".join(os.path.normpath(root / name) for name in present)
        raise OutputError(f"{shown}: already there; mpc init writes nothing over existing "
                          "files (start the project in an empty or new directory)")
    written = []
    try:
        for name, text in FILES.items():
            path = root / name
            path.parent.mkdir(parents=True, exist_ok=True)
            with path.open("x", encoding="utf-8") as stream:  # "x": never over a file
                stream.write(text)
            written.append(path)
    except OSError as exc:
        raise OutputError(f"cannot write {exc.filename or directory}: "
                          f"{exc.strerror or exc}") from None
    if not quiet():
        where = os.path.normpath(directory)
        click.echo(f"mpc init: created {', '.join(os.path.normpath(p) for p in written)}",
                   err=True)
        if where != ".":
            click.echo(f"next: cd {where} && mpc build", err=True)
        else:
            click.echo("next: mpc build", err=True)

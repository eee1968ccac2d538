"""Shell completion: file names for the FILE arguments of every command, program names for
`--call` and the project's devices for `--to`."""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

import click

if TYPE_CHECKING:  # loaded only when a completion asks for them (every command names these
    # functions, few runs call them)
    from click.shell_completion import CompletionItem

    from mplang.tools.project import Project


def complete_paths(ctx: click.Context, param: click.Parameter,
                   incomplete: str) -> list[CompletionItem]:
    """Let the shell complete file and directory names. A shell_complete function rather
    than `type=click.Path()`, which would also stat every argument while parsing and so
    change what bad names report (and exit with)."""
    from click.shell_completion import CompletionItem

    return [CompletionItem(incomplete, type="file")]


_HEADER = r"^[ \t]*(MP|ISR)[ \t]+(?:(\d+)[ \t]+)?([A-Za-z_][A-Za-z0-9_]*)?"
"""A program's header line, compiled (by `re`'s own cache) when a completion first reads
one: every command imports this module, few runs complete."""
_MAX_SCANNED_BYTES = 1 << 20  # completion reads headers, not a build: a file at most this big


def _project() -> Project | None:
    """The mpc.toml above the working directory, or None (also when it cannot be read)."""
    from mplang.tools.project import ProjectError, find_project, load_project

    found = find_project(Path.cwd())
    if found is None:
        return None
    try:
        return load_project(found)
    except (ProjectError, OSError):
        return None


def _sources(ctx: click.Context) -> list[Path]:
    """The .mp files the command line names (files, folders), else the project's. While
    completing, click leaves FILE... in `ctx.args` (its parse stops at the option)."""
    named = [Path(f) for f in ctx.params.get("files") or ctx.args or ()]
    if not named:
        project = _project()
        named = list(project.sources) if project is not None else []
    found: list[Path] = []
    for path in named:
        if path.is_dir():
            found += sorted(path.rglob("*.mp"))[:200]
        elif path.suffix.lower() == ".mp":
            found.append(path)
    return found


def program_names(paths: list[Path]) -> list[tuple[str, str]]:
    """(name, description) of every program the files' headers declare: its name, and its
    `MPn` when it is numbered; read from the text, not compiled, so that completing stays
    instant (a program INCLUDEd from elsewhere is not offered)."""
    names: dict[str, str] = {}
    for path in paths:
        try:
            if not path.is_file() or path.stat().st_size > _MAX_SCANNED_BYTES:
                continue
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            continue
        for match in re.finditer(_HEADER, text, re.IGNORECASE | re.MULTILINE):
            kind, number, name = match.group(1).upper(), match.group(2), match.group(3)
            if kind != "MP":
                continue  # --call starts an MP; an ISR runs on its interrupt
            title = f"{kind}{number}" if number else "MP (auto-placed)"
            if name and name.upper() not in ("END",):
                names.setdefault(name, f"{title} in {path.name}")
            if number:
                names.setdefault(f"MP{number}", f"{name or 'unnamed'} in {path.name}")
    return sorted(names.items())


def complete_programs(ctx: click.Context, param: click.Parameter,
                      incomplete: str) -> list[CompletionItem]:
    """`--call`: the programs of the FILEs on the command line, else of the project."""
    from click.shell_completion import CompletionItem

    wanted = incomplete.upper()
    return [CompletionItem(name, help=about)
            for name, about in program_names(_sources(ctx))
            if name.upper().startswith(wanted)]


def complete_targets(ctx: click.Context, param: click.Parameter,
                     incomplete: str) -> list[CompletionItem]:
    """`--to`: the [targets.NAME] devices of the project's mpc.toml."""
    from click.shell_completion import CompletionItem

    project = _project()
    if project is None:
        return []
    return [CompletionItem(name, help=target.address())
            for name, target in project.targets.items() if name.startswith(incomplete)]

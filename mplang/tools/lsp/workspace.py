"""Which build an open document belongs to, and with which options, without pygls.

`mpc build` in a project (an `mpc.toml` in the file's directory or above it) compiles all the
project's sources together: a program may CALL one of another file by name, the linker places
every program of the project, and the project file's options and slot pins apply. A document
listed among those sources is checked the same way, so the editor agrees with `mpc build`.
Any other document is checked on its own, with its INCLUDEs, as `mpc build FILE` would.
Options given to `mpc lsp` on its command line win over the project file's.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mplang.m8194h.compiler import Options
from mplang.tools.project import ProjectError, find_project, load_project


@dataclass(frozen=True)
class Overrides:
    """Options given to `mpc lsp` itself; None leaves the choice to the project file."""

    target: str | None = None
    temps: range | None = None
    allow_outside_includes: bool | None = None


@dataclass(frozen=True)
class BuildContext:
    """The sources compiled with a document (in build order, the document among them) and the
    options of that build."""

    sources: tuple[Path, ...]
    options: Options
    project_file: Path | None = None
    problem: str = ""  # why the project file could not be used ("" if it could)


def _defaults(overrides: Overrides) -> Options:
    base = Options()
    return Options(target=overrides.target or base.target,
                   temps=base.temps if overrides.temps is None else overrides.temps,
                   allow_outside_includes=bool(overrides.allow_outside_includes))


def context_for(document: Path, overrides: Overrides | None = None) -> BuildContext:
    """The build `document` is checked in: its project's, or its own."""
    overrides = overrides or Overrides()
    alone = (document,)
    found = find_project(document.parent)
    if found is None:
        return BuildContext(alone, _defaults(overrides))
    try:
        project = load_project(found)
    except ProjectError as exc:
        return BuildContext(alone, _defaults(overrides), found,
                            f"{exc} (checked without the project file)")
    sources = tuple(p.resolve() for p in project.sources)
    in_project = document.resolve() in sources
    base = Options()
    options = Options(
        target=overrides.target or project.target or base.target,
        word_order=project.word_order,
        temps=overrides.temps if overrides.temps is not None else
        project.temp_vars if project.temp_vars is not None else base.temps,
        allow_outside_includes=overrides.allow_outside_includes
        if overrides.allow_outside_includes is not None
        else bool(project.allow_outside_includes),
        # Pins name programs of the project's sources: only that build can satisfy them.
        pins=project.pins if in_project else (),
        var_pool=project.var_pool if project.var_pool is not None else base.var_pool)
    return BuildContext(sources if in_project else alone, options, found)

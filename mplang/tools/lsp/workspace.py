"""Which build an open document belongs to, and with which options, without pygls.

`mpc build` in a project (an `mpc.toml` in the file's directory or above it) compiles all the
project's sources together: a program may CALL one of another file by name, the linker places
every program of the project, and the project file's options and slot pins apply. A document
listed among those sources is checked the same way, so the editor agrees with `mpc build`.
Any other document is checked on its own, with its INCLUDEs, as `mpc build FILE` would.
Options given to `mpc lsp` on its command line win over the project file's.

The server reads from disk only what it can read safely (`read_text`): regular files of at most
`MAX_FILE_BYTES`, never a device, FIFO or socket, which could block the server or feed it
without end.
"""

from __future__ import annotations

import errno
import os
import stat
from dataclasses import dataclass
from pathlib import Path

from mplang.ir.unit import Options
from mplang.tools.fmt import FormatOptions
from mplang.tools.project import ProjectError, find_project, load_project

# The largest file the server reads from disk: .mp sources are a few KiB; anything near this is
# not a macro program, and reading it would only cost memory and time.
MAX_FILE_BYTES = 1024 * 1024
LIMIT_TEXT = f"{MAX_FILE_BYTES / 2**20:g} MiB"
_CHUNK = 64 * 1024
# O_NONBLOCK: should a FIFO take the place of a checked file, opening it does not wait for a
# writer. O_NOCTTY: a terminal never becomes the server's. O_BINARY (Windows): bytes as stored.
_OPEN_FLAGS = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | \
    getattr(os, "O_BINARY", 0)


class RefusedFile(OSError):
    """A file the server will not read (not a regular file, or too large)."""

    def __init__(self, path: Path, reason: str) -> None:
        super().__init__(f"cannot read {path}: {reason}")
        self.path = path
        self.reason = reason


def refusal(info: os.stat_result) -> str | None:
    """Why a file with this status is not read, or None when it may be."""
    if not stat.S_ISREG(info.st_mode):
        return "not a regular file"
    if info.st_size > MAX_FILE_BYTES:
        return f"larger than {LIMIT_TEXT} ({info.st_size} bytes)"
    return None


def read_text(path: Path) -> str:
    """A file's text as `Path.read_text` gives it (UTF-8, universal newlines), read only when
    it is a regular file of at most MAX_FILE_BYTES: checked with stat before it is opened,
    with fstat once open, and never more than the limit read. Raises RefusedFile, OSError
    (missing, unreadable) or UnicodeDecodeError."""
    info = os.stat(path)
    if stat.S_ISDIR(info.st_mode):  # as open() fails on it, so the loader's message stays
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(path))
    reason = refusal(info)
    if reason is not None:
        raise RefusedFile(path, reason)
    handle = os.open(path, _OPEN_FLAGS)
    try:
        reason = refusal(os.fstat(handle))  # the file may have changed since the stat
        if reason is not None:
            raise RefusedFile(path, reason)
        data = bytearray()
        while len(data) <= MAX_FILE_BYTES:
            chunk = os.read(handle, min(_CHUNK, MAX_FILE_BYTES + 1 - len(data)))
            if not chunk:
                break
            data += chunk
    finally:
        os.close(handle)
    if len(data) > MAX_FILE_BYTES:  # it grew after the fstat
        raise RefusedFile(path, f"larger than {LIMIT_TEXT}")
    return data.decode("utf-8").replace("\r\n", "\n").replace("\r", "\n")


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
    ignore: frozenset[str] = frozenset()  # the project's [lint] ignore, as mpc lint reads it


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
        reason = refusal(os.stat(found))
    except OSError as exc:
        reason = exc.strerror or str(exc)
    if reason is not None:  # find_project saw a regular file; a huge one is not read
        return BuildContext(alone, _defaults(overrides), found,
                            f"cannot read {found}: {reason} (checked without the project "
                            "file)")
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
    return BuildContext(sources if in_project else alone, options, found,
                        ignore=project.ignore)


def format_options_for(document: Path) -> FormatOptions:
    """The `[fmt]` settings of the document's project, as `mpc fmt` reads them (the nearest
    `mpc.toml` above the document), else the formatter's defaults. Raises ProjectError or
    FormatOptionsError when the project file cannot be used, so nothing is reformatted with
    settings the project did not ask for."""
    found = find_project(document.parent)
    if found is None:
        return FormatOptions()
    reason = refusal(os.stat(found))
    if reason is not None:
        raise RefusedFile(found, reason)
    project = load_project(found)
    return FormatOptions.from_mapping(project.fmt, where=f"{found} [fmt]")

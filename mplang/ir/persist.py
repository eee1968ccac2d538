"""Program lowerings kept across runs, so that `mpc build` after an edit lowers only the
programs the edit changed (`mplang.ir.reuse` does the same within one process).

A program's entry holds what `reuse.Lowered` keeps: its macro lines, its diagnostics and
what a back end derived from it (W111 warnings, frames, each with the key it was made for).
It is found by a key of everything its lowering reads: the program's text (the lines from
its header to its end, by number and file name) and the build's context
(`reuse.lowering_context`: CONST values, ALIASes, placement, the programs' names, the
options), with the caller's `salt` (the catalogue, the code that lowers, encodes and warns)
and mpc's and Python's version (`caches.STAMP`). The key names the entry's file and heads it,
and is compared before the entry is unpickled (`caches.load`). Entries live in the user
cache dir (`lowered/`), written under a fresh name and renamed into place, so builds side
by side never read half of one; a damaged, truncated or foreign entry is a miss, lowered
again and replaced. `--no-cache` and `MPLANG_CACHE=off` turn the store off with the other
caches. The directory stays bounded: past `LIMIT` entries the oldest ones (by the time
they were written) that this build did not use are deleted.
"""

from __future__ import annotations

import contextlib
import io
import os
import pickle
from collections.abc import Callable, Hashable, Iterable
from pathlib import Path

from mplang.ir.catalogue import Catalogue, Command
from mplang.ir.macro import LoweredProgram
from mplang.ir.reuse import Context, Lowered, Lowerings
from mplang.ir.scope import Scope
from mplang.lang import ast, caches
from mplang.lang.diagnostics import DiagnosticSink

FORMAT = "lowered 1"
"""Part of every key: change it when what an entry holds changes shape."""

LIMIT = 4096
"""Entries kept at most (a full device is 177 programs; each edit adds one or a few)."""


def code_key(directories: Iterable[Path]) -> str:
    """A digest of the modules and data files (`.py`, `.toml`) in `directories`, by name,
    size and time of change: part of `salt`, so an entry made by other code or from another
    catalogue is never read (an edited file is a miss; its content is not read: reading
    the dozens of modules that lower, warn and encode would cost more than a build saves).
    An install without sources is covered by mpc's version (`caches.STAMP`)."""
    parts: list[str] = []
    for directory in directories:
        try:
            with os.scandir(directory) as found:
                for item in found:
                    if item.name.endswith((".py", ".toml")):
                        stat = item.stat()
                        parts.append(f"{item.path} {stat.st_size} {stat.st_mtime_ns}")
        except OSError:
            parts.append(f"{directory} unreadable")
    return caches.digest(*sorted(parts))


def _stable(value: object) -> str:
    """A text of a context part that is the same in every process for equal values: sets
    sorted (their order follows hashing), the catalogue left out (the salt stands for it)."""
    if isinstance(value, Catalogue):
        return "catalogue"
    if isinstance(value, frozenset | set):
        return "{" + ", ".join(sorted(_stable(v) for v in value)) + "}"
    if isinstance(value, tuple | list):
        return "(" + ", ".join(_stable(v) for v in value) + ")"
    return repr(value)


class _Pickler(pickle.Pickler):
    """Pickles an entry with each catalogue command as its index (an entry is read back
    only with the same catalogue: the salt), so the commands are not copied into it."""

    def __init__(self, stream: io.BytesIO, index: dict[int, int]) -> None:
        super().__init__(stream, protocol=pickle.HIGHEST_PROTOCOL)
        self.index = index

    def persistent_id(self, obj: object) -> int | None:
        if type(obj) is Command:
            return self.index[id(obj)]
        return None


class _Unpickler(pickle.Unpickler):
    def __init__(self, stream: io.BytesIO, commands: tuple[Command, ...]) -> None:
        super().__init__(stream)
        self.commands = commands

    def persistent_load(self, pid: object) -> Command:
        if type(pid) is not int or not 0 <= pid < len(self.commands):
            raise pickle.UnpicklingError("no such command")
        return self.commands[pid]


class StoredLowerings(Lowerings):
    """`reuse.Lowerings` for one build of a process that also reads and writes the disk
    store (`mpc build`, `lint`, `run`, ...): a program its memory does not hold is looked up
    on disk before it is lowered; `save`, once the build is over (its back end has derived
    what it derives), writes what was made or derived anew."""

    def __init__(self, directory: Path, sources: dict[str, list[str]], salt: str) -> None:
        super().__init__()
        self.directory = directory / "lowered"
        self.sources = sources  # each file's lines by display name: the programs' texts
        self.salt = salt
        self._build_key: str | None = None
        self._commands: tuple[Command, ...] = ()
        self._used: list[tuple[str, Lowered, dict[str, Hashable] | None]] = []

    def start(self, context: Context) -> None:
        super().start(context)
        self._build_key = None  # made with the scope, at the first program
        self._used = []

    def lower(self, program: ast.Program, scope: Scope, sink: DiagnosticSink,
              lower: Callable[[], LoweredProgram | None]) -> LoweredProgram | None:
        key = self._key(program, scope)
        loaded: dict[str, Hashable] | None = None
        if key is not None and self.recall(program.span) is None:
            found = self._load(key, program)
            if found is not None:
                self.keep(found)
                loaded = _derived_keys(found)
        copy = super().lower(program, scope, sink, lower)
        entry = self.recall(program.span)
        if key is not None and entry is not None:
            self._used.append((key, entry, loaded))
        return copy

    def _key(self, program: ast.Program, scope: Scope) -> str | None:
        """The key of the program's entry, or None when its text is not known."""
        lines = self.sources.get(program.span.file)
        first, last = program.span.line, program.end_span.line
        if lines is None or not 1 <= first <= last <= len(lines):
            return None
        if self._build_key is None:
            self._commands = scope.catalogue.commands
            # beside the context, where the CONSTs and ALIASes are written (a diagnostic
            # may point at them)
            self._build_key = caches.digest(
                FORMAT, self.salt, _stable(self.context),
                _stable(tuple(scope.const_exprs.items())),
                _stable(tuple(sorted(scope.alias_spans.items()))))
        return caches.digest(self._build_key, program.span.file, str(first),
                             "\n".join(lines[first - 1:last]))

    def _load(self, key: str, program: ast.Program) -> Lowered | None:
        """The entry stored under `key`, as `program`'s lowering; None when absent or
        unreadable."""
        found = caches.load(self.directory / f"{key}.pickle", key)
        if type(found) is not bytes:
            return None
        try:
            entry = _Unpickler(io.BytesIO(found), self._commands).load()
            result, diagnostics, derived = entry
            if not (result is None or type(result) is LoweredProgram) or \
                    type(diagnostics) is not list or type(derived) is not dict:
                return None
            return Lowered(program, result, diagnostics, derived)
        except Exception:  # a damaged entry of the right key: lowered again
            return None

    def save(self) -> None:
        """Write the entries this build made, or gave a derived value they lacked; then
        keep the store within `LIMIT`. Silently nothing where the directory cannot be
        written."""
        index = {id(command): n for n, command in enumerate(self._commands)}
        wrote = False
        for key, entry, loaded in self._used:
            if loaded is not None and loaded == _derived_keys(entry):
                continue
            stream = io.BytesIO()
            try:
                _Pickler(stream, index).dump((entry.result, entry.diagnostics, entry.derived))
            except Exception:  # something unpicklable: this program is lowered next time
                continue
            caches.store(self.directory / f"{key}.pickle", key, stream.getvalue())
            wrote = True
        if wrote:
            self._evict({f"{key}.pickle" for key, _, _ in self._used})

    def _evict(self, used: set[str]) -> None:
        """Past `LIMIT` entries, delete the oldest this build did not use, down to three
        quarters of it (so that not every build past the limit deletes)."""
        try:
            with os.scandir(self.directory) as found:
                entries = [(e.stat().st_mtime_ns, e.name) for e in found
                           if e.name.endswith(".pickle")]
        except OSError:
            return
        if len(entries) <= LIMIT:
            return
        entries.sort()
        for _, name in entries[:len(entries) - LIMIT * 3 // 4]:
            if name not in used:
                with contextlib.suppress(OSError):
                    os.unlink(self.directory / name)


def _derived_keys(entry: Lowered) -> dict[str, Hashable]:
    """The kinds and keys of what was derived from an entry: changed, it is written again."""
    return {kind: key for kind, (key, _) in entry.derived.items()}

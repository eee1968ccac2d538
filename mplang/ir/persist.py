"""Program lowerings kept across runs, so that `mpc build` after an edit lowers only the
programs the edit changed (`mplang.ir.reuse` does the same within one process).

A program's entry holds what `reuse.Lowered` keeps: its macro lines, its diagnostics and
what a back end derived from it (W111 warnings, frames, each with the key it was made for).
It is found by a key of everything its lowering reads: the program's text (the lines from
its header to its end, by number and file name) and the build's context
(`reuse.lowering_context`: CONST values, ALIASes, placement, the programs' names, the
options), with the caller's `salt` (the catalogue, the code that lowers, encodes and warns)
and mpc's and Python's version (`caches.STAMP`). An entry is held flat (tuples of numbers
and strings, each catalogue command as its index) and made into records again when read:
that unpickles several times faster.

The entries of one source file's programs live in one pack (`lowered/`, a file per source
file and directory it is built from), read in one go at the file's first program: a full
device is one file read, not 177 opened. A pack maps each entry's key to its pickle, and
a program's entry is unpickled only when its key is there; a damaged pack, or entry, is a
miss, lowered again. A build that made or changed an entry writes the file's pack again
whole (the entries it used, the unchanged ones as the bytes it read, then up to as many
of the earlier ones, so that undoing an edit finds them), under a fresh name renamed into
place, so builds side by side never read half of one. `--no-cache` and `MPLANG_CACHE=off`
turn the store off with the other caches. The directory stays bounded: past `LIMIT`
packs the oldest ones (by the time they were written) that this build did not use are
deleted.
"""

from __future__ import annotations

import contextlib
import os
import pickle
from collections.abc import Callable, Hashable, Iterable
from pathlib import Path
from typing import Any

from mplang.ir.blockmemo import Statements
from mplang.ir.catalogue import Catalogue, Command
from mplang.ir.macro import (
    BVarRef,
    CallSite,
    LoweredProgram,
    MacroLine,
    Operand,
    ProgramRef,
    VarRef,
)
from mplang.ir.reuse import Context, Lowered, Lowerings
from mplang.ir.scope import Scope
from mplang.lang import ast, caches
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Severity, Span, make_span
from mplang.lang.digest import sha256

FORMAT = "lowered 4"
"""Part of every key: change it when what an entry holds changes shape."""

LIMIT = 512
"""Packs kept at most: source files built, each holding its programs' entries."""


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


class _Unstorable(Exception):
    """A value an entry cannot hold in its flat form: that program is not stored."""


SpanTuple = tuple[str, int, int, int | None]


def _span_out(span: Span) -> SpanTuple:
    return (span.file, span.line, span.col, span.end_col)


def _operand_out(operand: object) -> object:
    """An operand as an entry holds it: numbers as they are, references as tagged tuples
    (an operand is never a tuple)."""
    kind = type(operand)
    if kind is int or kind is float:
        return operand
    if kind is VarRef:
        return ("V", operand.index)  # type: ignore[attr-defined]
    if kind is BVarRef:
        return ("B", operand.index)  # type: ignore[attr-defined]
    if kind is ProgramRef:
        return ("P", operand.name, operand.slot)  # type: ignore[attr-defined]
    raise _Unstorable


def _operands_out(operands: tuple[Operand, ...]) -> tuple[Operand, ...] | list[object]:
    """A line's operands: the tuple itself when all are numbers (most lines), else a list
    of each as `_operand_out` holds it (a list: `_entry_in` tells the two apart)."""
    if all(type(o) is int or type(o) is float for o in operands):
        return operands
    return [_operand_out(o) for o in operands]


def _operand_in(held: Any) -> Operand:
    if type(held) is not tuple:
        number: int | float = held
        return number
    if held[0] == "V":
        return VarRef(held[1])
    if held[0] == "B":
        return BVarRef(held[1])
    return ProgramRef(held[1], held[2])


def _diagnostic_out(item: Diagnostic) -> tuple[object, ...]:
    return (item.code, item.severity.value, item.message, _span_out(item.span), item.hint,
            tuple((_span_out(span), note) for span, note in item.related))


_SEVERITIES = {severity.value: severity for severity in Severity}


def _diagnostic_in(held: tuple[Any, ...]) -> Diagnostic:
    """A diagnostic as `Diagnostic(...)` makes it, its fields filled in directly (the
    frozen dataclass's `__init__` sets each through `object.__setattr__`: most of the cost
    of reading an entry back)."""
    code, severity, message, span, hint, related = held
    made: Diagnostic = object.__new__(Diagnostic)
    fields = made.__dict__
    fields["code"] = code
    fields["severity"] = _SEVERITIES[severity]
    fields["message"] = message
    fields["span"] = make_span(*span)
    fields["hint"] = hint
    fields["related"] = tuple((make_span(*at), note) for at, note in related) if related \
        else ()
    return made


def _entry_out(entry: Lowered, index: dict[int, int]) -> tuple[object, ...]:
    """An entry in its flat form: tuples of numbers and strings, which unpickle several
    times faster than the records they stand for (each made again in `_entry_in`)."""
    result = entry.result
    program = None if result is None else (
        result.kind, result.slot, result.name, result.source, _span_out(result.span),
        _span_out(result.end_span),
        [(index[id(line.command)], _operands_out(line.operands), _span_out(line.span))
         for line in result.lines],
        [(("P", call.target.name, call.target.slot), _span_out(call.span))
         for call in result.calls])
    derived = {kind: (pickle.dumps(key, pickle.HIGHEST_PROTOCOL), _value_out(value))
               for kind, (key, value) in entry.derived.items()}
    return (program, [_diagnostic_out(d) for d in entry.diagnostics], derived)


def _value_out(value: object) -> tuple[str, object]:
    """A derived value: a list of diagnostics flat, anything else (frames, the programs
    a program names) as it is."""
    if isinstance(value, list) and value and all(type(d) is Diagnostic for d in value):
        return ("D", [_diagnostic_out(d) for d in value])
    return ("O", value)


def _entry_in(held: Any, program: ast.Program, commands: tuple[Command, ...],
              keys: dict[bytes, Hashable]) -> Lowered:
    """The entry `_entry_out` made, as `program`'s lowering (any damage raises). A derived
    value's key is held pickled, and read once per build however many entries hold it
    (`keys`): the W111 key holds the device's chip rules, the same for every program."""
    flat, diagnostics, derived = held
    result = None
    if flat is not None:
        kind, slot, name, source, span, end_span, lines, calls = flat
        result = LoweredProgram(
            kind, slot, name, source, make_span(*span), make_span(*end_span),
            [MacroLine(commands[command], operands if type(operands) is tuple
                       else tuple(map(_operand_in, operands)), make_span(*at))
             for command, operands, at in lines],
            [CallSite(ProgramRef(target[1], target[2]), make_span(*at))
             for target, at in calls])
    kept: dict[str, tuple[Hashable, object]] = {}
    for kind_name, (pickled, (tag, value)) in derived.items():
        if pickled in keys:
            key = keys[pickled]
        else:
            key = keys[pickled] = pickle.loads(pickled)
        kept[kind_name] = (key, [_diagnostic_in(d) for d in value] if tag == "D" else value)
    return Lowered(program, result, [_diagnostic_in(d) for d in diagnostics], kept)


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
        self._keys: dict[bytes, Hashable] = {}  # derived values' keys, by their pickle
        self._packs: dict[str, dict[str, bytes]] = {}  # each file's pack, as read
        self._used: list[tuple[str, Lowered, dict[str, Hashable] | None]] = []

    def start(self, context: Context) -> None:
        super().start(context)
        self._build_key = None  # made with the scope, at the first program
        self._used = []

    def lower(self, program: ast.Program, scope: Scope, sink: DiagnosticSink,
              lower: Callable[[Statements | None], LoweredProgram | None]
              ) -> LoweredProgram | None:
        key = self._key(program, scope)
        loaded: dict[str, Hashable] | None = None
        if key is not None and self.recall(program.span) is None:
            found = self._load(key, program, self._pack(program.span.file))
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

    def _pack(self, file: str) -> dict[str, bytes]:
        """The pack of `file`'s programs, read at its first program ({} when absent or
        damaged: every program of the file is then lowered)."""
        pack = self._packs.get(file)
        if pack is None:
            pack = self._packs[file] = read_pack(self._pack_path(file)) or {}
        return pack

    def _pack_path(self, file: str) -> Path:
        """Where `file`'s pack lives: named by the file as diagnostics show it and the
        directory it is built from (two projects' `main.mp` apart)."""
        name = sha256(f"{os.getcwd()}\0{file}".encode("utf-8", "surrogatepass")
                              ).hexdigest()[:32]
        return self.directory / f"{name}.pack"

    def _load(self, key: str, program: ast.Program, pack: dict[str, bytes]
              ) -> Lowered | None:
        """The entry stored under `key`, as `program`'s lowering; None when absent or
        unreadable."""
        held = pack.get(key)
        if held is None:
            return None
        try:
            return _entry_in(pickle.loads(held), program, self._commands, self._keys)
        except Exception:  # a damaged entry of the right key: lowered again
            return None

    def save(self) -> None:
        """Write again the pack of each file where this build made an entry, or gave one a
        derived value it lacked; then keep the store within `LIMIT`. Silently nothing where
        the directory cannot be written."""
        index = {id(command): n for n, command in enumerate(self._commands)}
        made: dict[str, dict[str, bytes]] = {}  # each file's entries this build used
        changed: set[str] = set()
        for key, entry, loaded in self._used:
            file = entry.program.span.file
            entries = made.setdefault(file, {})
            if loaded is not None and loaded == _derived_keys(entry):
                entries[key] = self._pack(file)[key]  # as read: not pickled again
                continue
            try:
                entries[key] = pickle.dumps(_entry_out(entry, index), pickle.HIGHEST_PROTOCOL)
            except (_Unstorable, KeyError):  # an operand or command of another kind
                continue
            changed.add(file)
        for file in changed:
            entries = made[file]
            kept = len(entries)
            for key, held in self._pack(file).items():  # earlier ones, up to as many again
                if len(entries) >= 2 * kept:
                    break
                entries.setdefault(key, held)
            caches.store(self._pack_path(file), PACK_KEY, entries)
        if changed:
            self._evict({self._pack_path(file).name for file in made})

    def _evict(self, used: set[str]) -> None:
        """Past `LIMIT` packs, delete the oldest this build did not use, down to three
        quarters of it (so that not every build past the limit deletes). The scratch files
        of writers that never renamed theirs (killed), and the entries of an earlier mpc
        (one file each), count as packs: they go as old."""
        try:
            with os.scandir(self.directory) as found:
                entries = [(e.stat().st_mtime_ns, e.name) for e in found
                           if e.name.endswith((".pack", ".pickle", ".tmp"))]
        except OSError:
            return
        if len(entries) <= LIMIT:
            return
        entries.sort()
        for _, name in entries[:len(entries) - LIMIT * 3 // 4]:
            if name not in used:
                with contextlib.suppress(OSError):
                    os.unlink(self.directory / name)


PACK_KEY = caches.digest(FORMAT)
"""The key heading every pack: a pack of another format, mpc or Python is not unpickled."""


def read_pack(path: Path) -> dict[str, bytes] | None:
    """The entries of the pack at `path` (each key's pickle), or None when it is absent,
    damaged or of another format."""
    found = caches.load(path, PACK_KEY)
    if not isinstance(found, dict) or not all(
            type(key) is str and type(held) is bytes for key, held in found.items()):
        return None
    return found


def _derived_keys(entry: Lowered) -> dict[str, Hashable]:
    """The kinds and keys of what was derived from an entry: changed, it is written again."""
    return {kind: key for kind, (key, _) in entry.derived.items()}

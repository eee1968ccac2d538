"""Diagnostics: every problem carries a stable code, a source span and, where possible, a hint.

The rule registry (code -> title, severity, explanation) lives in `mplang.lang.rules`, the
severities below both in `mplang.lang.severity`; this module holds the objects that flow
through the compiler, the way they are rendered, and the `# mpc: ignore` comment.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from operator import attrgetter
from typing import NoReturn

from mplang.lang.record import FrozenRecord
from mplang.lang.rules import RULES
from mplang.lang.severity import Severity as Severity

# `# mpc: ignore[W107]` (or `# mpc: ignore` for every warning) on a line silences warnings
# reported on that line. Errors cannot be silenced: the device would reject the program.
SUPPRESS = re.compile(r"mpc:\s*ignore(?:\[([A-Za-z0-9,\s]+)\])?")


class Span(FrozenRecord):
    """A place in a source file: 1-based line and column, end column exclusive. Frozen,
    hashable and ordered by its fields as `@dataclass(frozen=True, order=True)` made it,
    written out (see `mplang.lang.record`); compared and hashed by an explicit tuple, as the
    front end keys caches by it."""

    file: str
    line: int
    col: int
    end_col: int | None
    _fields = __match_args__ = ("file", "line", "col", "end_col")

    def __init__(self, file: str, line: int, col: int = 1, end_col: int | None = None) -> None:
        self.__dict__.update(file=file, line=line, col=col, end_col=end_col)

    def _key(self) -> tuple[str, int, int, int | None]:
        return (self.file, self.line, self.col, self.end_col)

    # Compared with a Span only (no subclass exists); ordered as the dataclass was, so two
    # spans on one column, one with and one without an end column, do not order.
    def __eq__(self, other: object) -> bool:
        if isinstance(other, Span):  # spelt out: spans are compared and hashed wherever trees are
            return (self.file == other.file and self.line == other.line and self.col == other.col
                    and self.end_col == other.end_col)
        return NotImplemented

    def __hash__(self) -> int:  # type: ignore[override]  # Record's is None
        return hash((self.file, self.line, self.col, self.end_col))

    def __lt__(self, other: object) -> bool:
        return self._key() < other._key() if isinstance(other, Span) else NotImplemented

    def __le__(self, other: object) -> bool:
        return self._key() <= other._key() if isinstance(other, Span) else NotImplemented

    def __gt__(self, other: object) -> bool:
        return self._key() > other._key() if isinstance(other, Span) else NotImplemented

    def __ge__(self, other: object) -> bool:
        return self._key() >= other._key() if isinstance(other, Span) else NotImplemented

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"


_new = object.__new__


def make_span(file: str, line: int, col: int = 1, end_col: int | None = None) -> Span:
    """`Span(file, line, col, end_col)`, filled in without a call to `__init__`: the parser
    makes one per token, the statement cache one per moved span."""
    made: Span = _new(Span)
    fields = made.__dict__
    fields["file"] = file
    fields["line"] = line
    fields["col"] = col
    fields["end_col"] = end_col
    return made


class Diagnostic(FrozenRecord):
    """One problem found in the sources. Frozen, hashable and compared by its fields as
    `@dataclass(frozen=True)` made it, written out on `mplang.lang.record` (a whole
    device's check makes and compares tens of thousands); pickled as the dataclass was
    (its fields in `__dict__`, in this order: the front cache stores syntax diagnostics)."""

    code: str
    severity: Severity
    message: str
    span: Span
    hint: str
    related: tuple[tuple[Span, str], ...]
    _fields = __match_args__ = ("code", "severity", "message", "span", "hint", "related")

    def __init__(self, code: str, severity: Severity, message: str, span: Span,
                 hint: str = "", related: tuple[tuple[Span, str], ...] = ()) -> None:
        self.__dict__.update(code=code, severity=severity, message=message, span=span,
                             hint=hint, related=related)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Diagnostic):  # no subclass exists; compared field by field
            return (self.code == other.code and self.severity == other.severity
                    and self.message == other.message and self.span == other.span
                    and self.hint == other.hint and self.related == other.related)
        return NotImplemented

    def __hash__(self) -> int:  # type: ignore[override]  # Record's is None
        return hash((self.code, self.severity, self.message, self.span, self.hint,
                     self.related))

    def render(self) -> str:
        """gcc-style one-liner, plus the hint on its own line."""
        text = f"{self.span}: {self.severity.value}[{self.code}]: {self.message}"
        for span, note in self.related:
            text += f"\n{span}: note: {note}"
        if self.hint:
            text += f"\n    hint: {self.hint}"
        return text

    def sort_key(self) -> tuple[str, int, int, str]:
        return (self.span.file, self.span.line, self.span.col, self.code)


_SORT_KEY = attrgetter("span.file", "span.line", "span.col", "code")
"""`Diagnostic.sort_key`, read in C (a whole device's check sorts thousands)."""
_SAME_KEY = attrgetter("code", "span.file", "span.line", "span.col", "span.end_col", "message")
"""What makes two diagnostics the same one for a sink: code, span and message, as a flat
tuple read and hashed in C (equal exactly when code, `Span` and message are)."""


class Run(list[Diagnostic]):
    """Diagnostics a build keeps for the next (a program's, as lowered or as a back end
    judged it), added to later builds' sinks whole: its sink keys and sort keys are made
    once, on its first build. A list that refuses change, so they never go stale."""

    __slots__ = ("_keys", "_order")

    def __init__(self, diagnostics: Iterable[Diagnostic] = ()) -> None:
        super().__init__(diagnostics)
        self._keys: frozenset[tuple[str, str, int, int, int | None, str]] | None = None
        self._order: list[tuple[str, int, int, str]] | None = None

    def keys(self) -> frozenset[tuple[str, str, int, int, int | None, str]] | None:
        """What a sink tells these diagnostics apart by; None when two of them are the same
        one (the run then enters one by one, as `add` would take it)."""
        if self._keys is None:
            self._keys = frozenset(map(_SAME_KEY, self))
        return self._keys if len(self._keys) == len(self) else None

    def sort_keys(self) -> list[tuple[str, int, int, str]]:
        """Each diagnostic's `Diagnostic.sort_key`, made once (a sink sorts every build)."""
        if self._order is None:
            self._order = list(map(_SORT_KEY, self))
        return self._order

    def _refuse(self, *args: object, **kwargs: object) -> NoReturn:
        raise TypeError("a kept run of diagnostics is not changed: copy it to a list")

    append = extend = insert = pop = remove = clear = sort = reverse = _refuse
    __setitem__ = __delitem__ = __iadd__ = __imul__ = _refuse

    def __reduce__(self) -> tuple[type[Run], tuple[list[Diagnostic]]]:
        return (Run, (list(self),))  # the keys are made again where it is loaded


class DiagnosticSink:
    """Collects diagnostics; the compiler never stops at the first problem."""

    def __init__(self) -> None:
        self.items: list[Diagnostic] = []
        self._seen: set[tuple[str, str, int, int, int | None, str]] = set()
        self._runs: list[tuple[int, Run]] = []  # runs that entered whole, where they start

    def add(self, code: str, span: Span, message: str, hint: str = "",
            related: tuple[tuple[Span, str], ...] = ()) -> None:
        key = (code, span.file, span.line, span.col, span.end_col, message)
        if key in self._seen:
            return
        self._seen.add(key)
        self.items.append(Diagnostic(code, RULES[code].severity, message, span, hint, related))

    def extend(self, diagnostics: Iterable[Diagnostic]) -> None:
        """Add diagnostics an earlier build made (the part of it an edit left alone), the
        same objects, each once as `add` would. A `Run` none of whose diagnostics the sink
        holds yet enters whole, its keys made and hashed when it was first added."""
        seen, items = self._seen, self.items
        if type(diagnostics) is Run:
            keys = diagnostics.keys()
            if keys is not None and keys.isdisjoint(seen):
                seen |= keys  # a set's stored hashes: nothing hashed again
                if diagnostics:
                    self._runs.append((len(items), diagnostics))
                items += diagnostics
                return
        for diagnostic in diagnostics:
            count = len(seen)
            seen.add(_SAME_KEY(diagnostic))  # hashed once
            if len(seen) != count:
                items.append(diagnostic)

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.items if d.severity is Severity.ERROR]

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.items if d.severity is Severity.WARNING]

    def sorted(self) -> list[Diagnostic]:
        """The diagnostics by `Diagnostic.sort_key`, stably: the keys of the runs that
        entered whole are the ones each run made once, the others are made here."""
        items = self.items
        if not self._runs:
            return sorted(items, key=_SORT_KEY)
        keys: list[tuple[str, int, int, str]] = []
        at = 0
        for start, run in self._runs:
            end = start + len(run)
            if end > len(items) or not run or items[start] is not run[0] or \
                    items[end - 1] is not run[-1]:
                return sorted(items, key=_SORT_KEY)  # not as it entered: made here
            keys += map(_SORT_KEY, items[at:start])
            keys += run.sort_keys()
            at = end
        keys += map(_SORT_KEY, items[at:])
        return list(map(items.__getitem__, sorted(range(len(items)), key=keys.__getitem__)))


def suppressed(diagnostic: Diagnostic, sources: dict[str, list[str]]) -> bool:
    """`# mpc: ignore[CODE]` (or `# mpc: ignore`) on its line silences a warning; used by
    every family's checks, so the comment works the same in .mp, .fbs and .csim files."""
    if diagnostic.severity is not Severity.WARNING:
        return False
    lines = sources.get(diagnostic.span.file, [])
    if not 0 < diagnostic.span.line <= len(lines):
        return False
    match = SUPPRESS.search(lines[diagnostic.span.line - 1])
    if match is None:
        return False
    codes = match.group(1)
    return codes is None or diagnostic.code in {c.strip().upper() for c in codes.split(",")}


def without_ignored(diagnostics: list[Diagnostic], ignore: frozenset[str]) -> list[Diagnostic]:
    """The diagnostics a project's `[lint] ignore` leaves: its warning codes are dropped in
    every file, as a `# mpc: ignore[CODE]` on every line would; errors always stay."""
    if not ignore:
        return diagnostics
    return [d for d in diagnostics
            if d.severity is not Severity.WARNING or d.code not in ignore]

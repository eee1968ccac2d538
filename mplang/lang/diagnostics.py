"""Diagnostics: every problem carries a stable code, a source span and, where possible, a hint.

The rule registry (code -> title, severity, explanation) lives in `mplang.lang.rules`, the
severities below both in `mplang.lang.severity`; this module holds the objects that flow
through the compiler, the way they are rendered, and the `# mpc: ignore` comment.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field

from mplang.lang.rules import RULES
from mplang.lang.severity import Severity as Severity

# `# mpc: ignore[W107]` (or `# mpc: ignore` for every warning) on a line silences warnings
# reported on that line. Errors cannot be silenced: the device would reject the program.
SUPPRESS = re.compile(r"mpc:\s*ignore(?:\[([A-Za-z0-9,\s]+)\])?")


@dataclass(frozen=True, order=True)
class Span:
    """A place in a source file: 1-based line and column, end column exclusive."""

    file: str
    line: int
    col: int = 1
    end_col: int | None = None

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"


_new = object.__new__


def make_span(file: str, line: int, col: int = 1, end_col: int | None = None) -> Span:
    """`Span(file, line, col, end_col)`, without the frozen dataclass's `__init__` (one
    `object.__setattr__` per field): the parser makes one per token, the statement cache
    one per moved span."""
    made: Span = _new(Span)
    fields = made.__dict__
    fields["file"] = file
    fields["line"] = line
    fields["col"] = col
    fields["end_col"] = end_col
    return made


@dataclass(frozen=True)
class Diagnostic:
    code: str
    severity: Severity
    message: str
    span: Span
    hint: str = ""
    related: tuple[tuple[Span, str], ...] = field(default=())

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


class DiagnosticSink:
    """Collects diagnostics; the compiler never stops at the first problem."""

    def __init__(self) -> None:
        self.items: list[Diagnostic] = []
        self._seen: set[tuple[str, Span, str]] = set()

    def add(self, code: str, span: Span, message: str, hint: str = "",
            related: tuple[tuple[Span, str], ...] = ()) -> None:
        key = (code, span, message)
        if key in self._seen:
            return
        self._seen.add(key)
        self.items.append(Diagnostic(code, RULES[code].severity, message, span, hint, related))

    def extend(self, diagnostics: Iterable[Diagnostic]) -> None:
        """Add diagnostics an earlier build made (the part of it an edit left alone), the
        same objects, each once as `add` would."""
        seen, items = self._seen, self.items
        for diagnostic in diagnostics:
            count = len(seen)
            seen.add((diagnostic.code, diagnostic.span, diagnostic.message))  # hashed once
            if len(seen) != count:
                items.append(diagnostic)

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.items if d.severity is Severity.ERROR]

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.items if d.severity is Severity.WARNING]

    def sorted(self) -> list[Diagnostic]:
        return sorted(self.items, key=Diagnostic.sort_key)


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

"""Diagnostics: every problem carries a stable code, a source span and, where possible, a hint.

The rule registry (code -> title, severity, explanation) lives in `mplang.lang.rules`; this module
only holds the objects that flow through the compiler and the way they are rendered.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum


class Severity(StrEnum):
    ERROR = "error"
    WARNING = "warning"


@dataclass(frozen=True, order=True)
class Span:
    """A place in a source file: 1-based line and column, end column exclusive."""

    file: str
    line: int
    col: int = 1
    end_col: int | None = None

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"


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
        from mplang.lang.rules import RULES

        key = (code, span, message)
        if key in self._seen:
            return
        self._seen.add(key)
        self.items.append(Diagnostic(code, RULES[code].severity, message, span, hint, related))

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.items if d.severity is Severity.ERROR]

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.items if d.severity is Severity.WARNING]

    def sorted(self) -> list[Diagnostic]:
        return sorted(self.items, key=Diagnostic.sort_key)

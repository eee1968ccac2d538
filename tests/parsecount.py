"""A statement cache's parse function that counts: tests of incremental parsing (the
front end's and the language server's) see which texts were parsed, never how long it took."""

from __future__ import annotations

from mplang.lang.diagnostics import DiagnosticSink
from mplang.lang.parser import parse_recorded, parse_text


class CountedParse:
    """Parses through `parse_text`, keeping the texts it was given."""

    def __init__(self) -> None:
        self.texts: list[str] = []

    def __call__(self, text: str, file: str, sink: DiagnosticSink) -> list[object]:
        self.texts.append(text)
        return parse_text(text, file, sink)  # type: ignore[return-value]

    def recorded(self, text: str, file: str, sink: DiagnosticSink
                 ) -> tuple[list[object], list[object]]:
        """`parse_recorded`'s shape (a front cache that keeps recipes parses so)."""
        self.texts.append(text)
        return parse_recorded(text, file, sink)  # type: ignore[return-value]

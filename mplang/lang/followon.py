"""One error where an INCLUDE goes wrong, not one per name it would have brought (issue 15
item 6). A missing INCLUDE keeps its own error (E102) and the unknown-name errors that follow
from it are left out; a library file (`std:...`) whose required CONSTs the program does not
define gets one error at the user's INCLUDE line naming them, instead of one error per use
inside the library with did-you-means among the library's own names.

Works on the diagnostics and the source lines every family's compiler already has, so the
M8194H, FATEK and CSIM builds and the editor report the same."""

from __future__ import annotations

import re
from operator import attrgetter

from mplang.lang.diagnostics import Diagnostic, Severity, Span
from mplang.lang.sources import LIBRARY_PREFIX

INCLUDE_LINE = re.compile(r"""^(\s*)INCLUDE\s+"([^"]*)"\s*""", re.IGNORECASE)
INCLUDE_FAILED = frozenset({"E102", "E104", "E105"})
"""An INCLUDE whose file is missing, outside the project or not text."""
FOLLOW_ON = frozenset({"E202", "E423", "E434"})
"""What a name nobody defined draws: unknown name, assignment to a non-variable, CALL of a
program not in the build."""
UNKNOWN_NAME = re.compile(r"unknown name '([^']+)'")
_CODE = attrgetter("code")


def settle_includes(diagnostics: list[Diagnostic], sources: dict[str, list[str]]
                    ) -> list[Diagnostic]:
    """`diagnostics` with the follow-on errors of failed INCLUDEs left out and a library's
    missing CONSTs said once at the INCLUDE that brought it (`sources`: each file's lines,
    by the name diagnostics give it)."""
    codes = set(map(_CODE, diagnostics))  # one pass in C: most checks have neither code
    if "E202" in codes:
        diagnostics = _library_constants(diagnostics, sources)
    if codes.isdisjoint(INCLUDE_FAILED):
        return diagnostics
    failed = [d for d in diagnostics if d.code in INCLUDE_FAILED and _is_include(d.span, sources)]
    if not failed:
        return diagnostics
    kept = [d for d in diagnostics if d.code not in FOLLOW_ON]
    dropped = len(diagnostics) - len(kept)
    if not dropped:
        return diagnostics
    note = (f"{dropped} error{'s' if dropped != 1 else ''} about names it may define "
            f"{'are' if dropped != 1 else 'is'} left out until it is found")
    first = failed[0]
    return [d.replace(hint=f"{d.hint}; {note}" if d.hint else note) if d is first else d
            for d in kept]


def _is_include(span: Span, sources: dict[str, list[str]]) -> bool:
    lines = sources.get(span.file, [])
    return 0 < span.line <= len(lines) and INCLUDE_LINE.match(lines[span.line - 1]) is not None


def _library_constants(diagnostics: list[Diagnostic], sources: dict[str, list[str]]
                       ) -> list[Diagnostic]:
    """Unknown names inside a library file, gathered into one error per library at the
    INCLUDE of the user's file that brought it in."""
    missing: dict[str, list[str]] = {}
    for d in diagnostics:
        if d.code != "E202" or not d.span.file.startswith(LIBRARY_PREFIX):
            continue  # the message is read only when it can matter (a device's thousands)
        match = UNKNOWN_NAME.match(d.message)
        if match:
            names = missing.setdefault(d.span.file, [])
            if match.group(1) not in names:
                names.append(match.group(1))
    if not missing:
        return diagnostics
    settled: dict[str, Diagnostic] = {}
    for library, names in missing.items():
        span = _including_line(library, sources)
        if span is None:
            continue
        listed = ", ".join(names)
        settled[library] = Diagnostic(
            "E202", Severity.ERROR,
            f"{library} needs CONST{'s' if len(names) > 1 else ''} the including program "
            f"defines, and {'these are' if len(names) > 1 else 'this is'} missing: {listed}",
            span, hint=f"define {'them' if len(names) > 1 else 'it'} before or after the "
            f"INCLUDE, e.g. CONST {names[0]} = ...; the header of {library} (docs/stdlib.md) "
            "says what each one means")
    kept = [d for d in diagnostics
            if not (d.code == "E202" and d.span.file in settled)]
    return sorted([*kept, *settled.values()], key=Diagnostic.sort_key)


def _including_line(library: str, sources: dict[str, list[str]]) -> Span | None:
    """The INCLUDE of `library` in a file that is not itself a library (the user's), else
    in a library; None if no line includes it."""
    found: Span | None = None
    for name, lines in sources.items():
        for number, line in enumerate(lines, start=1):
            match = INCLUDE_LINE.match(line)
            if match is None or match.group(2).strip() != library:
                continue
            span = Span(name, number, len(match.group(1)) + 1, len(line.rstrip()) + 1)
            if not name.startswith(LIBRARY_PREFIX):
                return span
            found = found or span
    return found

"""The CALL tree of a build, for the editor's call hierarchy, and the places a word names in
one document, for its highlights (without pygls).

A call is a `CALL name`, `CALL MPn` or raw `MP_CALL ...` statement inside a program; the
program it names is the one the build's linker placed (by name, by number or by slot). The
tree's depth is a device limit (the profile's nesting of calls), which is why editors show
it: incoming calls answer "who reaches this program", outgoing "what does it start".
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mplang.tools.lsp.analysis import Analysis, ProgramBlock
from mplang.tools.lsp.editing import references
from mplang.tools.lsp.features import _program_target, target_at
from mplang.tools.lsp.positions import Location, Pos, Range, line_range
from mplang.tools.lsp.tokens import lex_line

CALL_WORDS = ("CALL", "MP_CALL")


@dataclass(frozen=True)
class Call:
    """One call statement: the program it is in, the one it names, and the callee's word."""

    caller: ProgramBlock
    callee: ProgramBlock
    at: Range  # the callee's name or number on the CALL line


def _lines(analysis: Analysis, path: Path) -> list[str]:
    entry = analysis.files.get(path)
    return entry.lines if entry is not None else []


def calls(analysis: Analysis) -> list[Call]:
    """Every call of the build whose callee is a program of it, in file and line order."""
    found: list[Call] = []
    for program in analysis.programs:
        lines = _lines(analysis, program.path)
        for number in range(program.first_line + 1, min(program.last_line + 1, len(lines))):
            code = [t for t in lex_line(lines[number]) if t.kind != "comment"]
            if len(code) < 2 or code[0].upper not in CALL_WORDS or \
                    code[1].kind not in ("name", "int"):
                continue
            callee = _program_target(analysis, code[1].text, "mp").program
            if callee is not None:
                found.append(Call(program, callee,
                                  line_range(number, code[1].start, code[1].end)))
    return found


def program_at(analysis: Analysis, pos: Pos) -> ProgramBlock | None:
    """The program a call hierarchy starts from: the one the word at `pos` names (a header's
    name, a CALL's target), else the one `pos` is inside."""
    found = target_at(analysis, pos)
    if found is not None and found[1].kind == "program" and found[1].program is not None:
        return found[1].program
    return analysis.program_at(pos.line)


def find_program(analysis: Analysis, path: Path, line: int) -> ProgramBlock | None:
    """The program whose header is on 0-based `line` of `path` (how an item comes back)."""
    return next((p for p in analysis.programs if p.path == path and p.first_line == line),
                None)


def related(analysis: Analysis, program: ProgramBlock, incoming: bool
            ) -> list[tuple[ProgramBlock, list[Range]]]:
    """`incoming`: the programs that call `program`, each with the places of its calls;
    else the programs `program` calls, each with the places (in `program`) that call it."""
    grouped: dict[int, tuple[ProgramBlock, list[Range]]] = {}
    for call in calls(analysis):
        mine, other = (call.callee, call.caller) if incoming else (call.caller, call.callee)
        if mine is program:
            grouped.setdefault(id(other), (other, []))[1].append(call.at)
    return list(grouped.values())


def highlights(analysis: Analysis, pos: Pos) -> list[tuple[Range, bool]]:
    """The places in the open document that name what the word at `pos` names, each marked
    True where it is written (its definition), False where it is read."""
    found = target_at(analysis, pos)
    if found is None:
        return []
    places: list[Location] = references(analysis, pos, include_declaration=True)
    if not places:  # a command, a VARn, an axis: the same word on the document's lines
        word = found[0]
        if word.kind != "name":
            return []
        places = [Location(analysis.path, line_range(number, token.start, token.end))
                  for number, text in enumerate(analysis.lines)
                  for token in lex_line(text)
                  if token.kind in ("name", "int") and token.upper == word.upper]
        return [(p.range, False) for p in places]
    definition = places[0] if places else None
    target = found[1]
    has_definition = target.kind == "program" or target.definition is not None
    return [(p.range, has_definition and p == definition) for p in places
            if p.path == analysis.path]

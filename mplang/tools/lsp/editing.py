"""Edits the editor applies: formatting, quick fixes, references and rename, without pygls.

Formatting runs the `mpc fmt` engine on the whole text and hands back only the lines that
change (so the cursor and the undo history stay where they were); range formatting keeps the
changes that touch the lines asked for. A source the formatter refuses (syntax errors) gets
no edit, as `mpc fmt` leaves such a file untouched. Quick fixes come from the compiler's own
hints ("did you mean X?") and from the `# mpc: ignore[CODE]` comment. References and rename
resolve every word the way hover does, in the document and every file of its build.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from pathlib import Path

from mplang.lang.diagnostics import SUPPRESS
from mplang.tools.fmt import FormatOptions, FormatterBug, SourceNotFormattable, format_source
from mplang.tools.lsp.analysis import Analysis, EditorDiagnostic, ProgramBlock
from mplang.tools.lsp.features import Target, resolve, target_at
from mplang.tools.lsp.positions import Location, Pos, Range, line_range
from mplang.tools.lsp.tokens import Cursor, Token, lex_line, line_words

_MEANT = re.compile(r"did you mean ([A-Za-z_][A-Za-z0-9_.]*)\?")
_QUOTED = re.compile(r"'([^']+)'")
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
RENAMEABLE = ("const", "alias", "declared", "label", "program")


@dataclass(frozen=True)
class TextEdit:
    """Replace `range` (0-based code points) of a file with `text`."""

    range: Range
    text: str


@dataclass(frozen=True)
class QuickFix:
    title: str
    diagnostic: EditorDiagnostic
    edit: TextEdit
    preferred: bool


class RenameRefused(ValueError):
    """The new name cannot be used; the message says why."""


# ------------------------------------------------------------------------------ formatting


def _lines_with_breaks(text: str) -> list[str]:
    return re.findall(r"[^\n]*\n|[^\n]+$", text)


def _end_of(lines: list[str]) -> Pos:
    """The position after the last character of a text split by `_lines_with_breaks`."""
    if not lines:
        return Pos(0, 0)
    last = lines[-1]
    if last.endswith("\n"):
        return Pos(len(lines), 0)
    return Pos(len(lines) - 1, len(last))


def format_edits(text: str, options: FormatOptions, lines: tuple[int, int] | None = None
                 ) -> list[TextEdit]:
    """The edits that give `text` the canonical layout; with `lines` (first, last: 0-based,
    inclusive) only those touching that line range. None when the formatter refuses the text:
    a syntax error (or a lone carriage return, which the editor and the compiler would count
    as different line breaks) leaves the document as it is.

    The formatter keeps every non-blank line, in order, and only changes its whitespace or
    the blank lines between: so the old and new lines pair up in one pass (a general diff
    would take quadratic time on a large file), each changed line and each changed run of
    blank lines an edit of its own."""
    if re.search(r"\r(?!\n)", text):
        return []
    try:
        formatted = format_source(text, options)
    except (SourceNotFormattable, FormatterBug):
        return []
    old, new = _lines_with_breaks(text), _lines_with_breaks(formatted)
    old_code = [i for i, line in enumerate(old) if line.strip()]
    new_code = [i for i, line in enumerate(new) if line.strip()]
    if len(old_code) != len(new_code):
        return []  # cannot happen: the formatter checks it keeps every line

    def end(index: int) -> Pos:
        return Pos(index, 0) if index < len(old) else _end_of(old)

    pieces: list[tuple[int, int, str]] = []  # old lines [first, stop) -> new text
    previous_old = previous_new = -1
    for at_old, at_new in [*zip(old_code, new_code, strict=True), (len(old), len(new))]:
        run_old, run_new = old[previous_old + 1:at_old], new[previous_new + 1:at_new]
        if run_old != run_new:
            pieces.append((previous_old + 1, at_old, "".join(run_new)))
        if at_old < len(old) and old[at_old] != new[at_new]:
            pieces.append((at_old, at_old + 1, new[at_new]))
        previous_old, previous_new = at_old, at_new
    edits = []
    for first, stop, replacement in pieces:
        if lines is not None and (max(first, stop - 1) < lines[0] or first > lines[1]):
            continue
        edits.append(TextEdit(Range(Pos(first, 0), end(stop)), replacement))
    return edits


# ------------------------------------------------------------------------------ quick fixes


def quick_fixes(analysis: Analysis, within: Range) -> list[QuickFix]:
    """For each diagnostic of the document on the lines of `within` (a cursor anywhere on
    the line is enough): the replacement its hint names, and for a warning the comment that
    silences it on its line."""
    fixes: list[QuickFix] = []
    for found in analysis.diagnostics:
        where = found.range
        lines_apart = where.end.line < within.start.line or where.start.line > within.end.line
        if found.elsewhere or lines_apart:
            continue  # a fix belongs in the file the problem is in
        meant = _MEANT.search(found.hint)
        word = _misspelled(analysis, found) if meant else None
        if meant and word is not None:
            replacement = _spelled(analysis, meant.group(1), where.start.line)
            fixes.append(QuickFix(f"Replace '{word.text}' with '{replacement}'", found,
                                  TextEdit(line_range(where.start.line, word.start, word.end),
                                           replacement), True))
        if found.severity == "warning" and found.code:
            edit = _ignore_edit(analysis, where.start.line, found.code)
            if edit is not None:
                fixes.append(QuickFix(f"Ignore {found.code} on this line", found, edit, False))
    return fixes


def _misspelled(analysis: Analysis, found: EditorDiagnostic) -> Token | None:
    """The word a did-you-mean hint replaces: the name the message quotes, else the only
    name in the diagnostic's range, else the one most like the suggestion."""
    line = found.range.start.line
    if not 0 <= line < len(analysis.lines):
        return None
    end = found.range.end.character if found.range.end.line == line else 1 << 30
    on_line = [t for t in lex_line(analysis.lines[line]) if t.kind == "name"]
    names = [t for t in on_line if t.end >= found.range.start.character and t.start <= end]
    quoted = {q.upper() for q in _QUOTED.findall(found.message)}
    # the quoted name, nearest the range first (a CALL's span may cover only `CALL`)
    for token in sorted(on_line, key=lambda t: (t not in names, t.start)):
        if token.upper in quoted:
            return token
    if len(names) == 1:
        return names[0]
    meant = _MEANT.search(found.hint)
    close = difflib.get_close_matches(meant.group(1).upper() if meant else "",
                                      [t.upper for t in names], n=1, cutoff=0.5)
    return next((t for t in names if close and t.upper == close[0]), None)


def _spelled(analysis: Analysis, suggestion: str, line: int = -1) -> str:
    """A suggested name as its definition spells it (the compiler suggests upper case): a
    CONST, ALIAS, variable, a label of the program at `line`, or a program."""
    upper = suggestion.upper()
    program_here = analysis.program_at(line)
    labels = program_here.labels if program_here is not None else {}
    for table in (analysis.consts, analysis.aliases, analysis.declared, labels):
        if upper in table:
            return table[upper].name
    program = analysis.program_named(upper)
    return program.name if program is not None and program.name else suggestion


def _ignore_edit(analysis: Analysis, line: int, code: str) -> TextEdit | None:
    """`  # mpc: ignore[CODE]` at the end of the line, or CODE added to the comment there."""
    if not 0 <= line < len(analysis.lines):
        return None
    text = analysis.lines[line]
    comment = next((t for t in lex_line(text) if t.kind == "comment"), None)
    if comment is not None:
        match = SUPPRESS.search(comment.text)
        if match is not None:
            if match.group(1) is None:
                return None  # a bare `mpc: ignore` already silences every warning
            codes = [c.strip() for c in match.group(1).split(",") if c.strip()]
            if code in {c.upper() for c in codes}:
                return None
            start = comment.start + match.start(1)
            return TextEdit(line_range(line, start, comment.start + match.end(1)),
                            ", ".join([*codes, code]))
        # another comment: keep it and put the directive after it (it is searched anywhere)
        return TextEdit(line_range(line, comment.end, comment.end),
                        f"  mpc: ignore[{code}]")
    end = len(text.rstrip())
    return TextEdit(line_range(line, end, len(text)), f"  # mpc: ignore[{code}]")


# ------------------------------------------------------------------------ references, rename


def _same(a: Target, b: Target) -> bool:
    if a.kind != b.kind:
        return False
    if a.kind == "program":
        return a.program is not None and a.program is b.program
    if a.definition is None or b.definition is None:
        return False
    return a.definition.location == b.definition.location


def _program_of(analysis: Analysis, path: Path, line: int) -> ProgramBlock | None:
    return next((p for p in analysis.programs if p.path == path and p.contains_line(line)),
                None)


def references(analysis: Analysis, pos: Pos, include_declaration: bool = True
               ) -> list[Location]:
    """Every place in the build that names what the word at `pos` names (CONST, ALIAS,
    `VAR name`, label, program by name), its definition first when asked for."""
    found = target_at(analysis, pos)
    if found is None or found[1].kind not in RENAMEABLE:
        return []
    target = found[1]
    definition = _definition_of(target)
    places: list[Location] = []
    upper = target.name.upper()
    for entry in analysis.files.values():
        for number, text in enumerate(entry.lines):
            if upper not in text.upper():
                continue
            for token, cursor in line_words(text):
                if token.upper != upper:
                    continue
                where = Location(entry.path, line_range(number, token.start, token.end))
                if where == definition or _names(analysis, entry.path, number, cursor,
                                                 target):
                    places.append(where)
    if definition is not None:
        places = [p for p in places if p != definition]
        if include_declaration:
            places.insert(0, definition)
    return places


def _definition_of(target: Target) -> Location | None:
    if target.kind == "program" and target.program is not None:
        return Location(target.program.path, target.program.name_range)
    return target.definition.location if target.definition else None


def _names(analysis: Analysis, path: Path, line: int, cursor: Cursor, target: Target) -> bool:
    """Whether the word under `cursor` (on `line` of `path`) stands for `target`."""
    token = cursor.word
    if token is None:
        return False
    if cursor.head in ("GOTO", "LABEL") and cursor.position == 1:
        program = _program_of(analysis, path, line)
        label = program.labels.get(token.upper) if program else None
        return target.kind == "label" and label is not None and \
            label == target.definition
    if cursor.head in ("MP", "ISR") and cursor.position in (1, 2):
        return False  # a header names its own program: found through its definition
    if target.kind == "label":
        return False
    if path != analysis.path and token.kind == "int":
        return False
    meant = resolve(analysis, line if path == analysis.path else -1, cursor, token)
    return meant is not None and _same(meant, target)


def rename_range(analysis: Analysis, pos: Pos) -> Range | None:
    """The word a rename at `pos` would change, None when it names nothing renameable (a
    command, a keyword, a VARn, a program known only by its slot)."""
    found = target_at(analysis, pos)
    if found is None:
        return None
    token, target = found
    if target.kind not in RENAMEABLE or token.kind != "name":
        return None
    if target.kind == "program" and (target.program is None or not target.program.name
                                     or token.upper != target.program.name.upper()):
        return None
    if _definition_of(target) is None:
        return None
    return line_range(pos.line, token.start, token.end)


def rename(analysis: Analysis, pos: Pos, new_name: str) -> dict[Path, list[TextEdit]]:
    """The edits, by file, that rename what the word at `pos` names everywhere in the build."""
    if rename_range(analysis, pos) is None:
        return {}
    if not NAME.fullmatch(new_name):
        raise RenameRefused(f"{new_name!r} is not a name (a letter or _, then letters, digits "
                            "or _)")
    from mplang.ir.scope import KEYWORDS

    upper = new_name.upper()
    if upper in KEYWORDS or analysis.catalogue.lookup(upper) is not None:
        raise RenameRefused(f"{new_name} is a keyword or a command")
    clash = _clash(analysis, pos, upper)
    if clash:
        raise RenameRefused(f"{new_name} already names {clash}")
    edits: dict[Path, list[TextEdit]] = {}
    for place in references(analysis, pos):
        edits.setdefault(place.path, []).append(TextEdit(place.range, new_name))
    return edits


def _clash(analysis: Analysis, pos: Pos, upper: str) -> str:
    """What the new name (upper case) already stands for where the renamed name is used."""
    found = target_at(analysis, pos)
    if found is None:
        return ""
    target = found[1]
    if upper == target.name.upper():
        return ""
    if target.kind == "label":
        program = target.program
        return f"a label of {program.title}" if program and upper in program.labels else ""
    for kind, table in (("a CONST", analysis.consts), ("an ALIAS", analysis.aliases),
                        ("a VAR", analysis.declared)):
        if upper in table:
            return kind
    program = analysis.program_named(upper)
    return f"the program {program.title}" if program else ""

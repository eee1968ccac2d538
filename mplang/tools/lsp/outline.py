"""The shape of a document for the editor: symbols, folding, semantic tokens and signature
help, without pygls.

Blocks are read from the parser's statements (the front end parses line by line, so a
syntax error hides only its own line) with a tolerant stack: an unclosed block runs to the
end of its program or of the file. Words are classified the way hover resolves them
(`features.resolve`), so the colours agree with what hover says a word is.
"""

from __future__ import annotations

import bisect
import itertools
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from mplang.ir.catalogue import Command
from mplang.ir.scope import KEYWORDS
from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink
from mplang.lang.parser import parse_text
from mplang.tools.lsp.analysis import Analysis, Definition
from mplang.tools.lsp.ends import shared_lines
from mplang.tools.lsp.features import param_accepts, resolve
from mplang.tools.lsp.positions import Pos, Range, line_range
from mplang.tools.lsp.tokens import cursor_at, lex_line, line_words


@dataclass
class Symbol:
    """One entry of the outline: a program with its labels, a declaration, a block."""

    name: str
    kind: str  # program const alias var label block
    detail: str
    range: Range  # the whole construct
    selection: Range  # its name
    children: list[Symbol] = field(default_factory=list)


@dataclass(frozen=True)
class Fold:
    first: int  # 0-based lines, inclusive
    last: int
    kind: str  # "region" | "comment"


@dataclass(frozen=True)
class Block:
    """A block written in the document: its kind and the lines from header to END."""

    kind: str  # mp isr for if while repeat init interrupts triggers
    header: ast.Statement
    first: int
    last: int


@dataclass(frozen=True)
class Signature:
    label: str
    documentation: str
    parameters: list[tuple[tuple[int, int], str]]  # label offsets, markdown
    active: int


_OPENS: dict[type, str] = {ast.ForStmt: "for", ast.IfStmt: "if", ast.WhileStmt: "while",
                           ast.RepeatStmt: "repeat", ast.InitHeader: "init",
                           ast.InterruptsHeader: "interrupts", ast.TriggersHeader: "triggers"}
_CONFIG = ("init", "interrupts", "triggers")


def blocks(lines: list[str]) -> list[Block]:
    """Every block of the text, closed or not, outermost first by header line."""
    statements = parse_text("\n".join(lines), "<outline>.mp", DiagnosticSink())
    stack: list[tuple[str, ast.Statement]] = []
    found: list[Block] = []

    def close_until(index: int, last: int) -> None:
        while len(stack) > index:
            kind, header = stack.pop()
            found.append(Block(kind, header, header.span.line - 1, max(last,
                                                                       header.span.line - 1)))

    for statement in statements:
        line = statement.span.line - 1
        match statement:
            case ast.ProgramHeader():
                close_until(0, line - 1)
                stack.append((statement.kind, statement))
            case ast.InitHeader() | ast.InterruptsHeader() | ast.TriggersHeader():
                close_until(0, line - 1)
                stack.append((_OPENS[type(statement)], statement))
            case ast.ForStmt() | ast.IfStmt() | ast.WhileStmt() | ast.RepeatStmt():
                stack.append((_OPENS[type(statement)], statement))
            case ast.Next() | ast.End():
                kind = "for" if isinstance(statement, ast.Next) else statement.what
                index = next((i for i in range(len(stack) - 1, -1, -1)
                              if stack[i][0] == kind), None)
                if index is not None:
                    close_until(index + 1, line - 1)
                    close_until(index, line)
    close_until(0, len(lines) - 1)
    return sorted(found, key=lambda b: (b.first, -b.last))


def folding_ranges(analysis: Analysis) -> list[Fold]:
    """Every block of more than one line, and every run of two or more comment lines."""
    folds = [Fold(b.first, b.last, "region") for b in blocks(analysis.lines)
             if b.last > b.first]
    run_start: int | None = None
    for number, text in enumerate([*analysis.lines, ""]):
        code = lex_line(text)
        is_comment = bool(code) and all(t.kind == "comment" for t in code)
        if is_comment and run_start is None:
            run_start = number
        elif not is_comment and run_start is not None:
            if number - 1 > run_start:
                folds.append(Fold(run_start, number - 1, "comment"))
            run_start = None
    return sorted(folds, key=lambda f: (f.first, f.last))


# ------------------------------------------------------------------------------ symbols


def _declaration(definition: Definition, kind: str) -> Symbol:
    where = definition.location.range
    line = where.start.line
    return Symbol(definition.name, kind, definition.text,
                  line_range(line, 0, max(where.end.character, len(definition.text))),
                  where)


def document_symbols(analysis: Analysis) -> list[Symbol]:
    """The outline of the open document: its CONSTs, ALIASes, `VAR`s, programs (with their
    labels) and INIT / INTERRUPTS / TRIGGERS blocks, in source order."""
    symbols = _declarations(analysis, analysis.path)
    for block in blocks(analysis.lines):
        if block.kind in ("mp", "isr"):
            program = analysis.program_at(block.first)
            if program is None:
                continue
            symbol = Symbol(program.name or program.title, "program", program.title,
                            line_range(block.first, 0, 0), program.name_range,
                            [_declaration(label, "label")
                             for label in program.labels.values()])
        elif block.kind in _CONFIG:
            title = analysis.lines[block.first].split("#")[0].strip()
            symbol = Symbol(title or block.kind.upper(), "block", block.kind.upper(),
                            line_range(block.first, 0, 0),
                            line_range(block.first, 0, len(analysis.lines[block.first])))
        else:
            continue
        end_text = analysis.lines[block.last] if block.last < len(analysis.lines) else ""
        symbol.range = Range(Pos(block.first, 0), Pos(block.last, len(end_text)))
        symbols.append(symbol)
    return sorted(symbols, key=lambda s: s.range.start)


def _declarations(analysis: Analysis, path: Path) -> list[Symbol]:
    tables = (("const", analysis.consts), ("alias", analysis.aliases),
              ("var", analysis.declared))
    return [_declaration(d, kind) for kind, table in tables for d in table.values()
            if d.location.path == path]


def workspace_symbols(analyses: list[Analysis], query: str) -> list[tuple[Symbol, Path]]:
    """Every program, label and declaration of the builds of the open documents whose name
    contains `query` (any case), each once."""
    wanted = query.upper()
    seen: set[tuple[str, Path, Range]] = set()
    found: list[tuple[Symbol, Path]] = []

    def add(symbol: Symbol, path: Path) -> None:
        key = (symbol.name, path, symbol.selection)
        if wanted in symbol.name.upper() and key not in seen:
            seen.add(key)
            found.append((symbol, path))

    for analysis in analyses:
        for path in analysis.files:
            for symbol in _declarations(analysis, path):
                add(symbol, path)
        for program in analysis.programs:
            add(Symbol(program.name or program.title, "program", program.title,
                       program.header_range, program.name_range), program.path)
            for label in program.labels.values():
                add(_declaration(label, "label"), program.path)
    return found


# ------------------------------------------------------------------------ semantic tokens

TOKEN_TYPES = ["keyword", "function", "variable", "enumMember", "namespace", "label",
               "number", "string", "comment", "operator"]
TOKEN_MODIFIERS = ["declaration", "readonly", "defaultLibrary"]
_TARGET_TYPES = {"command": "function", "keyword": "keyword", "const": "variable",
                 "alias": "variable", "declared": "variable", "variable": "variable",
                 "bvariable": "variable", "program": "namespace", "slot": "namespace",
                 "label": "label", "axis": "enumMember", "symbol": "enumMember"}
_LEXED_TYPES = {"int": "number", "string": "string", "comment": "comment", "op": "operator"}


_TYPE_NUMBERS = {name: number for number, name in enumerate(TOKEN_TYPES)}
_DECLARATION, _READONLY, _DEFAULT_LIBRARY = (1 << TOKEN_MODIFIERS.index(name) for name in (
    "declaration", "readonly", "defaultLibrary"))
_KEPT_LINES = 32_768
"""How many line texts one set of names keeps classified (a full device has ~6,000 lines)."""
_KEPT_NAME_SETS = 4
"""How many sets of names (about one per open document) keep their lines."""
Names = tuple[frozenset[str], ...]
Classified = list[tuple[int, int, int, int]]  # start, end, type, modifiers (no declaration)
Line = tuple[Classified, list[int]]
"""A line's tokens, and the encoded data of all but its first (relative to the token before,
on the same line: the same wherever the line is)."""
Kept = dict[str | tuple[str, bool], Line]
"""Classified lines by text (a program header's by its text and whether a block holds it)."""
_classified_lines: dict[Names, Kept] = {}


def _names(analysis: Analysis) -> Names:
    """What a word's class depends on besides its line: the names the build defines (a
    program's labels and slots do not matter: a label is a label and a program or slot is a
    namespace, found or not)."""
    return (frozenset(analysis.consts), frozenset(analysis.aliases),
            frozenset(analysis.declared),
            frozenset(p.name.upper() for p in analysis.programs if p.name))


def _lines_for(names: Names) -> Kept:
    """The classified lines kept for a set of names (the least recently used set dropped)."""
    kept = _classified_lines.pop(names, None)
    if kept is None:
        kept = {}
        while len(_classified_lines) >= _KEPT_NAME_SETS:
            del _classified_lines[next(iter(_classified_lines))]
    elif len(kept) >= _KEPT_LINES:
        kept.clear()
    _classified_lines[names] = kept
    return kept


def _classify(analysis: Analysis, number: int, text: str) -> Classified:
    """The semantic tokens of one line: start, end, type and modifiers of each."""
    cursors = {token.start: cursor for token, cursor in line_words(text)}
    found: Classified = []
    for token in lex_line(text):
        kind = _LEXED_TYPES.get(token.kind)
        modifiers = 0
        if token.kind in ("name", "int"):
            cursor = cursors.get(token.start)
            target = resolve(analysis, number, cursor, token) if cursor else None
            if target is not None:
                kind = _TARGET_TYPES.get(target.kind)
                if target.kind == "const":
                    modifiers |= _READONLY
                if target.kind in ("command", "axis", "symbol"):
                    modifiers |= _DEFAULT_LIBRARY
            elif token.kind == "name" and token.upper in KEYWORDS:
                kind = "keyword"
            elif token.kind == "name":
                kind = None
        if kind is not None:
            found.append((token.start, token.end, _TYPE_NUMBERS[kind], modifiers))
    return found


_HEADER = re.compile(r"\s*(MP|ISR)\b", re.IGNORECASE)
"""A program header line: its words' class depends on the block the line is in."""


def _rest_of_line(classified: Classified) -> list[int]:
    """The encoded data of a line's tokens after its first."""
    data: list[int] = []
    for (before, _, _, _), (start, end, kind, modifiers) in itertools.pairwise(classified):
        data += [0, start - before, end - start, kind, modifiers]
    return data


class _Pass(NamedTuple):
    """What `semantic_tokens` computed for one analysis, for the next analysis of the same
    document to take the lines an edit left alone from."""

    lines: list[str]
    names: Names
    declared: list[tuple[int, int, int]]  # declarations on one line: line, start, end
    blocks: list[tuple[int, int]]  # the document's program blocks: first and last line
    data: list[int]
    firsts: list[int]  # where each line's tokens begin in `data`, and len(data) last
    # the last pass's data this one was spliced from (None: made afresh), and how many
    # numbers at its start, and then at its end, were taken from it as they were
    base: list[int] | None = None
    same: tuple[int, int] = (0, 0)


_KEPT_PASSES = 8
"""How many documents keep their last tokens (about one per open document)."""
_passes: dict[Path, _Pass] = {}


def semantic_tokens(analysis: Analysis) -> list[int]:
    """The document's words as LSP semantic tokens, relative-encoded (line delta, start
    delta, length, type, modifiers), lengths and starts in code points.

    A line's tokens depend on its text and on the names the build defines, so they are kept
    by line text for each set of names: after an edit that defines no new name, only the
    edited lines are classified again (a program header's are kept by its text and whether a
    block holds it). When the last tokens of the same document were made with the same
    names, declarations and blocks on the lines the edit left alone, those lines' tokens
    are taken from them as slices (`_spliced`): only the first token after the edited lines
    is encoded again (it counts its line from the token before it); the document's other
    lines are not walked. The list returned is the one kept for that: callers read it and
    never change it (a whole device's is a few hundred thousand numbers, not copied)."""
    names, declared = _names(analysis), _declared_here(analysis)
    blocks = sorted((p.first_line, p.last_line) for p in analysis.programs
                    if p.path == analysis.path)
    kept = _lines_for(names)
    last = _passes.pop(analysis.path, None)
    made = _spliced(analysis, last, names, declared, blocks, kept) \
        if last is not None else None
    if made is None:
        data: list[int] = []
        firsts: list[int] = []
        _encode_lines(analysis, kept, set(declared), range(len(analysis.lines)), (0, 0), data,
                      firsts)
        firsts.append(len(data))
        made = _Pass(analysis.lines, names, declared, blocks, data, firsts)
    while len(_passes) >= _KEPT_PASSES:
        del _passes[next(iter(_passes))]
    _passes[analysis.path] = made
    return made.data  # kept for the next pass, never changed: not copied (a megabyte)


def _declared_here(analysis: Analysis) -> list[tuple[int, int, int]]:
    """Line, start and end of each name the document declares on one line (a CONST, ALIAS
    or VAR, a label, a program's name), in order."""
    path = analysis.path
    definitions = [d.location for table in (analysis.consts, analysis.aliases,
                                            analysis.declared) for d in table.values()]
    definitions += [label.location for program in analysis.programs
                    for label in program.labels.values()]
    found = [(where.range.start.line, where.range.start.character, where.range.end.character)
             for where in definitions
             if where.path == path and where.range.start.line == where.range.end.line]
    found += [(p.name_range.start.line, p.name_range.start.character,
               p.name_range.end.character) for p in analysis.programs
              if p.path == path and p.name_range.start.line == p.name_range.end.line]
    return sorted(set(found))


def _encode_lines(analysis: Analysis, kept: Kept, declared: set[tuple[int, int, int]],
                  numbers: range, previous: tuple[int, int], data: list[int],
                  firsts: list[int]) -> tuple[int, int]:
    """Encode the tokens of some lines onto `data` after the token at `previous` (its line
    and start), noting where each line's begin in `firsts`; the last token's line and
    start."""
    previous_line, previous_start = previous
    declaring = {line for line, _, _ in declared}
    lines = analysis.lines
    for number in numbers:
        firsts.append(len(data))
        text = lines[number]
        line = kept.get(text)
        if line is None:
            # a header's words name its program when a block holds the line (a header the
            # parser refused may stand outside any): kept by its text and that
            key: str | tuple[str, bool] = text
            if _HEADER.match(text) is not None:
                key = (text, analysis.program_at(number) is not None)
                line = kept.get(key)
            if line is None:
                classified = _classify(analysis, number, text)
                line = kept[key] = (classified, _rest_of_line(classified))
        classified, rest = line
        if not classified:
            continue
        if number in declaring:  # a declaration's modifier depends on where it is
            for start, end, kind, modifiers in classified:
                if (number, start, end) in declared:
                    modifiers |= _DECLARATION
                delta = start - previous_start if number == previous_line else start
                data += [number - previous_line, delta, end - start, kind, modifiers]
                previous_line, previous_start = number, start
            continue
        start, end, kind, modifiers = classified[0]
        data += [number - previous_line, start, end - start, kind, modifiers]
        data += rest
        previous_line, previous_start = number, classified[-1][0]
    return previous_line, previous_start


def _spliced(analysis: Analysis, last: _Pass, names: Names,
             declared: list[tuple[int, int, int]], blocks: list[tuple[int, int]], kept: Kept
             ) -> _Pass | None:
    """The pass of `analysis` (its tokens and line starts) made from the last pass of its
    document: the lines before and after the edited ones taken as they were (their tokens
    relative to each other are the same wherever they are), the edited lines encoded, and
    the first token after them re-counted from the token before it; with the last pass's
    tokens and how many numbers at their start and end were taken as they were. None when
    anything those lines' tokens depend on differs: the names, or the declarations and
    blocks outside the edit."""
    old, new = last.lines, analysis.lines
    if names != last.names:
        return None
    edited = analysis.edited  # found by the check, when made against the same lines
    head, tail = edited[1:] if edited is not None and edited[0] is old else \
        shared_lines(old, new)
    shift = len(new) - len(old)
    # the same declarations (blocks), none moved: the same outside any lines, told in C
    if (shift or declared != last.declared) and \
            _outside(last.declared, head, len(old) - tail, 0) != \
            _outside(declared, head, len(new) - tail, shift):
        return None
    if (shift or blocks != last.blocks) and \
            _ends_outside(last.blocks, head, len(old) - tail, 0) != \
            _ends_outside(blocks, head, len(new) - tail, shift):
        return None
    firsts = last.firsts[:head]
    data = last.data[:last.firsts[head]]
    before = _last_token(last, head)
    previous = _encode_lines(analysis, kept, set(declared), range(head, len(new) - tail),
                             before, data, firsts)
    cut = last.firsts[len(old) - tail]
    offset = len(data) - cut  # the later lines' tokens begin this much further on
    after = last.firsts[len(old) - tail:]
    firsts += after if not offset else map(offset.__add__, after)
    at = len(data)
    data += last.data[cut:]
    if len(data) > at:  # the first token after the edit: its line counted from the one before
        line = next(n for n in range(len(old) - tail, len(old))
                    if last.firsts[n + 1] > last.firsts[n]) + shift
        data[at] = line - previous[0]
        if line == previous[0]:  # never: the token before is on an earlier line
            return None
    return _Pass(new, names, declared, blocks, data, firsts, last.data,
                 (last.firsts[head], max(len(last.data) - cut - 5, 0)))


def _last_token(last: _Pass, before: int) -> tuple[int, int]:
    """The line and start of the last token of a pass on a line before `before` ((0, 0):
    none, as the encoding counts from there)."""
    line = before - 1
    while line >= 0 and last.firsts[line + 1] == last.firsts[line]:
        line -= 1
    if line < 0:
        return 0, 0
    start = 0
    at = last.firsts[line]
    while at < last.firsts[line + 1]:  # starts are relative within a line
        start = last.data[at + 1] + (start if at > last.firsts[line] else 0)
        at += 5
    return line, start


def _outside(declared: list[tuple[int, int, int]], start: int, stop: int, shift: int
             ) -> tuple[list[tuple[int, int, int]], list[tuple[int, int, int]]]:
    """The declarations before line `start` and from line `stop` on (moved back by `shift`,
    the lines the edit added): the ones an edit of the lines between leaves in place."""
    cut = bisect.bisect_left(declared, (start,))
    rest = bisect.bisect_left(declared, (stop,))
    after = [(line - shift, s, e) for line, s, e in declared[rest:]] if shift else \
        declared[rest:]
    return declared[:cut], after


def _ends_outside(blocks: list[tuple[int, int]], start: int, stop: int, shift: int
                  ) -> list[tuple[int | None, int | None]]:
    """Program blocks as the lines before `start` and from `stop` on see them (moved back by
    `shift`): a first or last line between is only known to be there, since whether a
    block holds a line outside depends on no more."""
    return [(_seen_from_outside(first, start, stop, shift),
             _seen_from_outside(last, start, stop, shift)) for first, last in blocks]


def _seen_from_outside(line: int, start: int, stop: int, shift: int) -> int | None:
    if line < start:
        return line
    return line - shift if line >= stop else None


_STRIDES = (5 * 4096, 5 * 256, 5 * 16, 5)
"""Tokens compared at once while looking for the first and last difference (a slice
comparison runs in C; one token at a time, a whole device's 20,000 tokens took as long as
computing them)."""


def token_delta(old: list[int], new: list[int]) -> tuple[int, int, list[int]]:
    """One edit that turns `old` into `new`: start, number deleted, data inserted (over
    whole tokens of five numbers, as the protocol's delta reply expects), the least one.
    When `new` was spliced from `old` (the server's last tokens, sent to the client), the
    ends the splice took as they were are not compared again."""
    limit = min(len(old), len(new))
    # a pass spliced from `old` says how much of either end it took as it was (whole tokens)
    prefix, suffix = next((p.same for p in _passes.values() if p.data is new and p.base is old),
                          (0, 0))
    # of two lists of one length, the end the splice took is not scanned for the prefix:
    # reaching it, the prefix has found the lists equal
    stop = limit - suffix if len(old) == len(new) else limit
    for step in _STRIDES:
        while prefix + step <= stop and old[prefix:prefix + step] == new[prefix:prefix + step]:
            prefix += step
    if prefix == stop and stop < limit:
        return limit, 0, []
    suffix = min(suffix, limit - prefix)
    for step in _STRIDES:
        while suffix + step <= limit - prefix and \
                old[len(old) - suffix - step:len(old) - suffix] == \
                new[len(new) - suffix - step:len(new) - suffix]:
            suffix += step
    return prefix, len(old) - prefix - suffix, new[prefix:len(new) - suffix]


# ------------------------------------------------------------------------ signature help


def signature_help(analysis: Analysis, pos: Pos) -> Signature | None:
    """The catalogue's call form of the command whose arguments the cursor stands in."""
    if not 0 <= pos.line < len(analysis.lines):
        return None
    cursor = cursor_at(analysis.lines[pos.line], pos.character)
    if cursor.in_comment or cursor.string is not None:
        return None
    slot = cursor.argument()
    command = analysis.catalogue.lookup(slot.command) if slot else None
    if slot is None or command is None or not command.params:
        return None
    return _signature(analysis, command, min(slot.index, len(command.params) - 1))


def _signature(analysis: Analysis, command: Command, active: int) -> Signature:
    head = f"{command.short_name}(" if command.returns else f"{command.short_name} "
    label = head
    parameters = []
    for index, param in enumerate(command.params):
        if index:
            label += ", "
        start = len(label)
        label += param.name
        text = f"`{param.type}` {param_accepts(analysis, param)}"
        parameters.append(((start, len(label)), text + (f": {param.doc}" if param.doc else "")))
    if command.returns:
        label += ")"
    return Signature(label, command.summary or "", parameters, active)

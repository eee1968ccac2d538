"""What the editor needs to know about one open `.mp` document, computed without pygls.

`analyse` compiles the document's in-editor text with the real compiler (`compile_sources`,
INCLUDEs read from disk or from other open documents) for the diagnostics, in one pass: the
sources it read and what it lowered and linked also give what the image does not hold:
where each CONST, ALIAS, program and label is defined, each program's lines against its
slot budget (also while the build has errors), and the include graph. `mplang.tools.lsp.features`
answers hover, completion and definition from the result.
"""

from __future__ import annotations

import bisect
import logging
import re
from array import array
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from itertools import compress
from pathlib import Path
from typing import Protocol, cast

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.ir.lower import Scope
from mplang.ir.unit import Options, lower_unit
from mplang.lang import ast
from mplang.lang.diagnostics import (
    Diagnostic,
    DiagnosticSink,
    Span,
    without_ignored,
)
from mplang.lang.linecache import StatementCache
from mplang.lang.sources import SourceFile, SourceSet, load_sources
from mplang.lang.structure import build_unit
from mplang.m8194h.compiler import BuildMemo, Lowering, compile_sources
from mplang.m8194h.link import Placement, link
from mplang.tools.lsp.ends import (
    picked,
    picked_again,
    same_ends,
    shared_lines,
    shared_text_lines,
)
from mplang.tools.lsp.opentexts import OpenTexts, refusals
from mplang.tools.lsp.positions import Location, Range, line_range, span_range, split_lines
from mplang.tools.lsp.tokens import Token, lex_line
from mplang.tools.lsp.workspace import BuildContext
from mplang.tools.report import check_page

_VAR_USE = re.compile(r"\bVAR(\d+)\b", re.IGNORECASE)
logger = logging.getLogger("mplang.tools.lsp")


@dataclass(frozen=True)
class Definition:
    """A name the build defines, and where."""

    kind: str  # "const" | "alias" | "program" | "label"
    name: str
    location: Location  # the name itself
    text: str  # the defining statement as written, without its comment


@dataclass
class ProgramBlock:
    """An MP or ISR block as written in one file (also when it is not closed)."""

    kind: str  # "mp" | "isr"
    number: int | None
    name: str | None
    path: Path
    name_range: Range  # the name, else the number, else the keyword
    header_range: Range  # the header's code, for a lens or a hint
    first_line: int  # 0-based: the header line
    last_line: int  # 0-based: the END line, or the file's last line when unclosed
    labels: dict[str, Definition] = field(default_factory=dict)  # upper-case label -> def

    @property
    def title(self) -> str:
        number = "" if self.number is None else f" {self.number}"
        name = f" {self.name}" if self.name else ""
        return f"{self.kind.upper()}{number}{name}"

    def contains_line(self, line: int) -> bool:
        return self.first_line <= line <= self.last_line


@dataclass(frozen=True)
class SlotUse:
    """Lines a program takes against the budget of the slot the linker gave it."""

    kind: str
    slot: int | None  # None: the linker found no slot
    lines_used: int
    budget: int | None
    auto: bool

    @property
    def summary(self) -> str:
        """`MP3: 41/64 lines`, with what is wrong or notable after it."""
        if self.slot is None or self.budget is None:
            return f"{self.kind.upper()}: {self.lines_used} lines, no slot"
        text = f"{self.kind.upper()}{self.slot}: {self.lines_used}/{self.budget} lines"
        if self.lines_used > self.budget:
            return text + ", over budget"
        return text + " (auto-placed)" if self.auto else text


@dataclass(frozen=True)
class EditorDiagnostic:
    """A compiler diagnostic placed in the open document."""

    range: Range
    severity: str  # "error" | "warning"
    code: str
    message: str
    hint: str
    related: tuple[tuple[Location, str], ...]
    docs: Path | None  # the check's page, when the documentation is at hand
    elsewhere: bool = False  # found in another file, shown where it joined this one


@dataclass(frozen=True)
class IncludeLine:
    """An INCLUDE of the open document: the quoted path and the file it names."""

    range: Range
    target: Path
    spelled: str  # the path as written between the quotes


@dataclass
class SourceText:
    path: Path  # resolved
    display: str  # as the compiler names it in diagnostics
    lines: list[str]


@dataclass
class Analysis:
    path: Path  # the open document, resolved
    lines: list[str]
    catalogue: Catalogue
    options: Options
    files: dict[Path, SourceText] = field(default_factory=dict)
    consts: dict[str, Definition] = field(default_factory=dict)  # upper-case name -> def
    const_values: dict[str, int | None] = field(default_factory=dict)
    aliases: dict[str, Definition] = field(default_factory=dict)
    declared: dict[str, Definition] = field(default_factory=dict)  # `VAR name [@ VARn]`
    pinned: set[str] = field(default_factory=set)  # declared variables with `@ VARn`
    alias_targets: dict[str, int] = field(default_factory=dict)  # alias or VAR name -> n
    programs: list[ProgramBlock] = field(default_factory=list)
    slot_uses: dict[tuple[Path, int], SlotUse] = field(default_factory=dict)  # by header
    diagnostics: list[EditorDiagnostic] = field(default_factory=list)
    includes: list[IncludeLine] = field(default_factory=list)
    _variables_used: set[int] | None = field(default=None, repr=False, compare=False)
    # Built on the first lookup, with the count of programs each was built from: upper-case
    # program name -> its first block, and this document's blocks with their first lines
    # (semantic tokens look up every word and header of the document).
    _named: tuple[int, dict[str, ProgramBlock]] = field(default=(-1, {}), repr=False,
                                                         compare=False)
    _here: tuple[int, list[int], list[ProgramBlock]] = field(default=(-1, [], []),
                                                             repr=False, compare=False)
    # Diagnostics placed afresh in this document from its own text, by id: the diagnostic,
    # its line's text then, and where it was placed
    placed: dict[int, tuple[Diagnostic, str, EditorDiagnostic]] = field(
        default_factory=dict, repr=False, compare=False)
    # The compiler's diagnostics as this analysis placed them (the next analysis takes what
    # still holds): each one, its placement (None: shown in another document) and the line
    # (0-based) whose text the placement was made from (-1: placed from no line of its own)
    raw: list[Diagnostic] = field(default_factory=list, repr=False, compare=False)
    raw_placed: list[EditorDiagnostic | None] = field(default_factory=list, repr=False,
                                                      compare=False)
    raw_lines: array[int] = field(default_factory=lambda: array("l"), repr=False,
                                  compare=False)
    # Placements moved from the last analysis's (a program that only moved), by id: the
    # placement, the one it was moved from and by how many lines (the server moves the JSON)
    moved: dict[int, tuple[EditorDiagnostic, EditorDiagnostic, int]] = field(
        default_factory=dict, repr=False, compare=False)
    # The last analysis's lines (the very list) and how many lines at the start, and then at
    # the end, this text shares with them (`ends.shared_lines`), once found: semantic tokens
    # made for that analysis take them instead of comparing the texts again
    edited: tuple[list[str], int, int] | None = field(default=None, repr=False,
                                                      compare=False)
    text: str | None = field(default=None, repr=False, compare=False)  # the lines', whole

    @property
    def variables_used(self) -> set[int]:
        """Every VARn the build's files name (completion offers them): looked for when first
        asked, not on every edit. One search of each whole text, not one per line: a line
        break is no word character, so the words found are the same."""
        if self._variables_used is None:
            self._variables_used = {int(number) for entry in self.files.values()
                                    for number in _VAR_USE.findall("\n".join(entry.lines))}
        return self._variables_used

    def program_at(self, line: int) -> ProgramBlock | None:
        """The program of the open document that line (0-based) belongs to."""
        count, firsts, blocks = self._here
        if count != len(self.programs):
            blocks = [p for p in self.programs if p.path == self.path]
            order = sorted(range(len(blocks)), key=lambda i: (blocks[i].first_line, i))
            blocks = [blocks[i] for i in order]
            firsts = [p.first_line for p in blocks]
            self._here = (len(self.programs), firsts, blocks)
        # blocks of one file do not overlap: the last one starting at or before the line
        index = bisect.bisect_right(firsts, line) - 1
        return blocks[index] if index >= 0 and blocks[index].contains_line(line) else None

    def program_named(self, name: str) -> ProgramBlock | None:
        count, named = self._named
        if count != len(self.programs):
            named = {}
            for program in self.programs:
                if program.name:
                    named.setdefault(program.name.upper(), program)
            self._named = (len(self.programs), named)
        return named.get(name.upper())

    def program_in_slot(self, kind: str, slot: int) -> ProgramBlock | None:
        """The program written with that number, or placed there by the linker."""
        for program in self.programs:
            if program.kind == kind and program.number == slot:
                return program
        for (path, line), use in self.slot_uses.items():
            if use.kind == kind and use.slot == slot:
                return next((p for p in self.programs
                             if p.path == path and p.first_line == line), None)
        return None

    def slot_use(self, program: ProgramBlock) -> SlotUse | None:
        return self.slot_uses.get((program.path, program.first_line))

    def alias_names_of(self, index: int) -> list[str]:
        """The ALIAS and VAR names of variable `index`."""
        names = {**self.aliases, **self.declared}
        return [names[key].name for key, target in self.alias_targets.items()
                if target == index and key in names]


def analyse(path: Path, text: str, context: BuildContext | None = None,
            open_texts: Mapping[Path, str] | None = None,
            lines: StatementCache | None = None, memo: BuildMemo | None = None,
            previous: Analysis | None = None) -> Analysis:
    """Compile `text` as the contents of `path` and index what the editor features need.

    `context` says which sources are compiled with it and how (`workspace.context_for`);
    by default the document is compiled alone with the default options. `open_texts` holds
    other documents open in the editor (by resolved path): the build reads their editor
    text, not the disk. A failure inside the compiler does not escape: the analysis then
    holds one diagnostic that says so, and the features that need only the text and the
    catalogue (hover on commands, completion of commands) keep working. `lines`, kept by
    the caller between analyses (the server's), makes an edit parse the edited lines only;
    `memo`, kept for this document, makes it re-check only the programs it changed
    (`mplang.ir.reuse`), and `previous`, the document's last analysis, gives the
    diagnostics placed as then that stand where they stood.
    """
    context = context or BuildContext((path,), Options())
    catalogue = catalogue_module.load()
    try:
        return _analyse(path, text, context, open_texts or {}, catalogue, lines, memo,
                        previous)
    except Exception as exc:  # a compiler bug must not take the editor's features down
        logger.exception("checking %s failed", path)
        analysis = Analysis(path.resolve(), split_lines(text), catalogue, context.options,
                            text=text)
        analysis.diagnostics = [EditorDiagnostic(
            line_range(0, 0, 0), "error", "", f"mpc could not check this text: "
            f"{type(exc).__name__}: {exc}", "this is a bug in mpc; please report it with the "
            "file", (), None)]
        return analysis


def _analyse(path: Path, text: str, context: BuildContext, open_texts: Mapping[Path, str],
             catalogue: Catalogue, statements: StatementCache | None = None,
             memo: BuildMemo | None = None, previous: Analysis | None = None) -> Analysis:
    """`analyse`, with its failures let through. One function: the steps share the loaded
    sources and the files' index, and each is a few lines."""
    family = _family_of(context.options.target)
    # a FATEK or CSIM project: its .mp files are M8194H language, checked by that family
    options = context.options if family is None else context.options.replace(target="et")
    texts = OpenTexts(open_texts)
    resolve = texts.resolve
    resolved = resolve(path)
    texts[resolved] = text
    analysis = Analysis(resolved, split_lines(text), catalogue, options, text=text)
    if previous is not None and previous.path == resolved:  # what the edit left alone:
        old = previous.text  # found on the texts when their lines are split at "\n" only
        analysis.edited = (previous.lines, *(
            shared_text_lines(old, text) if old is not None and "\r" not in old and
            "\r" not in text else shared_lines(previous.lines, analysis.lines)))
    paths = [path if resolve(p) == resolved else p for p in context.sources]
    if resolved not in {resolve(p) for p in paths}:
        paths = [path]
    lowering: Lowering | None = None
    if family is None:  # one pass: the sources read once, lowered once, for all of it
        sink = DiagnosticSink()
        sources = load_sources(paths, sink, allow_outside=options.allow_outside_includes,
                               texts=texts, store=lambda p: resolve(p) in texts.disk,
                               lines=statements)
        # the parses of files read from disk are kept for the next change; editor buffers,
        # text being typed, are not
        lowering = Lowering()
        diagnostics = compile_sources(paths, sources, sink, options, lowering, memo,
                                      encode=False).diagnostics
    else:
        diagnostics = family.compile_mp(paths, options, context.options.target,
                                        texts=texts).diagnostics
        scratch = DiagnosticSink()  # the family's run above reports; this one is discarded
        sources = load_sources(paths, scratch, allow_outside=options.allow_outside_includes,
                               texts=texts, lines=statements)
    diagnostics = [*without_ignored(diagnostics, context.ignore),
                   *refusals(sources.files, paths, texts.refused)]
    by_display: dict[str, SourceText] = {}
    spelled: dict[Path, list[str]] = {}  # by file: its INCLUDEs' paths as spelt
    for source in sources.files:
        if resolve(source.path) in texts.refused:
            continue
        lines = analysis.lines if resolve(source.path) == resolved else \
            split_lines(source.text)
        entry = SourceText(resolve(source.path), source.display, lines)
        analysis.files[entry.path] = entry
        by_display[entry.display] = entry
        spelled[entry.path] = _index_file(analysis, source, entry, resolve)
    analysis.includes = [replace(i, target=_include_target(analysis.path, i.spelled, analysis,
                                                           by_display, resolve))
                         for i in analysis.includes]
    _measure_programs(analysis, sources.files, by_display, catalogue, options, lowering)
    graph = _include_graph(sources.files, spelled, analysis, by_display, resolve)
    pages: dict[str, Path | None] = {}  # a check's page, looked up once per code
    # the loaded files that are the open document, told apart without comparing paths for
    # each of the thousands of diagnostics a whole device can have
    own = {id(entry) for entry in by_display.values() if entry.path == analysis.path}
    here = {display for display, entry in by_display.items() if id(entry) in own}
    shifted = memo.lowerings.shifted if memo is not None and lowering is not None else {}
    analysis.diagnostics = _placed_all(analysis, diagnostics, previous if previous is not None
                                       and previous.path == resolved else None, here, shifted,
                                       lambda d: _place_diagnostic(analysis, d, by_display,
                                                                   graph, pages, own))
    if context.problem:
        analysis.diagnostics.insert(0, EditorDiagnostic(line_range(0, 0, 0), "error", "",
                                                        context.problem, "", (), None))
    return analysis


def _placed_all(analysis: Analysis, diagnostics: list[Diagnostic], previous: Analysis | None,
                here: set[str], shifted: Mapping[int, tuple[Diagnostic, Diagnostic, int]],
                place: Callable[[Diagnostic], EditorDiagnostic | None]
                ) -> list[EditorDiagnostic]:
    """Every diagnostic placed in the document, in order: the last analysis's placement where
    it still holds, else a new one (`place`; None: shown in another document).

    The diagnostics the last analysis placed at the start and at the end of its list that
    are the very objects found there now (a program the edit left alone keeps its own; a
    whole device has thousands) keep their placements as slices, when the lines those were
    made from are among the lines the edit left as they were (`_still_placed`): compared as
    pointers and numbers in C, the objects not read. Of the ones in between, a diagnostic
    kept by identity on a line of the same text, or moved with a program that only moved,
    keeps its placement; so does one equal to one placed last time on a line of the same
    text (a program that was checked again reports mostly the same diagnostics as new
    objects). Only the rest are placed afresh."""
    count = len(diagnostics)
    found: list[EditorDiagnostic | None] = [None] * count
    keys = array("l", [-1]) * count
    rest: list[int] = list(range(count))  # the indices looked at one by one
    before: dict[int, tuple[Diagnostic, str, EditorDiagnostic]] = {}
    if previous is not None and previous.raw:
        old, old_lines = previous.raw, previous.lines
        head, tail = same_ends(old, diagnostics)
        found[:head] = previous.raw_placed[:head]
        keys[:head] = previous.raw_lines[:head]
        if tail:
            found[count - tail:] = previous.raw_placed[len(old) - tail:]
            keys[count - tail:] = previous.raw_lines[len(old) - tail:]
        # the kept ones whose line the edit may have changed, or placed from none, too
        edited = analysis.edited
        if edited is None or edited[0] is not old_lines:
            edited = analysis.edited = (old_lines, *shared_lines(old_lines, analysis.lines))
        _, start, end = edited
        unplaced = _unplaced(old_lines, analysis.lines, start, end).__getitem__
        rest = [*compress(range(head), map(unplaced, keys[:head])),
                *range(head, count - tail),
                *compress(range(count - tail, count), map(unplaced, keys[count - tail:]))]
        for index in [*range(head, len(old) - tail),  # the last one's among them, by id
                      *(i - count + len(old) for i in rest if i < head or i >= count - tail)]:
            line, placed = previous.raw_lines[index], previous.raw_placed[index]
            if line >= 0 and placed is not None:
                before[id(old[index])] = (old[index], old_lines[line], placed)
    lines, kept_now = analysis.lines, analysis.placed
    missed: list[int] = []
    for index in rest:
        diagnostic = diagnostics[index]
        placed = _reuse_placed(analysis, diagnostic, before, here, shifted) if before else None
        if placed is None:
            missed.append(index)
        found[index] = placed
    alike: dict[Diagnostic, tuple[Diagnostic, str, EditorDiagnostic]] = {}
    if missed and before:
        taken = set(kept_now)  # by identity: the same ids as last time
        taken.update(id(shifted[key][1]) for key in kept_now.keys() & shifted.keys())
        alike = {before[key][0]: before[key] for key in before.keys() - taken}
    for index in missed:
        diagnostic = diagnostics[index]
        kept = alike.get(diagnostic)
        span = diagnostic.span
        if kept is not None and span.file in here and 0 < span.line <= len(lines) and \
                lines[span.line - 1] == kept[1]:
            kept_now[id(diagnostic)] = (diagnostic, kept[1], kept[2])
            found[index] = kept[2]
        else:
            found[index] = place(diagnostic)
    for index in rest:  # placed from a line of its own: kept next time
        keys[index] = diagnostics[index].span.line - 1 if id(diagnostics[index]) in kept_now \
            else -1
    analysis.raw, analysis.raw_placed, analysis.raw_lines = diagnostics, found, keys
    return list(filter(None, found))  # in C: a placement is never false


def _unplaced(old: list[str], new: list[str], start: int, end: int) -> bytearray:
    """For each line of the old text (0-based), and for -1 (placed from no line of its
    own) last, whether a placement made from it must be looked at again: from the first line
    the edit changed to its last one when it kept the number of lines, else to the end
    (`start`, `end`: the lines both texts share at either end, `ends.shared_lines`).
    Looked up per placement in C. A placement's line is always one of the old text's."""
    flags = bytearray(len(old) + 1)
    stop = len(old) - end if len(old) == len(new) else len(old)
    if stop > start:
        flags[start:stop] = b"\x01" * (stop - start)
    flags[-1] = 1
    return flags


class _Family(Protocol):
    TARGETS: tuple[str, ...]

    def compile_mp(self, paths: list[Path], options: Options, target: str, *,
                   texts: dict[Path, str] | None = None) -> _FamilyBuild: ...


class _FamilyBuild(Protocol):
    @property
    def diagnostics(self) -> list[Diagnostic]: ...


def _family_of(target: str) -> _Family | None:
    """The FATEK or CSIM package a project's target names, None for the M8194H."""
    if target in ("et", "rs"):
        return None
    from mplang import csim, fatek

    for family in (fatek, csim):
        if target in family.TARGETS:
            return cast(_Family, family)
    return None


def _code_text(line: str, tokens: list[Token]) -> str:
    code = [t for t in tokens if t.kind != "comment"]
    return line[code[0].start:code[-1].end] if code else ""


def _span_location(span: Span, entry: SourceText) -> Location:
    return Location(entry.path, span_range(span, entry.lines))


def _line_tokens(entry: SourceText, line: int) -> list[Token]:
    """Tokens of a 1-based line of a file."""
    return lex_line(entry.lines[line - 1]) if 0 < line <= len(entry.lines) else []


_INDEXED = (ast.Const, ast.Alias, ast.VarDecl, ast.ProgramHeader, ast.End, ast.LabelStmt,
            ast.Include)
"""The statements `_index_file` reads."""
_INDEXED_TYPES = frozenset(_INDEXED)
"""The same, looked up by exact type (thousands of statements a check; no syntax-tree class
has subclasses)."""


@dataclass
class _FileIndex:
    """What `_index_file` found in one file, kept for the next check: the statements it
    read (the very objects), the lines whose text it read and those texts, the file's line
    count, and what it found (a table's candidates in order, blocks, INCLUDEs as spelt)."""

    indexed: list[ast.Statement]
    positions: array[int]  # where each of `indexed` stands in the file's statements
    count: int  # how many statements the file had
    lines: list[str]  # the file's lines they were found on (the very list)
    read: list[int]  # 0-based lines of the statements other than END
    texts: list[str]
    line_count: int
    definitions: list[tuple[int, str, Definition]]  # table (0-2), upper-case key, definition
    blocks: list[ProgramBlock]
    includes: list[tuple[Range, str]]  # of the open document: where, and the path as spelt
    spelled: list[str]  # every INCLUDE's path as spelt


_KEPT_INDEXES = 64
"""How many files keep their index (the open documents and the files they INCLUDE)."""
_indexes: dict[tuple[Path, bool], _FileIndex] = {}
_TABLES = {ast.Const: (0, "const"), ast.Alias: (1, "alias"), ast.VarDecl: (2, "var")}


def _index_file(analysis: Analysis, source: SourceFile, entry: SourceText,
                resolve: Callable[[Path], Path]) -> list[str]:
    """Definitions, program blocks and INCLUDE lines of one file: what the last check of
    the file found, when it read the very same statements (an edit of a command line leaves
    every statement this reads as it was) on lines of the same text, else read again. The
    paths its INCLUDEs spell, for the include graph."""
    root = entry.path == analysis.path
    kept = _indexes.get((entry.path, root))
    statements = source.statements
    found = _indexed_after_edit(statements, kept, analysis.edited, entry.lines) \
        if root and kept is not None else None
    indexed, positions = found if found is not None else picked(statements,
                                                                _INDEXED_TYPES)
    if kept is None or kept.line_count != len(entry.lines) or \
            len(kept.indexed) != len(indexed) or \
            same_ends(kept.indexed, indexed)[0] != len(indexed) or \
            kept.texts != list(map(entry.lines.__getitem__, kept.read)):
        kept = _index_of(indexed, entry, root)
        if len(_indexes) >= _KEPT_INDEXES:
            _indexes.clear()
        _indexes[(entry.path, root)] = kept
    kept.positions, kept.count, kept.lines = positions, len(statements), entry.lines
    tables = (analysis.consts, analysis.aliases, analysis.declared)
    for table, key, definition in kept.definitions:  # the first of a name wins, over files
        if all(key not in t for t in tables):
            tables[table][key] = definition
    analysis.programs += kept.blocks  # the same blocks: nothing changes one once indexed
    analysis.includes += [IncludeLine(where, resolve(entry.path.parent / spelled), spelled)
                          for where, spelled in kept.includes]
    return kept.spelled


def _indexed_after_edit(statements: list[ast.Statement], kept: _FileIndex,
                        edited: tuple[list[str], int, int] | None, lines: list[str]
                        ) -> tuple[list[ast.Statement], array[int]] | None:
    """The statements `_index_file` reads in the open document after an edit that kept its
    number of lines, looking only at those of the edited lines (`ends.picked_again`): a
    statement of a line the edit left alone is of the kind it was, one statement per line
    being parsed by its text alone (`lang.linecache`). None when the kept index was not
    found on the last text, or a statement is not where it stood."""
    if edited is None or kept.lines is not edited[0] or len(edited[0]) != len(lines):
        return None
    _, head, tail = edited
    # the statements of the edited lines (1-based head + 1 .. len - tail; in line order)
    start = bisect.bisect_left(statements, head + 1, key=_statement_line)
    stop = bisect.bisect_left(statements, len(lines) - tail + 1, key=_statement_line)
    return picked_again(statements, _INDEXED_TYPES, (kept.indexed, kept.positions, kept.count),
                        start, stop)


def _statement_line(statement: ast.Statement) -> int:
    return statement.span.line


def _index_of(indexed: list[ast.Statement], entry: SourceText, root: bool) -> _FileIndex:
    """`_index_file` of statements it has not read as they are."""
    found = _FileIndex(indexed, array("l"), 0, entry.lines, [], [], len(entry.lines), [], [],
                       [], [])
    open_block: ProgramBlock | None = None

    def close(last_line: int) -> None:
        nonlocal open_block
        if open_block is not None:
            open_block.last_line = max(open_block.first_line, last_line)
            found.blocks.append(open_block)
            open_block = None

    for statement in indexed:
        # commands and the like define nothing: they are not visited
        if isinstance(statement, ast.End):
            if statement.what in ("mp", "isr"):
                close(statement.span.line - 1)
            continue
        line = statement.span.line
        found.read.append(line - 1)
        found.texts.append(entry.lines[line - 1])
        tokens = _line_tokens(entry, line)
        text = _code_text(entry.lines[line - 1], tokens) if tokens else ""
        if isinstance(statement, ast.Include):
            found.spelled.append(statement.path)
        match statement:
            case ast.Const() | ast.Alias() | ast.VarDecl():
                table, kind = _TABLES[type(statement)]
                found.definitions.append((table, statement.name.upper(), Definition(
                    kind, statement.name, _span_location(statement.name_span, entry), text)))
            case ast.ProgramHeader():
                close(line - 2)
                open_block = _program_block(statement, entry, tokens, line - 1)
            case ast.LabelStmt() if open_block is not None:
                label = tokens[1] if len(tokens) > 1 and tokens[1].kind in ("name", "int") \
                    else None
                key = statement.label.upper()
                if label is not None and key not in open_block.labels:
                    open_block.labels[key] = Definition(
                        "label", statement.label,
                        Location(entry.path, line_range(line - 1, label.start, label.end)),
                        text)
            case ast.Include() if root:
                quoted = next((t for t in tokens if t.kind == "string"), None)
                if quoted is not None:
                    found.includes.append((line_range(line - 1, quoted.start, quoted.end),
                                           statement.path))
    close(len(entry.lines) - 1)
    return found


_header_ranges: dict[tuple[str, int], tuple[Range, Range]] = {}
"""A header line's name and code ranges, by its text and line: a whole device's 1,770
headers, nearly all where they were at the last check."""


def _program_block(header: ast.ProgramHeader, entry: SourceText, tokens: list[Token],
                   line: int) -> ProgramBlock:
    key = (entry.lines[line], line)
    ranges = _header_ranges.get(key)
    if ranges is None:
        if len(_header_ranges) >= 32_768:
            _header_ranges.clear()
        ranges = _header_ranges[key] = _header_ranges_of(tokens, line)
    return ProgramBlock(header.kind, header.number, header.name, entry.path, ranges[0],
                        ranges[1], line, line)


def _header_ranges_of(tokens: list[Token], line: int) -> tuple[Range, Range]:
    """A header's name (else number, else keyword) and its code without the comment."""
    code = [t for t in tokens if t.kind != "comment"]
    named = [t for t in code[1:3] if t.kind in ("name", "int")]
    chosen = named[-1] if named else (code[0] if code else None)
    name_range = line_range(line, chosen.start, chosen.end) if chosen else \
        line_range(line, 0, 0)
    header_range = line_range(line, code[0].start, code[-1].end) if code else name_range
    return name_range, header_range


def _measure_programs(analysis: Analysis, files: list[SourceFile],
                      by_display: dict[str, SourceText], catalogue: Catalogue,
                      options: Options, lowering: Lowering | None = None) -> None:
    """Lines used and slot of every program, from the compiler's own lowering and linker.

    The compiler links also when the build has errors, so the budgets show while the
    document is being fixed (lines that do not compile are not counted): `lowering` holds
    what its pass worked out. Without it (a FATEK or CSIM project, whose `.mp` files the
    family compiles) the same passes run here.
    """
    if lowering is None or lowering.scope is None:
        sink = DiagnosticSink()
        unit = build_unit(SourceSet(files), sink)
        scope = Scope.declared(unit, catalogue, sink, options.var_pool, options.temps)
        lowered = lower_unit(unit, scope, sink, options).programs
        linked = link(lowered, catalogue.profile, sink, options.pins)
    else:
        scope, lowered, linked = lowering.scope, lowering.programs, lowering.placements
    analysis.const_values = dict(scope.const_values)
    analysis.alias_targets = dict(scope.aliases)
    analysis.pinned = {v.name.upper() for v in scope.variables if v.pinned}
    placements: dict[int, Placement] = {id(p.program): p for p in linked}
    close_counts = catalogue.profile.close_counts_as_line
    uses = analysis.slot_uses
    for program in lowered:
        entry = by_display.get(program.span.file)
        if entry is None:
            continue
        placement = placements.get(id(program))
        key = (program.kind, placement.slot, placement.lines_used, placement.budget,
               placement.auto) if placement is not None else \
            (program.kind, None, program.lines_used(close_counts), None, False)
        use = _slot_uses.get(key)
        if use is None:
            if len(_slot_uses) >= 4096:
                _slot_uses.clear()
            use = _slot_uses[key] = SlotUse(*key)
        uses[(entry.path, program.span.line - 1)] = use


_slot_uses: dict[tuple[str, int | None, int, int | None, bool], SlotUse] = {}
"""Slot uses by their fields (frozen: shared by every analysis that has one alike; a whole
device's check has 177, nearly all as they were at the last check)."""


def _include_target(including: Path, spelled: str, analysis: Analysis,
                    by_display: dict[str, SourceText], resolve: Callable[[Path], Path]
                    ) -> Path:
    """The file an INCLUDE names: relative to the including file or, when no loaded file is
    there, the loaded file the loader named by that spelling (a library include)."""
    candidate = resolve(including.parent / spelled)
    if candidate not in analysis.files and spelled in by_display:
        return by_display[spelled].path
    return candidate


def _include_graph(files: list[SourceFile], spelled: dict[Path, list[str]],
                   analysis: Analysis, by_display: dict[str, SourceText],
                   resolve: Callable[[Path], Path]) -> dict[Path, list[Path]]:
    """The files each file INCLUDEs (`spelled`: the paths as its index read them)."""
    graph: dict[Path, list[Path]] = {}
    for source in files:
        including = resolve(source.path)
        graph[including] = [_include_target(including, path, analysis, by_display, resolve)
                            for path in spelled.get(including, ())]
    return graph


def _reachable(start: Path, graph: dict[Path, list[Path]]) -> set[Path]:
    seen: set[Path] = set()
    todo = [start]
    while todo:
        current = todo.pop()
        if current in seen:
            continue
        seen.add(current)
        todo.extend(graph.get(current, []))
    return seen


def _reuse_placed(analysis: Analysis, diagnostic: Diagnostic,
                  before: dict[int, tuple[Diagnostic, str, EditorDiagnostic]],
                  here: set[str],
                  shifted: Mapping[int, tuple[Diagnostic, Diagnostic, int]]
                  ) -> EditorDiagnostic | None:
    """The placement of the last analysis, for the same diagnostic object (a program the
    edit left alone: `mplang.ir.reuse`) on a line of this document (`here`: its names)
    whose text is unchanged: a placement reads nothing else. A diagnostic of a program that
    only moved (`shifted`: it, the kept one, the offset) takes the kept one's placement on
    a line moved as much. None when it must be placed afresh."""
    kept = before.get(id(diagnostic))
    offset = 0
    if kept is None:
        moved = shifted.get(id(diagnostic))
        if moved is None or moved[0] is not diagnostic:
            return None
        _, old, offset = moved
        kept = before.get(id(old))
        if kept is None or kept[0] is not old:
            return None
    elif kept[0] is not diagnostic:
        return None
    span = diagnostic.span
    lines = analysis.lines
    if span.file not in here or not 0 < span.line <= len(lines) or \
            lines[span.line - 1] != kept[1]:
        return None
    if offset:
        placed = kept[2]
        start, end = placed.range.start, placed.range.end
        if not start.line == end.line == span.line - 1 - offset:
            return None  # placed on another line than its own (never, as placed now)
        kept = (diagnostic, kept[1], EditorDiagnostic(  # written out: `replace` costs 3x
            line_range(span.line - 1, start.character, end.character), placed.severity,
            placed.code, placed.message, placed.hint, placed.related, placed.docs,
            placed.elsewhere))
        analysis.moved[id(kept[2])] = (kept[2], placed, offset)
    analysis.placed[id(diagnostic)] = kept
    return kept[2]


def _place_diagnostic(analysis: Analysis, diagnostic: Diagnostic,
                      by_display: dict[str, SourceText],
                      graph: dict[Path, list[Path]], pages: dict[str, Path | None],
                      own: set[int]) -> EditorDiagnostic | None:
    """Put a diagnostic where the editor shows it: at its own place in the open document,
    on the INCLUDE line through which the file it is in joined the build, or (a file that is
    no source, such as mpc.toml) on the first line. One that belongs to another source of the
    project is left to that document."""
    related = tuple((_span_location(span, by_display[span.file]), note)
                    for span, note in diagnostic.related if span.file in by_display)
    if diagnostic.code not in pages:  # shipped in the package, or the checkout's docs/
        pages[diagnostic.code] = check_page(diagnostic.code)
    docs = pages[diagnostic.code]
    entry = by_display.get(diagnostic.span.file)
    message = diagnostic.message
    here = id(entry) in own  # never the id of None: `own` holds loaded files only
    if here:
        where = span_range(diagnostic.span, analysis.lines)
        line = diagnostic.span.line
        if not related and 0 < line <= len(analysis.lines):
            placed = EditorDiagnostic(where, diagnostic.severity.value, diagnostic.code,
                                      message, diagnostic.hint, related, docs)
            analysis.placed[id(diagnostic)] = (diagnostic, analysis.lines[line - 1], placed)
            return placed
    else:
        message = f"{diagnostic.span}: {message}"
        where = line_range(0, 0, 0)
        if entry is not None:
            related = ((_span_location(diagnostic.span, entry), diagnostic.message), *related)
            through = next((include for include in analysis.includes
                            if entry.path in _reachable(include.target, graph)), None)
            if through is None:
                return None
            where = through.range
    return EditorDiagnostic(where, diagnostic.severity.value, diagnostic.code, message,
                            diagnostic.hint, related, docs, elsewhere=not here)

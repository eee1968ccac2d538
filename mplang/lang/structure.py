"""Flat line statements -> programs with nested FOR and IF blocks.

This is where MP/END MP, FOR/NEXT and IF/ELSE/END IF are matched. Every imbalance is
reported (the device's download errors 0x03-0x05 and 0x08-0x0A) and the pass carries on, so
that one run lists all of them. The raw command spellings of block commands (`END_IF`,
`EXIT_FOR`, `MP_CALL`, ...) are turned into the same statements as the keywords.
"""

from __future__ import annotations

import re

from mplang.lang import ast
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Span
from mplang.lang.limits import MAX_BLOCK_DEPTH
from mplang.lang.linecache import text_lines
from mplang.lang.sources import SourceSet

BLOCK_WORD = {"mp": "END MP", "isr": "END ISR", "for": "NEXT", "if": "END IF",
              "while": "END WHILE", "repeat": "END REPEAT", "init": "END INIT",
              "interrupts": "END INTERRUPTS", "triggers": "END TRIGGERS"}
# Top-level configuration blocks (docs/configuration.md): not programs, no nesting.
CONFIG_KINDS = ("init", "interrupts", "triggers")
CONFIG_HEADERS = (ast.InitHeader, ast.InterruptsHeader, ast.TriggersHeader)
STRAY_CLOSE = {"for": "E304", "if": "E308", "while": "E315", "repeat": "E315"}
_MATCHED = frozenset({*CONFIG_HEADERS, ast.End, ast.OnStmt, ast.Const, ast.Alias, ast.VarDecl,
                      ast.Include, ast.ProgramHeader, ast.ForStmt, ast.IfStmt, ast.WhileStmt,
                      ast.RepeatStmt, ast.Next, ast.Else})
"""The statement classes `_build_file` matches by a case of their own; any other statement
inside a program is a line of its innermost block (most of a build's lines)."""
_LONE_CR = re.compile(r"\r(?!\n)")


class _Open:
    """A block being built: the program, a FOR or an IF (with its two branches). A slots
    class, not a dataclass: creating one at import costs every command's start."""

    __slots__ = ("body", "dropped", "else_span", "head", "kind", "otherwise", "target")

    def __init__(self, kind: str, head: ast.Statement) -> None:
        self.kind = kind  # "mp" | "isr" | "for" | "if" | "while" | "repeat"
        self.head = head
        self.body: list[ast.Node] = []
        self.otherwise: list[ast.Node] | None = None
        self.else_span: Span | None = None
        self.dropped = False  # nested beyond MAX_BLOCK_DEPTH: reported, left out of the tree
        # where its lines go: its body, or after an ELSE the other branch (`begin_else`)
        self.target = self.body

    def begin_else(self, span: Span) -> None:
        """The ELSE of this IF: the lines after it go to the other branch."""
        self.otherwise = self.target = []
        self.else_span = span


_BLOCK_COMMANDS = frozenset({"END_IF", "ELSE", "EXIT_FOR", "EXIT_MACRO", "MP_TERMINATE",
                             "NEXT", "FOR", "IF", "MP_CALL", "GOTO", "LABEL"})
"""The raw command names `normalise` turns into statements (besides their RSM_MACRO_ and
ETM_MACRO_ spellings): any other command is taken as it is, after one set lookup."""


_PLAIN_LIMIT = 4096
_plain_names: set[str] = set()
"""Command names, as written, that `normalise` leaves as they are (a function of the name
alone), learnt as they are met, at most `_PLAIN_LIMIT` of them: block matching tests one
set membership for most of its commands instead of calling `normalise`."""


def normalise(statement: ast.Statement) -> ast.Statement:
    """Raw spellings of block commands become the statements their keywords make."""
    if not isinstance(statement, ast.Command):
        return statement
    name = statement.name.upper()
    if name not in _BLOCK_COMMANDS and not name.startswith(("RSM_MACRO_", "ETM_MACRO_")):
        if len(_plain_names) < _PLAIN_LIMIT:
            _plain_names.add(statement.name)
        return statement
    for prefix in ("RSM_MACRO_", "ETM_MACRO_"):
        if name.startswith(prefix):
            name = name[len(prefix):]
    span, args = statement.span, statement.args
    if not args:
        simple: dict[str, ast.Statement] = {
            "END_IF": ast.End("if", span), "ELSE": ast.Else(span),
            "EXIT_FOR": ast.ExitFor(span), "EXIT_MACRO": ast.Exit(span),
            "MP_TERMINATE": ast.Terminate(span),
        }
        if name in simple:
            return simple[name]
    if name == "NEXT" and not args:
        return ast.Next(span)
    if name == "FOR" and len(args) == 1:
        return ast.ForStmt(args[0], span)
    if name == "IF" and len(args) == 3:  # the operator as a string, a code or LE/EQ/...
        return ast.IfStmt(args[0], _operator_text(args[1]), args[2], span)
    if len(args) == 1 and isinstance(args[0], ast.Name | ast.Num):
        target = args[0].name if isinstance(args[0], ast.Name) else str(args[0].value)
        if name == "MP_CALL":
            return ast.CallStmt(target, span, args[0].span)
        if name in ("GOTO", "LABEL"):
            return ast.Goto(target, span, args[0].span) if name == "GOTO" else \
                ast.LabelStmt(target, span)
    return statement


def _operator_text(expr: ast.Expr) -> str:
    """A raw IF's operator as written ("<=", 0x3D3C, LE), for the lowering to resolve: any
    three-argument IF opens a block, so a refused operator is one error, not also an
    unmatched END IF."""
    match expr:
        case ast.Str(value=value) | ast.Name(name=value):
            return value
        case ast.Num(value=number):
            return hex(number)  # operator codes are written in hex (0x3D3D)
    return "?"


class _Built:
    """A program as one build matched it: its statements, from its header to its END, the
    program and what matching them reported (a slots class, as `_Open`)."""

    __slots__ = ("diagnostics", "program", "statements", "texts")

    def __init__(self, statements: list[ast.Statement], program: ast.Program,
                 diagnostics: list[Diagnostic], texts: list[str] | None = None) -> None:
        self.statements = statements
        self.program = program
        self.diagnostics = diagnostics
        self.texts: list[str] = [] if texts is None else texts  # its lines, header to END


RUN = 16
"""Top-level statements (a line, or a whole block) per kept run at most: an edit inside a
long program matches again the run it falls in, statement by statement, and takes every
other run whole."""


class _Run:
    """Consecutive top-level statements of a program, as one build matched them with nothing
    to report: their statements, opening to closing, the nodes they made, and the blocks
    among them as `BlockMemo.find_block` keeps them (a slots class, as `_Open`). At the
    top level of a program, matching a statement depends on it alone (and on what follows
    it, for a block), so equal statements make the same nodes."""

    __slots__ = ("blocks", "nodes", "statements")

    def __init__(self, statements: list[ast.Statement], nodes: list[ast.Node],
                 blocks: list[tuple[Span, tuple[list[ast.Statement], ast.Node]]]) -> None:
        self.statements = statements
        self.nodes = nodes
        self.blocks = blocks


class _Runs:
    """The run being gathered while one file's programs are matched: the top-level
    statements from `start` to the last boundary `end` between two of them where nothing
    had been reported since `start`, and the nodes and kept blocks they made."""

    __slots__ = ("body_end", "body_start", "end", "file", "items", "mark", "memo", "program",
                 "recent_end", "recent_start", "start", "statements")

    def __init__(self, memo: BlockMemo, file: str, statements: list[ast.Statement]) -> None:
        self.memo, self.file, self.statements = memo, file, statements
        self.program: _Open | None = None
        self.start = self.end = self.mark = self.items = 0
        self.body_start = self.body_end = self.recent_start = self.recent_end = 0

    def boundary(self, program: _Open, index: int, reported: int) -> None:
        """`statements[index]` is at the top level of `program` (a statement ends there),
        with `reported` diagnostics in the sink so far."""
        if program is self.program and reported == self.mark:
            if index > self.end:
                self.items += 1
                self.end, self.body_end = index, len(program.body)
                self.recent_end = len(self.memo.recent)
                if self.items == RUN:
                    self.begin(program, index, reported)
            return
        self.begin(program, index, reported)

    def begin(self, program: _Open, index: int, reported: int) -> None:
        """Keep the run gathered so far, and gather another from `index` on."""
        self.close()
        self.program, self.start, self.end, self.mark, self.items = \
            program, index, index, reported, 0
        self.body_start = self.body_end = len(program.body)
        self.recent_start = self.recent_end = len(self.memo.recent)

    def close(self) -> None:
        """Keep the run gathered so far, if any."""
        if self.program is not None and self.items:
            self.memo.keep_run(self.file, _Run(
                self.statements[self.start:self.end],
                self.program.body[self.body_start:self.body_end],
                self.memo.recent[self.recent_start:self.recent_end]))
        self.program = None


class BlockMemo:
    """The programs of the last build, so that the next one takes a program whose
    statements are unchanged (equal, and at the same place) as the same `ast.Program`
    object, with the diagnostics it had, instead of matching its blocks again.

    Only a program that starts at the top level and is closed by its own END is kept: its
    matching then depends on its statements alone. The same objects also tell the later
    passes (`mplang.ir.reuse`) what an edit left alone. Entries no build used last time are
    dropped, so the memo holds about one build's programs.

    A program that only moved (lines inserted or deleted above it) is matched again, from
    the statements the parse moved, and `moved` names the program it was last time and
    by how many lines it moved: its lines' texts, header to END, are those of a kept
    program, so its statements are the same but for their lines (a line's statements are
    a function of its text: `lang.linecache`). The later passes shift what they kept."""

    def __init__(self) -> None:
        self._now: dict[Span, _Built] = {}
        self._before: dict[Span, _Built] = {}
        self._texts_now: dict[tuple[str, str], _Built] = {}  # by file and header text
        self._texts_before: dict[tuple[str, str], _Built] = {}
        # this build's programs that only moved: id -> (the program, as kept, by lines)
        self.moved: dict[int, tuple[ast.Program, ast.Program, int]] = {}
        # blocks at the top level of a program, by the span of their opening line: (their
        # statements, opening to closing, and the node they made), for `find_block`
        self._blocks_now: dict[Span, tuple[list[ast.Statement], ast.Node]] = {}
        self._blocks_before: dict[Span, tuple[list[ast.Statement], ast.Node]] = {}
        # runs of a program's top-level statements (`find_run`), by file and first line
        self._runs_now: dict[tuple[str, int], _Run] = {}
        self._runs_before: dict[tuple[str, int], _Run] = {}
        # the blocks this build found or kept, in order, for the runs that hold them
        self.recent: list[tuple[Span, tuple[list[ast.Statement], ast.Node]]] = []

    def find_run(self, file: str, statements: list[ast.Statement], index: int) -> _Run | None:
        """The kept run of top-level statements (`_Run`) that starts at `statements[index]`,
        if the statements that follow are still its statements; else None, and the blocks
        it holds can be found one by one again (`find_block`)."""
        key = (file, statements[index].span.line)
        run = self._runs_before.pop(key, None)
        if run is None:
            return None
        if statements[index:index + len(run.statements)] != run.statements:
            self._blocks_now.update(run.blocks)
            return None
        self._runs_now[key] = run
        return run

    def keep_run(self, file: str, run: _Run) -> None:
        """Keep a run of top-level statements matched with nothing to report."""
        self._runs_now[(file, run.statements[0].span.line)] = run

    def find_block(self, statements: list[ast.Statement], index: int
                   ) -> tuple[list[ast.Statement], ast.Node] | None:
        """The kept top-level block (FOR, IF, WHILE, REPEAT) that `statements[index]`
        opens, if the statements that follow are still its statements: an edit inside a
        long program matches again only the blocks it changed, and the later passes see
        the others as the same objects (`mplang.ir.blockmemo`)."""
        span = statements[index].span
        kept = self._blocks_now.get(span) or self._blocks_before.get(span)
        if kept is None or statements[index:index + len(kept[0])] != kept[0]:
            return None
        self._blocks_now[span] = kept
        self.recent.append((span, kept))
        return kept

    def keep_block(self, statements: list[ast.Statement], node: ast.Node) -> None:
        """Keep a top-level block that matched with nothing to report: its matching then
        depends on its statements alone (a program's header or END, a declaration, a depth
        beyond the limit inside it is reported)."""
        kept = (statements, node)
        self._blocks_now[statements[0].span] = kept
        self.recent.append((statements[0].span, kept))

    def find(self, statements: list[ast.Statement], index: int) -> _Built | None:
        """The kept program whose header is `statements[index]`, if the statements that
        follow it are still its statements."""
        span = statements[index].span
        kept = self._now.get(span) or self._before.get(span)
        if kept is None:
            return None
        count = len(kept.statements)
        if statements[index:index + count] != kept.statements:  # identity first, then value
            return None
        self._now[span] = kept
        if kept.texts:
            self._texts_now[(span.file, kept.texts[0])] = kept
        return kept

    def find_moved(self, file: str, texts: list[str], line: int) -> _Built | None:
        """The kept program of `file` that stood elsewhere and whose lines' texts are those
        from `line` (its header, 1-based) on."""
        key = (file, texts[line - 1])
        kept = self._texts_now.get(key) or self._texts_before.get(key)
        if kept is None or not kept.texts or kept.statements[0].span.line == line or \
                texts[line - 1:line - 1 + len(kept.texts)] != kept.texts:
            return None
        return kept

    def keep(self, built: _Built, origin: _Built | None = None) -> None:
        """Keep a program matched in this build; `origin`, the kept program whose lines it
        has at another place (`find_moved`), is recorded in `moved` when the matching took
        the same lines and statements (it does: a guard, not a choice)."""
        header = built.statements[0].span
        self._now[header] = built
        if built.texts:
            self._texts_now[(header.file, built.texts[0])] = built
        if origin is not None and len(origin.statements) == len(built.statements) and \
                origin.texts == built.texts:
            self.moved[id(built.program)] = (
                built.program, origin.program, header.line - origin.statements[0].span.line)

    def start(self) -> None:
        """A build begins: `moved` is about its programs only."""
        self.moved = {}

    def turn(self) -> None:
        """A build is over: what it did not use is forgotten."""
        self._before, self._now = self._now, {}
        self._texts_before, self._texts_now = self._texts_now, {}
        self._blocks_before, self._blocks_now = self._blocks_now, {}
        self._runs_before, self._runs_now = self._runs_now, {}
        self.recent = []


def has_lone_cr(text: str) -> bool:
    """Whether `text` has a carriage return that does not end a line: the parse then
    numbers its lines otherwise, and its lines are not `text.split("\n")`."""
    return "\r" in text and _LONE_CR.search(text) is not None


def build_unit(sources: SourceSet, sink: DiagnosticSink, memo: BlockMemo | None = None
               ) -> ast.Unit:
    """The files' statements matched into programs and configuration blocks; `memo`, kept
    between builds, takes unchanged programs from the last one."""
    unit = ast.Unit()
    if memo is not None:
        memo.start()
    for source in sources.files:
        # the lines' texts, as the parse numbers them (a lone carriage return: no texts)
        texts = text_lines(source.text) if memo is not None and \
            not has_lone_cr(source.text) else None
        _build_file(source.statements, source.display, unit, sink, memo, texts)
    if memo is not None:
        memo.turn()
    return unit


def _build_file(statements: list[ast.Statement], file: str, unit: ast.Unit,
                sink: DiagnosticSink, memo: BlockMemo | None = None,
                texts: list[str] | None = None) -> None:
    """One file's statements matched into blocks (`texts`, the file's lines, tell a kept
    program that moved). One function: the nested helpers share the stack of open blocks,
    and each rule reads as one case of the match."""
    stack: list[_Open] = []
    started: int | None = None  # where the program being matched began, when it can be kept
    mark = 0  # the sink's length then
    origin: _Built | None = None  # the kept program it is, moved
    # the top-level block being matched, when it can be kept: where it began, the sink then
    block_start: int | None = None
    block_mark = 0
    runs = _Runs(memo, file, statements) if memo is not None else None

    def close_program(end_span: Span) -> None:
        block = stack.pop()
        header = block.head
        assert isinstance(header, ast.ProgramHeader)
        unit.programs.append(ast.Program(header.kind, header.number, header.name, block.body,
                                         header.span, end_span, file))

    def unclosed(block: _Open, at: Span) -> None:
        code = {"for": "E305", "if": "E309", "mp": "E302", "isr": "E302", "while": "E314",
                "repeat": "E314"}[block.kind]
        what = block.kind.upper()
        sink.add(code, block.head.span, f"{what} is not closed by {BLOCK_WORD[block.kind]}",
                 hint=f"add {BLOCK_WORD[block.kind]} before line {at.line}"
                 if block.kind not in ("mp", "isr") else f"add {BLOCK_WORD[block.kind]}")

    def close_inner(block: _Open, end_span: Span) -> None:
        node: ast.Node
        if block.dropped:
            return
        if block.kind == "for":
            assert isinstance(block.head, ast.ForStmt)
            node = ast.ForBlock(block.head.count, block.body, block.head.span, end_span)
        elif block.kind == "while":
            assert isinstance(block.head, ast.WhileStmt)
            node = ast.WhileBlock(block.head.left, block.head.op, block.head.right, block.body,
                                  block.head.span, end_span)
        elif block.kind == "repeat":
            assert isinstance(block.head, ast.RepeatStmt)
            node = ast.RepeatBlock(block.head.count, block.body, block.head.span, end_span)
        else:
            assert isinstance(block.head, ast.IfStmt)
            node = ast.IfBlock(block.head.left, block.head.op, block.head.right, block.body,
                               block.otherwise, block.head.span, block.else_span, end_span)
        stack[-1].target.append(node)
        if memo is not None and len(stack) == 1 and block_start is not None and \
                len(sink.items) == block_mark:
            memo.keep_block(statements[block_start:index], node)

    def in_program() -> bool:
        return bool(stack)

    def open_block(kind: str, statement: ast.Statement) -> None:
        """Push a FOR/IF/WHILE/REPEAT. Beyond MAX_BLOCK_DEPTH the block is matched with its
        closer as usual but left out of the program (reported once, at its outermost
        level), so no later pass walks a tree deeper than that."""
        nonlocal block_start, block_mark
        block = _Open(kind, statement)
        if len(stack) == 1:
            block_start, block_mark = index - 1, len(sink.items)
        if stack[-1].dropped:
            block.dropped = True
        elif len(stack) > MAX_BLOCK_DEPTH:
            block.dropped = True
            code = "E310" if kind in ("if", "while") else "E311"
            sink.add(code, statement.span, f"{kind.upper()} nested {len(stack)} blocks deep: "
                     f"the compiler follows {MAX_BLOCK_DEPTH} levels of blocks (the device "
                     "far fewer); the lines inside are not compiled",
                     hint="flatten the conditions, or move the inner part into a called MP")
        stack.append(block)

    def close_config(end_span: Span) -> None:
        block = stack.pop()
        head = block.head
        if isinstance(head, ast.InitHeader):
            unit.inits.append(ast.InitBlock(
                [s for s in block.body if isinstance(s, ast.Command)], head.span, end_span, file))
        elif isinstance(head, ast.InterruptsHeader):
            unit.interrupts.append(ast.InterruptsBlock(
                head.target, head.target_span,
                [s for s in block.body if isinstance(s, ast.OnStmt)], head.span, end_span,
                file))
        else:
            assert isinstance(head, ast.TriggersHeader)
            unit.triggers.append(ast.TriggersBlock(
                [s for s in block.body if isinstance(s, ast.OnStmt)], head.span, end_span,
                file))

    def config_line(statement: ast.Statement) -> bool:
        """A line inside INIT/INTERRUPTS/TRIGGERS; False when it ends the block instead
        (a header of any kind, or an END), to be handled by the normal rules."""
        block = stack[0]
        kind = block.kind
        if isinstance(statement, ast.End) and statement.what == kind:
            close_config(statement.span)
            return True
        if isinstance(statement, (ast.ProgramHeader, ast.End, *CONFIG_HEADERS)):
            sink.add("E805", block.head.span, f"{kind.upper()} is not closed by "
                     f"{BLOCK_WORD[kind]}", hint=f"add {BLOCK_WORD[kind]} before line "
                     f"{statement.span.line}")
            close_config(statement.span)
            return False
        wanted = {"init": ast.Command, "interrupts": ast.OnStmt, "triggers": ast.OnStmt}[kind]
        fits = isinstance(statement, wanted)
        if isinstance(statement, ast.OnStmt) and fits:
            fits = statement.is_trigger == (kind == "triggers")
        if fits:
            block.body.append(statement)
            return True
        allowed = {"init": "initial-table commands (SET_MAX_V X, 200000)",
                   "interrupts": "interrupt factors (ON X P>=C+ CALL ISR 3)",
                   "triggers": "DI triggers (ON DI 8.0 OFF_TO_ON CALL cycle)"}[kind]
        article = "a" if kind == "triggers" else "an"
        sink.add("E802", statement.span, f"{article} {kind.upper()} block holds only {allowed}",
                 hint="move this line into a program or the block where it belongs")
        return True

    def close_block(kind: str, at: Span) -> None:
        """NEXT or END IF: close the innermost block of `kind`, reporting blocks left open
        inside it (they are closed too, so the rest of the file still makes sense)."""
        if stack and stack[-1].kind == kind:  # the innermost block: most closings
            close_inner(stack.pop(), at)
            return
        word = BLOCK_WORD[kind]
        if not any(b.kind == kind for b in stack):
            sink.add(STRAY_CLOSE[kind], at, f"{word} without an open {kind.upper()}")
            return
        while stack[-1].kind != kind:
            inner = stack[-1]
            sink.add("E303", at, f"{word} closes the {kind.upper()} of line "
                     f"{_innermost(kind, stack).head.span.line} while the "
                     f"{inner.kind.upper()} of line {inner.head.span.line} is still open",
                     hint=f"write {BLOCK_WORD[inner.kind]} before {word}")
            close_inner(stack.pop(), at)
        close_inner(stack.pop(), at)

    index, count = 0, len(statements)
    while index < count:
        raw = statements[index]
        if memo is not None and not stack and isinstance(raw, ast.ProgramHeader):
            kept = memo.find(statements, index)
            if kept is not None:
                unit.programs.append(kept.program)
                sink.extend(kept.diagnostics)
                index += len(kept.statements)
                continue
            started, mark = index, len(sink.items)
            origin = memo.find_moved(file, texts, raw.span.line) if texts is not None and \
                0 < raw.span.line <= len(texts) else None
        elif runs is not None and len(stack) == 1 and stack[0].kind in ("mp", "isr"):
            runs.boundary(stack[0], index, len(sink.items))
            run = runs.memo.find_run(file, statements, index)
            if run is not None:
                stack[0].body += run.nodes
                index += len(run.statements)
                runs.begin(stack[0], index, len(sink.items))
                continue
            found = runs.memo.find_block(statements, index)
            if found is not None:
                stack[0].target.append(found[1])
                index += len(found[0])
                continue
        index += 1
        statement = raw if type(raw) is not ast.Command or raw.name in _plain_names else \
            normalise(raw)
        klass = type(statement)
        if stack:  # the commonest cases below, taken first: most of a build's lines
            if stack[0].kind in CONFIG_KINDS:
                if config_line(statement):
                    continue
            elif klass not in _MATCHED:
                stack[-1].target.append(statement)
                continue
            elif klass is ast.IfStmt or klass is ast.ForStmt:
                open_block("if" if klass is ast.IfStmt else "for", statement)
                continue
            elif klass is ast.Next:
                close_block("for", statement.span)
                continue
            elif isinstance(statement, ast.End) and statement.what in ("if", "for"):
                close_block(statement.what, statement.span)
                continue
        match statement:
            case ast.InitHeader() | ast.InterruptsHeader() | ast.TriggersHeader():
                kind = {ast.InitHeader: "init", ast.InterruptsHeader: "interrupts",
                        ast.TriggersHeader: "triggers"}[type(statement)]
                if in_program():
                    sink.add("E805", statement.span, f"{kind.upper()} block inside the "
                             f"{stack[0].kind.upper()} that starts at line "
                             f"{stack[0].head.span.line}",
                             hint=f"close that program with {BLOCK_WORD[stack[0].kind]} first: "
                             "configuration blocks stand at the top level")
                    while len(stack) > 1:
                        unclosed(stack[-1], statement.span)
                        close_inner(stack.pop(), statement.span)
                    close_program(statement.span)
                    started = None
                stack.append(_Open(kind, statement))
            case ast.End(what="init" | "interrupts" | "triggers"):
                sink.add("E805", statement.span, f"END {statement.what.upper()} without an "
                         f"open {statement.what.upper()} block")
            case ast.OnStmt() if statement.is_trigger or not in_program():
                where = "a TRIGGERS block" if statement.is_trigger else \
                    "an INTERRUPTS block or a program"
                sink.add("E802", statement.span, f"ON {statement.subject} belongs in {where}",
                         hint="ON DI lines make the stand-alone trigger table: TRIGGERS ... "
                         "END TRIGGERS" if statement.is_trigger else
                         "INTERRUPTS setup ... END INTERRUPTS wires factors in program setup")
            case ast.Const() | ast.Alias() | ast.VarDecl():
                if in_program():
                    sink.add("E301", statement.span, "CONST, ALIAS and VAR must stand at the "
                             "top level, outside MP/ISR blocks")
                elif isinstance(statement, ast.Const):
                    unit.consts.append(statement)
                elif isinstance(statement, ast.Alias):
                    unit.aliases.append(statement)
                else:
                    unit.variables.append(statement)
            case ast.Include():
                pass  # handled while loading sources
            case ast.ProgramHeader():
                if in_program():
                    # Close what is open so the rest of the file still parses sensibly.
                    sink.add("E312", statement.span, f"{statement.kind.upper()} header inside "
                             f"the {stack[0].kind.upper()} that starts at line "
                             f"{stack[0].head.span.line}",
                             hint=f"close that program with {BLOCK_WORD[stack[0].kind]} first")
                    while len(stack) > 1:
                        unclosed(stack[-1], statement.span)
                        close_inner(stack.pop(), statement.span)
                    close_program(statement.span)
                    started = None
                stack.append(_Open(statement.kind, statement))
            case ast.End(what="mp" | "isr"):
                if not in_program():
                    sink.add("E303", statement.span, f"END {statement.what.upper()} without an "
                             f"open {statement.what.upper()} block")
                    continue
                while len(stack) > 1:
                    unclosed(stack[-1], statement.span)
                    close_inner(stack.pop(), statement.span)
                if stack[0].kind != statement.what:
                    sink.add("E303", statement.span, f"END {statement.what.upper()} closes the "
                             f"{stack[0].kind.upper()} opened at line {stack[0].head.span.line}",
                             hint=f"write {BLOCK_WORD[stack[0].kind]}")
                close_program(statement.span)
                if memo is not None and started is not None:
                    head, end = statements[started].span.line, statement.span.line
                    memo.keep(_Built(statements[started:index], unit.programs[-1],
                                     sink.items[mark:],
                                     texts[head - 1:end] if texts is not None else []),
                              origin)
                started = None
            case ast.ForStmt():
                if not in_program():
                    sink.add("E301", statement.span, "FOR outside an MP block")
                    continue
                open_block("for", statement)
            case ast.IfStmt():
                if not in_program():
                    sink.add("E301", statement.span, "IF outside an MP/ISR block")
                    continue
                open_block("if", statement)
            case ast.WhileStmt() | ast.RepeatStmt():
                kind = "while" if isinstance(statement, ast.WhileStmt) else "repeat"
                if not in_program():
                    sink.add("E301", statement.span, f"{kind.upper()} outside an MP block")
                    continue
                open_block(kind, statement)
            case ast.End(what="while" | "repeat"):
                close_block(statement.what, statement.span)
            case ast.Next() | ast.End(what="for"):
                close_block("for", statement.span)
            case ast.End(what="if"):
                close_block("if", statement.span)
            case ast.Else():
                if not stack or stack[-1].kind != "if":
                    sink.add("E307", statement.span, "ELSE outside an IF block")
                elif stack[-1].otherwise is not None:
                    assert stack[-1].else_span is not None
                    sink.add("E307", statement.span, f"second ELSE in the IF of line "
                             f"{stack[-1].head.span.line} (first ELSE at line "
                             f"{stack[-1].else_span.line})", hint="an IF takes one ELSE")
                else:
                    stack[-1].begin_else(statement.span)
            case _:
                if not in_program():
                    sink.add("E301", statement.span, "statement outside an MP/ISR block",
                             hint="put it between MP ... END MP")
                    continue
                stack[-1].target.append(statement)
    if runs is not None:
        runs.close()
    while stack:
        last = Span(file, (statements[-1].span.line if statements else 1))
        block = stack[-1]
        if block.kind in CONFIG_KINDS:
            sink.add("E805", block.head.span, f"{block.kind.upper()} is not closed by "
                     f"{BLOCK_WORD[block.kind]}", hint=f"add {BLOCK_WORD[block.kind]}")
            close_config(last)
            continue
        unclosed(block, last)
        if len(stack) > 1:
            close_inner(stack.pop(), last)
        else:
            close_program(last)


def _innermost(kind: str, stack: list[_Open]) -> _Open:
    return next(b for b in reversed(stack) if b.kind == kind)

"""Reuse inside one program: an edit lowers again only the top-level statements it changed.

`reuse.Lowerings` keeps a whole program's lowering while the program is unchanged. A long
program (the editor's 512-line file is one MP) changes at every keystroke, so each program
also keeps a `Statements` table: its top-level statements (a line, or a whole FOR / IF /
WHILE / REPEAT block with everything inside it) as last lowered, each with what it emitted
(macro lines, call sites, diagnostics) and what it did to the program's running state.

Lowering carries state from one top-level statement to the next; a kept statement is used
only when all of it that the statement read is as it was then (`Entered`):

- the statement itself, equal (same text at the same place: spans are part of it);
- the free temporaries and the labels left for WHILE loops (a statement may take some and
  give some back: what it left is kept and restored);
- whether the macro line before it returns a value (W106 of a SET_RVAR);
- for each variable whose read it checked for W103, whether that variable was written
  before it, and whether its W103 was already given: the statement's own writes and
  warnings follow from these, so they are kept as what it adds.

The table keeps its statements in chunks of consecutive ones (`Chunk`), each checked and
replayed whole, so that an edit of a long program costs the chunk it falls in and one check
per other chunk, not one per statement.

What does not change within one lowering of a program is checked once for the whole table:
the build's context (`reuse.lowering_context`, which drops every kept program and with it
its table), the program's kind and its label numbers. Block nesting is empty at the top
level, and the W101 "unreachable" check between top-level statements is made every time.

A back end derives per statement too (`Statement.derived_for`, the M8194H's W111): a
statement's macro lines are the same objects while it is kept, so what follows from them
and from the state they start from is kept beside them.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import TYPE_CHECKING

from mplang.lang import ast
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Run, Span

if TYPE_CHECKING:
    from mplang.ir.lower import ProgramLowerer
    from mplang.ir.macro import CallSite, MacroLine


REPLAYED = ("after_return", "calls", "derived", "diagnostics", "free_after", "free_temps",
            "jumps", "lines", "spare_after", "spare_labels", "warned", "writes")
"""What a statement and a chunk of them both hold: the state entered and left, what was
emitted (`replay` reads these), and what a back end derived from it."""


class Statement:
    """One top-level statement as lowered: the state it entered with, what it emitted, and
    the state it left."""

    __slots__ = (*REPLAYED, "node", "read_state", "reads")

    def __init__(self, node: ast.Node, free_temps: tuple[int, ...],
                 spare_labels: tuple[int, ...], after_return: bool) -> None:
        self.node = node
        self.free_temps = free_temps
        self.spare_labels = spare_labels
        self.after_return = after_return
        self.reads: tuple[int, ...] = ()  # variables whose W103 state it checked
        self.read_state: tuple[tuple[bool, bool], ...] = ()  # (written, warned) on entry
        # what it made and left (set by `record`; empty ones shared: a long document
        # keeps thousands of statements, every object more for the collector to walk)
        self.lines: list[MacroLine] = []
        self.calls: tuple[CallSite, ...] = ()
        self.diagnostics: list[Diagnostic] | tuple[()] = ()
        self.jumps = False
        self.writes: frozenset[int] = _NONE
        self.warned: frozenset[int] = _NONE
        self.free_after: tuple[int, ...] = ()
        self.spare_after: tuple[int, ...] = ()
        self.derived: dict[str, tuple[Hashable, object]] | None = None

    def fits(self, node: ast.Node, lowerer: ProgramLowerer) -> bool:
        """Whether lowering `node` in `lowerer`'s present state gives what this gave."""
        return (self.node is node or self.node == node) and self.enters(lowerer)

    def enters(self, lowerer: ProgramLowerer) -> bool:
        """Whether `lowerer`'s present state is the one this statement entered with, as far
        as its lowering read it (the statement itself aside)."""
        if self.free_temps != tuple(lowerer.free_temps) or \
                self.spare_labels != tuple(lowerer.spare_labels) or \
                self.after_return != _after_return(lowerer):
            return False
        written, warned = lowerer.written, lowerer.warned_reads
        return all((index in written, index in warned) == state
                   for index, state in zip(self.reads, self.read_state, strict=True))

    def derived_for(self, kind: str, key: Hashable, make: Callable[[], object]) -> object:
        """What a back end derives from this statement's lines (`kind`) for `key`, what
        else it read (the state its lines start from): kept for the last key only."""
        if self.derived is None:
            self.derived = {}
        return derived_for(self.derived, kind, key, make)


_NONE: frozenset[int] = frozenset()


def derived_for(derived: dict[str, tuple[Hashable, object]], kind: str, key: Hashable,
                make: Callable[[], object]) -> object:
    """`derived[kind]` if it was made for `key`, else made by `make` and kept for `key`
    alone: a kept lowering keeps one of each kind, not one per state it was seen in."""
    kept = derived.get(kind)
    if kept is not None and kept[0] == key:
        return kept[1]
    made = make()
    derived[kind] = (key, made)
    return made


def _after_return(lowerer: ProgramLowerer) -> bool:
    last = lowerer.last_command
    return bool(last is not None and last.returns)


class Chunk:
    """Consecutive top-level statements of one lowering, replayed as one while their nodes
    are the same and the state entering them is, as far as any of them read it: an edit of
    a long program then costs the statements of the chunk it falls in, not one check per
    statement of the program. What it requires on entry is its first statement's free
    temporaries, labels and W106 state, and for each variable a statement of it checked
    for W103 and no statement before it in the chunk wrote (warned about), the written
    (warned) state its first reader entered with: the statements after it see the state
    its statements left, as they saw it then. Only its last statement may jump (the W101
    check between statements is then left to the loop around it)."""

    __slots__ = (*REPLAYED, "labels", "nodes", "statements", "warned_false", "warned_true",
                 "written_false", "written_true")

    def __init__(self, statements: list[Statement]) -> None:
        first, last = statements[0], statements[-1]
        self.statements = statements
        self.nodes = [s.node for s in statements]
        self.free_temps, self.spare_labels = first.free_temps, first.spare_labels
        self.after_return = first.after_return
        self.free_after, self.spare_after = last.free_after, last.spare_after
        self.jumps = last.jumps
        needs: tuple[set[int], set[int], set[int], set[int]] = (set(), set(), set(), set())
        writes: set[int] = set()
        warned: set[int] = set()
        lines: list[MacroLine] = []
        calls: list[CallSite] = []
        diagnostics: list[Diagnostic] = []
        for statement in statements:
            for index, (was_written, was_warned) in zip(statement.reads, statement.read_state,
                                                        strict=True):
                if index not in writes:
                    needs[0 if was_written else 1].add(index)
                if index not in warned:
                    needs[2 if was_warned else 3].add(index)
            writes |= statement.writes
            warned |= statement.warned
            lines += statement.lines
            calls += statement.calls
            diagnostics += statement.diagnostics
        self.written_true, self.written_false, self.warned_true, self.warned_false = \
            map(frozenset, needs)
        self.writes, self.warned = frozenset(writes), frozenset(warned)
        self.lines = lines
        self.calls = tuple(calls)
        self.diagnostics: Run | tuple[()] = Run(diagnostics) if diagnostics else ()
        self.derived: dict[str, tuple[Hashable, object]] | None = None
        self.labels: list[ast.LabelStmt] = []  # the LABELs in its nodes, at any depth
        label_statements(self.nodes, self.labels)

    def fits(self, body: list[ast.Node], index: int, lowerer: ProgramLowerer) -> bool:
        """Whether `body` from `index` on starts with this chunk's statements, entered in a
        state that lowers them as they were."""
        return body[index:index + len(self.nodes)] == self.nodes and self.enters(lowerer)

    def enters(self, lowerer: ProgramLowerer) -> bool:
        """Whether `lowerer`'s present state lowers the chunk's statements as they were."""
        if self.free_temps != tuple(lowerer.free_temps) or \
                self.spare_labels != tuple(lowerer.spare_labels) or \
                self.after_return != _after_return(lowerer):
            return False
        written, warned = lowerer.written, lowerer.warned_reads
        return self.written_true <= written and self.written_false.isdisjoint(written) and \
            self.warned_true <= warned and self.warned_false.isdisjoint(warned)

    def derived_for(self, kind: str, key: Hashable, make: Callable[[], object]) -> object:
        """As `Statement.derived_for`, for the chunk's lines together."""
        if self.derived is None:
            self.derived = {}
        return derived_for(self.derived, kind, key, make)


CHUNK = 16
"""Statements per chunk at most: an edit lowers again the statement it changed and checks
the others of its chunk one by one, and every other chunk of the program once."""

ALONE = 4
"""A lowering that lowered afresh at most this many statements (an edit) keeps each of them
as a chunk of its own: the next keystroke in the same statement then opens no chunk
around it. More of them (a first lowering, a change of state) are chunked as they come."""


class Statements:
    """A program's top-level statements as last lowered, in chunks (`Chunk`) by the line of
    their first statement; `order` lists the statements of the latest lowering, in order
    (its macro lines are theirs, concatenated), and `items` the same as the chunks and the
    statements replayed or lowered one by one that it consisted of."""

    def __init__(self) -> None:
        self.kind: str | None = None
        self.labels: tuple[tuple[str, int], ...] = ()
        self.chunks: dict[int, Chunk] = {}
        self.kept: dict[Span, Statement] = {}  # statements of chunks opened by this lowering
        self.order: list[Statement] = []
        self.items: list[Statement | Chunk] = []
        self.fresh: set[int] = set()  # ids of the statements this lowering made afresh

    def start(self, lowerer: ProgramLowerer) -> None:
        """A lowering of the program begins (its labels numbered): a table made for another
        kind of program or other label numbers is dropped."""
        labels = tuple(lowerer.labels.items())
        if lowerer.kind != self.kind or labels != self.labels:
            self.chunks = {}
            self.kind, self.labels = lowerer.kind, labels
        self.kept = {}
        self.order = []
        self.items = []
        self.fresh = set()

    def find_labels(self, body: list[ast.Node], found: list[ast.LabelStmt]) -> None:
        """The LABEL statements of a program's `body`, in order, added to `found`: those of
        a kept chunk whose nodes are the same taken from it, not walked again."""
        index, count = 0, len(body)
        while index < count:
            chunk = self.chunks.get(body[index].span.line)
            if chunk is not None and body[index:index + len(chunk.nodes)] == chunk.nodes:
                found += chunk.labels
                index += len(chunk.nodes)
            else:
                label_statements(body[index:index + 1], found)
                index += 1

    def replay_chunk(self, body: list[ast.Node], index: int, lowerer: ProgramLowerer
                     ) -> Chunk | None:
        """The kept chunk that starts at `body[index]`, replayed into `lowerer`, if it fits;
        else None, and its statements are looked up one by one (`lower`)."""
        chunk = self.chunks.pop(body[index].span.line, None)
        if chunk is None:
            return None
        if chunk.fits(body, index, lowerer):
            replay(chunk, lowerer)
            self.order += chunk.statements
            self.items.append(chunk)
            return chunk
        for statement in chunk.statements:
            self.kept[statement.node.span] = statement
        return None

    def lower(self, node: ast.Node, lowerer: ProgramLowerer,
              make: Callable[[ast.Node], bool]) -> bool:
        """Lower the top-level statement `node` in `lowerer` (`make` lowers it afresh),
        or replay the kept lowering that fits; True if control never falls through it."""
        chunk = self.chunks.pop(node.span.line, None)
        if chunk is not None:  # not replayed whole (after a jump): its statements one by one
            for statement in chunk.statements:
                self.kept[statement.node.span] = statement
        kept = self.kept.get(node.span)
        if kept is not None and kept.fits(node, lowerer):
            replay(kept, lowerer)
            made = kept
        else:
            made = record(node, lowerer, make)
            self.fresh.add(id(made))
        self.order.append(made)
        self.items.append(made)
        return made.jumps

    def finish(self) -> None:
        """The lowering is over: statements it did not use are forgotten, and so is one
        whose expression was too deep to lower (comparing it again could be as deep); the
        statements it took one by one are chunked anew."""
        chunks: dict[int, Chunk] = {}
        loose: list[Statement] = []
        alone = self.fresh if len(self.fresh) <= ALONE else set()

        def close() -> None:
            if loose:
                chunks[loose[0].node.span.line] = Chunk(loose[:])
                loose.clear()

        for item in self.items:
            if type(item) is Chunk:
                close()
                chunks[item.statements[0].node.span.line] = item
            elif any(d.code == "E107" for d in item.diagnostics):
                close()
            else:
                assert isinstance(item, Statement)
                if id(item) in alone:
                    close()
                loose.append(item)
                if item.jumps or len(loose) == CHUNK or id(item) in alone:
                    close()
        close()
        self.chunks, self.kept, self.fresh = chunks, {}, set()

    def segments(self, lines: list[MacroLine]
                 ) -> list[tuple[Statement | Chunk, int, int]] | None:
        """(statement or chunk, first, end) of each part of `lines` (the program's macro
        lines as this table's last lowering made them) that one of `items` made, None when
        they are not exactly its items' lines (another pass added some)."""
        out: list[tuple[Statement | Chunk, int, int]] = []
        first = 0
        for item in self.items:
            end = first + len(item.lines)
            if end > len(lines) or (end > first and lines[first] is not item.lines[0]):
                return None
            out.append((item, first, end))
            first = end
        return out if first == len(lines) else None


def replay(kept: Statement | Chunk, lowerer: ProgramLowerer) -> None:
    """Do to `lowerer` what lowering the kept statement (chunk) did."""
    lowerer.out.lines.extend(kept.lines)
    lowerer.out.calls.extend(kept.calls)
    if kept.diagnostics:
        lowerer.sink.extend(kept.diagnostics)
    lowerer.written |= kept.writes
    lowerer.warned_reads |= kept.warned
    lowerer.free_temps[:] = kept.free_after
    lowerer.spare_labels[:] = kept.spare_after


def record(node: ast.Node, lowerer: ProgramLowerer, make: Callable[[ast.Node], bool]
            ) -> Statement:
    """Lower `node` afresh, noting the state it entered with and what it did (the
    lowerer logs the variables it checks and adds: copying its sets would cost more than
    most statements' lowering)."""
    made = Statement(node, tuple(lowerer.free_temps), tuple(lowerer.spare_labels),
                     _after_return(lowerer))
    first_line, first_call = len(lowerer.out.lines), len(lowerer.out.calls)
    own = DiagnosticSink()
    shared, scope_sink = lowerer.sink, lowerer.scope.sink
    log = lowerer.log = VariableLog()
    lowerer.sink = lowerer.scope.sink = own
    try:
        made.jumps = make(node)
    finally:
        lowerer.sink, lowerer.scope.sink = shared, scope_sink
        lowerer.log = None
        shared.extend(own.items)
    # the sets only grow: a variable was in one on entry if it is now and was not added
    written, warned = lowerer.written, lowerer.warned_reads
    made.reads = tuple(log.reads)
    made.read_state = tuple((index in written and index not in log.writes,
                             index in warned and index not in log.warned)
                            for index in made.reads)
    made.lines = lowerer.out.lines[first_line:]
    if len(lowerer.out.calls) > first_call:
        made.calls = tuple(lowerer.out.calls[first_call:])
    if own.items:
        made.diagnostics = own.items
    if log.writes:
        made.writes = frozenset(log.writes)
    if log.warned:
        made.warned = frozenset(log.warned)
    free, spare = tuple(lowerer.free_temps), tuple(lowerer.spare_labels)
    made.free_after = made.free_temps if free == made.free_temps else free
    made.spare_after = made.spare_labels if spare == made.spare_labels else spare
    return made


class VariableLog:
    """What one top-level statement's lowering did with the W103 state: the variables whose
    state it checked, and those it added to the written and the warned ones."""

    __slots__ = ("reads", "warned", "writes")

    def __init__(self) -> None:
        self.reads: set[int] = set()
        self.writes: set[int] = set()
        self.warned: set[int] = set()


def label_statements(body: list[ast.Node], found: list[ast.LabelStmt]) -> None:
    """The LABEL statements of `body` and the blocks in it, in order, added to `found`
    (a plain walk: generators nested as deep as the blocks cost more than a program's
    labels are worth)."""
    for node in body:
        if type(node) is ast.LabelStmt:
            found.append(node)
        elif type(node) is ast.IfBlock:
            label_statements(node.then, found)
            if node.otherwise:
                label_statements(node.otherwise, found)
        elif type(node) is ast.ForBlock or type(node) is ast.WhileBlock or \
                type(node) is ast.RepeatBlock:
            label_statements(node.body, found)

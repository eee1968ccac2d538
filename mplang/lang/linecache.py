"""Parsed statements kept by line text, so an edit parses the edited lines only.

The grammar is one statement per line (`grammar/mplang.lark`): no token, comment or string
crosses a newline, and the tokenizer's choices depend on the parser state within the line
only. So a line's statements and syntax diagnostics are a function of its text, and of its
position only through their spans. A `StatementCache` keeps, per line text, the result of
one parse and where it was made; a line found at another place (lines moved, the same text
elsewhere, another file) gets a copy whose spans name its own file and line. A line where
it was last time is the very same result, objects shared: nothing downstream changes an AST
node.

Lark stays the parser: the lines nobody has parsed yet are parsed in one call of
`parser.parse_text`, either the whole text (most lines new: positions come out right) or
the new lines alone joined into one text, their spans moved after. Text with a carriage
return that does not end a line is parsed whole and kept out of the cache (a lone `\\r` is a
syntax error whose line only the whole text has).

The language server keeps one `StatementCache` for the documents it analyses and passes it
to `mplang.lang.sources.load_sources(..., lines=cache)`; the front cache on disk
(`mplang.lang.frontcache`) keeps the first line of each text of a file (`distinct_of`) and
seeds a cache with them in the next run, so `mpc build` after an edit parses the edited
lines. A cache made with `record=True` (the front cache's) also keeps how lark built each
line with numbers (`mplang.lang.recipes`), and builds a new line that differs from one of
them in its numbers only from that recipe, without a parse.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from operator import itemgetter
from typing import TYPE_CHECKING, Any, NamedTuple

from mplang.lang import ast
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Span, make_span

if TYPE_CHECKING:
    from mplang.lang.recipes import Call, Recipe

Parse = Callable[[str, str, DiagnosticSink], list[ast.Statement]]
"""`parser.parse_text`'s shape: text, file name, sink -> statements."""

Line = tuple[str, list[ast.Statement], list[Diagnostic]]
"""One source line: its text, its statements and its syntax diagnostics, at its place."""

Numbered = tuple[int, Line]
"""A line with its (1-based) number in its file."""

_LONE_CR = re.compile(r"\r(?!\n)")
_last_split: tuple[str, list[str]] = ("", [""])
_new = object.__new__
_SLACK = 4096
"""Line texts kept beyond those of the files held, before the table is swept."""


def text_lines(text: str) -> list[str]:
    """`text.split("\n")`, the very list of the last call when `text` is the very string
    of that call: one check splits one text in four places (this cache, the blocks, the
    sources kept for `mpc: ignore`, the editor's lines), a whole device's split costing
    half a millisecond each. The list is shared: never change it."""
    global _last_split
    last = _last_split  # one read: a tuple, consistent even if another thread splits
    if last[0] is text:
        return last[1]
    lines = text.split("\n")
    _last_split = (text, lines)
    return lines


def _parse_text(text: str, file: str, sink: DiagnosticSink) -> list[ast.Statement]:
    """`parser.parse_text`, its module (and lark with it) imported when a line misses."""
    from mplang.lang import parser

    return parser.parse_text(text, file, sink)


def _parse_recorded(text: str, file: str, sink: DiagnosticSink
                    ) -> tuple[list[ast.Statement], list[Call]]:
    """`parser.parse_recorded`: `_parse_text` and the builder calls that made the result."""
    from mplang.lang import parser

    return parser.parse_recorded(text, file, sink)


_PLAIN = frozenset({"str", "int", "bool", "str | None", "int | None"})
"""Field annotations of a syntax-tree class that can hold no span: copied as they are."""

Mover = Callable[[Any, str, int], Any]
"""A value, a file and a line -> the value with every span moved there."""


def _span_moved(value: Span, file: str, line: int) -> Span:
    return make_span(file, line, value.col, value.end_col)


def _list_moved(value: list[Any], file: str, line: int) -> list[Any]:
    return [moved(item, file, line) for item in value]


def _kept(value: Any, file: str, line: int) -> Any:
    return value


_movers: dict[type, Mover] = {Span: _span_moved, list: _list_moved}


def _mover(kind: type) -> Mover:
    """The function that moves a value of class `kind`, made once per class: for a
    syntax-tree class, one written for its fields (from its annotations) that copies the
    node's dict and replaces only the fields that can hold a span, a span made in place,
    anything else moved as it is. A cached line found at another place costs this per
    node, and a loop over the fields testing each value's class cost twice as much."""
    names: tuple[str, ...] | None = getattr(kind, "_fields", None)
    if names is None:  # a string, a number, None: nothing to move
        _movers[kind] = _kept
        return _kept
    hints: dict[str, str] = {}
    for klass in reversed(kind.__mro__):
        hints.update(getattr(klass, "__annotations__", {}))
    body = ["def mover(value, file, line):", "    state = value.__dict__.copy()"]
    for name in names:
        hint = hints.get(name)
        if hint in _PLAIN:
            continue
        body.append(f"    item = state[{name!r}]")
        if hint == "Span":
            body += ["    made = new(Span)", "    fields = made.__dict__",  # as make_span
                     "    fields['file'] = file", "    fields['line'] = line",
                     "    fields['col'] = item.col", "    fields['end_col'] = item.end_col",
                     f"    state[{name!r}] = made"]
        else:
            body.append(f"    if item is not None: state[{name!r}] = moved(item, file, line)")
    body += ["    copy = new(kind)", "    copy.__dict__ = state", "    return copy"]
    scope: dict[str, Any] = {"Span": Span, "moved": moved, "new": _new, "kind": kind}
    exec("\n".join(body), scope)  # the text made above from the class's fields
    made: Mover = scope["mover"]
    _movers[kind] = made
    return made


def moved(value: Any, file: str, line: int) -> Any:
    """`value` (a statement, an expression, a list of them) with every span moved to
    `file`:`line`, columns kept; shared parts that hold no span are not copied (`_mover`)."""
    mover = _movers.get(type(value))
    return (mover or _mover(type(value)))(value, file, line)


def _moved_diagnostic(item: Diagnostic, file: str, line: int) -> Diagnostic:
    return Diagnostic(item.code, item.severity, item.message,
                      make_span(file, line, item.span.col, item.span.end_col), item.hint,
                      tuple((make_span(file, line, s.col, s.end_col), note)
                            for s, note in item.related))


def _placed(found: Line, file: str, line: int, where: tuple[str, int]) -> Line:
    """`found` (parsed at `where`) as it reads at `file`:`line`."""
    if where == (file, line):
        return found
    text, statements, reported = found
    return (text, [moved(s, file, line) for s in statements],
            [_moved_diagnostic(d, file, line) for d in reported])


class _Last(NamedTuple):
    """A file's last text and what its parse gave: its lines (the very list `_files`
    holds), its statements, where each line's statements begin in them (one more entry
    than lines: the end) and the lines that reported syntax diagnostics (0-based)."""

    text: str
    lines: list[Line]
    statements: list[ast.Statement]
    starts: list[int]
    reported: list[int]


def _unchanged_ends(before: str, after: str, count_before: int, count_after: int
                    ) -> tuple[int, int]:
    """How many whole lines at the start and at the end two texts (of `count_before` and
    `count_after` lines) share, never overlapping in either: found by comparing slices of
    the texts (in C, halving the length each step), not line by line."""
    low, high = 0, min(len(before), len(after))
    while low < high:  # the longest common prefix, in characters
        middle = (low + high + 1) // 2
        if before[low:middle] == after[low:middle]:
            low = middle
        else:
            high = middle - 1
    if low == len(before) == len(after):
        return count_after, 0  # the same text: every line as it was
    head = after.count("\n", 0, low)  # lines wholly before the first difference
    limit = min(count_before, count_after) - head
    low, high = 0, min(len(before), len(after)) - after.rfind("\n", 0, low) - 1
    while low < high:  # the longest common suffix within what the prefix left
        middle = (low + high + 1) // 2
        if before[len(before) - middle:len(before) - low] == \
                after[len(after) - middle:len(after) - low]:
            low = middle
        else:
            high = middle - 1
    tail = after.count("\n", len(after) - low) if low else 0
    return head, max(0, min(tail, limit))


def _gathered(lines: list[Line], first: int) -> tuple[list[ast.Statement], list[int], list[int]]:
    """The statements of `lines` (line `first` (0-based) on) in order, where each line's
    begin among them (and the end), and which lines reported syntax diagnostics."""
    statements: list[ast.Statement] = []
    starts: list[int] = []
    reported: list[int] = []
    for index, (_, found, diagnostics) in enumerate(lines, start=first):
        starts.append(len(statements))
        statements.extend(found)
        if diagnostics:
            reported.append(index)
    starts.append(len(statements))
    return statements, starts, reported


class StatementCache:
    """Statements by line text, and the lines of each file as last parsed (see the module
    docstring). Not thread-safe: one per server or process."""

    def __init__(self, parse: Parse | None = None, record: bool = False) -> None:
        self._given = parse
        self._record = record  # keep recipes of the lines lark parses (`recipes_for`)
        self._recipes: dict[str, tuple[str, Recipe]] = {}  # line text -> template, recipe
        self._by_template: dict[str, Recipe] | None = None  # made when a line first misses
        self._packed: list[tuple[bytes, dict[int, str]]] = []  # seeded, not yet unpickled
        self._texts: dict[str, tuple[Line, tuple[str, int]]] = {}
        self._files: dict[str, list[Line]] = {}
        self._last: dict[str, _Last] = {}  # per file: its last text and what it gave

    def lines_of(self, file: str) -> list[Line]:
        """`file`'s lines as last parsed (empty if never, or if its text was parsed whole)."""
        return self._files.get(file, [])

    def distinct_of(self, file: str) -> list[Numbered] | None:
        """The first line of each text among `file`'s lines as last parsed, with its number:
        what the front cache stores (every other line is a copy of one of them, its spans
        moved). None when the last text of `file` was parsed whole and not kept (a lone
        carriage return): nothing of it may be stored."""
        lines = self._files.get(file)
        if lines is None:
            return None
        texts = list(map(itemgetter(0), lines))
        texts.reverse()
        # each text's first index, found in C: of repeated keys the last stored (the first
        # line, counted from the end) stays; a whole device repeats most of its lines
        first = dict(zip(texts, range(len(texts) - 1, -1, -1), strict=True))
        return [(index + 1, lines[index]) for index in sorted(first.values())]

    def seed(self, file: str, lines: list[Numbered], recipes: bytes = b"") -> None:
        """Take lines of `file` from an earlier run (`distinct_of` then: the front cache's
        entry): a text among them is not parsed again, wherever it now stands. `recipes`
        (`recipes_for` of those lines) are unpickled when a line first misses: a line
        differing from one of them in its numbers only is then built without lark."""
        for number, found in lines:
            self._texts.setdefault(found[0], (found, (file, number)))
        if recipes:
            self._packed.append((recipes, {number: found[0] for number, found in lines}))

    def recipes_for(self, lines: list[Numbered]) -> bytes:
        """The recipes of `lines` (`distinct_of`'s) this cache holds, pickled by line
        number, for the front cache: `seed` takes them back."""
        import pickle

        known = self._known_recipes()
        kept = {number: entry for number, (text, _, _) in lines
                if (entry := known.get(text)) is not None}
        return pickle.dumps(kept, protocol=pickle.HIGHEST_PROTOCOL) if kept else b""

    def _known_recipes(self) -> dict[str, tuple[str, Recipe]]:
        """Every recipe held, those seeded unpickled first (a damaged one is dropped)."""
        if self._packed:
            import pickle

            for packed, texts in self._packed:
                try:
                    held = pickle.loads(packed)
                    self._recipes.update((texts[number], (key, recipe))
                                         for number, (key, recipe) in held.items()
                                         if number in texts and type(key) is str)
                except Exception:
                    continue
            self._packed.clear()
            self._by_template = None
        return self._recipes

    def _replayed(self, text: str, file: str, line: int) -> Line | None:
        """`text` at `file`:`line` built from the recipe of a line of its template, or
        None (no such recipe, or lark must say why it fails: `recipes.replay`)."""
        from mplang.lang import recipes

        shape = recipes.template(text)
        if shape is None:
            return None
        by_template = self._by_template
        if by_template is None:
            by_template = self._by_template = {
                key: recipe for key, recipe in self._known_recipes().values()}
        recipe = by_template.get(shape[0])
        if recipe is None:
            return None
        statement = recipes.replay(recipe, text, shape[1], file, line)
        if statement is None:
            return None
        self._recipes[text] = (shape[0], recipe)
        return (text, [statement], [])

    def forget(self, file: str) -> None:
        """Drop `file`'s lines (a document closed); their texts go at the next sweep."""
        self._files.pop(file, None)
        self._last.pop(file, None)

    def parse(self, text: str, file: str, sink: DiagnosticSink) -> list[ast.Statement]:
        """What `parser.parse_text(text, file, sink)` gives, parsing only lines this cache
        has not seen; the diagnostics reach `sink` in the same order.

        A file parsed here before is compared with its last text: the lines before the first
        change and after the last are taken as they were (their statements sliced off the
        last result, not gathered line by line; those after it moved to their new numbers
        when lines were inserted or removed), so an edit of one line of a whole device
        costs the edited line, not every line."""
        if "\r" in text and _LONE_CR.search(text):
            self._files.pop(file, None)  # parsed whole, kept nowhere
            self._last.pop(file, None)
            return self._parse_with(text, file, sink)
        segments = text_lines(text)
        last = self._last.get(file)
        known = self._files.get(file, [])
        if last is not None and last.lines is known:
            head, tail = _unchanged_ends(last.text, text, len(known), len(segments))
        else:
            last, head, tail = None, 0, 0
        lines: list[Line | None] = []
        missing: dict[str, list[int]] = {}
        for index in range(head, len(segments) - tail):
            segment = segments[index]
            if index < len(known) and known[index][0] == segment:
                lines.append(known[index])
                continue
            found = self._texts.get(segment)
            if found is None and (self._recipes or self._packed) and segment not in missing:
                built = self._replayed(segment, file, index + 1)
                if built is not None:
                    self._texts[segment] = (built, (file, index + 1))
                    lines.append(built)
                    continue
            if found is None:
                missing.setdefault(segment, []).append(index)
                lines.append(None)
            else:
                lines.append(_placed(found[0], file, index + 1, found[1]))
        shift = len(segments) - len(known)
        after = len(known) - tail  # the first of the unchanged lines at the end, as it was
        if tail and shift:  # the lines after the change moved: their spans move with them
            lines.extend(_placed(found, file, index + 1 + shift, (file, index + 1))
                         for index, found in enumerate(known[after:], start=after))
        if missing:
            self._fill(segments[head:], lines, missing, file, head,
                       whole=not head and not tail and 2 * len(missing) > len(segments))
        middle: list[Line] = [line for line in lines if line is not None]
        statements, starts, reported = _gathered(middle, head)
        placed = known[:head] + middle if head else middle
        if last is not None:  # the unchanged ends, sliced off the last result
            first = last.starts[head]
            statements = last.statements[:first] + statements
            starts = last.starts[:head] + [first + start for start in starts]
            reported = [index for index in last.reported if index < head] + reported
            if tail and not shift:  # the same objects, at the same lines
                placed = placed + known[after:]
                cut = last.starts[after]
                offset = starts.pop() - cut
                statements += last.statements[cut:]
                starts += last.starts[after:] if not offset else \
                    [offset + start for start in last.starts[after:]]
                reported += [index for index in last.reported if index >= after]
        self._files[file] = placed
        self._last[file] = _Last(text, placed, statements, starts, reported)
        for index in reported:
            for item in placed[index][2]:
                sink.add(item.code, item.span, item.message, item.hint, item.related)
        if len(self._texts) > _SLACK + sum(len(f) for f in self._files.values()):
            self._sweep()
        return list(statements)

    def _fill(self, segments: list[str], lines: list[Line | None],
              missing: dict[str, list[int]], file: str, head: int, whole: bool) -> None:
        """Parse the missing lines in one call: the whole text (`whole`: most lines are new;
        every span is then already in place), else the new texts alone, joined. `segments`
        and `lines` are the text's lines from number `head` (0-based) on; `missing` gives
        each new text's lines by their index in the whole text."""
        batch = segments if whole else list(missing)
        scratch = DiagnosticSink()
        calls: list[Call] = []
        if self._record and self._given is None:
            found, calls = _parse_recorded("\n".join(batch), file, scratch)
        else:
            found = self._parse_with("\n".join(batch), file, scratch)
        per_line: list[tuple[list[ast.Statement], list[Diagnostic]]] = [
            ([], []) for _ in batch]
        for statement in found:
            per_line[statement.span.line - 1][0].append(statement)
        for item in scratch.items:
            per_line[item.span.line - 1][1].append(item)
        if calls:
            self._keep_recipes(calls, batch, per_line)
        for number, (segment, (statements, reported)) in enumerate(
                zip(batch, per_line, strict=True), start=1):
            line: Line = (segment, statements, reported)
            if whole:
                if lines[number - 1] is None:
                    lines[number - 1] = line
                self._texts.setdefault(segment, (line, (file, number)))
                continue
            self._texts[segment] = (line, (file, number))
            for index in missing[segment]:
                lines[index - head] = _placed(line, file, index + 1, (file, number))

    def _keep_recipes(self, calls: list[Call], batch: list[str],
                      per_line: list[tuple[list[ast.Statement], list[Diagnostic]]]) -> None:
        """Record the recipes of the new texts of `batch` (lark's calls, `recipes.record`)
        that reported nothing."""
        from mplang.lang import recipes

        wanted: dict[str, int] = {}
        for index, (segment, (_, reported)) in enumerate(zip(batch, per_line, strict=True)):
            if not reported and segment not in self._recipes:
                wanted.setdefault(segment, index)
        made = recipes.record(calls, batch, set(wanted.values()),
                              [statements for statements, _ in per_line])
        for index, entry in made.items():
            self._recipes[batch[index]] = entry
            if self._by_template is not None:
                self._by_template.setdefault(entry[0], entry[1])

    def _parse_with(self, text: str, file: str, sink: DiagnosticSink) -> list[ast.Statement]:
        """The parse given to the cache, else `parser.parse_text`."""
        return (self._given or _parse_text)(text, file, sink)

    def _sweep(self) -> None:
        """Keep only the texts of the lines the files hold now."""
        live = {found[0] for lines in self._files.values() for found in lines}
        self._texts = {text: entry for text, entry in self._texts.items() if text in live}
        self._recipes = {text: entry for text, entry in self._known_recipes().items()
                         if text in live}
        self._by_template = None

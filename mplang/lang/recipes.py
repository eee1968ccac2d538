"""A line whose text differs from a parsed one only in its numbers, built without lark.

The grammar is one statement per line and LALR is deterministic: the same terminals give
the same reductions. Which terminal a token is depends on its shape and the parser state
(`mplang.lang.tokenizer`), and an integer literal's shape (decimal or hex) gives INT
wherever it stands. So two lines whose texts differ only in the values of their integer
literals (as many, each of the same kind, every other character the same: strings,
comments and words with digits are not numbers) go through the same reductions, and the
builder (`mplang.lang.builder.Rules`) is called the same way but for the numbers' tokens.

When lark parses a line, each builder call is recorded (`record`) with its arguments as
references: a token of the line, the result of an earlier call, or None. `replay` makes
that recipe's calls again for another line of the same template (`template`), its tokens
made from its own text. What cannot be recorded faithfully is not recorded: a token that
is not the whole of a number yet covers part of one (an interrupt condition `P>=100`), a
number lark did not take as INT, a line with a diagnostic or not one statement. What
fails in replay (a number too long, E108; an expression too deep, E107; any exception)
gives None, and the line is parsed by lark, which reports it. The front cache keeps the
recipes beside the lines (`mplang.lang.frontcache`), so `mpc build` after a number edit
never imports lark.
"""

from __future__ import annotations

import re
from typing import Any

from mplang.lang import ast
from mplang.lang.builder import Rules, lexeme
from mplang.lang.limits import MAX_EXPRESSION_DEPTH, too_deep

TokenRef = tuple[int] | tuple[str, str, int, int]
"""A token of the line: (k,) the k-th number, as INT; or (terminal, text, k, offset): a
token `offset` characters after the end of the k-th number (k = 0: of the line's start),
k counted from 1."""

Ref = TokenRef | int | None
"""An argument: a token, the result of the call of that index, or None."""

Recipe = tuple[tuple[str, tuple[Ref, ...]], ...]
"""The builder calls that make a line's statement, in order: the last one's result."""

Call = tuple[str, list[Any], Any, int]
"""A call as the parser logged it: the rule, its arguments, its result, the line offset
the tokens' lines count from."""

RULES = frozenset(name for name, value in vars(Rules).items()
                  if callable(value) and not name.startswith("_"))
"""The builder's rule methods: a recipe calls these only."""

_PIECE = re.compile(r"""(?:\#|//)[^\n]*|"[^"\n]*"|'[^'\n]*'|[A-Za-z_][A-Za-z0-9_]*
                        |(0[xX][0-9a-fA-F]+|[0-9]+)""", re.VERBOSE)
"""What the tokenizer reads as a comment, a string, a word or a number (group 1): only a
number outside the others is one."""

_DIGIT = re.compile(r"[0-9]")


def template(text: str) -> tuple[str, list[tuple[int, int]]] | None:
    """The line's template (its text, each number replaced by a mark of its kind) and where
    its numbers are; None for a line without numbers (or with a NUL, which the marks use)."""
    if _DIGIT.search(text) is None or "\0" in text:
        return None
    numbers: list[tuple[int, int]] = []
    parts: list[str] = []
    last = 0
    for found in _PIECE.finditer(text):
        if found.lastindex is None:
            continue
        start, end = found.span()
        parts.append(text[last:start])
        parts.append("\0x" if end - start > 2 and text[start + 1] in "xX" else "\0d")
        numbers.append((start, end))
        last = end
    if not numbers:
        return None
    parts.append(text[last:])
    return "".join(parts), numbers


def record(calls: list[Call], texts: list[str], wanted: set[int],
           statements: list[list[ast.Statement]]) -> dict[int, tuple[str, Recipe]]:
    """The template and recipe of each line of `wanted` (0-based in `texts`, the text
    lark parsed split into lines) that can be replayed, from the builder calls lark made
    (`calls`); `statements` are each line's statements (the line is left out when it
    reported a diagnostic: the caller does not ask)."""
    made: dict[int, tuple[int, int]] = {}  # id(result) -> (line, its index in the line)
    per_line: dict[int, list[tuple[str, list[Any]]]] = {}
    spoilt: set[int] = set()
    for name, children, result, offset in calls:
        if name not in RULES or name in ("start", "line"):
            continue
        line = -1
        refs: list[Any] = []
        for child in children:
            if child is None:
                refs.append(None)
                continue
            if isinstance(child, str):
                where = (getattr(child, "line", None) or 1) + offset - 1
                refs.append(child)
            else:
                known = made.get(id(child))
                if known is None:
                    return {}  # an argument not made by a call: nothing is sure
                where = known[0]
                refs.append(known[1])
            if line not in (-1, where):
                spoilt.update((line, where))
            line = where
        if line == -1:
            return {}
        own = per_line.setdefault(line, [])
        made[id(result)] = (line, len(own))
        own.append((name, refs))
    recipes: dict[int, tuple[str, Recipe]] = {}
    for index in wanted - spoilt:
        steps = per_line.get(index)
        if steps is None or len(statements[index]) != 1:
            continue
        if made.get(id(statements[index][0])) != (index, len(steps) - 1):
            continue
        made_recipe = _recipe(steps, texts[index])
        if made_recipe is not None:
            recipes[index] = made_recipe
    return recipes


def _recipe(calls: list[tuple[str, list[Any]]], text: str) -> tuple[str, Recipe] | None:
    """The template of `text` and its recipe from its calls, or None if a token does not
    fall on the template's numbers as replay needs (see the module docstring)."""
    shape = template(text)
    if shape is None:
        return None
    key, numbers = shape
    starts = {start: slot for slot, (start, _) in enumerate(numbers, start=1)}
    covered: set[int] = set()
    steps: list[tuple[str, tuple[Ref, ...]]] = []
    for name, refs in calls:
        made: list[Ref] = []
        for ref in refs:
            if not isinstance(ref, str):
                made.append(ref)
                continue
            token = _token_ref(ref, numbers, starts)
            if token is None:
                return None
            if len(token) == 1:
                covered.add(token[0])
            made.append(token)
        steps.append((name, tuple(made)))
    if len(covered) != len(numbers):
        return None  # a number no call took as INT
    return key, tuple(steps)


def _token_ref(token: Any, numbers: list[tuple[int, int]], starts: dict[int, int]
               ) -> TokenRef | None:
    """Where `token` (lark's) is in terms of the line's numbers, or None when it covers
    part of a number or is a number lark did not take as INT."""
    column = getattr(token, "column", None)
    terminal = getattr(token, "type", None)
    if not isinstance(column, int) or not isinstance(terminal, str):
        return None
    start, end = column - 1, column - 1 + len(token)
    slot = starts.get(start)
    if slot is not None:
        if terminal != "INT" or numbers[slot - 1][1] != end:
            return None
        return (slot,)
    after = 0
    for slot, (low, high) in enumerate(numbers, start=1):
        if low < end and start < high:
            return None  # overlaps a number
        if high <= start:
            after = slot
    base = numbers[after - 1][1] if after else 0
    return (terminal, str(token), after, start - base)


def replay(recipe: Recipe, text: str, numbers: list[tuple[int, int]], file: str,
           line: int) -> ast.Statement | None:
    """The statement `recipe` builds from `text` (of its template, `numbers` where
    `template` found them) at `file`:`line`, or None when the builder refuses it or it is
    nested too deep: lark's parse then reports why."""
    rules = Rules(file)
    results: list[Any] = []
    try:
        for name, refs in recipe:
            if name not in RULES:
                return None
            arguments: list[Any] = []
            for ref in refs:
                if ref is None:
                    arguments.append(None)
                elif isinstance(ref, int):
                    arguments.append(results[ref])
                elif len(ref) == 1:
                    start, end = numbers[ref[0] - 1]
                    arguments.append(lexeme(text[start:end], "INT", line, start + 1))
                else:
                    terminal, word, after, offset = ref
                    start = (numbers[after - 1][1] if after else 0) + offset
                    if not text.startswith(word, start):
                        return None  # a recipe of another text (a damaged entry)
                    arguments.append(lexeme(word, terminal, line, start + 1))
            results.append(getattr(rules, name)(*arguments))
    except Exception:
        return None
    statement = results[-1] if results else None
    if not isinstance(statement, ast.Statement):
        return None
    if len(text) > MAX_EXPRESSION_DEPTH and too_deep(statement) is not None:
        return None
    return statement

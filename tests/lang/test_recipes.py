"""Lines built from a recorded parse (mplang/lang/recipes.py) against lark's parse of the
same text: the same statements, spans and diagnostics, or (where lark reports something) no
statement at all, so the caller parses the line and lark reports it."""

from __future__ import annotations

import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from parsecount import CountedParse

from mplang.lang import ast, linecache, recipes
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink
from mplang.lang.linecache import StatementCache
from mplang.lang.parser import parse_recorded, parse_text

ROOT = Path(__file__).resolve().parents[2]

FORMS = [
    "MP {}", "ISR {} tick", "FOR {}", "REPEAT {}", "LABEL {}", "GOTO {}", "CALL {}",
    "IF a > {} THEN", "WHILE x < {}", "CONST N = {}", "INTERRUPTS MP {}", "INTERRUPTS {}",
    "ON X P>=C+ CALL ISR {}", "ON Y {} HOLD", "ON X OFF_TO_ON CALL MP {}",
    "  SET_V X, -{}", "x = -(a + {}) * F(b, {}) / {} & 7 | {}", "FIXED_MOVE(XY, {}, -{})",
    "  VAR{} = VAR1 + {}  # {} more", "SAY 'n {}', {}, \"{}\"", "X = +-{} - -{}",
    "FOO ({}, {}), {}", "FOO (1, {}) + 2", "CONST K = (({})) // {}", "ON X ABC>={} CALL 3",
    "ON DI 8.{} OFF_TO_ON CALL cycle", "x1 = {}x", "X = {}.{}", "Y = 0x{}", "X = = {}",
]
"""Statement forms with numbers, and some that must not be replayed (an interrupt condition
or DI channel holding a number, a number joined to a word, a syntax error)."""


def _number(draw: Callable[[st.SearchStrategy[Any]], Any], hexadecimal: bool) -> str:
    if hexadecimal:
        digits = draw(st.text(alphabet="0123456789abcdefABCDEF", min_size=1, max_size=19))
        return draw(st.sampled_from(["0x", "0X"])) + digits
    value = draw(st.one_of(st.integers(0, 2**31), st.integers(0, 10**24)))
    return "0" * draw(st.integers(0, 2)) + str(value)


@st.composite
def numbered(draw: st.DrawFn) -> str:
    """A form with numbers drawn for its holes, decimal or hex."""
    form = draw(st.sampled_from(FORMS))
    return form.format(*(_number(draw, draw(st.booleans()))
                         for _ in range(form.count("{}"))))


def _lines_of(text: str) -> tuple[list[str], dict[int, tuple[str, recipes.Recipe]]]:
    """`text`'s lines and the recipes recorded while lark parsed it."""
    sink = DiagnosticSink()
    found, calls = parse_recorded(text, "t.mp", sink)
    lines = text.split("\n")
    statements: list[list[ast.Statement]] = [[] for _ in lines]
    for statement in found:
        statements[statement.span.line - 1].append(statement)
    reported = {item.span.line - 1 for item in sink.items}
    return lines, recipes.record(calls, lines, set(range(len(lines))) - reported, statements)


def _lark(text: str, line: int) -> tuple[list[ast.Statement], list[Diagnostic]]:
    sink = DiagnosticSink()
    return parse_text("\n" * (line - 1) + text, "u.mp", sink), sink.items


def _renumbered(text: str, number: Callable[[str, bool], str]) -> str:
    """`text` with each number replaced by `number(it, whether it is hex)`."""
    shape = recipes.template(text)
    assert shape is not None
    parts, last = [], 0
    for start, end in shape[1]:
        parts += [text[last:start], number(text[start:end],
                                           end - start > 2 and text[start + 1] in "xX")]
        last = end
    return "".join(parts) + text[last:]


def _check(recipe: tuple[str, recipes.Recipe], text: str, line: int) -> bool:
    """Replay `text` at `line` and compare with lark; whether it was replayed."""
    shape = recipes.template(text)
    assert shape is not None and shape[0] == recipe[0]
    built = recipes.replay(recipe[1], text, shape[1], "u.mp", line)
    statements, reported = _lark(text, line)
    if built is None:  # lark must say why (a number too long, E108)
        assert reported, text
        return False
    assert not reported, text
    assert [built] == statements and repr([built]) == repr(statements), text
    return True


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(first=st.lists(numbered(), min_size=1, max_size=4), data=st.data(),
       line=st.integers(1, 40))
def test_a_replayed_line_is_lark_s_parse(first: list[str], data: st.DataObject,
                                         line: int) -> None:
    lines, made = _lines_of("\n".join(first))
    for index, recipe in made.items():
        assert _check(recipe, lines[index], line)
        _check(recipe, _renumbered(lines[index], lambda _, hexadecimal: _number(
            data.draw, hexadecimal)), line)


def test_the_samples_lines_are_replayed_as_lark_parses_them() -> None:
    """Every line of the samples with a number is recorded, but for those the module's
    docstring names; each, its numbers changed, builds what lark gives."""
    replayed = 0
    for path in sorted((ROOT / "samples").glob("*.mp")):
        text = path.read_text(encoding="utf-8")
        lines, made = _lines_of(text)
        for index, recipe in made.items():
            changed = _renumbered(lines[index], lambda old, hexadecimal: (
                hex if hexadecimal else str)(int(old, 0 if hexadecimal else 10) * 7 + 3))
            replayed += _check(recipe, changed, index + 3)
    assert replayed > 100


@pytest.mark.parametrize("text", [
    "ON X ABC>=100 CALL 3", "ON DI 8.0 OFF_TO_ON CALL cycle", "X = 1.5", "X = = 1",
    "x1 = 12x", "SAY 'no 1 here'", "X = 99999999999999999999999", "x == 1",
])
def test_lines_that_must_be_parsed_have_no_recipe(text: str) -> None:
    """A token covering part of a number, a number lark does not take as INT, a line with
    a diagnostic, a line without numbers: lark parses them every time."""
    _, made = _lines_of(text)
    assert made == {}


def test_a_number_too_long_is_left_to_lark() -> None:
    _, made = _lines_of("X = 12 + 3")
    (recipe,) = made.values()
    assert not _check(recipe, "X = 12 + " + "9" * 25, 4)


def test_the_statement_cache_parses_only_lines_of_a_new_shape(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A cache that records builds a line of a known template without a parse; what it
    gives, statements and diagnostics, is the parse of the whole text."""
    counted = CountedParse()
    monkeypatch.setattr(linecache, "_parse_recorded", counted.recorded)
    cache = StatementCache(record=True)
    text = "MP 1\n  SET_V X, 2000\n  FOO 1, 'a 2'\n  X = 0x10 + 1\nEND MP\n"
    cache.parse(text, "c.mp", DiagnosticSink())
    counted.texts.clear()
    edited = (text.replace("2000", "99999999999999999999999").replace("0x10", "0xFF")
              .replace("'a 2'", "'a 3'") + "  X = 0x20 + 77\n  SET_V X, 3000\n")
    sink = DiagnosticSink()
    statements = cache.parse(edited, "c.mp", sink)
    reference = DiagnosticSink()
    assert (statements, sink.items) == (parse_text(edited, "c.mp", reference), reference.items)
    assert [d.code for d in sink.items] == ["E108"]
    assert counted.texts == ["  SET_V X, 99999999999999999999999\n  FOO 1, 'a 3'"]
    # the recipes travel with the lines: a fresh cache seeded from this one replays too
    kept = cache.distinct_of("c.mp")
    assert kept is not None
    seeded = StatementCache(record=True)
    seeded.seed("c.mp", kept, cache.recipes_for(kept))
    counted.texts.clear()
    again = edited.replace("3000", "4000")
    sink = DiagnosticSink()
    assert seeded.parse(again, "c.mp", sink) == parse_text(again, "c.mp", DiagnosticSink())
    assert counted.texts == []


def test_damaged_recipes_leave_the_line_to_lark(monkeypatch: pytest.MonkeyPatch) -> None:
    """Recipes that do not unpickle, or name no rule of the builder, build nothing: the
    line is parsed, and gives what lark gives."""
    counted = CountedParse()
    monkeypatch.setattr(linecache, "_parse_recorded", counted.recorded)
    first = StatementCache(record=True)
    first.parse("X = 1\n", "d.mp", DiagnosticSink())
    kept = first.distinct_of("d.mp")
    assert kept is not None
    _, made = _lines_of("X = 1")
    ((key, recipe),) = made.values()
    forged = (("__init__", recipe[-1][1]),)
    for damaged in (b"\x80not a pickle", pickle.dumps({1: (key, forged)})):
        counted.texts.clear()
        table = StatementCache(record=True)
        table.seed("d.mp", kept, damaged)
        sink = DiagnosticSink()
        assert table.parse("X = 2\n", "d.mp", sink) == parse_text("X = 2\n", "d.mp",
                                                                 DiagnosticSink())
        assert counted.texts == ["X = 2"] and sink.items == []

"""The statement cache by line text (mplang.lang.linecache): after any sequence of edits
an incremental parse gives what a full parse gives (statements with their spans,
diagnostics, and the image built from them), and an edit parses the edited lines only.
Parses are counted through the cache's own parse function, never timed."""

from __future__ import annotations

import dataclasses
import pickle
from pathlib import Path
from typing import ClassVar

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from parsecount import CountedParse

from mplang.lang import caches, frontcache, linecache
from mplang.lang.diagnostics import DiagnosticSink, Span, make_span
from mplang.lang.limits import MAX_EXPRESSION_DEPTH
from mplang.lang.linecache import StatementCache
from mplang.lang.parser import parse_text
from mplang.m8194h.compiler import compile_paths

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = sorted((ROOT / "samples").glob("*.mp"))
CHECKS = sorted((ROOT / "tests" / "data" / "checks").glob("*.mp"))
SOURCES = {path.name: path.read_text(encoding="utf-8") for path in [*SAMPLES, *CHECKS]}
SPARE_LINES = sorted({line for text in SOURCES.values() for line in text.split("\n")})
BROKEN = ["  X = = 1", "  FOO 999999999999999999999", "IF X >", "  SET_V X, (1", "\r",
          "  SET_V X, 2000 # a comment", "END MP", "MP 3", "  é = 1"]


def _full(text: str) -> tuple[object, ...]:
    sink = DiagnosticSink()
    return parse_text(text, "edited.mp", sink), sink.items


def _incremental(cache: StatementCache, text: str) -> tuple[object, ...]:
    sink = DiagnosticSink()
    return cache.parse(text, "edited.mp", sink), sink.items


def _edit(lines: list[str], action: tuple[int, int, int]) -> list[str]:
    """One edit a person makes: insert, delete or replace a line, change a number in one,
    break one. `action` holds the kind and two choices."""
    kind, where, what = action
    lines = list(lines)
    index = where % (len(lines) + 1)
    if kind == 0:
        lines.insert(index, SPARE_LINES[what % len(SPARE_LINES)])
    elif kind == 1 and lines:
        del lines[min(index, len(lines) - 1)]
    elif kind == 2 and lines:
        lines[min(index, len(lines) - 1)] = BROKEN[what % len(BROKEN)]
    elif kind == 3 and lines:
        target = min(index, len(lines) - 1)
        digits = [i for i, c in enumerate(lines[target]) if c.isdigit()]
        if digits:
            at = digits[what % len(digits)]
            text = lines[target]
            lines[target] = text[:at] + str((int(text[at]) + 1) % 10) + text[at + 1:]
    elif kind == 4 and lines:  # a block of lines moves down
        lines[index:index] = lines[:what % 5]
    return lines


EDITS = st.lists(st.tuples(st.integers(0, 4), st.integers(0, 10_000), st.integers(0, 10_000)),
                 min_size=1, max_size=8)


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(sorted(SOURCES)), edits=EDITS)
def test_random_edits_parse_as_a_full_parse_does(name: str,
                                                 edits: list[tuple[int, int, int]]) -> None:
    cache = StatementCache()
    lines = SOURCES[name].split("\n")
    assert _incremental(cache, "\n".join(lines)) == _full("\n".join(lines))
    for action in edits:
        lines = _edit(lines, action)
        text = "\n".join(lines)
        assert _incremental(cache, text) == _full(text)


def _image(path: Path, text: str, cache: StatementCache | None) -> tuple[object, ...]:
    result = compile_paths([path], texts={path: text, path.resolve(): text}, lines=cache)
    return (result.ok, [d.render() for d in result.diagnostics],
            result.to_json() if result.ok else None)


@settings(max_examples=15, deadline=None)
@given(name=st.sampled_from([p.name for p in SAMPLES]), edits=EDITS)
def test_random_edits_build_the_image_a_full_build_does(name: str,
                                                       edits: list[tuple[int, int, int]]
                                                       ) -> None:
    caches.turn_off(True)
    try:
        cache = StatementCache()
        path = ROOT / "samples" / name
        lines = SOURCES[name].split("\n")
        for action in [(1, 0, 0), *edits]:  # the first, a no-op edit of an empty file aside
            text = "\n".join(lines)
            assert _image(path, text, cache) == _image(path, text, None)
            lines = _edit(lines, action)
    finally:
        caches.turn_off(False)


def test_an_edit_parses_the_edited_line_only() -> None:
    counted = CountedParse()
    cache = StatementCache(counted)  # type: ignore[arg-type]
    text = (ROOT / "samples" / "full_mp156.mp").read_text(encoding="utf-8")
    lines = text.split("\n")
    cache.parse(text, "full.mp", DiagnosticSink())
    assert len(counted.texts) == 1  # all new: one parse of every distinct line, once each
    assert counted.texts[0].split("\n") == list(dict.fromkeys(lines))
    number = next(i for i, line in enumerate(lines) if "0" in line and "MP" not in line
                  and not line.lstrip().startswith(("#", "//")))
    lines[number] = lines[number].replace("0", "7", 1)
    lines.insert(1, "# a new comment line above, so every later line moves")
    edited = "\n".join(lines)
    counted.texts.clear()
    sink = DiagnosticSink()
    statements = cache.parse(edited, "full.mp", sink)
    assert counted.texts == ["\n".join([lines[1], lines[number + 1]])]
    assert (statements, sink.items) == _full_named(edited, "full.mp")
    counted.texts.clear()
    cache.parse(edited, "other.mp", DiagnosticSink())  # another file of the same lines
    assert counted.texts == []


def test_a_repeated_line_is_parsed_once() -> None:
    """Within one text too: a line repeated all over a file is parsed once and copied to
    its other places, its spans moved there; lines all distinct parse as the whole text."""
    counted = CountedParse()
    cache = StatementCache(counted)  # type: ignore[arg-type]
    body = ["  IF VAR2 > 10", "    SET_A Y, 5000", "  END IF", "  X = = 1"] * 40
    text = "\n".join(["MP 1", *body, "END MP", ""])
    sink = DiagnosticSink()
    statements = cache.parse(text, "repeat.mp", sink)
    assert counted.texts == ["\n".join(["MP 1", *body[:4], "END MP", ""])]
    assert (statements, sink.items) == _full_named(text, "repeat.mp")
    assert [d.span.line for d in sink.items] == list(range(5, 162, 4))
    distinct = "\n".join(f"  VAR{n} = {n}" for n in range(40))
    counted.texts.clear()
    assert StatementCache(counted).parse(distinct, "d.mp", DiagnosticSink())  # type: ignore[arg-type]
    assert counted.texts == [distinct]


DEEP = "  X = " + "(" * (MAX_EXPRESSION_DEPTH + 5) + "1" + ")" * (MAX_EXPRESSION_DEPTH + 5)
"""E107: nested deeper than the compiler follows."""


@settings(max_examples=60, deadline=None)
@given(picks=st.lists(st.integers(0, 10_000), min_size=1, max_size=120),
       pool=st.lists(st.sampled_from(SPARE_LINES), min_size=1, max_size=12))
def test_a_text_of_repeated_lines_parses_as_a_full_parse_does(picks: list[int],
                                                              pool: list[str]) -> None:
    """Lines drawn from a few (good, broken, too deep, blank), so most repeat: each is
    parsed once and copied, and statements, spans and diagnostics (their order too) are
    those of a full parse, in a fresh cache and in one that saw another text first."""
    choices = [*pool, *BROKEN, DEEP, ""]
    text = "\n".join(choices[pick % len(choices)] for pick in picks)
    assert _incremental(StatementCache(), text) == _full(text)
    warm = StatementCache()
    warm.parse("\n".join(reversed(choices)), "edited.mp", DiagnosticSink())
    assert _incremental(warm, text) == _full(text)


def _full_named(text: str, name: str) -> tuple[object, ...]:
    sink = DiagnosticSink()
    return parse_text(text, name, sink), sink.items


def test_a_line_in_place_is_the_same_object() -> None:
    """Unchanged lines at their place are shared, not copied: a caller can tell by identity
    which statements an edit left alone."""
    cache = StatementCache()
    text = "MP 1\n  SET_V X, 2000\n  FIXED_MOVE X, 10\nEND MP\n"
    first = cache.parse(text, "a.mp", DiagnosticSink())
    again = cache.parse(text.replace("10", "11"), "a.mp", DiagnosticSink())
    assert first[1] is again[1] and first[2] is not again[2]
    assert again[2].span.line == 3


def test_a_lone_carriage_return_parses_whole() -> None:
    cache = StatementCache()
    for text in ("MP 1\r\n  X = 1\r\nEND MP\r\n", "MP 1\n  X = 1\rEND MP\n", "MP 1\nEND MP\r"):
        assert _incremental(cache, text) == _full(text)


class _Loud:
    """Records every time it is unpickled."""

    loads: ClassVar[list[int]] = []

    def __reduce__(self) -> tuple[object, ...]:
        return (_Loud._loaded, ())

    @staticmethod
    def _loaded() -> _Loud:
        _Loud.loads.append(1)
        return _Loud()


def test_an_entry_of_another_key_is_never_unpickled(tmp_path: Path) -> None:
    entry = tmp_path / "entry.pickle"
    caches.store(entry, "key-one", [_Loud()], "key-two")
    _Loud.loads.clear()
    assert caches.load(entry, "key-three") is None
    assert _Loud.loads == []
    found = caches.load_keyed(entry, ("key-three", "key-two"))
    assert found is not None and found[0] == 1 and _Loud.loads == [1]


def test_the_front_cache_keeps_lines_of_an_earlier_text(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """On disk: an edited file is parsed from its earlier entry's lines plus the new ones,
    and gives what a full parse gives."""
    monkeypatch.setenv("MPLANG_CACHE", str(tmp_path / "cache"))
    text = (ROOT / "samples" / "full_mp156.mp").read_text(encoding="utf-8")
    frontcache.parse(text, "full.mp", DiagnosticSink(), where="/p/full.mp")
    edited = text.replace("2000", "2500", 1).replace("SET_V", "SET_A", 1) + "  BAD = = 1\n"
    counted = CountedParse()
    monkeypatch.setattr(linecache, "_parse_text", counted)
    monkeypatch.setattr(linecache, "_parse_recorded", counted.recorded)
    sink = DiagnosticSink()
    statements = frontcache.parse(edited, "full.mp", sink, where="/p/full.mp")
    assert (statements, sink.items) == _full_named(edited, "full.mp")
    assert len(counted.texts) == 1 and counted.texts[0].count("\n") <= 2
    counted.texts.clear()
    sink = DiagnosticSink()
    assert frontcache.parse(edited, "full.mp", sink, where="/p/full.mp") == statements
    assert counted.texts == [] and [d.code for d in sink.items] == ["E101"]


def test_a_made_span_is_a_span() -> None:
    """make_span (the parser's and the cache's) gives what Span(...) gives: equal, same
    hash and order, frozen, pickled alike."""
    made, built = make_span("a.mp", 3, 5, 9), Span("a.mp", 3, 5, 9)
    assert made == built and hash(made) == hash(built) and repr(made) == repr(built)
    assert make_span("a.mp", 3) == Span("a.mp", 3) and made < make_span("a.mp", 4)
    with pytest.raises(dataclasses.FrozenInstanceError):
        made.line = 4  # type: ignore[misc]
    assert pickle.loads(pickle.dumps(made)) == built


def test_the_front_cache_keeps_each_text_once(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """An entry holds the first line of each text with its number; the next run places
    every line from them (spans moved) without a parse, as a full parse gives it."""
    monkeypatch.setenv("MPLANG_CACHE", str(tmp_path / "cache"))
    body = ["  IF VAR2 > 10", "    SET_A Y, 5000", "  END IF", "  X = = 1"] * 30
    text = "\n".join(["MP 1", *body, "END MP", ""])
    frontcache.parse(text, "r.mp", DiagnosticSink(), where="/p/r.mp")
    (entry,) = (tmp_path / "cache" / "front").iterdir()
    kept, _ = pickle.loads(entry.read_bytes().split(b"\n", 1)[1])
    assert [(number, line[0]) for number, line in kept] == [
        (1, "MP 1"), (2, body[0]), (3, body[1]), (4, body[2]), (5, body[3]),
        (122, "END MP"), (123, "")]
    counted = CountedParse()
    monkeypatch.setattr(linecache, "_parse_text", counted)
    monkeypatch.setattr(linecache, "_parse_recorded", counted.recorded)
    for again in (text, text.replace("Y, 5000", "Z, 5000")):
        sink = DiagnosticSink()
        statements = frontcache.parse(again, "r.mp", sink, where="/p/r.mp")
        assert (statements, sink.items) == _full_named(again, "r.mp")
    assert counted.texts == ["    SET_A Z, 5000"]


def test_a_text_parsed_whole_is_never_kept(tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """A lone carriage return makes the text parse whole, outside the statement cache: the
    next run parses it again and reports the same (it once found an empty entry there)."""
    monkeypatch.setenv("MPLANG_CACHE", str(tmp_path / "cache"))
    text = "MP 1\n  X = 1\r  Y = 2\nEND MP\n"
    for _ in range(2):
        sink = DiagnosticSink()
        statements = frontcache.parse(text, "cr.mp", sink, where="/p/cr.mp")
        assert (statements, sink.items) == _full_named(text, "cr.mp")
        assert [d.code for d in sink.items] == ["E101"]
    assert not (tmp_path / "cache" / "front").exists()


def _naive_ends(before: list[str], after: list[str]) -> tuple[int, int]:
    head = 0
    while head < min(len(before), len(after)) and before[head] == after[head]:
        head += 1
    tail = 0
    while tail < min(len(before), len(after)) - head and \
            before[len(before) - 1 - tail] == after[len(after) - 1 - tail]:
        tail += 1
    return head, tail


@settings(max_examples=200, deadline=None)
@given(before=st.lists(st.sampled_from(["a", "ab", "", "b", "a\r"]), min_size=1, max_size=8),
       after=st.lists(st.sampled_from(["a", "ab", "", "b", "a\r"]), min_size=1, max_size=8))
def test_unchanged_ends_are_whole_equal_lines_that_never_overlap(before: list[str],
                                                                 after: list[str]) -> None:
    """The lines taken as they were at each end are equal in both texts and overlap in
    neither; at most the line of a change at a line's edge is left to the middle (it is
    then compared there)."""
    head, tail = linecache._unchanged_ends("\n".join(before), "\n".join(after), len(before),
                                           len(after))
    assert before[:head] == after[:head]
    assert before[len(before) - tail:] == after[len(after) - tail:]
    assert head + tail <= min(len(before), len(after)) or before == after
    naive_head, naive_tail = _naive_ends(before, after)
    assert head <= naive_head and tail <= naive_tail
    assert (naive_head - head <= 1 and naive_tail - tail <= 1) or before == after


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(sorted(SOURCES)), edits=EDITS)
def test_edits_at_the_ends_keep_diagnostics_in_order(name: str,
                                                     edits: list[tuple[int, int, int]]) -> None:
    """A broken line at the top and one at the bottom stay in the unchanged ends of every
    edit between them: their diagnostics still reach the sink, in line order, moved with
    their lines when lines are inserted or removed, as a full parse reports them."""
    cache = StatementCache()
    lines = ["  X = = 1", *SOURCES[name].split("\n"), "IF X >"]
    assert _incremental(cache, "\n".join(lines)) == _full("\n".join(lines))
    for action in edits:
        middle = _edit(lines[1:-1], action)
        lines = [lines[0], *middle, lines[-1]]
        text = "\n".join(lines)
        assert _incremental(cache, text) == _full(text)
        assert _incremental(cache, text) == _full(text)  # the same text again


def test_text_lines_are_split_once_per_text_object() -> None:
    """One check splits its text once: the same string object gives the very list of the
    last split; any other string (even an equal one, or one split in between) is split
    afresh, so no text is ever given another text's lines."""
    text = "MP 1\n  X = 1\nEND MP\n"
    lines = linecache.text_lines(text)
    assert lines == text.split("\n")
    assert linecache.text_lines(text) is lines
    other = "MP 2\n  X = 2\nEND MP\n"
    assert linecache.text_lines(other) == other.split("\n")
    assert linecache.text_lines(text) == text.split("\n")
    equal = "".join(["MP 1\n", "  X = 1\nEND MP\n"])  # equal, another object
    assert linecache.text_lines(equal) == text.split("\n")


class _CountedSplits(str):
    """A text that counts how often it is split into lines."""

    splits = 0

    def split(self, sep: str | None = None, maxsplit: int = -1) -> list[str]:
        if sep == "\n" and maxsplit == -1:
            type(self).splits += 1
        return super().split(sep, maxsplit)


def test_one_check_splits_its_text_once(tmp_path: Path) -> None:
    """The editor's lines, the kept parse, the blocks and the build's texts of one check
    are one split of the text."""
    from mplang.tools.lsp.analysis import analyse

    _CountedSplits.splits = 0
    text = _CountedSplits("MP 1\n  VAR1 = 1\nEND MP\n")
    analysis = analyse(tmp_path / "a.mp", text, lines=StatementCache())
    assert not analysis.diagnostics
    assert _CountedSplits.splits == 1

"""Compiler spans -> editor ranges, and code points <-> the client's code units."""

from __future__ import annotations

import random

from hypothesis import given, settings
from hypothesis import strategies as st
from lspedits import ALPHABET, random_edit

from mplang.lang.diagnostics import Span
from mplang.tools.lsp.positions import (
    ENCODINGS,
    Pos,
    Range,
    apply_change,
    from_client_character,
    line_range,
    span_range,
    split_lines,
    to_client_character,
)

LINES = ["MP 21 main", "    FIXD_MOVE X, 1000", "", "END MP"]


def test_span_with_end_column_becomes_a_0_based_exclusive_range() -> None:
    # 1-based col 5 .. end_col 14 (exclusive) is 0-based 4 .. 13 (exclusive)
    assert span_range(Span("a.mp", 2, 5, 14), LINES) == line_range(1, 4, 13)


def test_span_without_end_covers_the_word_at_its_column() -> None:
    assert span_range(Span("a.mp", 2, 15), LINES) == line_range(1, 14, 15)
    assert span_range(Span("a.mp", 2, 5), LINES) == line_range(1, 4, 13)


def test_span_at_column_1_without_end_covers_the_code_of_the_line() -> None:
    assert span_range(Span("a.mp", 2), LINES) == line_range(1, 4, 21)
    assert span_range(Span("a.mp", 3), LINES) == line_range(2, 0, 0)


def test_span_past_the_text_is_clamped_to_the_last_line() -> None:
    assert span_range(Span("a.mp", 99, 1, 4), LINES) == line_range(3, 0, 3)
    assert span_range(Span("a.mp", 1, 1, 99), LINES) == line_range(0, 0, 10)
    assert span_range(Span("a.mp", 1), []) == line_range(0, 0, 0)


def test_lines_split_like_the_compiler_counts_them() -> None:
    assert split_lines("a\r\nb\n\nc") == ["a", "b", "", "c"]
    assert split_lines("a\n") == ["a", ""]


def test_range_contains_its_end() -> None:
    word = Range(Pos(1, 4), Pos(1, 8))
    assert word.contains(Pos(1, 8)) and word.contains(Pos(1, 4))
    assert not word.contains(Pos(1, 9)) and not word.contains(Pos(0, 5))


def test_characters_outside_the_bmp_take_two_utf16_units() -> None:
    line = 'FIXED_MOVE X, "😀", Q'
    q = line.index("Q")
    assert to_client_character(line, q, "utf-16") == q + 1
    assert to_client_character(line, q, "utf-8") == q + 3
    assert to_client_character(line, q, "utf-32") == q
    assert from_client_character(line, q + 1, "utf-16") == q
    assert from_client_character(line, 10_000, "utf-16") == len(line)


@given(st.text(max_size=30), st.data())
def test_every_character_boundary_survives_the_round_trip(line: str, data: st.DataObject
                                                          ) -> None:
    index = data.draw(st.integers(0, len(line)))
    for encoding in ENCODINGS:
        units = to_client_character(line, index, encoding)
        assert from_client_character(line, units, encoding) == index


@settings(max_examples=200, deadline=None)
@given(st.lists(st.sampled_from(ALPHABET), max_size=30).map("".join),
       st.integers(min_value=0, max_value=2**32 - 1), st.integers(min_value=1, max_value=12))
def test_random_incremental_edits_give_the_full_text(start: str, seed: int, count: int
                                                     ) -> None:
    """Incremental sync: a sequence of random range edits, sent as a client counts positions
    (in each encoding, CRLF/LF/CR lines), applied one by one, gives the text a full sync would send;
    also with form feeds and U+2028, which `str.splitlines` would take for line breaks."""
    for encoding in ENCODINGS:
        rng = random.Random(seed)
        text = expected = start
        for _ in range(count):
            begin, end, inserted, expected = random_edit(expected, rng, encoding)
            text = apply_change(text, begin, end, inserted, encoding)
            assert text == expected


def test_a_position_past_a_line_or_the_text_is_clamped() -> None:
    assert apply_change("ab\ncd", (0, 99), (1, 1), "X", "utf-16") == "abXd"
    assert apply_change("ab\ncd", (7, 0), (9, 9), "!", "utf-16") == "ab\ncd!"
    assert apply_change("a😀b", (0, 1), (0, 3), "", "utf-16") == "ab"  # two UTF-16 units
    assert apply_change("a😀b", (0, 1), (0, 5), "", "utf-8") == "ab"  # four UTF-8 bytes


_UNIT_BYTES = {"utf-8": ("utf-8", 1), "utf-16": ("utf-16-le", 2), "utf-32": ("utf-32-le", 4)}


@given(st.text(alphabet=st.sampled_from(["a", " ", "~", "\t", "é", "😀", "\x7f", "\x80"]),
               max_size=20), st.integers(-3, 25), st.integers(-3, 45))
def test_the_ascii_fast_path_counts_as_the_encodings_do(line: str, character: int,
                                                         units: int) -> None:
    """ASCII lines and UTF-32 skip the per-character walk; every line, ASCII or not, any
    position (also before the line or past its end) converts as the encoded text counts."""
    for encoding in ENCODINGS:
        codec, size = _UNIT_BYTES[encoding]
        clamped = min(max(character, 0), len(line))
        assert to_client_character(line, character, encoding) == \
            len(line[:clamped].encode(codec)) // size
        # the first code point boundary at or after `units` code units, else the line's end
        boundaries = [i for i in range(len(line) + 1)
                      if len(line[:i].encode(codec)) // size >= units]
        assert from_client_character(line, units, encoding) == \
            (boundaries[0] if boundaries else len(line))

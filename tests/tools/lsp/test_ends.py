"""`same_ends`: the shared ends of two lists, by identity."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from mplang.tools.lsp.ends import (
    picked,
    picked_again,
    same_ends,
    shared_lines,
    shared_text_lines,
)


def test_equal_objects_that_are_not_the_same_do_not_count() -> None:
    a, b = [1000 + i for i in range(3)], [1000 + i for i in range(3)]  # equal, not the same
    kept = [object() for _ in range(4)]
    assert same_ends([kept[0], *a, kept[1]], [kept[0], *b, kept[1]]) == (1, 1)


def test_an_unchanged_list_is_all_head() -> None:
    items = [object() for _ in range(5)]
    assert same_ends(items, list(items)) == (5, 0)


@given(st.integers(0, 30), st.integers(0, 8), st.integers(0, 8), st.integers(0, 30))
def test_head_and_tail_around_a_replaced_middle(head: int, removed: int, added: int,
                                                tail: int) -> None:
    """Items replaced in the middle by new objects (counts that may differ): the ends found
    are the kept ones, never running into the middle or past each other."""
    front = [object() for _ in range(head)]
    back = [object() for _ in range(tail)]
    old = [*front, *(object() for _ in range(removed)), *back]
    new = [*front, *(object() for _ in range(added)), *back]
    start, end = same_ends(old, new)
    assert start + end <= min(len(old), len(new))
    assert all(old[i] is new[i] for i in range(start))
    assert all(old[len(old) - 1 - i] is new[len(new) - 1 - i] for i in range(end))
    if removed and added:  # the middle holds no shared object: the ends are exact
        assert (start, end) == (head, tail)


@given(st.lists(st.sampled_from(["a", "b", "c"]), max_size=600),
       st.lists(st.sampled_from(["a", "b", "c"]), max_size=600))
def test_shared_lines_are_the_longest_alike_ends(old: list[str], new: list[str]) -> None:
    """Lines alike at the start, then at the end (strides of many lines and of one agree
    with a count line by line), never overlapping."""
    start, end = shared_lines(old, new)
    limit = min(len(old), len(new))
    expected_start = next((i for i in range(limit) if old[i] != new[i]), limit)
    rest = limit - expected_start
    expected_end = next((i for i in range(rest) if old[-1 - i] != new[-1 - i]), rest)
    assert (start, end) == (expected_start, expected_end)


@given(st.integers(0, 1200), st.integers(0, 1200), st.integers(0, 3), st.integers(0, 3))
def test_shared_lines_around_an_edit_of_a_long_text(head: int, tail: int, removed: int,
                                                   added: int) -> None:
    """A long text with lines replaced in its middle: the ends found are the unchanged
    lines (as many as a count line by line finds)."""
    front = [f"line {i}" for i in range(head)]
    back = [f"end {i}" for i in range(tail)]
    old = [*front, *(["old"] * removed), *back]
    new = [*front, *(["new"] * added), *back]
    start, end = shared_lines(old, new)
    assert start + end <= min(len(old), len(new))
    if removed and added:
        assert (start, end) == (head, tail)
    else:
        assert start >= head and start + end >= min(head + tail, min(len(old), len(new)))


class _Kind:
    """An item `picked` picks."""


def test_picked_again_looks_between_and_takes_the_rest_where_it_stood() -> None:
    """After an edit of items[start:stop], the picked items are those the last pick found
    before and after it (moved as far as the edit changed the count, the very objects) and
    those between; an item not where it stood leaves it to a full pick."""
    kinds = frozenset({_Kind})
    items: list[object] = [_Kind(), 1, _Kind(), 2, 3, _Kind(), 4]
    last_items, positions = picked(items, kinds)
    assert last_items == [items[0], items[2], items[5]] and list(positions) == [0, 2, 5]
    edited = [*items[:3], _Kind(), "new", *items[4:]]  # item 3 replaced by two, one picked
    found = picked_again(edited, kinds, (last_items, positions, len(items)), 3, 5)
    assert found is not None
    assert found[0] == picked(edited, kinds)[0] and list(found[1]) == [0, 2, 3, 6]
    assert all(a is b for a, b in zip(found[0], picked(edited, kinds)[0], strict=True))
    replaced = [*edited[:6], _Kind(), 4]  # a kept one replaced outside the edited items
    assert picked_again(replaced, kinds, (last_items, positions, len(items)), 3, 5) is None
    before = [_Kind(), *edited[1:]]  # and one before the edited items
    assert picked_again(before, kinds, (last_items, positions, len(items)), 3, 5) is None


@given(st.lists(st.sampled_from(["", "a", "b", "ab"]), max_size=8),
       st.lists(st.sampled_from(["", "a", "b", "ab"]), max_size=8))
def test_shared_text_lines_are_the_shared_lines_of_the_texts(old: list[str], new: list[str]
                                                             ) -> None:
    """Found on the texts, the lines both share at either end are those `shared_lines`
    finds on their lists of lines (short lines of a few letters: ends that meet, a text
    that is the start or the end of the other, empty lines and texts)."""
    assert shared_text_lines("\n".join(old), "\n".join(new)) == \
        shared_lines("\n".join(old).split("\n"), "\n".join(new).split("\n"))

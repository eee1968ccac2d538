"""One build lowers each distinct statement text once per state (mplang.ir.textmemo): the
same text in another state, another kind of program or another file is lowered for that
state, and a build whose repeated lines are made distinct (a comment numbering each, so
that no two lines share a text) gives the same diagnostics and frames."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.ir.blockmemo import CHUNK
from mplang.lang import caches
from mplang.lang.diagnostics import Diagnostic
from mplang.m8194h.compiler import BuildResult, compile_paths, compile_source


def build(text: str) -> BuildResult:
    caches.turn_off(True)  # every line parsed and lowered in this build
    try:
        return compile_source(text, "shared.mp")
    finally:
        caches.turn_off(False)


def numbered(text: str) -> str:
    """`text` with every line made distinct by a comment: no lowering shared between
    lines, the same statements at the same places."""
    return "".join(f"{line}  # {n}\n" for n, line in enumerate(text.split("\n"), start=1))


def seen(result: BuildResult) -> tuple[list[Diagnostic], list[object]]:
    return result.diagnostics, [(p.placement.slot, [(f.line.command.short_name,
                                                     f.line.operands, f.line.span, f.frame)
                                                    for f in p.lines])
                                for p in result.programs]


def at(result: BuildResult, code: str) -> list[int]:
    return sorted(d.span.line for d in result.diagnostics if d.code == code)


IF_BLOCK = ["  IF VAR5 > 10", "    SET_A Y, 5000", "  END IF"]


def test_a_repeated_block_warns_where_its_variable_is_unwritten() -> None:
    text = "\n".join(["MP 1", "  VAR5 = 1", *IF_BLOCK, "END MP",  # VAR5 written: no W103
                      "MP 2", *IF_BLOCK, *IF_BLOCK, "END MP",    # W103 at the first only
                      "MP 3", "  VAR5 = 2", *IF_BLOCK, "END MP", ""])
    result = build(text)
    assert at(result, "W103") == [8]
    assert seen(result) == seen(build(numbered(text)))
    lines = {f.line.span.line for p in build(text).programs for f in p.lines}
    assert {3, 8, 11, 17} <= lines  # each IF emitted at its own line


def test_set_rvar_warns_by_the_line_before_it() -> None:
    rvar = "  SET_RVAR 3"
    text = "\n".join(["MP 1", "  VAR2 = GET_LP(X)", rvar, "END MP",
                      "MP 2", "  SET_V X, 100", rvar, "END MP", ""])
    result = build(text)
    assert seen(result) == seen(build(numbered(text)))


def test_a_while_needs_a_spare_label_where_it_stands() -> None:
    loop = ["  WHILE VAR3 < 5", "    VAR3 = VAR3 + 1", "  END WHILE"]
    labels = [f"  LABEL {n}" for n in range(16)]
    text = "\n".join(["MP 1", "  VAR3 = 0", *loop, "END MP",
                      "MP 2", "  VAR3 = 0", *labels, *loop, "END MP", ""])
    result = build(text)
    assert seen(result) == seen(build(numbered(text)))
    assert at(result, "E329")  # every label taken in MP 2: its WHILE has none


def test_the_same_block_in_an_isr_is_checked_for_an_isr() -> None:
    loop = ["  FOR 3", "    SET_V X, 100", "  NEXT"]
    text = "\n".join(["MP 1", *loop, "END MP", "ISR 2", *loop, "END ISR", ""])
    result = build(text)
    assert at(result, "E313") == [7]
    assert seen(result) == seen(build(numbered(text)))


def test_a_const_error_is_reported_at_the_const_once() -> None:
    text = "\n".join(["CONST BAD = 1 / 0", "MP 1", "  SET_V X, BAD", "  SET_V X, BAD",
                      "END MP", "MP 2", "  SET_V X, BAD", "END MP", ""])
    result = build(text)
    assert seen(result) == seen(build(numbered(text)))


LINES = ["  VAR1 = 0", "  VAR2 = VAR1 + 3", "  VAR3 = (VAR1 + 2) * (VAR2 - 1) + VAR4 * 3",
         "  SET_V X, 2000", "  FIXED_MOVE XY, 100", "  SET_RVAR 3", "  VAR4 = GET_LP(X)",
         "  IF VAR1 > 10", "    SET_A Y, 5000", "  END IF", "  FOR 3", "    VAR5 = VAR5 + 1",
         "  NEXT", "  LABEL top", "  GOTO top", "  WHILE VAR6 < 4", "    VAR6 = VAR6 + 1",
         "  END WHILE", "  REPEAT VAR2", "    SET_V Y, 10", "  END REPEAT", "  EXIT",
         "  IF VAR9 = VAR8 + 1", "  ELSE", "  CALL MP2", "  VAR7 = VAR9 / 0"]


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["mp", "isr"]),
                          st.lists(st.sampled_from(LINES), max_size=12)),
                min_size=1, max_size=5))
def test_shared_lowerings_are_those_of_distinct_lines(
        programs: list[tuple[str, list[str]]]) -> None:
    text = []
    for slot, (kind, body) in enumerate(programs, start=1):
        text += [f"{kind.upper()} {slot}", *body, f"END {kind.upper()}"]
    joined = "\n".join(text) + "\n"
    assert seen(build(joined)) == seen(build(numbered(joined)))


def test_an_included_file_lowers_its_own_lines(tmp_path: Path) -> None:
    """The same text in an included file and in the file including it: each lowered where
    it stands, its spans naming its own file."""
    body = ["MP {slot}", "  VAR5 = 1", *IF_BLOCK, "END MP", "MP {other}", *IF_BLOCK, "END MP", ""]
    results = []
    for numbering in (False, True):
        library = "\n".join(body).format(slot=3, other=4)
        main = 'INCLUDE "lib.mp"\n' + "\n".join(body).format(slot=1, other=2)
        if numbering:
            library, main = numbered(library), numbered(main)
        (tmp_path / "lib.mp").write_text(library)
        (tmp_path / "main.mp").write_text(main)
        caches.turn_off(True)
        try:
            result = compile_paths([tmp_path / "main.mp"])
        finally:
            caches.turn_off(False)
        files = {d.span.file.rsplit("/", 1)[-1] for d in result.diagnostics if d.code == "W103"}
        assert files == {"lib.mp", "main.mp"}
        results.append(seen(result))
    assert results[0] == results[1]


FILLER = [f"  SET_V X, {25 * n}" for n in range(1, CHUNK)]


def test_a_repeated_chunk_is_lowered_again_where_its_state_differs() -> None:
    """Programs whose statements from the CHUNK-th on have the same texts share that chunk
    (`TextMemo.chunk`) only where it enters the same state: VAR5 is written before it in
    MP 1 and MP 3, not in MP 2, so the read inside it warns in MP 2 alone."""
    tail = [*IF_BLOCK, *FILLER, "  GOTO 1", "  SET_V X, 50", "  LABEL 1", "  IF VAR6 > 1",
            "    EXIT", "  END IF"]
    text = "\n".join(["MP 1", "  VAR5 = 1", *FILLER, *tail, "END MP",
                      "MP 2", "  VAR7 = 1", *FILLER, *tail, "END MP",
                      "MP 3", "  VAR5 = 1", *FILLER, *tail, "END MP", ""])
    result = build(text)
    assert seen(result) == seen(build(numbered(text)))
    lines = text.split("\n")
    second = lines.index("MP 2") + 1
    reads = [n for n in at(result, "W103") if lines[n - 1] == IF_BLOCK[0]]
    assert reads == [second + 1 + CHUNK]  # MP 2's IF VAR5, its 17th statement
    assert len([n for n in at(result, "W103") if lines[n - 1] == "  IF VAR6 > 1"]) == 3


@settings(max_examples=15, deadline=None)
@given(st.lists(st.lists(st.sampled_from(LINES), min_size=CHUNK - 2, max_size=3 * CHUNK),
                min_size=1, max_size=2),
       st.lists(st.tuples(st.sampled_from(["mp", "isr"]), st.integers(0, 1),
                          st.sampled_from(["", *LINES])), min_size=2, max_size=4))
def test_shared_chunks_are_those_of_distinct_lines(
        bodies: list[list[str]], programs: list[tuple[str, int, str]]) -> None:
    """Programs that repeat long bodies (each with a line of its own before, or not): the
    chunks they share give what their lines made distinct give."""
    text = []
    for slot, (kind, which, first) in enumerate(programs, start=1):
        body = bodies[which % len(bodies)]
        text += [f"{kind.upper()} {slot}", *([first] if first else []), *body,
                 f"END {kind.upper()}"]
    joined = "\n".join(text) + "\n"
    assert seen(build(joined)) == seen(build(numbered(joined)))

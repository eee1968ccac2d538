"""Builds that keep what an edit left alone (mplang.ir.reuse, lang.structure.BlockMemo): after
any sequence of edits, a build with a memo gives exactly what a build from scratch gives
(diagnostics, frames, the image and its listing), and an edit of one program lowers that
program alone. Reuse is told by object identity, never by time."""

from __future__ import annotations

from pathlib import Path

import pytest
from sourceedits import (
    LARGE,
    LARGE_WARM_UP,
    changed,
    changed_large,
    edit_sequences,
    large_edit_sequences,
    seen,
)

from mplang.ir import catalogue as catalogue_module
from mplang.ir.blockmemo import CHUNK, Chunk
from mplang.ir.macro import LoweredProgram, MacroLine
from mplang.ir.reuse import BuildMemo
from mplang.lang import ast
from mplang.lang.diagnostics import Span
from mplang.lang.linecache import StatementCache
from mplang.lang.structure import RUN
from mplang.m8194h.compiler import BuildResult, compile_paths


def _build(path: Path, text: str, lines: StatementCache | None = None,
           memo: BuildMemo | None = None) -> BuildResult:
    return compile_paths([path], texts={path: text}, lines=lines, memo=memo)


@edit_sequences
def test_random_edits_build_as_a_fresh_build_does(path: Path,
                                                  steps: list[tuple[int, int, int]]) -> None:
    lines, memo = StatementCache(), BuildMemo()
    text = path.read_text(encoding="utf-8").split("\n")
    assert seen(_build(path, "\n".join(text), lines, memo)) == seen(_build(path, "\n".join(text)))
    for step in steps:
        text = changed(text, step)
        joined = "\n".join(text)
        assert seen(_build(path, joined, lines, memo)) == seen(_build(path, joined))
        # the same text again, everything kept: still the same
        assert seen(_build(path, joined, lines, memo)) == seen(_build(path, joined))


def test_an_edit_lowers_only_the_program_it_changed(tmp_path: Path) -> None:
    path = tmp_path / "three.mp"
    text = "\n".join(["CONST FAST = 2000", "MP 1 first", "  SET_V X, FAST", "END MP",
                      "MP 2 second", "  VAR1 = 5", "  CALL first", "END MP",
                      "MP 3 third", "  SET_V Y, 300", "END MP", ""])
    lines, memo = StatementCache(), BuildMemo()

    def entries(result: BuildResult) -> dict[str | None, object]:
        return {p.placement.program.name: memo.lowerings.entry(p.placement.program)
                for p in result.programs}

    before = entries(_build(path, text, lines, memo))
    after = entries(_build(path, text.replace("VAR1 = 5", "VAR1 = 6"), lines, memo))
    assert all(before.values())
    assert after["first"] is before["first"] and after["third"] is before["third"]
    assert after["second"] is not before["second"]
    # a CONST is read by every program: changing one lowers them all again
    again = entries(_build(path, text.replace("2000", "2500"), lines, memo))
    assert all(again[name] is not after[name] for name in after)


def test_a_kept_program_is_its_own_copy_in_each_build(tmp_path: Path) -> None:
    """The wiring adds lines to the setup program and the linker sets slots: a program
    kept for the next build must not carry them over."""
    path = tmp_path / "wired.mp"
    text = "\n".join(["INTERRUPTS setup", "  ON X P>=C+ CALL ISR 3", "END INTERRUPTS",
                      "MP setup", "  SET_V X, 100", "END MP", "ISR 3", "  SET_V Y, 5",
                      "END ISR", ""])
    lines, memo = StatementCache(), BuildMemo()
    first = _build(path, text, lines, memo)
    for _ in range(3):
        assert seen(_build(path, text, lines, memo)) == seen(first)


def test_w111_follows_the_max_v_a_kept_program_starts_from(tmp_path: Path) -> None:
    """An unchanged program's W111 warnings are kept for the MAX_V values it starts from:
    editing the INIT block's SET_MAX_V, and back, gives each time what a fresh build does."""
    path = tmp_path / "maxv.mp"
    text = "\n".join(["INIT", "  SET_MAX_V X, 200000", "END INIT", "MP 1 moves",
                      "  SET_ACC X, 123457", "  SET_V X, 70001", "END MP", ""])
    lines, memo = StatementCache(), BuildMemo()
    for max_v in ("200000", "160000", "200000", "8000"):
        edited = text.replace("200000", max_v)
        kept = _build(path, edited, lines, memo)
        assert any(d.code == "W111" for d in kept.diagnostics)
        assert seen(kept) == seen(_build(path, edited))


def _frames_kept(memo: BuildMemo, result: BuildResult) -> dict[str | None, object]:
    """Each program's kept frames, by name: the same object across builds only when the
    program's lowering was kept (shifted or not), never made again."""
    found: dict[str | None, object] = {}
    for image in result.programs:
        entry = memo.lowerings.entry(image.placement.program)
        assert entry is not None
        found[image.placement.program.name] = entry.derived["frames"][1]
    return found


THREE = ["MP 1 first", "  SET_V X, 2000", "END MP", "", "MP 2 second", "  VAR1 = 5",
         "  SET_A X, 123457", "  CALL first", "END MP", "MP 3 third", "  SET_V Y, 70001",
         "END MP", ""]


def test_a_program_that_only_moved_is_shifted_not_lowered_again(tmp_path: Path) -> None:
    """Lines inserted or deleted above a program move it: what it kept (macro lines, W111
    warnings, frames) is shifted with it, and the build is what a fresh one gives."""
    path = tmp_path / "three.mp"
    lines, memo = StatementCache(), BuildMemo()
    before = _frames_kept(memo, _build(path, "\n".join(THREE), lines, memo))
    for edited in ([*THREE[:2], "  SET_V Y, 10", "  # two lines more", *THREE[2:]],
                   THREE[:3] + THREE[4:], ["# a comment on top", *THREE]):
        text = "\n".join(edited)
        kept = _build(path, text, lines, memo)
        assert seen(kept) == seen(_build(path, text))
        assert any(d.code == "W111" and d.span.line == edited.index("  SET_A X, 123457") + 1
                   for d in kept.diagnostics)
        after = _frames_kept(memo, kept)
        assert after["second"] is before["second"] and after["third"] is before["third"]
        before = after


def test_a_moved_program_whose_message_names_a_line_is_lowered_again(tmp_path: Path) -> None:
    """W101 names the line of the jump in its text: the program is lowered again when it
    moves, so the text names the line where the jump now is."""
    path = tmp_path / "jumps.mp"
    text = ["MP 1 first", "  SET_V X, 20", "END MP", "MP 2 second", "  GOTO done",
            "  SET_V X, 10", "  LABEL done", "END MP", ""]
    lines, memo = StatementCache(), BuildMemo()
    _build(path, "\n".join(text), lines, memo)
    edited = ["# a comment", "# another", *text]
    result = _build(path, "\n".join(edited), lines, memo)
    assert seen(result) == seen(_build(path, "\n".join(edited)))
    assert [d.message for d in result.diagnostics if d.code == "W101"] == \
        ["unreachable: line 7 always jumps away"]


@large_edit_sequences
def test_random_edits_inside_one_program_build_as_a_fresh_build_does(
        steps: list[tuple[int, int, int]]) -> None:
    """Edits inside one long program and across its blocks' boundaries (IF/ELSE/END IF,
    FOR/NEXT, LABEL/GOTO, WHILE, REPEAT): each build with the memo, which lowers again only
    the statements an edit changed, is the build from scratch."""
    path = Path("/large.mp")
    lines, memo = StatementCache(), BuildMemo()
    for text in LARGE_WARM_UP:
        assert seen(_build(path, "\n".join(text), lines, memo)) == \
            seen(_build(path, "\n".join(text)))
    text = list(LARGE)
    for step in steps:
        text = changed_large(text, step)
        joined = "\n".join(text)
        assert seen(_build(path, joined, lines, memo)) == seen(_build(path, joined))


def _statements_kept(memo: BuildMemo, result: BuildResult, name: str) -> list[object]:
    """The kept top-level statements of program `name`, in order."""
    for image in result.programs:
        if image.placement.program.name == name:
            entry = memo.lowerings.entry(image.placement.program)
            assert entry is not None and entry.statements is not None
            return list(entry.statements.order)
    raise AssertionError(name)


def test_an_edit_inside_a_program_lowers_only_the_statement_it_changed(tmp_path: Path
                                                                       ) -> None:
    """A number edited in one statement of a long program: that statement is lowered
    again, every other one (blocks, jumps, reads) is the same kept object, and the build
    is the fresh one."""
    path = tmp_path / "large.mp"
    lines, memo = StatementCache(), BuildMemo()
    first = _build(path, "\n".join(LARGE), lines, memo)
    entry = memo.lowerings.entry(first.programs[0].placement.program)
    assert entry is not None and entry.statements is None
    # the first edit of a program starts its table of statements
    warm = LARGE.index("  SET_V Z, 2")
    start = [*LARGE[:warm], "  SET_V Z, 9", *LARGE[warm + 1:]]
    before = _statements_kept(memo, _build(path, "\n".join(start), lines, memo), "long")
    at = LARGE.index("    FIXED_MOVE XY, 207")  # inside the third IF block
    edited = [*start[:at], "    FIXED_MOVE XY, 208", *start[at + 1:]]
    result = _build(path, "\n".join(edited), lines, memo)
    assert seen(result) == seen(_build(path, "\n".join(edited)))
    after = _statements_kept(memo, result, "long")
    assert len(after) == len(before)
    changed_at = [i for i, (a, b) in enumerate(zip(before, after, strict=True)) if a is not b]
    assert len(changed_at) == 1
    assert after[changed_at[0]].node.span.line < at + 1 <= \
        after[changed_at[0]].node.end_span.line  # type: ignore[attr-defined]


def test_a_statement_that_enters_another_state_is_lowered_again(tmp_path: Path) -> None:
    """A variable written earlier in the program is read later: W103 of the read comes and
    goes with the write, though the reading statement is unchanged."""
    path = tmp_path / "reads.mp"
    text = ["MP 1 main", "  VAR5 = 1", "  SET_V X, 100", "  IF VAR5 > 2", "    SET_V Y, 10",
            "  END IF", "END MP", ""]
    lines, memo = StatementCache(), BuildMemo()
    for first in ("  VAR5 = 1", "  VAR6 = 1", "  VAR5 = 2", "  VAR6 = 3"):
        edited = [text[0], first, *text[2:]]
        result = _build(path, "\n".join(edited), lines, memo)
        assert seen(result) == seen(_build(path, "\n".join(edited)))
        assert any(d.code == "W103" for d in result.diagnostics) == (first == "  VAR6 = 1"
                                                                     or first == "  VAR6 = 3")


def test_an_edit_inside_a_program_matches_again_only_the_block_it_changed(tmp_path: Path
                                                                          ) -> None:
    """The blocks at a program's top level that an edit left alone are the same syntax
    objects as before (matched once, `lang.structure.BlockMemo.find_block`); the edited
    one is matched again."""
    path = tmp_path / "large.mp"
    lines, memo = StatementCache(), BuildMemo()

    def body(result: BuildResult) -> list[object]:
        program = next(p.placement.program for p in result.programs
                       if p.placement.program.name == "long")
        entry = memo.lowerings.entry(program)
        assert entry is not None
        return list(entry.program.body)

    before = body(_build(path, "\n".join(LARGE), lines, memo))
    at = LARGE.index("      EXIT FOR")  # inside the first FOR, inside its IF
    edited = [*LARGE[:at], "      SET_V X, 5", *LARGE[at + 1:]]
    after = body(_build(path, "\n".join(edited), lines, memo))
    differs = [i for i, (a, b) in enumerate(zip(before, after, strict=True)) if a is not b]
    assert len(differs) == 1 and isinstance(after[differs[0]], ast.ForBlock)
    assert [type(n) for n in before] == [type(n) for n in after]


def test_lines_used_follows_the_lines_of_a_kept_program() -> None:
    """A kept program's cost, summed once, is taken by its copies while their lines are the
    ones copied: lines added as interrupt wiring adds them, or another list of lines of the
    same length, are summed again."""
    catalogue = catalogue_module.load()
    one, two = (next(c for c in catalogue.commands if c.line_cost == cost) for cost in (1, 2))
    span = Span("a.mp", 1)
    kept = LoweredProgram("mp", 1, "p", "a.mp", span, span,
                          [MacroLine(one, (), span), MacroLine(one, (), span)])
    assert kept.lines_used(False) == 2 and kept.lines_used(True) == 3
    copy = kept.copied()
    assert copy.lines is not kept.lines and copy.lines_used(False) == 2
    copy.lines[0:0] = [MacroLine(two, (), span)]  # as `ir.configure` wires an interrupt
    assert copy.lines_used(False) == 4 and kept.lines_used(False) == 2
    copy.lines = [MacroLine(two, (), span)] * 3  # the same length, other lines
    assert copy.lines_used(False) == 6
    assert kept.copied().lines_used(True) == 3


def _chunked(first: str, read: str) -> list[str]:
    """A program of more statements than a chunk holds several times over (in a slot that
    holds it): `first` at its top, `read` (a statement that reads VAR5) deep inside it,
    past the first chunks."""
    filler = [f"  SET_V X, {n}" for n in range(1, 3 * CHUNK)]
    return ["MP 156 main", *first.split("\n"), *filler, *read.split("\n"), *filler,
            "END MP", ""]


def test_a_chunk_of_statements_is_replayed_whole_and_again_only_where_edited(
        tmp_path: Path) -> None:
    """After an edit of one statement, the next edits of it lower that statement alone:
    every other statement is replayed in chunks, the same chunk objects as before."""
    path = tmp_path / "chunks.mp"
    lines, memo = StatementCache(), BuildMemo()
    before: list[object] = []
    for value in range(1, 7):
        text = _chunked(f"  VAR5 = {value}", "  IF VAR5 > 2\n    SET_V Y, 10\n  END IF")
        result = _build(path, "\n".join(text), lines, memo)
        assert seen(result) == seen(_build(path, "\n".join(text)))
        entry = memo.lowerings.entry(result.programs[0].placement.program)
        items = [] if entry is None or entry.statements is None else entry.statements.items
        # the second build lowers every statement (the table starts), the third opens the
        # chunk of the edited one, which is a chunk of its own from then on
        if value >= 5:
            assert len(items) == len(before)
            differs = [i for i, (a, b) in enumerate(zip(before, items, strict=True))
                       if a is not b]
            assert differs == [0] and isinstance(items[1], Chunk)
            assert len(items) <= 2 * 3 + 3  # 2 x 3 chunks of filler, the IF, the edited one
        before = list(items)


@pytest.mark.parametrize(("first", "read", "warns"), [
    # the write before a chunk comes and goes: the read inside it warns or not
    ("  VAR5 = 1", "  VAR6 = 1", "  IF VAR5 > 2\n    SET_V Y, 10\n  END IF"),
    # a read before the chunk warns first, then is gone: the read inside warns instead
    ("  IF VAR5 > 1\n    SET_V Y, 1\n  END IF", "  IF VAR7 > 1\n    SET_V Y, 1\n  END IF",
     "  VAR8 = VAR5 + 1"),
])
def test_a_chunk_entered_in_another_state_is_lowered_again(
        tmp_path: Path, first: str, read: str, warns: str) -> None:
    """W103 of a read deep in a long program follows a statement far above it, which the
    chunk holding the read does not contain: its W103 state on entry differs."""
    path = tmp_path / "reads.mp"
    lines, memo = StatementCache(), BuildMemo()
    for top in (first, read, first, read, read, first):
        text = _chunked(top, warns)
        result = _build(path, "\n".join(text), lines, memo)
        fresh = _build(path, "\n".join(text))
        assert seen(result) == seen(fresh)
        line = text.index(warns.split("\n")[0]) + 1
        assert [d.code for d in result.diagnostics if d.span.line == line] == \
            [d.code for d in fresh.diagnostics if d.span.line == line]


def test_a_run_of_top_level_statements_is_matched_whole_and_again_where_edited(
        tmp_path: Path) -> None:
    """The program's top-level statements are kept in runs (`lang.structure.BlockMemo`):
    an edit anywhere in one (a block's inner line, plain lines, a block made lines, a jump)
    makes the build from scratch, and its nodes outside the edited lines are the same
    objects as before."""
    path = tmp_path / "runs.mp"
    blocks = [f"  IF VAR{n} > 1\n    SET_V Y, {n}\n  END IF" for n in range(2, 4 * RUN)]
    lines, memo = StatementCache(), BuildMemo()
    before: list[object] = []
    for at, text in [(0, blocks[0]), (1, "  VAR9 = 1\n  SET_V X, 25\n  VAR9 = 2"),
                     (1, "  VAR9 = 1\n  SET_V X, 50\n  VAR9 = 2"),
                     (RUN + 3, "  IF VAR9 > 1\n    SET_V Y, 7\n  END IF"),
                     (2 * RUN, "  GOTO 3\n  SET_V X, 25\n  LABEL 3")]:
        blocks[at] = text
        source = "\n".join(["MP 156 main", *blocks, "END MP", ""])
        result = _build(path, source, lines, memo)
        assert seen(result) == seen(_build(path, source))
        entry = memo.lowerings.entry(result.programs[0].placement.program)
        assert entry is not None
        after = list(entry.program.body)
        if before:
            kept = {id(node) for node in before}
            first = 2 + 3 * at  # the edited lines, 1-based
            assert {node.span.line for node in after if id(node) not in kept} <= \
                set(range(first, first + 3))
            assert len(kept.intersection(map(id, after))) >= len(after) - 3
        before = after

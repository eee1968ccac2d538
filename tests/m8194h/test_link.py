"""Linker: deterministic best-fit placement, budgets with x2/x3/x4 costs, call graph."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from mplang.ir.unit import Options, SlotPin
from mplang.lang.diagnostics import Diagnostic, Span
from mplang.m8194h.compiler import compile_source


def body(lines: int) -> str:
    return "".join("  FIXED_MOVE X, 1\n" for _ in range(lines))


def slots(source: str) -> dict[str, int]:
    result = compile_source(source)
    assert result.ok, [d.render() for d in result.diagnostics]
    return {p.program.name or "": p.placement.slot for p in result.programs}


def test_smallest_fitting_slot_lowest_number_first() -> None:
    placed = slots(f"MP a\n{body(7)}END MP\nMP b\n{body(8)}END MP\nMP c\n{body(1)}END MP\n")
    assert placed == {"a": 1, "b": 41, "c": 2}  # 7+close fits 8; 8+close needs 16


def test_pinned_slots_are_left_alone() -> None:
    placed = slots(f"MP 1 pinned\n{body(1)}END MP\nMP auto\n{body(1)}END MP\n")
    assert placed == {"pinned": 1, "auto": 2}


PLACE = """
import json, sys
from mplang.m8194h.compiler import compile_source
result = compile_source(sys.stdin.read())
assert result.ok
print(json.dumps({p.program.name: p.placement.slot for p in result.programs}, sort_keys=True))
"""


def test_placement_is_deterministic() -> None:
    """The same placement in processes with different string hash seeds, so an order that
    follows a set or a hash of names would show."""
    source = "".join(f"MP p{i}\n{body(i % 20)}END MP\n" for i in range(30)) + "".join(
        f"ISR q{i}\n{body(i % 3)}END ISR\n" for i in range(5))
    placements = set()
    for seed in ("1", "2", "987654"):
        done = subprocess.run([sys.executable, "-c", PLACE], input=source, capture_output=True,
                              text=True, timeout=120, env={**os.environ, "PYTHONHASHSEED": seed})
        assert done.returncode == 0, done.stderr
        placements.add(done.stdout)
    assert len(placements) == 1
    assert json.loads(placements.pop()) == slots(source)


def test_costs_count_in_budgets() -> None:
    arc = "  ARC_CW 100, 0, 200, 0\n"  # x2
    result = compile_source(f"MP 1\n{arc * 3}  FIXED_MOVE X, 1\nEND MP\n")
    assert result.ok and result.programs[0].placement.lines_used == 8
    result = compile_source(f"MP 1\n{arc * 4}END MP\n")
    assert [d.code for d in result.diagnostics] == ["E503"]
    assert "needs 9 lines" in result.diagnostics[0].message


def test_the_close_line_counts_only_where_the_profile_says_so() -> None:
    """close_counts_as_line (device.toml, a documented choice): FIXED_MOVE (1) and ARC_CW
    (x2) take 3 lines, 4 with the close."""
    result = compile_source("MP 41\n  ARC_CW 100, 0, 200, 0\n  FIXED_MOVE X, 1\nEND MP\n")
    program = result.programs[0].program
    assert (program.lines_used(False), program.lines_used(True)) == (3, 4)


def test_slot_line_numbers_follow_costs() -> None:
    result = compile_source("MP 41\n  ARC_CW 100, 0, 200, 0\n  FIXED_MOVE X, 1\nEND MP\n")
    assert [lf.first_slot_line for lf in result.programs[0].lines] == [0, 2]


def test_isr_budget_and_full_device() -> None:
    result = compile_source(f"ISR 1\n{body(8)}END ISR\n")
    assert [d.code for d in result.diagnostics] == ["E503"]
    many = "".join(f"MP\n{body(1)}END MP\n" for _ in range(158))
    assert "E504" in {d.code for d in compile_source(many).diagnostics}


def test_call_by_name_resolves_after_placement() -> None:
    result = compile_source("MP 21 main\n  CALL helper\nEND MP\nMP helper\n  EXIT\nEND MP\n")
    assert result.ok
    main = next(p for p in result.programs if p.program.name == "main")
    helper = next(p for p in result.programs if p.program.name == "helper")
    assert main.frames[1] == [0x0CCB, helper.placement.slot]


# ------------------------------------- the linker's diagnostics, word for word (docs/testing.md)
# The slot table of the device profile (stdlib/m8194h/device.toml): MP1-MP40 8 lines,
# MP41-MP90 16, MP91-MP130 32, MP131-MP150 64, MP151-MP155 128, MP156-MP157 512;
# ISR1-ISR6 8, ISR7-ISR15 16, ISR16-ISR18 32, ISR19-ISR20 64. The close counts as a line.

def found(source: str, options: Options = Options()) -> list[Diagnostic]:
    return compile_source(source, "job.mp", options).diagnostics


def one(source: str, options: Options = Options()) -> Diagnostic:
    (diagnostic,) = found(source, options)
    return diagnostic


def test_a_numbered_program_fits_its_slot_to_the_last_line() -> None:
    assert compile_source(f"MP 1 full\n{body(7)}END MP\n").ok  # 7 + close = 8
    assert compile_source(f"ISR 7 full\n{body(15)}END ISR\n").ok  # 15 + close = 16


@pytest.mark.parametrize(("head", "lines", "message", "hint"), [
    ("MP 1 big", 8, "MP1 big needs 9 lines including the closing line, but MP1-MP40 slots "
     "hold 8", "use a slot in MP41-MP90 (16 lines), drop the number to let the linker "
     "choose, or split it"),
    ("MP 2", 15, "MP2 needs 16 lines including the closing line, but MP1-MP40 slots hold 8",
     "use a slot in MP41-MP90 (16 lines), drop the number to let the linker choose, or "
     "split it"),
    ("MP 41 big", 16, "MP41 big needs 17 lines including the closing line, but MP41-MP90 "
     "slots hold 16", "use a slot in MP91-MP130 (32 lines), drop the number to let the "
     "linker choose, or split it"),
    ("ISR 1 edge", 8, "ISR1 edge needs 9 lines including the closing line, but ISR1-ISR6 "
     "slots hold 8", "use a slot in ISR7-ISR15 (16 lines), drop the number to let the "
     "linker choose, or split it"),
    ("ISR 19 edge", 64, "ISR19 edge needs 65 lines including the closing line, but "
     "ISR19-ISR20 slots hold 64", "split it into several programs that CALL each other"),
    ("MP 156 huge", 512, "MP156 huge needs 513 lines including the closing line, but "
     "MP156-MP157 slots hold 512", "split it into several programs that CALL each other"),
])
def test_e503_names_the_budget_and_the_smallest_slot_range_that_fits(
        head: str, lines: int, message: str, hint: str) -> None:
    kind = head.split()[0]
    diagnostic = one(f"{head}\n{body(lines)}END {kind}\n")
    assert (diagnostic.code, diagnostic.span.line) == ("E503", 1)
    assert (diagnostic.message, diagnostic.hint, diagnostic.related) == (message, hint, ())


def test_e503_of_a_pinned_program_blames_the_pin_and_says_to_move_it() -> None:
    pin = SlotPin("big", "mp", 3, Span("mpc.toml", 5))
    diagnostic = one(f"MP big\n{body(9)}END MP\n", Options(pins=(pin,)))
    assert (diagnostic.code, diagnostic.span) == ("E503", pin.span)
    assert diagnostic.message == ("MP3 big needs 10 lines including the closing line, but "
                                  "MP1-MP40 slots hold 8")
    assert diagnostic.hint == ("pin it to a slot in MP41-MP90 (16 lines), remove the pin to "
                               "let the linker choose, or split it")
    assert [(span.line, note) for span, note in diagnostic.related] == [(1, "the program")]


@pytest.mark.parametrize(("head", "message"), [
    ("MP 158", "MP158 does not exist: slots are MP1..MP157"),
    ("ISR 21", "ISR21 does not exist: slots are ISR1..ISR20"),
])
def test_e501_gives_the_slot_numbers_that_exist(head: str, message: str) -> None:
    diagnostic = one(f"{head}\n{body(1)}END {head.split()[0]}\n")
    assert (diagnostic.code, diagnostic.message) == ("E501", message)


def test_e502_e505_name_the_first_program() -> None:
    taken = one(f"MP 5 a\n{body(1)}END MP\nMP 5 b\n{body(1)}END MP\n")
    assert (taken.code, taken.span.line, taken.message) == ("E502", 4, "MP5 is already taken")
    assert taken.hint == "give one of them another number, or none"
    assert [(s.line, note) for s, note in taken.related] == [(1, "first program in this slot")]
    twice = one(f"MP a\n{body(1)}END MP\nMP A\n{body(1)}END MP\n")
    assert (twice.code, twice.span.line) == ("E505", 4)
    assert twice.message == "a program named 'A' already exists"
    assert [(s.line, note) for s, note in twice.related] == [(1, "first definition")]


def test_e504_when_no_free_slot_is_big_enough() -> None:
    diagnostic = one(f"MP huge\n{body(512)}END MP\n")
    assert (diagnostic.code, diagnostic.message) == (
        "E504", "no free MP slot holds MP huge's 513 lines")
    assert diagnostic.hint == "split it into several programs that CALL each other"
    taken = "".join(f"MP {n}\n{body(1)}END MP\n" for n in range(91, 158))  # 32 lines and up
    diagnostic = one(f"{taken}MP big\n{body(20)}END MP\n")
    assert (diagnostic.code, diagnostic.message) == ("E504", "no free MP slot holds MP big's "
                                                     "21 lines")
    assert diagnostic.hint == ("use a slot in MP91-MP130 (32 lines), drop the number to let "
                               "the linker choose, or split it")


def test_an_unnumbered_program_takes_a_slot_exactly_its_size() -> None:
    assert slots(f"MP a\n{body(15)}END MP\n") == {"a": 41}  # 16 lines: MP41, not MP91


def test_slot_pins_and_their_refusals() -> None:
    def pin(name: str, kind: str, slot: int, line: int) -> SlotPin:
        return SlotPin(name, kind, slot, Span("mpc.toml", line))

    source = (f"MP a\n{body(1)}END MP\nISR b\n{body(1)}END ISR\nMP 7 c\n{body(1)}END MP\n"
              f"MP d\n{body(1)}END MP\n")
    # each refused pin comes before others: a refusal never ends the checking of the rest
    pins = (pin("a", "mp", 200, 5), pin("ghost", "mp", 3, 2), pin("b", "mp", 4, 3),
            pin("c", "mp", 8, 4), pin("c", "mp", 7, 7), pin("D", "mp", 12, 6))
    result = compile_source(source, "job.mp", Options(pins=pins))
    got = {(d.code, d.span.line): d for d in result.diagnostics}
    assert sorted(got) == [("E501", 5), ("E506", 3), ("E506", 4), ("W109", 2)]
    assert got["W109", 2].message == "the slot pin ghost = MP3 names no program of this build"
    assert got["W109", 2].hint == ("remove the pin, or add the file that defines ghost to "
                                   "the sources")
    assert got["E506", 3].message == "b is an ISR, but its pin is the MP slot MP4"
    assert got["E506", 3].hint == "pin it to an ISR slot"
    assert [(s.line, n) for s, n in got["E506", 3].related] == [(4, "b is defined here")]
    assert got["E506", 4].message == "c is pinned to MP8, but its source numbers it MP7"
    assert got["E506", 4].hint == "keep one of the two: the number in the source or the pin"
    assert [(s.line, n) for s, n in got["E506", 4].related] == [(7, "numbered here")]
    assert got["E501", 5].message == "MP200 does not exist: slots are MP1..MP157"
    # the pins that hold: d (named in another case) gets MP12, c's pin agrees with its number
    good = compile_source(source, "job.mp", Options(pins=(pins[4], pins[5])))
    assert good.ok, [d.render() for d in good.diagnostics]
    assert {p.program.name: p.placement.slot for p in good.programs} == {
        "a": 1, "b": 1, "c": 7, "d": 12}


@pytest.mark.parametrize(("source", "code", "line", "message", "hint"), [
    ("MP 1\n  CALL 99\nEND MP\n", "W105", 2, "MP99 is not part of this build",
     "make sure it is already on the device"),
    ("MP 1\n  CALL 1\nEND MP\n", "E432", 2, "recursive CALL: MP1 -> MP1",
     "the device has no recursion; use a loop instead"),
    ("MP 1\n  CALL 2\nEND MP\nMP 2\n  CALL 3\nEND MP\nMP 3\n  CALL 1\nEND MP\n", "E432", 8,
     "recursive CALL: MP1 -> MP2 -> MP3 -> MP1",
     "the device has no recursion; use a loop instead"),
    ("".join(f"MP {n}\n  CALL {n + 1}\nEND MP\n" for n in range(1, 8)) + "MP 8\n  EXIT\nEND MP\n",
     "E433", 1, "MP1 starts a chain of 8 nested programs; the device allows 7",
     "flatten the call chain"),
    ("MP 1\n  CALL 1\n  CALL 1\nEND MP\n", "E432", 2, "recursive CALL: MP1 -> MP1",
     "the device has no recursion; use a loop instead"),  # reported once per program
    ("ISR 1\n  VAR1 = 1\nEND ISR\nMP 1\n  CALL 99\nEND MP\n", "W105", 5,
     "MP99 is not part of this build", "make sure it is already on the device"),
])
def test_the_call_graph_s_diagnostics(source: str, code: str, line: int, message: str,
                                      hint: str) -> None:
    """The profile's call_depth is 7 (RS 9924: the top program plus six calls)."""
    diagnostic = one(source)
    assert (diagnostic.code, diagnostic.span.line) == (code, line)
    assert (diagnostic.message, diagnostic.hint) == (message, hint)


def test_a_chain_of_seven_programs_is_allowed() -> None:
    source = "".join(f"MP {n}\n  CALL {n + 1}\nEND MP\n" for n in range(1, 7))
    assert compile_source(source + "MP 7\n  EXIT\nEND MP\n").ok


def test_every_call_is_checked_after_one_that_is_not() -> None:
    """An unknown name (E434), a program outside the build (W105) and a recursion (E432)
    in one program: each is reported, none hides the ones after it."""
    diagnostics = found("MP 1\n  CALL nosuch\n  CALL 99\n  CALL 1\nEND MP\n")
    assert [(d.code, d.span.line) for d in diagnostics] == [
        ("E434", 2), ("W105", 3), ("E432", 4)]
    # a call to a program that got no slot (E504) has nothing to check; the next one has
    unplaced = found(f"MP 1\n  CALL big\n  CALL 99\nEND MP\nMP big\n{body(600)}END MP\n")
    assert [(d.code, d.span.line) for d in unplaced] == [("W105", 3), ("E504", 5)]


def test_a_recursion_does_not_cut_the_depth_of_the_chain_below_it() -> None:
    """MP1 calls itself, then MP2..MP7: MP10 -> MP1 -> ... -> MP7 is 8 programs."""
    source = ("MP 10\n  CALL 1\nEND MP\nMP 1\n  CALL 1\n  CALL 2\nEND MP\n"
              + "".join(f"MP {n}\n  CALL {n + 1}\nEND MP\n" for n in range(2, 7))
              + "MP 7\n  EXIT\nEND MP\n")
    assert [(d.code, d.span.line, d.message) for d in found(source)] == [
        ("E433", 1, "MP10 starts a chain of 8 nested programs; the device allows 7"),
        ("E432", 5, "recursive CALL: MP1 -> MP1")]


def test_every_program_that_fits_nowhere_is_reported() -> None:
    diagnostics = found(f"MP a\n{body(512)}END MP\nMP b\n{body(600)}END MP\n")
    assert [(d.code, d.span.line) for d in diagnostics] == [("E504", 1), ("E504", 515)]


def test_placements_carry_budget_lines_and_whether_the_linker_chose() -> None:
    """What `mpc build`'s map and the listing show for each program."""
    result = compile_source(f"MP 41 fixed\n{body(3)}END MP\nMP auto\n{body(9)}END MP\n")
    assert [(p.placement.slot, p.placement.lines_used, p.placement.budget, p.placement.auto)
            for p in result.programs] == [(41, 4, 16, False), (42, 10, 16, True)]

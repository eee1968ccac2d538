"""Linker: deterministic best-fit placement, budgets with x2/x3/x4 costs, call graph."""

from __future__ import annotations

import json
import os
import subprocess
import sys

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

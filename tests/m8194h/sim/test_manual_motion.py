"""The manual's position and motion examples (chapters 4 and 7.1-7.2, 7.5) end where their
statements say, run one by one on a fresh virtual controller.

The examples come from tests/data/manual_examples.toml (the same data the encoder is checked
against); every example of a command in `EXPECTED_COMMANDS` must have an expectation here,
so a new example cannot slip through untested. Expectations are computed from the statement
alone: relative moves from 0, absolute ones to their target, arcs to their finish point,
circles back to their start. A move given while its axes still run waits for them, so the
absolute examples start from wherever an earlier relative move left the axes.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from mplang.m8194h.compiler import compile_source
from mplang.m8194h.run import run_build
from mplang.m8194h.sim.controller import VirtualController

EXAMPLES = tomllib.loads((Path(__file__).resolve().parents[2] / "data" / "manual_examples.toml")
                         .read_text(encoding="utf-8"))["example"]

# section -> (statements run before the example, expected (LP, EP) per axis X, Y, Z, U)
EXPECTED: dict[str, tuple[str, list[tuple[int, int]]]] = {
    "4.1.1": ("", [(10000, 0)] * 4),  # SET_LP leaves the encoder counter alone
    "4.2.1": ("", [(0, 10000)] * 4),
    "4.3.1": ("", [(40000, 0), (0, 0), (0, 0), (0, 0)]),  # a logical position, like SET_LP
    "7.1.9": ("", [(10000, 10000)] * 4),
    "7.1.11": ("FIXED_MOVE XYZU, -3000", [(10000, 10000)] * 4),
    "7.2.10": ("", [(12000, 12000), (10000, 10000), (0, 0), (0, 0)]),
    "7.2.11": ("FIXED_MOVE XY, 500",
               [(12000, 12000), (10000, 10000), (0, 0), (0, 0)]),
    "7.2.12": ("AXIS_ASSIGN X, Y, Z", [(10000, 10000)] * 3 + [(0, 0)]),
    "7.2.13": ("AXIS_ASSIGN X, Y, Z\n FIXED_MOVE XYZ, 777",
               [(10000, 10000)] * 3 + [(0, 0)]),
    "7.2.14": ("", [(-10000, -10000), (-10000, -10000), (0, 0), (0, 0)]),
    "7.2.15": ("", [(-10000, -10000), (-10000, -10000), (0, 0), (0, 0)]),
    "7.2.16": ("", [(-10000, -10000), (-10000, -10000), (0, 0), (0, 0)]),
    "7.2.17": ("", [(-10000, -10000), (-10000, -10000), (0, 0), (0, 0)]),
    "7.2.18": ("", [(0, 0)] * 4),
    "7.2.19": ("", [(0, 0)] * 4),
}
EXPECTED_COMMANDS = {
    "RSM_MACRO_SET_LP", "RSM_MACRO_SET_EP", "RSM_MACRO_ABS_SET_POSITION",
    "RSM_MACRO_FIXED_MOVE", "RSM_ABS_MACRO_FIXED_MOVE", "RSM_MACRO_LINE_2D",
    "RSM_ABS_MACRO_LINE_2D", "RSM_MACRO_LINE_3D", "RSM_ABS_MACRO_LINE_3D",
    "RSM_MACRO_ARC_CW", "RSM_MACRO_ARC_CCW", "RSM_ABS_MACRO_ARC_CW", "RSM_ABS_MACRO_ARC_CCW",
    "RSM_MACRO_CIRCLE_CW", "RSM_MACRO_CIRCLE_CCW",
}
CASES = [e for e in EXAMPLES if e["command"] in EXPECTED_COMMANDS]


def run(body: str) -> VirtualController:
    build = compile_source(f"MP 151\n {body}\nEND MP\n")
    assert build.ok, [d.render() for d in build.diagnostics]
    report = run_build(build)
    assert report.result.finished, report.result.error
    return report.controller


def positions(vc: VirtualController) -> list[tuple[int, int]]:
    return [(vc.motion.lp(1 << i, vc.clock), vc.motion.ep(1 << i, vc.clock)) for i in range(4)]


def test_every_motion_example_has_an_expectation() -> None:
    assert {e["command"] for e in CASES} == EXPECTED_COMMANDS
    assert {e["section"] for e in CASES} == set(EXPECTED)


@pytest.mark.parametrize("example", CASES, ids=[f"{e['section']}" for e in CASES])
def test_example_ends_where_its_statements_say(example: dict[str, str]) -> None:
    before, expected = EXPECTED[example["section"]]
    vc = run(f"{before}\n {example['source']}" if before else example["source"])
    assert positions(vc) == expected


def test_circle_examples_travel_the_whole_circle() -> None:
    """CIRCLE_CW 0, 10000 (7.2.18): centre 10000 above the start, so halfway round the
    path is 20000 above it and the motion takes a full circumference at the vector speed."""
    vc = VirtualController()
    build = compile_source("MP 151\n SET_VV 10000\n CIRCLE_CW 0, 10000\nEND MP\n")
    for program in build.programs:
        assert vc.load_frames("mp", program.placement.slot, program.frames) is None
    vc.call(151)
    vc.advance(0.01)
    end = vc.motion.idle_at(3, vc.clock)
    assert end is not None and end > 2 * 3.14159 * 10000 / 10000
    start = vc.clock
    samples = [start + (end - start) * k / 200 for k in range(201)]
    highest = max(vc.motion.lp(2, t) for t in samples)
    assert abs(highest - 20000) <= 10


def test_continue_move_example_runs_until_stopped() -> None:
    """CONTINUE_MOVE XYZU, 1000 (7.1.12) never ends by itself; STOP_SUDDENLY ends it."""
    example = next(e for e in EXAMPLES if e["command"] == "RSM_MACRO_CONTINUE_MOVE")
    vc = run(f"{example['source']}\n TIMER 2000\n VAR1 = GET_LP(X)\n STOP_SUDDENLY XYZU")
    assert 1900 <= vc.vars[1] <= 2001  # about 1000 pulses/s for 2 s after a short ramp
    assert not vc.motion.busy(15, vc.clock)
    assert all(lp == vc.motion.lp(1 << i, vc.clock) for i, (lp, _ep) in
               enumerate(positions(vc)))

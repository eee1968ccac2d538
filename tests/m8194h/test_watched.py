"""A watched run (`mplang.m8194h.watched`, what `mpc run` does for its status line and
Ctrl-C) computes what an unwatched run computes, stops where its watch asks, and a run
without a time limit still ends a wait that nothing can end (issue 14 item 4)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from mplang.family.run_error import SourcePlace
from mplang.family.watch import Where
from mplang.m8194h.compiler import BuildResult, compile_paths, compile_source
from mplang.m8194h.run import run_build

SAMPLES = Path(__file__).resolve().parents[2] / "samples"
QUICK = ("tour", "home_then_square", "pick_and_place", "find_edge", "glue_bead", "cc_peck")

SPIN = """MP 1 spin
    VAR1 = 0
    LABEL again
    VAR1 = VAR1 + 1
    GOTO again
END MP
"""


@pytest.fixture(scope="module")
def samples() -> BuildResult:
    return compile_paths(sorted(SAMPLES.glob("*.mp")))


def never(time_s: float, where: Where) -> bool:
    return False


@pytest.mark.parametrize("program", QUICK)
def test_a_watched_run_is_the_same_run(samples: BuildResult, program: str) -> None:
    plain = run_build(samples, program)
    watched = run_build(samples, program, watch=never)
    traced = run_build(samples, program, trace_period=0.01, watch=never)
    for other in (watched, traced):
        assert other.result.finished == plain.result.finished
        assert math.isclose(other.time_s, plain.time_s, abs_tol=1e-9)
        assert other.result.steps == plain.result.steps
        assert other.named_vars() == plain.named_vars()
        assert other.controller.snapshot()["axes"] == plain.controller.snapshot()["axes"]


@pytest.mark.parametrize("period", [None, 0.001])
def test_the_watch_stops_the_run_where_it_is(period: float | None) -> None:
    build = compile_source(SPIN, "spin.mp")
    seen: list[tuple[float, SourcePlace]] = []

    def third_call_stops(time_s: float, where: Where) -> bool:
        seen.append((time_s, where()))
        return len(seen) == 3

    report = run_build(build, "spin", max_time=math.inf, trace_period=period,
                       watch=third_call_stops)
    assert not report.finished and report.error is None and report.failure is None
    assert len(seen) == 3 and seen[0][0] < seen[2][0] == pytest.approx(report.time_s)
    place = seen[-1][1]
    assert (place.file, place.program) == ("spin.mp", "MP1 spin") and 3 <= (place.line or 0) <= 5
    assert report.named_vars()[0]["VAR1"] > 0


def test_no_time_limit_ends_a_wait_for_ever_at_once() -> None:
    build = compile_source("MP 1 stuck\n    FRNET_WAIT 8, 1, 1, 0\nEND MP\n", "stuck.mp")
    for period in (None, 0.001):
        report = run_build(build, "stuck", max_time=math.inf, trace_period=period)
        failure = report.failure
        assert failure is not None and failure.code == "R201"
        assert math.isfinite(report.time_s) and report.time_s < 1.0

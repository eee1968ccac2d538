"""Tracing a run (`mplang.m8194h.trace`, `mpc run --trace`): the samples describe the motion the
program commands, and taking them changes nothing the run computes."""

from __future__ import annotations

import csv
import io
import json
import math
from itertools import pairwise
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.cli import main
from mplang.family.trace import Trace, position_text, trace_from_samples
from mplang.m8194h.compiler import BuildResult, Options, compile_paths, compile_source
from mplang.m8194h.run import run_build
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.trace import record, run_traced

SAMPLES = Path(__file__).resolve().parents[2] / "samples"

# A full circle of radius 10000 around (5000, 5000), started from (15000, 5000).
CIRCLE = """MP 41 circle
    SET_V XY, 40000
    ABS_FIXED_MOVE X, 15000
    ABS_FIXED_MOVE Y, 5000
    STOP_WAIT X
    STOP_WAIT Y
    AXIS_ASSIGN X, Y, 0
    VECTOR_SPEED 0
    SET_VSV 20000
    SET_VV 20000
    CIRCLE_CCW -10000, 0
    STOP_WAIT X
END MP
"""


def built(source: str) -> BuildResult:
    build = compile_source(source)
    assert build.ok, [d.render() for d in build.diagnostics]
    return build


def traced(source: str, period: float = 0.001, max_time: float = 3600.0) -> tuple[
        BuildResult, Trace]:
    build = built(source)
    report = run_build(build, max_time=max_time, trace_period=period)
    assert report.trace is not None
    return build, report.trace


def assert_same_run(build: BuildResult, call: str | None, period: float,
                    max_time: float = 3600.0) -> Trace:
    """The traced run ends exactly as the plain one, and its last sample is the end state."""
    plain = run_build(build, call, max_time=max_time)
    with_trace = run_build(build, call, max_time=max_time, trace_period=period)
    assert with_trace.result == plain.result
    assert with_trace.to_json() == plain.to_json()
    assert with_trace.controller.execution_error == plain.controller.execution_error
    trace = with_trace.trace
    assert trace is not None
    assert trace.time[-1] == plain.result.time_s
    axes = plain.to_json()["axes"]
    assert isinstance(axes, dict)
    for index, name in enumerate(trace.axes):
        assert (trace.lp[index][-1], trace.ep[index][-1]) == (axes[name]["lp"],
                                                              axes[name]["ep"])
    assert all(a < b for a, b in pairwise(trace.time))
    return trace


def test_full_circle_extents_are_centre_plus_minus_radius() -> None:
    _build, trace = traced(CIRCLE)
    assert trace.extent("X") == (5000 - 10000, 5000 + 10000)
    assert trace.extent("Y") == (5000 - 10000, 5000 + 10000)
    assert trace.moving_axes() == ("X", "Y")
    x, y = trace.lp[0], trace.lp[1]
    on_circle = [k for k in range(len(trace)) if trace.time[k] > 1.0]
    for k in on_circle:  # every sample of the circle lies on it (LP rounds to a pulse)
        assert abs(math.hypot(x[k] - 5000, y[k] - 5000) - 10000) <= 1.5


def test_velocity_is_signed_and_as_fast_as_the_controller_says() -> None:
    _build, trace = traced("MP 1\n  SET_V X, 20000\n  FIXED_MOVE X, -50000\n  STOP_WAIT X\n"
                           "END MP\n")
    velocity = trace.velocity[trace.axis("X")]
    assert min(velocity) == pytest.approx(-20000)
    assert max(velocity) == 0.0
    assert trace.extent("X") == (-50000, 0)
    assert trace.moving_axes() == ("X",)


def test_velocity_magnitude_is_the_models_cv() -> None:
    build = built(CIRCLE)
    controller = VirtualController(word_order=build.word_order)
    for image in build.programs:
        controller.load_frames(image.program.kind, image.placement.slot, image.frames)
    controller.call(41)
    controller.advance(2.0)  # on the circle
    trace = Trace(0.001)
    record(trace, controller)
    for index in range(2):
        speed = controller.motion.cv(1 << index, controller.clock)
        assert speed > 0
        assert abs(trace.velocity[index][0]) == pytest.approx(speed)


def test_samples_fall_on_the_period_grid_or_at_motion_ends() -> None:
    _build, trace = traced("MP 1\n  SET_V X, 10000\n  FIXED_MOVE X, 3333\n  STOP_WAIT X\n"
                           "  TIMER 50\nEND MP\n", period=0.01)
    gaps = [b - a for a, b in pairwise(trace.time)]
    assert max(gaps) <= 0.01 + 1e-9
    off_grid = [t for t in trace.time if abs(t / 0.01 - round(t / 0.01)) > 1e-6]
    # the moment the move ends, then the last line's time: nothing else is off the grid
    assert len(off_grid) <= 3, off_grid
    end = trace.time[trace.lp[0].index(3333)]
    assert end in off_grid
    assert trace.velocity[0][trace.time.index(end)] == 0.0


def test_every_sample_program_runs_the_same_with_a_trace() -> None:
    build = compile_paths(sorted(SAMPLES.glob("*.mp")), Options())
    assert build.ok
    slots = [p.placement.slot for p in build.programs if p.program.kind == "mp"]
    assert len(slots) >= 10
    for slot in slots:
        assert_same_run(build, f"MP{slot}", period=0.05)


def test_fine_period_on_arcs_and_homing_runs_the_same() -> None:
    build = compile_paths(sorted(SAMPLES.glob("*.mp")), Options())
    trace = assert_same_run(build, "home_then_square", period=0.002)
    assert trace.moving_axes() == ("X", "Y")


def test_continuous_interpolation_sample_reaches_its_arc_extremes() -> None:
    """samples/continuous_interpolation.mp: the slot's half circles span X 70..170 mm and
    its straights lie at Y 90 and 130 mm (1000 pulses per mm)."""
    build = compile_paths([SAMPLES / "continuous_interpolation.mp"], Options())
    trace = assert_same_run(build, None, period=0.001)
    x, y = trace.lp[0], trace.lp[1]
    assert max(x) == 170000 and max(y) == 130000
    slot_region = [x[k] for k in range(len(trace)) if y[k] >= 90000]
    assert min(slot_region) == 70000


def test_failed_run_is_traced_up_to_the_failure() -> None:
    source = ("MP 1\n  SET_V X, 10000\n  FIXED_MOVE X, 100000\n  TIMER 200\n"
              "  VAR1 = VAR2 / VAR3\nEND MP\n")
    trace = assert_same_run(built(source), None, period=0.001)
    assert 0.2 < trace.time[-1] < 0.21
    assert 0 < trace.lp[0][-1] < 100000  # the move was still running


def test_runs_that_do_not_finish_end_alike() -> None:
    spin = built("MP 1\n  SET_V X, 1000\n  CONTINUE_MOVE X, 5000\n  LABEL a\n  GOTO a\n"
                 "END MP\n")
    trace = assert_same_run(spin, None, period=0.003, max_time=0.1)
    assert trace.lp[0][-1] > 0
    forever = built("MP 1\n  FIXED_MOVE Y, 500\n  FRNET_WAIT 8, 0, 1, 0\nEND MP\n")
    trace = assert_same_run(forever, None, period=0.01, max_time=0.5)
    assert trace.time[-1] == pytest.approx(0.5)
    assert trace.lp[1][-1] == 500


def test_no_motion_gives_start_and_end_samples() -> None:
    _build, trace = traced("MP 1\n  VAR1 = 5\nEND MP\n")
    assert len(trace) == 2 and trace.time[0] == 0.0
    assert trace.moving_axes() == ()


def test_a_period_must_be_positive() -> None:
    controller = VirtualController()
    with pytest.raises(ValueError, match="positive"):
        run_traced(controller, 0.0)


def test_csv_has_a_header_and_numbers_only() -> None:
    _build, trace = traced(CIRCLE, period=0.01)
    stream = io.StringIO()
    trace.write_csv(stream)
    rows = list(csv.reader(io.StringIO(stream.getvalue())))
    assert rows[0] == ["time_s"] + [f"{axis}_{column}" for axis in "XYZU"
                                    for column in ("lp", "ep", "velocity")] + ["source"]
    assert len(rows) == len(trace) + 1
    for row in rows[1:]:
        assert len(row) == 14
        assert "-0.000" not in row
        assert all(math.isfinite(float(cell)) for cell in row[:-1])  # numbers, then where
    assert [int(v) for v in rows[-1][1:3]] == [trace.lp[0][-1], trace.ep[0][-1]]


@settings(max_examples=25, deadline=None)
@given(moves=st.lists(st.tuples(st.sampled_from(["X", "Y", "Z", "U"]),
                                st.integers(-30000, 30000), st.integers(1, 40)),
                      min_size=1, max_size=4),
       period=st.sampled_from([0.0007, 0.001, 0.0123, 0.25]),
       wait=st.booleans())
def test_any_moves_run_the_same_and_stay_between_their_points(
        moves: list[tuple[str, int, int]], period: float, wait: bool) -> None:
    lines = ["MP 100 moves"]
    for axis, distance, speed in moves:
        lines += [f"  SET_V {axis}, {speed * 1000}", f"  FIXED_MOVE {axis}, {distance}"]
        if wait:
            lines.append(f"  STOP_WAIT {axis}")
    build = built("\n".join([*lines, "END MP", ""]))
    trace = assert_same_run(build, None, period)
    for name in "XYZU":
        points = [0]
        for axis, distance, _speed in moves:
            if axis == name:
                points.append(points[-1] + distance)
        low, high = trace.extent(name)
        assert low >= min(points) and high <= max(points)


# ----------------------------------------------------------------------- mpc run --trace


def invoke(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, list(args))
    return result.exit_code, result.stdout, result.stderr


@pytest.fixture
def project(tmp_path: Path) -> Path:
    (tmp_path / ".git").mkdir()
    (tmp_path / "circle.mp").write_text(CIRCLE)
    return tmp_path


def test_run_trace_csv_ends_where_run_json_says(project: Path) -> None:
    out = project / "circle.csv"
    code, stdout, _ = invoke("run", str(project / "circle.mp"), "--json", "--trace", str(out),
                             "--trace-period", "0.005")
    assert code == 0
    report = json.loads(stdout)
    rows = list(csv.DictReader(out.open()))
    last = rows[-1]
    assert float(last["time_s"]) == pytest.approx(report["time_ms"] / 1000, abs=1e-6)
    for axis, position in report["axes"].items():
        assert (int(last[f"{axis}_lp"]), int(last[f"{axis}_ep"])) == (position["lp"],
                                                                     position["ep"])
    xs = [int(row["X_lp"]) for row in rows]
    assert (min(xs), max(xs)) == (-5000, 15000)
    times = [float(row["time_s"]) for row in rows]
    assert max(b - a for a, b in pairwise(times)) <= 0.005 + 1e-6


def test_run_trace_default_period_is_one_millisecond(project: Path) -> None:
    out = project / "t.csv"
    assert invoke("run", str(project / "circle.mp"), "--trace", str(out))[0] == 0
    times = [float(row["time_s"]) for row in csv.DictReader(out.open())]
    assert times[1] == pytest.approx(0.001) and len(times) > 3000


def test_run_trace_of_a_failing_program_is_written_and_exits_5(project: Path) -> None:
    (project / "fail.mp").write_text("MP 1\n  FIXED_MOVE X, 100000\n  TIMER 20\n"
                                     "  VAR1 = VAR2 / VAR3\nEND MP\n")
    out = project / "fail.csv"
    code, _, err = invoke("run", str(project / "fail.mp"), "--trace", str(out))
    assert code == 5 and "division by zero" in err
    rows = list(csv.DictReader(out.open()))
    assert 0.02 < float(rows[-1]["time_s"]) < 0.021


def test_run_trace_usage_and_output_errors(project: Path) -> None:
    source = str(project / "circle.mp")
    code, _, err = invoke("run", source, "--trace-period", "0.01")
    assert code == 2 and "--trace-period needs --trace" in err
    assert invoke("run", source, "--trace", "-")[0] == 2
    assert invoke("run", source, "--trace", str(project / "t.csv"), "--trace-period", "0")[0] == 2
    code, _, err = invoke("run", source, "--trace", str(project / "nowhere" / "t.csv"))
    assert code == 4 and "no directory" in err
    assert invoke("run", source, "--trace", str(project))[0] == 4
    assert invoke("run", str(project / "missing.mp"), "--trace", str(project / "t.csv"))[0] == 3
    assert not (project / "t.csv").exists()


# ---- traces of the other families (`trace_from_samples`)

def test_family_samples_become_a_trace_with_ep_lp_and_mean_velocity() -> None:
    samples = [(0.0, {"X": 0, "Y": 0, "T4": 0}), (0.5, {"X": 100, "Y": 0, "T4": 1.5}),
               (1.0, {"X": 100, "Y": -50, "T4": 1.5})]
    trace = trace_from_samples(samples, 0.5, "units")
    assert trace.axes == ("X", "Y", "T4") and trace.unit == "units"
    assert trace.time == [0.0, 0.5, 1.0]
    assert trace.lp == trace.ep == [[0, 100, 100], [0, 0, -50], [0, 1.5, 1.5]]
    assert trace.velocity == [[0.0, 200.0, 0.0], [0.0, 0.0, -100.0], [0.0, 3.0, 0.0]]
    assert trace.header()[:4] == ["time_s", "X_lp", "X_ep", "X_velocity"]
    assert list(trace.rows())[1] == ["0.500000", "100", "100", "200.000", "0", "0", "0.000",
                                     "1.5", "1.5", "3.000"]


def test_a_repeated_instant_keeps_the_later_sample_and_missing_axes_hold() -> None:
    trace = trace_from_samples([(0.0, {"X": 0}), (0.1, {"X": 5, "Y": 2}), (0.1, {"X": 7}),
                                (0.2, {"Y": 4})], 0.1)
    assert trace.time == [0.0, 0.1, 0.2]
    assert trace.lp == [[0, 7, 7], [0, 2, 4]]  # the later reading of 0.1 names no Y: Y holds
    assert trace.velocity[0][1] == pytest.approx(70.0)
    assert trace_from_samples([(0.0, {"X": 1}), (1.0, {"Y": 3})], 1.0).lp == [[1, 1], [0, 3]]


@pytest.mark.parametrize(("value", "text"), [(12, "12"), (-3, "-3"), (12.0, "12"), (-0.0, "0"),
                                             (70.710678118, "70.710678"), (0.5, "0.5"),
                                             (-1e-9, "0"), (2.0000004, "2")])
def test_position_text(value: float, text: str) -> None:
    assert position_text(value) == text


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0.0001, 1.0), st.floats(-1e6, 1e6)), min_size=1,
                max_size=30))
def test_velocities_integrate_back_to_the_positions(steps: list[tuple[float, float]]) -> None:
    """Whatever the samples, the mean velocities over the intervals add up to the motion."""
    samples: list[tuple[float, dict[str, float]]] = [(0.0, {"X": 0.0})]
    when = 0.0
    for delay, position in steps:
        when += delay
        samples.append((when, {"X": position}))
    trace = trace_from_samples(samples, 0.001)
    assert trace.lp[0] == trace.ep[0] == [p["X"] for _, p in samples]
    position = 0.0
    for k in range(1, len(trace)):
        position += trace.velocity[0][k] * (trace.time[k] - trace.time[k - 1])
        assert position == pytest.approx(trace.lp[0][k], abs=1e-6 * (1 + abs(position)))

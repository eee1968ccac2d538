"""Motions run with the values the chip holds (issue 24 items 1, 2 and 8).

Every expected time is worked out by hand from the manual's rules (RS = RS-M8194H manual
line): a speed is at most MAX_V and a multiple of MAX_V / 8000 (RS 1146); an acceleration a
multiple of MAX_V / 64 within MAX_V / 64 .. MAX_V * 125 (RS 5157). A T-curve move from SV
to V at A covers (V² - SV²) / 2A per ramp in (V - SV) / A; a fixed move runs its 8 offset
pulses (AO, RS 5351) at SV after the deceleration.
"""

from __future__ import annotations

import pytest
from test_queues import loaded

from mplang.ir import catalogue
from mplang.m8194h.chipvalues import ChipRules
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.motion import MotionModel
from mplang.m8194h.sim.registers import RegisterMap

X, Y = 1, 2
RULES = ChipRules.from_profile(catalogue.load().profile.raw)


def model() -> MotionModel:
    return MotionModel(None, RULES)


def test_the_profile_holds_the_manuals_numbers() -> None:
    assert ChipRules() == RULES
    assert RULES.acceleration_step(200_000) == 3125 and RULES.speed_step(200_000) == 25


@pytest.mark.parametrize(("acc", "pulses", "seconds", "probe"), [
    # A = 10,000 at MAX_V 200,000 is 9,375 (3 x 3,125). FIXED_MOVE 20,000 from SV 1,000 to
    # V 10,000: each ramp 9,000 / 9,375 = 0.96 s over 99e6 / 18,750 = 5,280 pulses; cruise
    # (20,000 - 8 - 10,560) / 10,000 = 0.9432 s; offset 8 / 1,000 = 0.008 s: 2.8712 s (with
    # A as written it would be 2.8172 s). At 0.5 s it accelerates at 9,375.
    (10_000, 20_000, 2.8712, (0.5, 1_000 + 0.5 * 9_375)),
    # A = 1,000 is below MAX_V / 64 = 3,125 and runs at 3,125. FIXED_MOVE 7,688: the ramps
    # over 7,680 pulses peak where 5,000² = 1,000² + 7,680 x 3,125, so 2 x 4,000 / 3,125 =
    # 2.56 s, plus 0.008 s of offset: 2.568 s (A 1,000 as written: over 7.4 s). The peak,
    # 5,000, comes at 1.28 s.
    (1_000, 7_688, 2.568, (1.28, 5_000)),
])
def test_an_acceleration_off_its_steps_runs_at_the_chips_value(
        acc: int, pulses: int, seconds: float, probe: tuple[float, float]) -> None:
    m = model()
    m.set_a(X, acc)
    m.fixed_move(X, pulses, 0.0)
    assert m.idle_at(X, 0.0) == pytest.approx(seconds, abs=1e-9)
    assert m.cv(X, probe[0]) == pytest.approx(probe[1])


def test_a_speed_above_max_v_runs_at_max_v() -> None:
    """MAX_V 8,000, V 12,000: X cruises at 8,000 (speed step 1, acceleration step 125, A
    100,000 a step). FIXED_MOVE 8,000: ramps 7,000 / 100,000 = 0.07 s over 315 pulses each;
    cruise (8,000 - 8 - 630) / 8,000 = 0.92025 s; offset 0.008 s: 1.06825 s."""
    m = model()
    m.set_max_v(X, 8000)
    m.set_v(X, 12_000)
    m.fixed_move(X, 8000, 0.0)
    assert m.idle_at(X, 0.0) == pytest.approx(1.06825, abs=1e-9)
    assert m.cv(X, 0.5) == pytest.approx(8000)


def test_an_acceleration_above_max_v_times_125_runs_at_it() -> None:
    """MAX_V 8,000, A 2,000,000: at most 8,000 x 125 = 1,000,000. V 8,000: ramps 0.007 s
    over 31.5 pulses; cruise (8,000 - 8 - 63) / 8,000 = 0.991125 s; +0.008 s = 1.013125 s.
    CA reads 1,000,000 during the ramp."""
    vc = VirtualController()
    m = vc.motion
    m.set_max_v(X, 8000)
    m.set_v(X, 8000)
    m.set_a(X, 2_000_000)
    m.fixed_move(X, 8000, 0.0)
    assert m.idle_at(X, 0.0) == pytest.approx(1.013125, abs=1e-9)
    vc.clock = 0.003
    regs = RegisterMap(vc)
    words = regs.read_input(50, 2)
    assert (words[0] << 16 | words[1]) == 1_000_000


def test_vector_acceleration_follows_the_first_axis_max_v() -> None:
    """VA 10,000 of a symmetric T-curve line (VECTOR_SPEED 1) at MAX_V 200,000 is 9,375:
    LINE_2D (20,000, 0) takes what the single-axis move took, 2.8712 s."""
    m = model()
    m.set_vector_mode(1)
    m.set_va(10_000)
    m.line((20_000, 0), 0.0)
    assert m.idle_at(X | Y, 0.0) == pytest.approx(2.8712, abs=1e-9)


def test_cv_register_shows_whole_speed_steps() -> None:
    """MAX_V 4,000,000 has a speed step of 500 (RS 1146): V 10,000 cruises at 10,000 and CV
    on the ramp reads a multiple of 500, though the ramp itself is continuous."""
    vc = VirtualController()
    m = vc.motion
    m.set_max_v(X, 4_000_000)
    m.set_sv(X, 500)
    m.set_v(X, 10_000)
    m.set_a(X, 62_500)  # 1 x MAX_V / 64
    m.fixed_move(X, 100_000, 0.0)
    regs = RegisterMap(vc)
    for t in (0.0123, 0.0777, 0.1234):
        vc.clock = t
        words = regs.read_input(42, 2)
        cv = words[0] << 16 | words[1]
        assert cv % 500 == 0 and abs(cv - m.cv(X, t)) <= 250
    vc.clock = 1.0
    words = regs.read_input(42, 2)
    assert words[0] << 16 | words[1] == 10_000


def test_a_program_run_by_the_virtual_controller_takes_the_stepped_time() -> None:
    """The interpreter of `mpc run` is the same controller: the move of the first example,
    started by its program's second line, ends 2.8712 s after it."""
    vc = loaded("MP 1\n SET_A X, 10000\n FIXED_MOVE X, 20000\nEND MP\n")
    vc.call(1)
    vc.advance(0.01)
    end = vc.motion.idle_at(X, vc.clock)
    assert end is not None and end == pytest.approx(2.8712 + 2 * vc.line_time, abs=1.5e-4)


# ----------------------------------------------------------------- W111 in the compiler
def _warnings(source: str) -> list[str]:
    build = compile_source(source)
    return [f"{d.span.line}: {d.message}" for d in build.diagnostics if d.code == "W111"]


def test_w111_gives_the_value_the_device_uses() -> None:
    got = _warnings("MP 1\n SET_A X, 10000\n SET_A X, 9375\n SET_V X, 10010\n"
                    " SET_D X, 1000\nEND MP\n")
    assert got == [
        "2: SET_A: the acceleration 10000 runs as 9375 on the device (an acceleration is a "
        "multiple of MAX_V/64 = 3125 with MAX_V 200000)",
        "4: SET_V: the speed 10010 runs as 10000 on the device (a speed is a multiple of "
        "MAX_V/8000 = 25 with MAX_V 200000)",
        "5: SET_D: the acceleration 1000 runs as 3125 on the device (an acceleration is at "
        "least MAX_V/64 = 3125 with MAX_V 200000)"]


def test_w111_reads_max_v_from_init_and_from_the_program() -> None:
    source = ("INIT\n SET_MAX_V X, 8000\nEND INIT\n"
              "MP 1\n SET_V X, 12000\n SET_MAX_V X, 16000\n SET_V X, 12000\n"
              " SET_V X, 12001\n RECTANGLE X, Y, 0, 0, 0, 1000, 1000, 100, 100, 1000, 3100, "
              "3125\n SET_MAX_V X, VAR1\n SET_V X, 12345\nEND MP\n")
    got = _warnings(source)
    assert got == [
        "5: SET_V: the speed 12000 runs as 8000 on the device (a speed is at most MAX_V 8000)",
        "8: SET_V: the speed 12001 runs as 12002 on the device (a speed is a multiple of "
        "MAX_V/8000 = 2 with MAX_V 16000)",
        "9: RECTANGLE RA: the acceleration 3100 runs as 3000 on the device (an acceleration "
        "is a multiple of MAX_V/64 = 250 with MAX_V 16000)",
        "9: RECTANGLE RD: the acceleration 3125 runs as 3250 on the device (an acceleration "
        "is a multiple of MAX_V/64 = 250 with MAX_V 16000)"]


def test_the_rounding_choice_and_the_ranges() -> None:
    """`acceleration_rounding`: 12,000 is nearest 12,500 and down 9,375; both keep one step
    at least and MAX_V * 125 at most. Jerks are raised to MAX_V * 0.0119211 only."""
    down = ChipRules(acceleration_rounding="down")
    assert RULES.acceleration(12_000, 200_000) == 12_500
    assert down.acceleration(12_000, 200_000) == 9_375
    assert down.acceleration(100, 200_000) == RULES.acceleration(100, 200_000) == 3_125
    assert RULES.acceleration(10**9, 200_000) == 25_000_000
    assert RULES.jerk(1, 200_000) == pytest.approx(2384.22)
    assert RULES.jerk(5_000_000, 200_000) == 5_000_000
    assert RULES.speed(1, 4_000_000) == 500 and RULES.speed(0, 8000) == 0
    raw = catalogue.load().profile.raw
    bad = {**raw, "chip_values": {**raw["chip_values"], "acceleration_rounding": "up"}}
    with pytest.raises(ValueError, match="'nearest' or 'down'"):
        ChipRules.from_profile(bad)

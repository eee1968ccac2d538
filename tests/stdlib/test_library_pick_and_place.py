"""std:pick_and_place.mp on the virtual controller: parts are counted, the gantry ends at the
place point, Z and the gripper switch in the right order (sampled while the cycle runs), the
group's other outputs are left alone, and a missing part ends the cycle early."""

from __future__ import annotations

from functools import cache

from library_support import Variables, X, Y, build, consts, load, lp, run, slot

from mplang.m8194h.compiler import BuildResult
from mplang.m8194h.sim.controller import VirtualController

PICK, PLACE = (50_000, 20_000), (300_000, 250_000)
DO_Z, DO_GRIP, LAMP = 1, 0, 1 << 2  # channels of DO group 0; the lamp is not the routine's
DI_GROUP, DI_PART = 8, 0
TIMEOUT_MS = 3000


@cache
def program() -> BuildResult:
    return build(consts(STD_PP_PICK_X=PICK[0], STD_PP_PICK_Y=PICK[1], STD_PP_PLACE_X=PLACE[0],
                        STD_PP_PLACE_Y=PLACE[1], STD_PP_DO_GROUP=0, STD_PP_DO_Z=DO_Z,
                        STD_PP_DO_GRIP=DO_GRIP, STD_PP_DI_GROUP=DI_GROUP,
                        STD_PP_DI_PART=DI_PART, STD_PP_PART_TIMEOUT_MS=TIMEOUT_MS,
                        STD_PP_STROKE_MS=250, STD_PP_GRIP_MS=150) + f"""
INCLUDE "std:pick_and_place.mp"

MP 100 main
    SET_MAX_V XY, 400000
    SET_SV XY, 2000
    SET_V XY, 200000
    SET_A XY, 1000000
    FRNET_OUT 0, {LAMP}
END MP
""")


def prepared(count: int) -> tuple[VirtualController, Variables]:
    """The profile set, the lamp on, std_pick_place called for `count` parts."""
    result = program()
    vc = load(result)
    run(vc, result)
    variables = Variables(result, vc)
    variables["std_pp_count"] = count
    vc.call(slot(result, "std_pick_place"))
    return vc, variables


def bit(vc: VirtualController, channel: int) -> int:
    return (vc.frnet[0] >> channel) & 1


def feed(vc: VirtualController, parts: int) -> set[tuple[int, int]]:
    """Run the cycle with an infeed holding `parts` parts: the sensor is on while a part
    waits, goes off when the gripper closes on it and on again (if any are left) when the
    gripper lets the previous one go. Checks on the way that the gantry never moves with Z
    down and carries a part exactly on its way to the place point; returns the (Z, gripper)
    states seen."""
    seen = set()
    gripping = False
    rest = (lp(vc, X), lp(vc, Y))  # where the gantry last stood still
    if parts:
        vc.frnet[DI_GROUP] |= 1 << DI_PART
    while vc.stack:
        vc.advance(vc.clock + 0.002)
        z, grip = bit(vc, DO_Z), bit(vc, DO_GRIP)
        seen.add((z, grip))
        if grip and not gripping:  # picked: the infeed is empty until the next part
            parts -= 1
            vc.frnet[DI_GROUP] &= ~(1 << DI_PART)
        if gripping and not grip and parts:
            vc.frnet[DI_GROUP] |= 1 << DI_PART
        gripping = bool(grip)
        if vc.motion.busy(X | Y, vc.clock):  # Z up; a part only on the way from the pick
            assert (z, grip) == (0, 1 if rest == PICK else 0)
        else:
            rest = (lp(vc, X), lp(vc, Y))
        vc.touch()
    assert vc.error is None, vc.error
    return seen


def test_a_batch_is_carried_part_by_part() -> None:
    vc, variables = prepared(3)
    seen = feed(vc, 3)
    assert variables["std_pp_done"] == 3
    assert (lp(vc, X), lp(vc, Y)) == PLACE
    assert seen == {(0, 0), (1, 0), (1, 1), (0, 1)}  # every Z / gripper state occurred
    assert vc.frnet[0] == LAMP  # Z up, gripper open, the lamp untouched


def test_no_part_ends_the_cycle_after_the_timeout_without_moving() -> None:
    vc, variables = prepared(3)
    began = vc.clock
    outcome = vc.run()
    assert outcome.finished, outcome.error
    assert variables["std_pp_done"] == 0
    assert (lp(vc, X), lp(vc, Y)) == (0, 0)
    assert 3.0 <= vc.clock - began <= 3.01


def test_the_supply_running_dry_ends_the_batch_early() -> None:
    vc, variables = prepared(5)
    began = vc.clock
    feed(vc, 2)
    assert variables["std_pp_done"] == 2
    assert (lp(vc, X), lp(vc, Y)) == PLACE
    assert vc.frnet[0] == LAMP
    assert vc.clock - began > TIMEOUT_MS / 1000  # it waited for a third part

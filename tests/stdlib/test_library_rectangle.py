"""std:rectangle.mp on the virtual controller: the sampled tool path lies on the rectangle's
sides, visits them in order, reaches every corner and ends where it started."""

from __future__ import annotations

from library_support import Variables, X, Y, Z, build, consts, load, lp, move_to, trace

from mplang.m8194h.compiler import BuildResult

WIDTH, HEIGHT = 30_000, -20_000


def program(axis1: int, axis2: int) -> BuildResult:
    return build(consts(STD_RECT_AXIS1=axis1, STD_RECT_AXIS2=axis2, STD_RECT_WIDTH=WIDTH,
                        STD_RECT_HEIGHT=HEIGHT, STD_RECT_VSV=1000, STD_RECT_VV=20_000,
                        STD_RECT_VA=100_000) + """
INCLUDE "std:rectangle.mp"

MP 100 main
    SET_MAX_V XYZU, 80000
END MP
""")


def rectangle(axis1: int, axis2: int, laps: int) -> tuple[Variables, list[tuple[int, int]]]:
    result = program(axis1, axis2)
    vc = load(result)
    move_to(vc, {axis1: 5000, axis2: 7000})
    variables = Variables(result, vc)
    variables["std_rect_laps"] = laps
    return variables, trace(vc, result, "std_rectangle", (axis1, axis2))


def side(point: tuple[int, int], x0: int, y0: int) -> str | None:
    """Which side a point lies on (None: a corner); it must lie on one."""
    x, y = point
    on = {name for name, hit in (("bottom", y == y0), ("right", x == x0 + WIDTH),
                                 ("top", y == y0 + HEIGHT), ("left", x == x0)) if hit}
    assert on, f"{point} is off the rectangle"
    if len(on) > 1:
        return None
    (name,) = on
    return name


def test_two_laps_on_the_sides_in_order_back_to_the_start() -> None:
    variables, samples = rectangle(X, Y, 2)
    order = [s for s in (side(p, 5000, 7000) for p in samples) if s is not None]
    visits = [s for i, s in enumerate(order) if i == 0 or order[i - 1] != s]
    assert visits == ["bottom", "right", "top", "left"] * 2
    xs, ys = [p[0] for p in samples], [p[1] for p in samples]
    assert (min(xs), max(xs), min(ys), max(ys)) == (5000, 35_000, -13_000, 7000)
    assert samples[-1] == (5000, 7000)
    assert variables["std_rect_laps_done"] == 2


def test_any_axis_pair_and_zero_laps() -> None:
    variables, samples = rectangle(Y, Z, 1)
    assert {side(p, 5000, 7000) for p in samples} >= {"bottom", "right", "top", "left"}
    assert (lp(variables.vc, Y), lp(variables.vc, Z), lp(variables.vc, X)) == (5000, 7000, 0)
    assert variables["std_rect_laps_done"] == 1
    variables, samples = rectangle(X, Y, 0)
    assert set(samples) == {(5000, 7000)}
    assert variables["std_rect_laps_done"] == 0

"""std:grid.mp on the virtual controller: the project's std_grid_point runs once at every
point of the grid, standing exactly on it, with std_grid_col / std_grid_row naming it; the
axes end at the first point."""

from __future__ import annotations

import pytest
from library_support import Variables, X, Y, build, consts, load, lp, move_to, run

PITCH_1, PITCH_2 = 10_000, -5_000


@pytest.mark.parametrize(("cols", "rows"), [(4, 3), (1, 1), (1, 3), (5, 1)])
def test_every_point_is_visited_once_standing_on_it(cols: int, rows: int) -> None:
    # the project's routine checks its own position against the grid and sums what it saw
    result = build(consts(STD_GRID_AXIS1=X, STD_GRID_AXIS2=Y, STD_GRID_COLS=cols,
                          STD_GRID_ROWS=rows, STD_GRID_PITCH_1=PITCH_1,
                          STD_GRID_PITCH_2=PITCH_2) + """
INCLUDE "std:grid.mp"
ALIAS visits = VAR1
ALIAS misplaced = VAR2
ALIAS index_sum = VAR3
ALIAS here = VAR4
ALIAS wanted = VAR5

MP 100 main
    SET_MAX_V XY, 80000
    SET_SV XY, 1000
    SET_V XY, 40000
    SET_A XY, 400000
    visits = 0
    misplaced = 0
    index_sum = 0
    CALL std_grid
END MP

MP std_grid_point
    visits = visits + 1  # mpc: ignore[W103]
    index_sum = index_sum + std_grid_row * 100 + std_grid_col  # mpc: ignore[W103]
    here = GET_LP(X)
    wanted = 3000 + std_grid_col * PITCH_1
    IF here != wanted
        misplaced = misplaced + 1  # mpc: ignore[W103]
    END IF
    here = GET_LP(Y)
    wanted = 2000 + std_grid_row * PITCH_2
    IF here != wanted
        misplaced = misplaced + 1
    END IF
END MP
""".replace("PITCH_1", str(PITCH_1)).replace("PITCH_2", str(PITCH_2)))
    vc = load(result)
    move_to(vc, {X: 3000, Y: 2000})
    run(vc, result)
    variables = Variables(result, vc)
    assert vc.vars[1] == cols * rows == variables["std_grid_points"]
    assert vc.vars[2] == 0
    assert vc.vars[3] == sum(r * 100 + c for r in range(rows) for c in range(cols))
    assert (variables["std_grid_col"], variables["std_grid_row"]) == (cols, rows)
    assert (lp(vc, X), lp(vc, Y)) == (3000, 2000)

"""An .mp build run on the virtual CSIM reports its declared variables (VAR name, ALIAS) by
name, with the CSIM variable each became beside it, as the M8194H's run does with VARn
(issue 14 item 2)."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from mplang import csim
from mplang.cli import main
from mplang.ir.unit import Options

JOB = """ALIAS parts = VAR10
VAR rows_done @ VAR400
VAR never_used

MP 100 job
    SET_V X, 20000
    parts = 0
    rows_done = 0
    FOR 3
        FIXED_MOVE X, 1000
        STOP_WAIT X
        parts = parts + 1  # mpc: ignore[W701]
        rows_done = rows_done + 2  # mpc: ignore[W701]
    NEXT
END MP
"""


def test_csim_run_json_keys_declared_variables_by_name(tmp_path: Path) -> None:
    source = tmp_path / "job.mp"
    source.write_text(JOB)
    build = csim.compile_mp([source], Options(), "csim")
    assert build.programs[0].names == {"parts": "R0", "rows_done": "R1"}
    summary = csim.run_build(build, None, 60.0).to_json()
    assert summary["names"] == {"parts": "R0", "rows_done": "R1"}
    assert summary["vars"]["parts"] == 3 and summary["vars"]["rows_done"] == 6
    assert "R0" not in summary["vars"] and "R1" not in summary["vars"]


def test_csim_run_text_names_variables_with_their_csim_variable(tmp_path: Path) -> None:
    source = tmp_path / "job.mp"
    source.write_text(JOB)
    result = CliRunner().invoke(main, ["run", str(source), "--target", "csim"])
    assert result.exit_code == 0, result.output
    assert "  parts (R0) = 3\n  rows_done (R1) = 6\n" in result.stdout
    as_json = CliRunner().invoke(main, ["run", str(source), "--target", "csim", "--json"])
    assert json.loads(as_json.stdout)["vars"]["rows_done"] == 6

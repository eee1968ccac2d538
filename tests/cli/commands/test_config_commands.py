"""The configuration blocks through the command line: `mpc run` loads INIT before the
call, `mpc build --format triggers` lists the table to enter in the utility, `mpc flash`
loads INIT and enables triggering on a running `mpc sim` (a real subprocess over TCP)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from click.testing import CliRunner
from simproc import start_sim

from mplang.cli import EXIT_NO_INPUT, EXIT_OK, main

ROOT = Path(__file__).resolve().parents[3]
SAMPLE = "samples/controller/controller.mp"
LIMITED = """INIT
    SET_SLMT X, 1000, -1000, 0
END INIT
MP 1 go
    SET_V X, 2000
    FIXED_MOVE X, 5000
END MP
"""


def test_run_loads_the_initial_table_before_the_call(tmp_path: Path) -> None:
    source = tmp_path / "limited.mp"
    source.write_text(LIMITED)
    limited = CliRunner().invoke(main, ["run", str(source), "--json"])
    assert limited.exit_code == EXIT_OK, limited.output
    x = json.loads(limited.stdout)["axes"]["X"]["lp"]
    assert 1000 <= x < 1100  # the software limit of the table stops the move ...
    assert "warning[R312]: axis X stopped on the software limit" in limited.stderr  # ... saying so
    source.write_text(LIMITED.replace("    SET_SLMT X, 1000, -1000, 0\n", ""))
    free = CliRunner().invoke(main, ["run", str(source), "--json"])
    assert json.loads(free.output)["axes"]["X"]["lp"] == 5000


def test_build_lists_the_trigger_table(tmp_path: Path) -> None:
    listed = CliRunner().invoke(main, ["build", str(ROOT / SAMPLE), "--format", "triggers"])
    assert listed.exit_code == EXIT_OK, listed.output
    rows = listed.output.splitlines()
    assert "holding register 9" in rows[0]
    assert rows[2].split() == ["8", "0", "OFF", "to", "ON", "MP41", "36"]
    assert rows[-1].strip() == "every other channel: None"
    plain = tmp_path / "plain.mp"
    plain.write_text("MP 1\n    VAR1 = 1\nEND MP\n")
    none = CliRunner().invoke(main, ["build", str(plain), "--format", "triggers"])
    assert none.exit_code == EXIT_OK and none.output.startswith("; no TRIGGERS block")


def mpc(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=60, cwd=ROOT)


def test_flash_loads_init_and_enables_triggering_on_a_running_sim(tmp_path: Path) -> None:
    proc, port = start_sim("--duration", "30")
    try:
        done = mpc("flash", SAMPLE, "--tcp", f"127.0.0.1:{port}", "--json")
        assert done.returncode == EXIT_OK, done.stderr
        report = json.loads(done.stdout)
        assert report["ok"] and report["init"]["status"] == "verified"
        assert report["triggers"]["status"] == "verified"
        assert report["triggers"]["detail"] == "holding register 9 = 1"
        assert "INIT: 9 frames written, initial table loaded" in done.stderr
        assert "initial table loaded, DI triggering set on Modbus TCP" in done.stderr
        assert "enter it in EzMove" in done.stderr
        image = tmp_path / "image.json"
        built = mpc("build", SAMPLE, "-o", str(image))
        assert built.returncode == EXIT_OK, built.stderr
        data = json.loads(image.read_text())
        data["init"]["frames"][0][1] = 0x0F  # a live axis code: not an initial-table write
        image.write_text(json.dumps(data))
        refused = mpc("flash", str(image), "--tcp", f"127.0.0.1:{port}")
        assert refused.returncode == EXIT_NO_INPUT
        assert "init.frames[0][1]: must be an INITIAL_* axis code" in refused.stderr
    finally:
        proc.terminate()
        proc.wait(10)

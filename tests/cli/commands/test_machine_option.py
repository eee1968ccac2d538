"""`--machine FILE` and the `[machine]` table of mpc.toml for `mpc run`, `mpc plot` and `mpc
sim` (issue 14 item 3): every bad machine file is one line at its file:line with exit 17; the
families whose virtual device has no machine to describe refuse `--machine` with their reason;
`mpc sim --machine` serves a controller whose inputs follow the file, read over Modbus TCP."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest
from click.testing import CliRunner
from simproc import start_sim

from mplang.cli import EXIT_OK, EXIT_USAGE, main
from mplang.cli.common import EXIT_BAD_MACHINE
from mplang.m8194h.modbus import DeviceLink, Endpoint

PROGRAM = "MP 100 go\n    VAR1 = FRNET_READ(8, 0)\nEND MP\n"


def run(*args: str | Path) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


@pytest.fixture
def program(tmp_path: Path) -> Path:
    path = tmp_path / "go.mp"
    path.write_text(PROGRAM)
    return path


BAD_MACHINES = [
    # (file text, line, words of the message)
    ("[machine]\nemg = false\nspeed = 3\n", 3, ["[machine] speed", "unknown key"]),
    ("[machine.X]\nlimit-plus = 10\nlimit-pluss = 3\n", 3, ["[machine.X] limit-pluss",
                                                           "unknown key"]),
    ("[machine]\nemg = false\n[machine.W]\nstart = 1\n", 3, ["[machine.W]: unknown axis",
                                                           "[machine.X]"]),
    ("[machine.X]\nstart = \"far\"\n", 2, ["[machine.X] start", "whole number of pulses"]),
    ("[machine.Y]\nhome = [5, 1]\n", 2, ["[machine.Y] home", "is empty"]),
    ("[machine.Y]\nnear-home = 7\n", 2, ["[machine.Y] near-home", "[FROM, TO]"]),
    ("[machine.Z]\nindex = { period = 0 }\n", 2, ["[machine.Z] index", "period"]),
    ("[machine.U]\nalarm = 1\n", 2, ["[machine.U] alarm", "true or false"]),
    ("[machine.U]\ninpos = \"maybe\"\n", 2, ["[machine.U] inpos", "\"auto\""]),
    ("[machine.X]\nlimit-plus = 10\nlimit-minus = 20\n", 3, ["limit-minus", "not below"]),
    ("[machine]\nevents = [\n  \"at 1 s DI8.0 = 1\",\n  \"at 2 s DI3 = 1\",\n]\n", 4,
     ["'at 2 s DI3 = 1'", "FRnet DI groups are 8..15"]),
    ("[machine]\nevents = [\n  \"at 1 s LAMP = 1\",\n]\n", 3, ["unknown input 'LAMP'",
                                                             "AXIS.IN3"]),
    ("[machine]\nevents = [\"at -1 s EMG = 1\"]\n", 2, ["0 or more seconds"]),
    ("[machine]\nevents = [\"at soon s EMG = 1\"]\n", 2, ["'soon' is not a time"]),
    ("[machine]\nevents = [\"at 1 h EMG = 1\"]\n", 2, ["at TIME s NAME = VALUE"]),
    ("[machine]\nevents = [\"when W >= 5 EMG = 1\"]\n", 2, ["unknown axis 'W'"]),
    ("[machine]\nevents = [\"when X >= 5 DI8.1 = 2\"]\n", 2, ["0 (off) or 1 (on)"]),
    ("[machine]\nevents = [\"when X = 5 EMG = 1\"]\n", 2, ["OP one of"]),
    ("[machine]\nevents = \"at 1 s EMG = 1\"\n", 2, ["[machine] events", "list of strings"]),
    ("[machine]\nemg = \"yes\"\n", 2, ["[machine] emg", "true or false"]),
    ("[machine]\nemg = false\n[machine.X\n", 3, ["not valid TOML"]),
    ("[project]\nsources = []\n", 1, ["unknown table or key 'project'"]),
    ("# nothing\n", 1, ["no [machine] table"]),
]


@pytest.mark.parametrize(("text", "line", "words"), BAD_MACHINES)
def test_a_bad_machine_file_exits_17_at_its_line(program: Path, tmp_path: Path, text: str,
                                                 line: int, words: list[str]) -> None:
    machine = tmp_path / "machine.toml"
    machine.write_text(text)
    for command in (("run",), ("plot", "-o", str(tmp_path / "out.svg"))):
        code, out, err = run(*command, "--machine", machine, program)
        assert code == EXIT_BAD_MACHINE, err
        assert out == "" and "Traceback" not in err
        assert err.startswith(f"mpc: error: {machine}:{line}: "), err
        for word in words:
            assert word in err


def test_a_machine_file_that_cannot_be_read_exits_17(program: Path, tmp_path: Path) -> None:
    code, _out, err = run("run", "--machine", tmp_path / "none.toml", program)
    assert code == EXIT_BAD_MACHINE and "none.toml: cannot read" in err
    (tmp_path / "bin.toml").write_bytes(b"\xff\xfe[machine]")
    code, _out, err = run("run", "--machine", tmp_path / "bin.toml", program)
    assert code == EXIT_BAD_MACHINE and "not UTF-8" in err
    code, _out, err = run("run", "--machine", "x" * 5000 + ".toml", program)
    assert code == EXIT_BAD_MACHINE and "cannot read" in err


def test_the_project_machine_table_is_used_and_checked(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "go.mp").write_text(PROGRAM)
    project = tmp_path / "mpc.toml"
    project.write_text('[project]\nsources = "go.mp"\n\n[machine]\n'
                       'events = ["at 0 s DI8.0 = 1"]\n')
    monkeypatch.chdir(tmp_path)
    code, out, err = run("run", "--json")
    assert code == EXIT_OK, err
    summary = json.loads(out)
    assert summary["vars"]["VAR1"] == 1 and summary["machine"] == "mpc.toml"
    # --machine wins over the project's table
    (tmp_path / "other.toml").write_text("[machine]\n")
    assert "VAR1" not in json.loads(run("run", "--json", "--machine", "other.toml")[1])["vars"]
    project.write_text('[project]\nsources = "go.mp"\n\n[machine]\nevents = ["at 1 s X = 1"]\n')
    code, _out, err = run("run")
    assert code == EXIT_BAD_MACHINE and err.startswith("mpc: error: mpc.toml:5: [machine] events")


@pytest.mark.parametrize(("source", "family", "reason"), [
    ("samples/csim/jog.csim", "CSIM", "no limit or home switches"),
    ("samples/fatek/jog_forward.fbs", "FATEK", "SIM lines"),
])
def test_families_without_a_machine_refuse_it_with_their_reason(
        tmp_path: Path, source: str, family: str, reason: str) -> None:
    machine = tmp_path / "machine.toml"
    machine.write_text("[machine]\n")
    root = Path(__file__).resolve().parents[3]
    code, _out, err = run("run", "--machine", machine, root / source)
    assert code == EXIT_USAGE and "--machine" in err and family in err and reason in err


def test_mpc_sim_serves_the_machine_over_modbus(tmp_path: Path) -> None:
    """The FRnet DI group 8 and the X axis's DI status (input registers 16, RS 4.6.2) of a
    served controller follow the machine file: EMG at once, DI 8.1 from the start."""
    machine = tmp_path / "machine.toml"
    machine.write_text('[machine]\nemg = true\nevents = ["at 0 s DI8.1 = 1"]\n'
                       '[machine.X]\nlimit-minus = 0\n')
    proc, port = start_sim("--machine", str(machine), "--duration", "30")

    async def read() -> tuple[list[int], list[int]]:
        async with DeviceLink(Endpoint(host="127.0.0.1", port=port)) as link:
            return await link.read_input(16, 1), await link.read_input(8, 1)

    try:
        (status,), (group,) = asyncio.run(read())
        assert status & 0b1100 == 0b1100  # LIMIT- engaged at 0, EMG asserted
        assert group == 0x0002
    finally:
        proc.kill()
        proc.wait()
        if proc.stdout is not None:
            proc.stdout.close()


def test_a_project_machine_is_noted_for_a_family_without_one(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "go.mp").write_text("MP 100 go\n    FIXED_MOVE X, 1000\n    STOP_WAIT X\n"
                                    "END MP\n")
    (tmp_path / "mpc.toml").write_text('[project]\nsources = "go.mp"\ntarget = "csim"\n\n'
                                       '[machine]\nemg = true\n')
    monkeypatch.chdir(tmp_path)
    code, out, err = run("run")
    assert code == EXIT_OK, err
    assert "mpc: note: mpc.toml: [machine] does not apply: the virtual CSIM has no limit" in err
    assert "finished" in out

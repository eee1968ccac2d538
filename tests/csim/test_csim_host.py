"""`mpc call`, `mpc var`, `mpc export` and `mplang.host` for a CSIM (issue 27 item 5): the
served CSIM is `mpc sim --target csim --serial pty` in a subprocess, `mpc` a second process
on the other end of the pty pair, and an independent client (pyserial, speaking the command
set by hand) reads and writes what the export names. A CSIM holds no build manifest: its
program listing (ULP, CS 119) is compared with the build before anything is written."""

from __future__ import annotations

import asyncio
import csv
import io
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import serial  # type: ignore[import-untyped]

import mplang.host
from mplang.cli.common import (
    EXIT_NO_DEVICE,
    EXIT_NO_INPUT,
    EXIT_OK,
    EXIT_OUT_OF_SYNC,
    EXIT_REJECTED,
    EXIT_RUN_FAILED,
    EXIT_USAGE,
    EXIT_WAIT_TIMEOUT,
)
from mplang.family.ptylink import PtyLink

JOB = """CONST STEP = 250
VAR parts
VAR scale
ALIAS total = VAR10

MP 100 tour
    SET_V X, 2000
    FIXED_MOVE X, STEP
    STOP_WAIT X
    parts = parts + 1  # mpc: ignore[W701]
    CALL tally
END MP

MP tally
    total = total + parts  # mpc: ignore[W701, W103]
END MP

MP 101 crash
    FOR 20
        scale = scale * 100000  # mpc: ignore[W701]
    NEXT  # mpc: ignore[W701]
END MP

MP 102 dwell
    TIMER 60000
END MP
"""
OTHER = JOB.replace("STEP = 250", "STEP = 260")
SCRIPT = "$START\nR5=1\nJP $DONE\n$AGAIN\nR5=R5+1  # mpc: ignore[W701]\n$DONE\nRET\n"
CSIM = ("--target", "csim")


def mpc(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=90, cwd=cwd)


@pytest.fixture
def job(tmp_path: Path) -> Path:
    (tmp_path / "job.mp").write_text(JOB)
    (tmp_path / "other.mp").write_text(OTHER)
    (tmp_path / "script.csim").write_text(SCRIPT)
    return tmp_path


def ask(port: str, text: str) -> list[str]:
    """One command to the CSIM by hand (the independent client): its data lines, after
    the echo, up to the status line, which must be OK."""
    with serial.Serial(port, 115200, timeout=5.0) as line:
        line.write(text.encode() + b"\r")
        echo = line.read_until(b"\r\n").decode().strip()
        assert echo == text
        data = []
        while (reply := line.read_until(b"\r\n").decode().strip()) != "OK":
            assert not reply.startswith("ERR"), reply
            data.append(reply)
        return data


def flashed(job: Path, port: str, source: str = "job.mp") -> None:
    done = mpc(job, "flash", source, *CSIM, "--serial", port)
    assert done.returncode == EXIT_OK, done.stderr


def test_export_names_the_commands_and_compiles(job: Path) -> None:
    view = json.loads(mpc(job, "export", "job.mp", *CSIM).stdout)
    assert view["family"] == "CSIM" and view["protocol"] == "rs232-ascii"
    built = mpc(job, "build", "job.mp", *CSIM, "--format", "json")
    lines = [x["text"] for x in json.loads(built.stdout)["programs"][0]["lines"]]
    assert view["listing"] == lines
    tour = next(p for p in view["programs"] if p["name"] == "tour")
    assert (tour["device_name"], tour["function"], tour["slot"]) == ("$TOUR", "G $TOUR", 100)
    assert tour["writes"] == ["parts", "total"] and tour["source"] == "job.mp:6"
    variables = {v["name"]: v for v in view["variables"]}
    assert variables["parts"]["device_name"] == "R0" and variables["parts"]["type"] == "float32"
    assert variables["total"]["source"] == "job.mp:4"
    assert view["consts"] == [{"name": "STEP", "value": 250, "source": "job.mp:1"}]

    rows = list(csv.DictReader(io.StringIO(mpc(job, "export", "job.mp", *CSIM, "--format",
                                               "csv").stdout)))
    assert rows[0]["device_name"] == view["build_id"]
    by_name = {r["name"]: r for r in rows}
    assert by_name["tour"]["function"] == "G $TOUR" and by_name["tour"]["access"] == "send"
    assert by_name["parts"]["function"] == "?R0 / R0=v" and by_name["parts"]["register"] == "0"

    python = mpc(job, "export", "job.mp", *CSIM, "--format", "python").stdout
    names: dict[str, object] = {}
    exec(compile(python, "export.py", "exec"), names)
    assert names["BUILD_ID"] == view["build_id"] and names["CALL_TOUR"] == "G $TOUR"
    assert names["VAR_PARTS"] == "R0" and names["CONST_STEP"] == 250
    csharp = mpc(job, "export", "job.mp", *CSIM, "--format", "csharp").stdout
    assert 'public const string CALL_TOUR = "G $TOUR";' in csharp
    header = job / "host.h"
    assert mpc(job, "export", "job.mp", *CSIM, "--format", "c", "-o", "host.h").returncode == 0
    assert '#define MPC_VAR_PARTS "R0"' in header.read_text()
    gcc = shutil.which("gcc")
    if gcc is not None:
        (job / "main.c").write_text('#include "host.h"\n#include <string.h>\nint main(void) '
                                    '{ return (int)strlen(MPC_BUILD_ID MPC_CALL_TOUR '
                                    'MPC_VAR_PARTS) + (int)MPC_CONST_STEP - 275; }\n')
        done = subprocess.run([gcc, "-Wall", "-Werror", "-o", "main", "main.c"], cwd=job,
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        assert subprocess.run([str(job / "main")], timeout=10).returncode == 0


def test_another_program_is_refused_before_anything_is_written(job: Path,
                                                               served: str) -> None:
    empty = mpc(job, "var", "parts=9", "job.mp", *CSIM, "--serial", served)
    assert empty.returncode == EXIT_OUT_OF_SYNC
    assert "the device holds no program (ULP lists nothing)" in empty.stderr
    flashed(job, served, "other.mp")
    ask(served, "R0=7")
    ours = json.loads(mpc(job, "export", "job.mp", *CSIM).stdout)["build_id"]
    theirs = json.loads(mpc(job, "export", "other.mp", *CSIM).stdout)["build_id"]
    for args in (["var", "parts=99"], ["call", "tour", "--set", "parts=99", "--wait"]):
        done = mpc(job, *args, "job.mp", *CSIM, "--serial", served)
        assert done.returncode == EXIT_OUT_OF_SYNC, done.stderr
        assert f"holds build {theirs}" in done.stderr and f"expects build {ours}" in done.stderr
        assert "line 3: the device holds 'XMR 260', the build has 'XMR 250'" in done.stderr
        assert ask(served, "?R0") == ["7"]  # nothing written
        assert ask(served, "?ST") == ["IDLE"] and ask(served, "?PE") == ["0"]  # nor called
    forced = mpc(job, "var", "parts=99", "job.mp", *CSIM, "--serial", served, "--no-check")
    assert forced.returncode == EXIT_OK, forced.stderr
    assert ask(served, "?R0") == ["99"]
    export = job / "job.json"
    export.write_text(mpc(job, "export", "job.mp", *CSIM).stdout)
    from_export = mpc(job, "var", "job.json", *CSIM, "--serial", served)
    assert from_export.returncode == EXIT_OUT_OF_SYNC and f"expects build {ours}" in \
        from_export.stderr


def test_call_and_var_by_name_real_valued(job: Path, served: str) -> None:
    flashed(job, served)
    wrote = mpc(job, "var", "parts=2.5", "total", "job.mp", *CSIM, "--serial", served)
    assert wrote.returncode == EXIT_OK, wrote.stderr
    assert wrote.stdout.splitlines() == ["total (R1) = 0", "parts (R0) = 2.5"]
    assert ask(served, "?R0") == ["2.5"]  # the independent client sees the same
    ask(served, "R1=-1.25")
    listed = mpc(job, "var", "job.mp", *CSIM, "--serial", served, "--json")
    assert json.loads(listed.stdout) == {"total": -1.25, "parts": 2.5, "scale": 0}
    ask(served, "R1=0")
    done = mpc(job, "call", "tour", "job.mp", *CSIM, "--serial", served, "--set", "parts=4",
               "--wait", "--json")
    assert done.returncode == EXIT_OK, done.stderr
    result = json.loads(done.stdout)
    assert result["program"] == "tour" and result["slot"] == "$TOUR"
    assert result["vars"] == {"parts": 5, "total": 5} and result["error"] is None
    assert ask(served, "?PE") == ["250"]
    again = mpc(job, "call", "MP100", "job.mp", *CSIM, "--serial", served, "--wait")
    assert again.returncode == EXIT_OK, again.stderr
    assert again.stdout.splitlines()[1:] == ["  parts = 6", "  total = 11"]
    started = mpc(job, "call", "$TALLY", "job.mp", *CSIM, "--serial", served)
    assert started.returncode == EXIT_OK and started.stdout.startswith("$TALLY tally started")


def test_a_run_error_is_exit_5_without_a_source_line_each_time(job: Path,
                                                               served: str) -> None:
    flashed(job, served)
    for _ in range(2):  # G clears the error: the second failure is told apart too
        done = mpc(job, "call", "crash", "job.mp", *CSIM, "--serial", served, "--set",
                   "scale=1e9", "--wait", "--json")
        assert done.returncode == EXIT_RUN_FAILED, done.stderr
        error = json.loads(done.stdout)["error"]
        assert error["code"] == "R401" and error["device_code"] == 1
        assert error["file"] is None and error["line"] is None
        assert "does not say at which program line" in error["message"]
    text = mpc(job, "call", "crash", "job.mp", *CSIM, "--serial", served, "--wait")
    assert text.returncode == EXIT_RUN_FAILED
    assert "error[R401]: the CSIM reports error 1 (?ERR)" in text.stderr
    fine = mpc(job, "call", "tour", "job.mp", *CSIM, "--serial", served, "--wait")
    assert fine.returncode == EXIT_OK and "note" not in fine.stderr


def test_wait_past_timeout_is_exit_20_and_a_running_csim_takes_no_call(
        job: Path, served: str) -> None:
    flashed(job, served)
    done = mpc(job, "call", "dwell", "job.mp", *CSIM, "--serial", served, "--wait",
               "--timeout", "0.2")
    assert done.returncode == EXIT_WAIT_TIMEOUT, done.stderr
    assert "still runs after 0.2 s" in done.stderr
    busy = mpc(job, "call", "tour", "job.mp", *CSIM, "--serial", served)
    assert busy.returncode == EXIT_REJECTED, busy.stderr
    assert "a running CSIM does not list its program" in busy.stderr
    unchecked = mpc(job, "call", "tour", "job.mp", *CSIM, "--serial", served, "--no-check")
    assert unchecked.returncode == EXIT_REJECTED
    assert "a program is running" in unchecked.stderr
    assert ask(served, "?ST") == ["WAIT"] and ask(served, "?PE") == ["0"]
    read = mpc(job, "var", "parts", "job.mp", *CSIM, "--serial", served, "--no-check")
    assert read.returncode == EXIT_OK and read.stdout == "parts (R0) = 0\n"


def test_a_script_calls_its_labels_and_declares_no_variables(job: Path,
                                                             served: str) -> None:
    flashed(job, served, "script.csim")
    done = mpc(job, "call", "again", "script.csim", "--serial", served, "--wait")
    assert done.returncode == EXIT_OK, done.stderr
    assert ask(served, "?R5") == ["1"]  # R5 was 0: R5=R5+1
    whole = mpc(job, "call", "script", "script.csim", "--serial", served, "--wait")
    assert whole.returncode == EXIT_OK, whole.stderr
    assert ask(served, "?R5") == ["1"]
    names = mpc(job, "var", "script.csim", "--serial", served)
    assert names.returncode == EXIT_OK and "a .csim script has no declarations" in names.stderr
    unknown = mpc(job, "call", "nowhere", "script.csim", "--serial", served)
    assert unknown.returncode == EXIT_USAGE
    assert "callable: G script, $START, $AGAIN, $DONE)" in unknown.stderr


def test_bad_input_is_refused_with_its_reason(job: Path, served: str) -> None:
    flashed(job, served)
    ask(served, "R0=3")
    cases = [
        (["var", "sped=1"], EXIT_USAGE, "no declared variable 'sped'"),
        (["var", "parts=1", "scale=abc"], EXIT_USAGE, "'abc' is not a number"),
        (["var", "parts=1", "scale=1e39"], EXIT_USAGE, "scale (R3) is float32"),
        (["call", "nosuch", "--set", "parts=1"], EXIT_USAGE, "$TOUR tour"),
        (["var", "--identity", "MD0-MD7"], EXIT_USAGE, "a CSIM holds none"),
        (["var", "--unit", "2"], EXIT_USAGE, "--unit is for a Modbus device"),
        (["call", "tour", "--retries", "0"], EXIT_USAGE, "--retries is for a Modbus device"),
    ]
    for args, code, text in cases:
        done = mpc(job, args[0], *args[1:], "job.mp", *CSIM, "--serial", served)
        assert done.returncode == code, (args, done.stderr)
        assert text in done.stderr, (args, done.stderr)
        assert "Traceback" not in done.stderr
    assert ask(served, "?R0") == ["3"]  # none of them wrote
    tcp = mpc(job, "var", "job.mp", *CSIM, "--tcp", "127.0.0.1:1")
    assert tcp.returncode == EXIT_USAGE and "RS232 line: give --serial" in tcp.stderr
    (job / "two.csim").write_text("MA 5\n")
    two = mpc(job, "var", "script.csim", "two.csim", "--serial", served)
    assert two.returncode == EXIT_NO_INPUT and "a CSIM holds one" in two.stderr
    missing = mpc(job, "var", "job.mp", *CSIM, "--serial", str(job / "no-such-port"))
    assert missing.returncode == EXIT_NO_DEVICE and "cannot open serial port" in missing.stderr
    with PtyLink() as silent:  # a line with nothing on the other end
        quiet = mpc(job, "call", "tour", "job.mp", *CSIM, "--serial", silent.client_end,
                    "--answer-timeout", "0.2")
    assert quiet.returncode == EXIT_NO_DEVICE and "no answer from the device" in quiet.stderr


def test_the_python_api_speaks_to_a_csim(job: Path, served: str) -> None:
    with pytest.raises(mplang.host.BuildMismatch, match="holds no program"), \
            mplang.host.connect(serial=served, sources=[job / "job.mp"], target="csim"):
        pass
    flashed(job, served)
    with mplang.host.connect(serial=served, sources=[job / "job.mp"], target="csim") as ctl:
        assert ctl.build_id == ctl.view.build_id and not ctl.running
        ctl.vars["parts"] = 0.5
        assert ctl.vars["parts"] == 0.5 and dict(ctl.vars) == {
            "total": 0, "parts": 0.5, "scale": 0}
        result = ctl.call("tour", timeout=30)
        assert result.vars == {"parts": 1.5, "total": 1.5}
        assert ctl.axes["X"].position == 250 and ctl.axes["X"].state == "stopped"
        assert ctl.errors == []
        ctl.vars["scale"] = 1e9
        with pytest.raises(mplang.host.ExecutionError) as failed:
            ctl.call("crash", timeout=30)
        assert failed.value.code == "R401" and failed.value.line is None
        assert [e.device_code for e in ctl.errors] == [1]
        ctl.call("dwell", wait=False)
        assert ctl.running
        with pytest.raises(mplang.host.WaitTimeout):
            ctl.wait(timeout=0.1)
        with pytest.raises(mplang.host.ProgramRunning, match="a program is running"):
            ctl.call("tour")
        with pytest.raises(mplang.host.BadValue):
            ctl.vars["parts"] = float("nan")
    with pytest.raises(mplang.host.ProgramRunning, match="does not list its program"), \
            mplang.host.connect(serial=served, sources=[job / "job.mp"], target="csim"):
        pass
    ask(served, "EXIT")
    with pytest.raises(mplang.host.BuildMismatch, match="XMR 260"), \
            mplang.host.connect(serial=served, sources=[job / "other.mp"], target="csim"):
        pass


def test_the_async_api_speaks_to_a_csim(job: Path, served: str) -> None:
    flashed(job, served)

    async def host() -> tuple[object, object, object]:
        async with mplang.host.connect_async(serial=served, sources=[job / "job.mp"],
                                             target="csim") as ctl:
            await ctl.write_vars({"parts": 1, "total": 0.25})
            result = await ctl.call("tally", timeout=30)
            return result.vars, await ctl.read_vars(["parts"]), await ctl.running()

    assert asyncio.run(host()) == ({"total": 1.25}, {"parts": 1}, False)
    assert ask(served, "?R1") == ["1.25"]

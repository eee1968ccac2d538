"""`mpc call`, `mpc var` and `mpc export` against `mpc sim` in a subprocess, over Modbus TCP
and over RTU on a pty, as a host computer sees the controller: the build checked before
anything is written, programs called by name, variables by name in the device's word order,
and an independent client (pymodbus used raw, and Debian's mbpoll) reading and writing the
registers `mpc export --format csv` names.
"""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from monitorproc import stop
from simproc import raw_holding, start_rtu_sim, start_sim

from mplang.cli.common import (
    EXIT_NO_DEVICE,
    EXIT_OK,
    EXIT_OUT_OF_SYNC,
    EXIT_REJECTED,
    EXIT_RUN_FAILED,
    EXIT_USAGE,
    EXIT_WAIT_TIMEOUT,
)

JOB = """CONST STEP = 250
VAR speed
VAR parts
VAR divisor
ALIAS total = VAR10

MP 100 tour
    SET_V X, speed
    FIXED_MOVE X, STEP
    parts = parts + 1
    CALL tally
END MP

MP tally
    total = total + parts
END MP

MP 101 crash
    parts = 100 / divisor
END MP

MP 102 dwell
    TIMER 60000
END MP

MP 103 crash_too
    total = 7 / divisor
END MP
"""
OTHER = JOB.replace("STEP = 250", "STEP = 260")
MBPOLL = shutil.which("mbpoll")


def mpc(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=60, cwd=cwd)


@pytest.fixture(scope="module")
def job(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("host")
    (folder / "job.mp").write_text(JOB)
    (folder / "other.mp").write_text(OTHER)
    return folder


@pytest.fixture(scope="module", params=["tcp", "rtu"])
def device(request: pytest.FixtureRequest, job: Path) -> Iterator[list[str]]:
    """A virtual controller that holds the build of job.mp: its `mpc` device options."""
    if request.param == "tcp":
        proc, port = start_sim("--duration", "300")
        options = ["--tcp", f"127.0.0.1:{port}"]
    else:
        proc, pty = start_rtu_sim("--duration", "300")
        options = ["--serial", pty]
    try:
        flashed = mpc(job, "flash", "job.mp", *options)
        assert flashed.returncode == EXIT_OK, flashed.stderr
        yield options
    finally:
        stop(proc)


def raw_read(options: list[str], register: int, count: int) -> list[int]:
    """`raw_holding` for a device given as `mpc` options."""
    return raw_holding({options[0].lstrip("-"): options[1]}, register, count)


def csv_rows(job: Path) -> dict[str, dict[str, str]]:
    done = mpc(job, "export", "job.mp", "--format", "csv")
    assert done.returncode == EXIT_OK, done.stderr
    return {row["name"]: row for row in csv.DictReader(io.StringIO(done.stdout))}


def test_call_by_name_sets_variables_waits_and_reports_what_the_program_writes(
        job: Path, device: list[str]) -> None:
    done = mpc(job, "call", "tour", "job.mp", *device, "--set", "speed=3000", "--set",
               "parts=4", "--wait", "--timeout", "20", "--json")
    assert done.returncode == EXIT_OK, done.stderr
    data = json.loads(done.stdout)
    assert data["program"] == "tour" and data["error"] is None
    assert data["vars"] == {"parts": 5, "total": data["vars"]["total"]}
    assert data["build_id"] == json.loads(mpc(job, "export", "job.mp").stdout)["build_id"]
    assert isinstance(data["time_ms"], float)
    text = mpc(job, "var", "speed", "job.mp", *device)
    assert text.returncode == EXIT_OK, text.stderr
    assert text.stdout == "speed (VAR400) = 3000\n"


def test_an_execution_error_is_reported_at_its_source_line_with_exit_5(
        job: Path, device: list[str]) -> None:
    assert mpc(job, "var", "divisor=0", "job.mp", *device).returncode == EXIT_OK
    text = mpc(job, "call", "crash", "job.mp", *device, "--wait")
    assert text.returncode == EXIT_RUN_FAILED
    assert "job.mp:19: error[R103]: division by zero in VAR_CALCULATE in MP101 crash" \
        in text.stderr
    done = mpc(job, "call", "MP103", "job.mp", *device, "--wait", "--json")
    assert done.returncode == EXIT_RUN_FAILED, done.stderr
    error = json.loads(done.stdout)["error"]
    assert (error["file"], error["line"], error["code"]) == ("job.mp", 27, "R103")
    assert error["slot"] == "MP103 crash_too" and error["device_code"] == 3
    # the device keeps only its last execution error (115-119): the same failure again
    # cannot be told apart from it, and mpc says so rather than claim either way
    again = mpc(job, "call", "crash_too", "job.mp", *device, "--wait")
    assert again.returncode == EXIT_OK, again.stderr
    assert "mpc: note: the device recorded execution error R103 in MP103 crash_too " \
        "before this call" in again.stderr


def test_var_lists_every_declared_variable_and_an_independent_client_agrees(
        job: Path, device: list[str]) -> None:
    rows = csv_rows(job)
    written = mpc(job, "var", "parts=-123456", "total=70000", "job.mp", *device, "--json")
    assert written.returncode == EXIT_OK, written.stderr
    assert json.loads(written.stdout) == {"parts": -123456, "total": 70000}
    for name, value in (("parts", -123456), ("total", 70000)):
        row = rows[name]
        assert row["word_order"] == "msw-first" and row["words"] == "2"
        high, low = raw_read(device, int(row["register"]), 2)
        assert ((high << 16 | low) ^ 0x80000000) - 0x80000000 == value
    listed = json.loads(mpc(job, "var", "job.mp", *device, "--json").stdout)
    assert set(listed) == {"speed", "parts", "divisor", "total"}
    assert listed["parts"] == -123456


def test_an_export_or_an_image_stands_for_the_sources(job: Path, device: list[str]) -> None:
    assert mpc(job, "export", "job.mp", "-o", "host.json").returncode == EXIT_OK
    assert mpc(job, "build", "job.mp", "-o", "image.json").returncode == EXIT_OK
    exported = mpc(job, "var", "divisor=9", "host.json", *device, "--json")
    assert exported.returncode == EXIT_OK, exported.stderr
    assert json.loads(exported.stdout) == {"divisor": 9}
    image = mpc(job, "var", "image.json", *device)
    assert image.returncode == EXIT_OK, image.stderr
    assert image.stdout == "" and "an image JSON names none" in image.stderr


@pytest.mark.skipif(MBPOLL is None and os.environ.get("MPC_ALLOW_NO_MBPOLL") == "1",
                    reason="mbpoll is not installed (make tools installs it)")
def test_mbpoll_writes_and_reads_the_registers_the_csv_names(job: Path,
                                                             device: list[str]) -> None:
    assert MBPOLL is not None, "mbpoll is not installed: run make tools"
    register = int(csv_rows(job)["speed"]["register"])
    # mbpoll counts references from 1 (-0 would make them 0-based: it is not everywhere)
    if device[0] == "--tcp":
        host, port = device[1].rsplit(":", 1)
        where = ["-m", "tcp", "-p", port]
        target = host
    else:
        where = ["-m", "rtu", "-b", "115200", "-P", "none"]
        target = device[1]
    common = [MBPOLL, *where, "-a", "1", "-t", "4:int", "-B", "-r", str(register + 1), "-1"]
    wrote = subprocess.run([*common, target, "77777"], capture_output=True, text=True,
                           timeout=30)
    assert wrote.returncode == 0, wrote.stdout + wrote.stderr
    seen = mpc(job, "var", "speed", "job.mp", *device, "--json")
    assert json.loads(seen.stdout) == {"speed": 77777}, seen.stderr
    assert mpc(job, "var", "speed=-5", "job.mp", *device).returncode == EXIT_OK
    read = subprocess.run([*common, target], capture_output=True, text=True, timeout=30)
    assert read.returncode == 0, read.stdout + read.stderr
    assert f"[{register + 1}]: \t-5" in read.stdout


def test_another_build_is_refused_with_exit_16_before_anything_is_written(
        job: Path, device: list[str]) -> None:
    rows = csv_rows(job)
    register = int(rows["parts"]["register"])
    assert mpc(job, "var", "parts=11", "job.mp", *device).returncode == EXIT_OK
    before = raw_read(device, register, 2)
    ours = json.loads(mpc(job, "export", "job.mp").stdout)["build_id"]
    theirs = json.loads(mpc(job, "export", "other.mp").stdout)["build_id"]
    for args in (["var", "parts=99", "other.mp"],
                 ["call", "tour", "other.mp", "--set", "parts=99", "--wait"]):
        done = mpc(job, *args, *device)
        assert done.returncode == EXIT_OUT_OF_SYNC, done.stderr
        assert f"holds build {ours}" in done.stderr and f"expects build {theirs}" in done.stderr
        assert raw_read(device, register, 2) == before  # nothing was written
        assert raw_read(device, 8, 1) == [0]  # nothing was called
    forced = mpc(job, "var", "parts=99", "other.mp", *device, "--no-check")
    assert forced.returncode == EXIT_OK, forced.stderr
    assert raw_read(device, register, 2) == [0, 99]


def test_unknown_names_are_usage_errors_that_list_the_declared_ones(
        job: Path, device: list[str]) -> None:
    done = mpc(job, "var", "sped=1", "job.mp", *device)
    assert done.returncode == EXIT_USAGE
    assert "no declared variable 'sped'" in done.stderr and "speed" in done.stderr
    parts = int(csv_rows(job)["parts"]["register"])
    before = raw_read(device, parts, 2)
    big = mpc(job, "var", "parts=1", "speed=2147483648", "job.mp", *device)
    assert big.returncode == EXIT_USAGE
    assert raw_read(device, parts, 2) == before != [0, 1]  # checked before any write
    assert "speed (VAR400) is int32: -2147483648..2147483647, not 2147483648" in big.stderr
    call = mpc(job, "call", "nosuch", "job.mp", *device, "--set", "parts=1")
    assert call.returncode == EXIT_USAGE
    assert "MP100 tour" in call.stderr


def test_wait_past_timeout_exits_20_and_a_running_program_refuses_a_call(
        job: Path, device: list[str]) -> None:
    """The last test on each device: the program it starts runs for a minute."""
    done = mpc(job, "call", "dwell", "job.mp", *device, "--wait", "--timeout", "0.2")
    assert done.returncode == EXIT_WAIT_TIMEOUT, done.stderr
    assert "still runs after 0.2 s" in done.stderr
    busy = mpc(job, "call", "tour", "job.mp", *device)
    assert busy.returncode == EXIT_REJECTED, busy.stderr
    assert "MP102 is running" in busy.stderr
    assert raw_read(device, 8, 1) == [102]  # the device says the same


def test_a_device_that_is_not_there_is_exit_7(job: Path) -> None:
    done = mpc(job, "var", "job.mp", "--tcp", "127.0.0.1:1")
    assert done.returncode == EXIT_NO_DEVICE
    assert done.stderr.startswith("mpc: error: cannot connect to 127.0.0.1:1")
    bad = mpc(job, "var", "job.mp", "--tcp", "127.0.0.1:1", "--identity", "MD5-MD2")
    assert bad.returncode == EXIT_USAGE and "MD5 comes after MD2" in bad.stderr


def test_a_fatek_build_is_refused_with_the_reason(job: Path) -> None:
    for args in (["call", "tour"], ["var"]):
        done = mpc(job, *args, "job.mp", "--target", "fbs-fun140", "--tcp", "127.0.0.1:1")
        assert done.returncode == EXIT_USAGE, done.stderr
        assert "FB documents no way to download the table" in done.stderr
    export = mpc(job, "export", "job.mp", "--target", "fbs-fun140")
    assert export.returncode == EXIT_USAGE and "FATEK" in export.stderr

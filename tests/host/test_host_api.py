"""`mplang.host` against `mpc sim` in a subprocess, over Modbus TCP and over RTU on a pty:
the sync and async controllers, the build check before anything is written, programs by
name, variables by name, axes, execution errors at their source line, and timeouts."""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from monitorproc import stop
from simproc import raw_holding, start_rtu_sim, start_sim

import mplang.host
from mplang.cli.common import EXIT_OK

CELL = Path(__file__).resolve().parents[2] / "samples" / "host"
OTHER = (CELL / "cell.mp").read_text().replace("FIXED_MOVE X, 1000", "FIXED_MOVE X, 1001")


def mpc(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=60, cwd=cwd)


@pytest.fixture(scope="module", params=["tcp", "rtu"])
def where(request: pytest.FixtureRequest) -> Iterator[dict[str, str]]:
    """A virtual controller holding the cell's build: `connect`'s device argument."""
    if request.param == "tcp":
        proc, port = start_sim("--duration", "300")
        device, option = {"tcp": f"127.0.0.1:{port}"}, ["--tcp", f"127.0.0.1:{port}"]
    else:
        proc, pty = start_rtu_sim("--duration", "300")
        device, option = {"serial": pty}, ["--serial", pty]
    try:
        flashed = mpc(CELL, "flash", *option)
        assert flashed.returncode == EXIT_OK, flashed.stderr
        yield device
    finally:
        stop(proc)


def test_vars_call_axes_and_an_execution_error(where: dict[str, str]) -> None:
    with mplang.host.connect(**where, project=CELL / "mpc.toml") as cell:
        assert cell.build_id == json.loads(mpc(CELL, "export").stdout)["build_id"]
        assert list(cell.vars) == ["speed", "batch", "parts", "rate"]
        assert not cell.running
        cell.vars["speed"] = 4000
        cell.vars["batch"] = 2
        cell.vars["parts"] = 10
        assert (cell.vars["speed"], cell.vars["parts"]) == (4000, 10)
        start = cell.axes["X"].position
        done = cell.call("tour", timeout=60)
        assert done.vars == {"batch": 0, "parts": 12} and done.error is None
        assert done.program.device_name == "MP100"
        x = cell.axes["x"]
        assert (x.position - start, x.state) == (2000, "stopped")
        with pytest.raises(mplang.host.ExecutionError) as failed:
            cell.call("MP101")
        err = failed.value
        assert (err.line, err.code, err.device_code) == (18, "R103", 3)
        assert Path(err.file or "").name == "cell.mp" and err.slot == "MP101 rate"
        assert [e.line for e in cell.errors] == [18]
        with pytest.raises(mplang.host.BadValue, match=r"batch \(VAR401\) is int32"):
            cell.vars["batch"] = 2**31
        with pytest.raises(mplang.host.UnknownName, match="declared: speed, batch"):
            cell.vars["sped"] = 1
        with pytest.raises(mplang.host.UnknownName, match="MP100 tour"):
            cell.call("nosuch")


def test_wait_and_timeout(where: dict[str, str]) -> None:
    with mplang.host.connect(**where, sources=[CELL / "cell.mp"]) as cell:
        cell.vars["speed"] = 4000
        cell.vars["batch"] = 6
        with pytest.raises(mplang.host.WaitTimeout) as late:
            cell.call("tour", timeout=0.05)
        assert isinstance(late.value, TimeoutError)
        assert cell.running
        with pytest.raises(mplang.host.ProgramRunning, match="MP100 is running"):
            cell.call("rate")
        cell.wait(timeout=60)
        assert not cell.running and cell.vars["batch"] == 0


def test_another_build_is_refused_before_anything_is_written(where: dict[str, str],
                                                             tmp_path: Path) -> None:
    (tmp_path / "cell.mp").write_text(OTHER)
    with mplang.host.connect(**where, project=CELL / "mpc.toml") as cell:
        cell.vars["parts"] = 5
        register = cell.view.variable("parts").register
    before = raw_holding(where, register, 2)
    with pytest.raises(mplang.host.BuildMismatch) as refused, \
            mplang.host.connect(**where, sources=[tmp_path / "cell.mp"]) as other:
        other.vars["parts"] = 99
    assert refused.value.expected != refused.value.device_build
    assert f"holds build {refused.value.device_build}" in str(refused.value)
    assert raw_holding(where, register, 2) == before == [0, 5]
    assert raw_holding(where, 8, 1) == [0]
    with mplang.host.connect(**where, sources=[tmp_path / "cell.mp"], check=False) as other:
        other.vars["parts"] = 99
    assert raw_holding(where, register, 2) == [0, 99]


def test_async_controller_and_an_exported_view(where: dict[str, str], tmp_path: Path) -> None:
    exported = mpc(CELL, "export", "-o", str(tmp_path / "cell.json"))
    assert exported.returncode == EXIT_OK, exported.stderr

    async def session() -> tuple[dict[str, int], int]:
        async with mplang.host.connect_async(**where, image=tmp_path / "cell.json") as cell:
            await asyncio.gather(cell.write_var("batch", 1), cell.write_var("speed", 8000))
            both = await asyncio.gather(cell.read_var("batch"), cell.read_vars(["speed"]))
            assert both == [1, {"speed": 8000}]  # one request at a time on the link
            done = await cell.call("tour", timeout=60)
            axes = await cell.axes()
            return done.vars, axes["X"].position

    written, position = asyncio.run(session())
    assert written == {"batch": 0, "parts": written["parts"]}
    assert isinstance(position, int)


def test_arguments_are_checked_before_any_connection() -> None:
    for device in ({}, {"tcp": ""}, {"tcp": "127.0.0.1:1", "serial": "/dev/null"}):
        with pytest.raises(ValueError, match="give one device"):
            mplang.host.connect(**device, sources=["x.mp"])
    with pytest.raises(ValueError, match="give the build one way"):
        mplang.host.connect(tcp="127.0.0.1:1", sources=["x.mp"], image="x.json")
    with pytest.raises(mplang.host.HostLinkError) as nobody, \
            mplang.host.connect(tcp="127.0.0.1:1", project=CELL / "mpc.toml"):
        pass
    assert not nobody.value.reached

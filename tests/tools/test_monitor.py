"""`mpc monitor` and `mpc sim --monitor` (issue 17, item 4) against `mpc sim` in a subprocess:
the dashboard reads the virtual controller over loopback Modbus TCP (and RTU on a pty pair)
as it would a real one (RS-M8194H manual 12.1 input registers, 12.3 holding registers), and
the tests talk to the dashboard over real HTTP and WebSocket.
"""

from __future__ import annotations

import asyncio
import socket
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import aiohttp
from monitorproc import (
    DIVIDE_LINE,
    JOB,
    SQUARE_LINE,
    get,
    mpc,
    post,
    session_token,
    start_monitor,
    state_until,
    stop,
)
from simproc import start_sim

from mplang.cli.common import EXIT_OK, EXIT_TRANSPORT, EXIT_USAGE


def folder(path: Path) -> Path:
    path.mkdir(parents=True, exist_ok=True)
    (path / "job.mp").write_text(JOB)
    return path


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_manual_12_1_api_state_over_http_read_only(tmp_path: Path) -> None:
    """GET /api/state: identity, state, axes with lamps, FRnet DI, variables by declared
    name, programs at their source lines; without --allow-write every write is 403 and the
    page is told to hide its buttons."""
    work = folder(tmp_path / "w")
    sim, port = start_sim("--duration", "120")
    try:
        flashed = mpc(work, "flash", "job.mp", "--tcp", f"127.0.0.1:{port}")
        assert flashed.returncode == EXIT_OK, flashed.stderr
        monitor, url = start_monitor(work, "--tcp", f"127.0.0.1:{port}", "job.mp")
        try:
            state = state_until(url, lambda s: s["connected"])
            assert state["error"] is None and state["write"] is False
            assert state["identity"]["module_id"] == 0x44 and state["word_order"] == 0
            assert state["state"]["name"] == "ready" and state["emergency"] is False
            assert [a["axis"] for a in state["axes"]] == ["X", "Y", "Z", "U"]
            x = state["axes"][0]
            assert {"lp", "ep", "cv", "state", "error_code", "lamps"} <= set(x)
            assert set(x["lamps"]) >= {"limit_plus", "limit_minus", "near_home", "home",
                                       "index", "alarm", "emg"}
            assert len(state["frnet_di"]) == 8
            assert {(v["name"], v["var"]) for v in state["variables"]} == {
                ("laps", 400), ("target", 20)}
            assert state["programs"] == [
                {"slot": "MP41", "name": "square", "source": f"job.mp:{SQUARE_LINE}"},
                {"slot": "MP42", "name": "divide", "source": f"job.mp:{DIVIDE_LINE - 1}"}]
            assert state["running"] == {"mp": 0, "top": 0, "program": None, "source": None}
            assert state["execution_error"]["error"] == 0
            status, page = get(url)
            assert status == 200 and "<canvas id=\"xy\"" in page
            status, script = get(url + "assets/monitor.js")
            assert status == 200 and "WebSocket" in script
            assert get(url + "assets/nothing.js")[0] == 404
            rebound = urllib.request.Request(url + "api/state",
                                             headers={"Host": "evil.example"})
            try:
                urllib.request.urlopen(rebound, timeout=10)
                raise AssertionError("a request for another host name was answered")
            except urllib.error.HTTPError as err:
                assert err.code == 421 and "evil.example" in err.read().decode()
            assert get(url.replace("127.0.0.1", "localhost") + "api/state")[0] == 200
            for endpoint, body in (("call", {"program": "square"}), ("stop", {}),
                                   ("var", {"name": "laps", "value": 3}),
                                   ("emergency-stop", {}), ("clear-emergency", {})):
                status, answer = post(url + "api/" + endpoint, body)
                assert status == 403 and "--allow-write" in answer["error"]
            after = state_until(url, lambda s: s["seq"] > state["seq"])
            assert after["running"]["mp"] == 0 and after["variables"][0]["value"] == 0
        finally:
            stop(monitor)
    finally:
        stop(sim)


def test_manual_12_3_writes_with_allow_write(tmp_path: Path) -> None:
    """With --allow-write: set a VAR by name (holding 300 + 2n), call an MP by name
    (holding 8), stop it (MP_TERMINATE and STOP_SLOWLY), emergency stop and clear it."""
    work = folder(tmp_path / "w")
    sim, port = start_sim("--duration", "120")
    try:
        assert mpc(work, "flash", "job.mp", "--tcp", f"127.0.0.1:{port}").returncode == 0
        monitor, url = start_monitor(work, "--tcp", f"127.0.0.1:{port}", "job.mp",
                                     "--allow-write")
        try:
            assert state_until(url, lambda s: s["connected"])["write"] is True
            token = session_token(url)
            status, answer = post(url + "api/var", {"name": "target", "value": "-1234"},
                                  token=token)
            assert status == 200 and answer["done"] == "target (VAR20) = -1234"
            state_until(url, lambda s: {v["name"]: v["value"] for v in s["variables"]}
                        ["target"] == -1234)
            status, answer = post(url + "api/call", {"program": "square"}, token=token)
            assert status == 200 and "MP41 square" in answer["done"]
            running = state_until(url, lambda s: s["running"]["mp"] == 41)
            assert running["running"]["program"] == "MP41 square"
            assert running["running"]["source"] == f"job.mp:{SQUARE_LINE}"
            state_until(url, lambda s: s["axes"][0]["lp"] > 0)
            status, answer = post(url + "api/stop", {}, token=token)
            assert status == 200 and "MP_TERMINATE" in answer["done"]
            stopped = state_until(url, lambda s: s["running"]["mp"] == 0
                                  and all(a["state"] == "stopped" for a in s["axes"]))
            assert stopped["axes"][0]["lp"] < 4000  # stopped before the end of its move
            assert post(url + "api/emergency-stop", {}, token=token)[0] == 200
            state_until(url, lambda s: s["emergency"] is True)
            assert post(url + "api/clear-emergency", {}, token=token)[0] == 200
            state_until(url, lambda s: s["emergency"] is False)
            bad = post(url + "api/var", {"name": "nosuch", "value": 1}, token=token)
            assert bad[0] == 400 and "no variable 'nosuch'" in bad[1]["error"]
            big = post(url + "api/var", {"name": "laps", "value": 1 << 40}, token=token)
            assert big[0] == 400 and "32-bit" in big[1]["error"]
            missing = post(url + "api/call", {"program": "MP999"}, token=token)
            assert missing[0] == 400 and "no MP 'MP999'" in missing[1]["error"]
            assert post(url + "api/stop", "stop", "text/plain", token=token)[0] == 415
            deep = post(url + "api/var", "[" * 100_000, token=token)  # past any decoder
            assert deep[0] == 400 and "not JSON" in deep[1]["error"]
            huge = post(url + "api/var", '{"name": "laps", "value": 1}' + " " * (2 << 20),
                        token=token)
            assert huge[0] == 413  # aiohttp's body limit, 1 MiB
            assert post(url + "api/var", {"name": "target", "value": 0}, token=token)[0] == 200
            state_until(url, lambda s: s["variables"][0]["value"] == 0)
            assert post(url + "api/call", {"program": "MP42"}, token=token)[0] == 200
            failed = state_until(url, lambda s: s["execution_error"]["error"] != 0)
            error = failed["execution_error"]
            assert (error["mp"], error["error"]) == (42, 0x03)
            assert error["text"] == "division by zero in VAR_CALCULATE"
            assert error["source"] == f"job.mp:{DIVIDE_LINE}"
        finally:
            stop(monitor)
    finally:
        stop(sim)


def test_updates_at_least_ten_a_second_over_websocket(tmp_path: Path) -> None:
    """The WebSocket sends one message per poll: at least 10 arrive in one second."""
    work = folder(tmp_path / "w")
    sim, port = start_sim("--duration", "120")
    try:
        monitor, url = start_monitor(work, "--tcp", f"127.0.0.1:{port}")
        try:
            state_until(url, lambda s: s["connected"])

            async def count() -> tuple[int, list[int]]:
                """Messages (distinct polls) in each of up to three one-second windows:
                the machine is shared, so one slow second does not decide."""
                async with aiohttp.ClientSession() as session, \
                        session.ws_connect(url.replace("http", "ws") + "ws") as ws:
                    first = await ws.receive_json()
                    loop = asyncio.get_running_loop()
                    counts: list[int] = []
                    while len(counts) < 3 and not any(n >= 10 for n in counts):
                        end = loop.time() + 1.0
                        seqs = set()
                        while loop.time() < end:
                            message = await ws.receive_json()
                            seqs.add(message["state"]["seq"])
                        counts.append(len(seqs))
                    return first["path_from"], counts

            path_from, counts = asyncio.run(count())
            assert path_from == 0 and max(counts) >= 10, counts
        finally:
            stop(monitor)
    finally:
        stop(sim)


def test_unreachable_device_shown_then_reconnected(tmp_path: Path) -> None:
    """No device at the address: the dashboard serves all the same and says so; once a
    device answers there, it reads it."""
    work = folder(tmp_path / "w")
    port = free_port()
    monitor, url = start_monitor(work, "--tcp", f"127.0.0.1:{port}")
    try:
        state = state_until(url, lambda s: s["error"] != "connecting")
        assert state["connected"] is False
        assert state["error"].startswith("device unreachable: ")
        assert f"127.0.0.1:{port}" in state["error"] and "reconnecting" in state["error"]
        sim, _ = start_sim("--tcp", f"127.0.0.1:{port}", "--duration", "60")
        try:
            back = state_until(url, lambda s: s["connected"])
            assert back["error"] is None and back["identity"]["module_id"] == 0x44
        finally:
            stop(sim)
        gone = state_until(url, lambda s: not s["connected"])
        assert "device unreachable" in gone["error"] and gone["axes"]  # the last state stays
    finally:
        stop(monitor)
    assert monitor.stdout is not None and "Traceback" not in monitor.stdout.read()


def test_port_in_use_is_a_clear_error(tmp_path: Path) -> None:
    work = folder(tmp_path / "w")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = mpc(work, "monitor", "--tcp", "127.0.0.1:1", "--port", str(port))
        assert result.returncode == EXIT_TRANSPORT
        assert f"cannot serve the dashboard on 127.0.0.1:{port}: the port is in use" \
            in result.stderr
        sim = mpc(work, "sim", "--tcp", "127.0.0.1:0", "--duration", "5", "--monitor",
                  str(port))
        assert sim.returncode == EXIT_TRANSPORT and "the port is in use" in sim.stderr
    assert "Traceback" not in result.stderr + sim.stderr


def test_other_bind_address_warns_and_bad_requests_are_usage_errors(tmp_path: Path) -> None:
    work = folder(tmp_path / "w")
    monitor = subprocess.run([sys.executable, "-m", "mplang", "monitor", "--tcp",
                              "127.0.0.1:1", "--port", "0", "--bind", "0.0.0.0",
                              "--duration", "0.3"], capture_output=True, text=True,
                             timeout=60, cwd=work)
    assert monitor.returncode == EXIT_OK, monitor.stderr
    assert "warning: listening on 0.0.0.0: other machines can reach the dashboard" \
        in monitor.stderr
    assert "dashboard on http://0.0.0.0:" in monitor.stdout
    nothing = mpc(work, "monitor")
    assert nothing.returncode == EXIT_USAGE and "give the device" in nothing.stderr
    csim = mpc(work, "monitor", "--serial", str(tmp_path / "tty"), "--target", "csim")
    assert csim.returncode == EXIT_USAGE and "no live view of a CSIM device" in csim.stderr
    fatek = mpc(work, "monitor", "--tcp", "127.0.0.1:1", "--target", "fbs-fun140")
    assert fatek.returncode == EXIT_USAGE
    assert "no live view of a FATEK" in fatek.stderr
    sim_csim = mpc(work, "sim", "--target", "csim", "--serial", "pty", "--monitor")
    assert sim_csim.returncode == EXIT_USAGE and "no live view of a CSIM" in sim_csim.stderr


def test_sim_monitor_serves_the_dashboard_of_its_device(tmp_path: Path) -> None:
    """`mpc sim FILE --monitor 0`: the dashboard of the virtual controller it serves, with
    the preloaded build's names and its writes."""
    work = folder(tmp_path / "w")
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "sim", "--tcp", "127.0.0.1:0",
                             "job.mp", "--duration", "60", "--monitor", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            cwd=work)
    try:
        assert proc.stdout is not None
        url = ""
        for line in proc.stdout:
            if "dashboard on " in line:
                url = line.split("dashboard on ", 1)[1].strip()
                break
        assert url.startswith("http://127.0.0.1:"), url
        state = state_until(url, lambda s: s["connected"])
        assert state["write"] is True and state["programs"][0]["name"] == "square"
        token = session_token(url)
        assert post(url + "api/call", {"program": "square"}, token=token)[0] == 200
        moved = state_until(url, lambda s: s["path_points"] > 2)
        assert moved["running"]["program"] == "MP41 square"
    finally:
        stop(proc)


def test_manual_12_1_monitor_over_modbus_rtu(tmp_path: Path) -> None:
    """The RS-M8194H: the same dashboard over a pty pair (`mpc sim --serial pty`)."""
    work = folder(tmp_path / "w")
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "sim", "--serial", "pty",
                             "--unit", "3", "job.mp", "--duration", "60"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            cwd=work)
    try:
        assert proc.stdout is not None
        line = ""
        for line in proc.stdout:
            if "Modbus RTU on " in line:
                break
        port = line.split("Modbus RTU on ", 1)[1].split()[0]
        monitor, url = start_monitor(work, "--serial", port, "--unit", "3", "job.mp",
                                     "--allow-write")
        try:
            state = state_until(url, lambda s: s["connected"])
            assert port in state["device"] and state["identity"]["module_id"] == 0x44
            token = session_token(url)
            assert post(url + "api/var", {"name": "laps", "value": 7}, token=token)[0] == 200
            state_until(url, lambda s: s["variables"][1]["value"] == 7)
        finally:
            stop(monitor)
    finally:
        stop(proc)


def test_monitor_to_a_project_target_names_its_variables(tmp_path: Path) -> None:
    """`mpc monitor --to NAME` in a project: the device of `[targets.NAME]`, the names of
    the project's sources."""
    work = folder(tmp_path / "w")
    sim, port = start_sim("--duration", "60")
    try:
        (work / "mpc.toml").write_text(f'[project]\nsources = ["job.mp"]\n\n[targets.cell]\n'
                                       f'tcp = "127.0.0.1:{port}"\n')
        monitor, url = start_monitor(work, "--to", "cell")
        try:
            state = state_until(url, lambda s: s["connected"])
            assert state["title"] == "cell" and f"127.0.0.1:{port}" in state["device"]
            assert [v["name"] for v in state["variables"]] == ["target", "laps"]
        finally:
            stop(monitor)
        unknown = mpc(work, "monitor", "--to", "nosuch")
        assert unknown.returncode == EXIT_USAGE and "no [targets.nosuch]" in unknown.stderr
    finally:
        stop(sim)

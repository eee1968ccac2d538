"""Start `mpc monitor` (and `mpc sim` with a program flashed) as subprocesses, and talk to the
dashboard over real HTTP on loopback (shared by the monitor tests)."""

from __future__ import annotations

import json
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

JOB = """VAR laps
VAR target @ VAR20

MP 41 square
    SET_V X, 4000
    SET_V Y, 4000
    SET_V Z, 4000
    FIXED_MOVE X, 4000
    STOP_WAIT X
    FIXED_MOVE Y, 4000
    STOP_WAIT Y
    FIXED_MOVE Z, 2000
    STOP_WAIT Z
    FIXED_MOVE X, -4000
    STOP_WAIT X
    FIXED_MOVE Y, -4000
    STOP_WAIT Y
    laps = laps + 1
END MP

MP 42 divide
    laps = laps / target
END MP
"""
SQUARE_LINE = 4  # where `MP 41 square` is declared in JOB
DIVIDE_LINE = 22  # `laps = laps / target`: division by zero while target is 0


def mpc(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=60, cwd=cwd)


def start_monitor(cwd: Path, *args: str, stderr: IO[str] | None = None,
                  open_files: int | None = None) -> tuple[subprocess.Popen[str], str]:
    """`mpc monitor --port 0 ARGS...`; the process and the dashboard's URL it prints.
    Standard error goes to `stderr` when given (else with standard output); `open_files`
    lowers the process's open-file limit (RLIMIT_NOFILE, soft) before it starts."""
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "monitor", "--port", "0", *args],
                            stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT if stderr is None else stderr, text=True,
                            cwd=cwd, preexec_fn=None if open_files is None else
                            (lambda: limit_open_files(open_files)))
    return proc, dashboard_url(proc, "mpc monitor")


def start_sim_monitor(cwd: Path, *args: str) -> tuple[subprocess.Popen[str], str]:
    """`mpc sim --tcp 127.0.0.1:0 ARGS... --monitor 0`: the process and its dashboard's
    URL."""
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "sim", "--tcp", "127.0.0.1:0",
                             *args, "--monitor", "0"], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, cwd=cwd)
    return proc, dashboard_url(proc, "mpc sim --monitor")


def dashboard_url(proc: subprocess.Popen[str], command: str) -> str:
    """The URL a starting dashboard prints; a failure names `command` and what it printed."""
    assert proc.stdout is not None
    seen = []
    for line in proc.stdout:
        seen.append(line)
        if "dashboard on " in line:
            return line.split("dashboard on ", 1)[1].split()[0]
    proc.wait(10)
    raise AssertionError(f"{command} did not start (exit {proc.returncode}): {seen}")


def limit_open_files(soft: int, pid: int = 0) -> None:
    """Lower the soft open-file limit of process `pid` (0: this one), as `ulimit -n` does."""
    import resource

    hard = resource.prlimit(pid, resource.RLIMIT_NOFILE)[1]
    resource.prlimit(pid, resource.RLIMIT_NOFILE, (soft, hard))


def get(url: str) -> tuple[int, Any]:
    """GET; the status and the JSON (or text) answer."""
    try:
        with urllib.request.urlopen(url, timeout=10) as answer:
            body = answer.read().decode()
            kind = answer.headers.get_content_type()
            return answer.status, json.loads(body) if kind == "application/json" else body
    except urllib.error.HTTPError as err:
        body = err.read().decode()
        return err.code, json.loads(body) if err.headers.get_content_type() == \
            "application/json" else body


def session_token(url: str) -> str:
    """The dashboard's write token, as a script gets it (GET /api/session)."""
    status, answer = get(url + "api/session")
    assert status == 200, answer
    return str(answer["token"])


def post(url: str, body: object, content_type: str = "application/json",
         token: str | None = None, headers: dict[str, str] | None = None) -> tuple[int, Any]:
    """POST with the session's `token` (none: a write without it) and any other headers;
    the status and the JSON (or text) answer."""
    data = body.encode() if isinstance(body, str) else json.dumps(body).encode()
    sent = {"Content-Type": content_type, **(headers or {})}
    if token is not None:
        sent["X-MPC-Token"] = token
    request = urllib.request.Request(url, data=data, method="POST", headers=sent)
    try:
        with urllib.request.urlopen(request, timeout=10) as answer:
            return answer.status, json.loads(answer.read().decode())
    except urllib.error.HTTPError as err:
        body = err.read().decode()
        return err.code, json.loads(body) if err.headers.get_content_type() == \
            "application/json" else body


def state_until(url: str, wanted: Callable[[dict[str, Any]], bool],
                attempts: int = 1500) -> dict[str, Any]:
    """GET /api/state until `wanted(state)` holds, pausing a poll period between answers;
    the state (AssertionError after `attempts` answers: nothing here measures time)."""
    state: dict[str, Any] = {}
    for _ in range(attempts):
        _status, state = get(url + "api/state")
        if wanted(state):
            return state
        time.sleep(0.02)
    raise AssertionError(f"the state never matched: {state}")


def stop(proc: subprocess.Popen[str]) -> None:
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(10)

"""Every mpc command as a subprocess on a Windows-like Python (tests/data/windowslike:
mplang's imports of POSIX-only modules fail, asyncio loops have no add_signal_handler), so
that what would break on Windows breaks here: no Windows machine runs these tests yet."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

from monitorproc import JOB, get

from mplang.cli.common import EXIT_OK, EXIT_TRANSPORT

WINDOWS_LIKE = Path(__file__).parent / "data" / "windowslike"
WAIT_S = 60  # a bound on a process that hangs: a failure instead of a blocked suite


def windows_like_env() -> dict[str, str]:
    """This process's environment with the Windows-like sitecustomize first on the path."""
    path = [str(WINDOWS_LIKE), *filter(None, [os.environ.get("PYTHONPATH")])]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(path)}


def mpc(cwd: Path, *args: str, stdin: bytes | None = None
        ) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], cwd=cwd, input=stdin,
                          capture_output=True, timeout=WAIT_S, env=windows_like_env())


def start(cwd: Path, *args: str) -> subprocess.Popen[str]:
    """A long-running command; on Windows in a process group of its own, so that it can be
    sent Ctrl-Break (Windows sends no SIGINT to another process)."""
    flags = 0
    if sys.platform == "win32":
        flags = subprocess.CREATE_NEW_PROCESS_GROUP
    return subprocess.Popen([sys.executable, "-m", "mplang", *args], cwd=cwd, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            env=windows_like_env(), creationflags=flags)


def first_line_with(proc: subprocess.Popen[str], text: str) -> str:
    """The process's first output line holding `text` (AssertionError if it ends first)."""
    assert proc.stdout is not None
    seen = []
    for line in proc.stdout:
        seen.append(line)
        if text in line:
            return line
    proc.wait(WAIT_S)
    raise AssertionError(f"no {text!r} (exit {proc.returncode}): {''.join(seen)}")


def stopped(proc: subprocess.Popen[str], sig: signal.Signals) -> tuple[int, str]:
    """Send `sig` (Ctrl-C is SIGINT; on Windows Ctrl-Break stands for both); the exit code
    and the rest of the output."""
    if sys.platform == "win32":
        proc.send_signal(signal.CTRL_BREAK_EVENT)
    else:
        proc.send_signal(sig)
    try:
        rest, _ = proc.communicate(timeout=WAIT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, rest


def test_the_windows_like_python_lacks_what_windows_lacks(tmp_path: Path) -> None:
    """The premise: in the subprocesses below, mplang's code cannot import pty and an event
    loop refuses signal handlers, while other packages (pyserial) import as before."""
    probe = tmp_path / "probe.py"
    probe.write_text(
        "import asyncio, serial\n"
        "try:\n"
        "    exec('import termios', {'__name__': 'mplang.probe'})\n"
        "except ModuleNotFoundError as exc:\n"
        "    print('refused', exc.name)\n"
        "try:\n"
        "    asyncio.new_event_loop().add_signal_handler(2, print)\n"
        "except NotImplementedError:\n"
        "    print('no signal handlers')\n")
    done = subprocess.run([sys.executable, str(probe)], capture_output=True, text=True,
                          timeout=WAIT_S, env=windows_like_env())
    assert done.stdout == "refused termios\nno signal handlers\n", done.stderr


def test_every_mplang_module_imports_without_posix_only_modules(tmp_path: Path) -> None:
    """No module of the package imports pty, tty, termios, fcntl, resource, grp or pwd at
    its top: each one is imported, none fails."""
    script = ("import importlib, pkgutil, mplang\n"
              "names = [m.name for m in pkgutil.walk_packages(mplang.__path__, 'mplang.')\n"
              "         if m.name != 'mplang.__main__']\n"
              "for name in names:\n"
              "    importlib.import_module(name)\n"
              "print(len(names))\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=WAIT_S, env=windows_like_env(), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert int(done.stdout) > 150


def test_the_commands_that_need_no_device(tmp_path: Path) -> None:
    (tmp_path / "job.mp").write_text(JOB)
    for args in (["build", "job.mp", "-o", "job.json"], ["lint", "job.mp"],
                 ["fmt", "--check", "job.mp"], ["disasm", "job.json"],
                 ["run", "job.mp", "--call", "square"], ["completion", "bash"],
                 ["plot", "job.mp", "--call", "square", "-o", "job.png"]):
        done = mpc(tmp_path, *args)
        assert done.returncode == EXIT_OK, (args, done.stderr)
        assert b"Traceback" not in done.stderr
    assert (tmp_path / "job.png").stat().st_size > 0
    c_program = Path(__file__).parent / "data" / "import" / "et_example5.c"
    done = mpc(tmp_path, "import", str(c_program))
    assert done.returncode == EXIT_OK, done.stderr
    assert b"END MP" in done.stdout


def test_sim_flash_status_monitor_and_ctrl_c(tmp_path: Path) -> None:
    """mpc sim starts and stops on Ctrl-C (SIGINT, through signal.signal since the loop takes
    no handler), mpc flash and mpc status talk to it, mpc monitor serves it and stops on
    SIGTERM."""
    (tmp_path / "job.mp").write_text(JOB)
    sim = start(tmp_path, "sim", "--tcp", "127.0.0.1:0")
    try:
        line = first_line_with(sim, "Modbus TCP on")
        device = line.split(" on ", 1)[1].split()[0]
        flashed = mpc(tmp_path, "flash", "job.mp", "--tcp", device, "--record", "r.json",
                      "--json")
        assert flashed.returncode == EXIT_OK, flashed.stderr
        assert json.loads(flashed.stdout)["programs"]
        status = mpc(tmp_path, "status", "--tcp", device, "job.mp", "--json")
        assert status.returncode == EXIT_OK, status.stderr
        assert {s["status"] for s in json.loads(status.stdout)["slots"]} == {"in sync"}
        monitor = start(tmp_path, "monitor", "--port", "0", "--tcp", device, "job.mp")
        try:
            url = first_line_with(monitor, "dashboard on ").split("dashboard on ")[1].split()[0]
            code, state = get(url + "api/state")
            assert code == 200 and isinstance(state, dict)
        finally:
            code, rest = stopped(monitor, signal.SIGTERM)
        assert code == EXIT_OK and "Traceback" not in rest, rest
    finally:
        code, rest = stopped(sim, signal.SIGINT)
    assert code == EXIT_OK, rest
    assert "mpc sim: stopped" in rest and "Traceback" not in rest


def test_sim_on_a_pty_pair_says_there_is_none_and_names_the_windows_way(tmp_path: Path
                                                                        ) -> None:
    done = mpc(tmp_path, "sim", "--serial", "pty", "--duration", "1")
    assert done.returncode == EXIT_TRANSPORT
    message = done.stderr.decode()
    assert "needs a POSIX system" in message and "com0com" in message
    assert "Traceback" not in message


def framed(message: dict[str, Any]) -> bytes:
    body = json.dumps(message).encode()
    return b"Content-Length: %d\r\n\r\n%s" % (len(body), body)


def replies(output: bytes) -> list[dict[str, Any]]:
    """The JSON messages of a Content-Length framed stream."""
    found = []
    while output:
        header, _, output = output.partition(b"\r\n\r\n")
        size = int(header.split(b"Content-Length:")[1].split(b"\r\n")[0])
        found.append(json.loads(output[:size]))
        output = output[size:]
    return found


def test_lsp_and_dap_over_stdio(tmp_path: Path) -> None:
    """The editors' servers start, answer `initialize` and end when asked."""
    lsp = mpc(tmp_path, "lsp", stdin=b"".join(framed(m) for m in (
        {"jsonrpc": "2.0", "id": 1, "method": "initialize",
         "params": {"processId": None, "rootUri": None, "capabilities": {}}},
        {"jsonrpc": "2.0", "method": "initialized", "params": {}},
        {"jsonrpc": "2.0", "id": 2, "method": "shutdown"},
        {"jsonrpc": "2.0", "method": "exit"})))
    assert lsp.returncode == EXIT_OK, lsp.stderr
    answers = {m["id"]: m for m in replies(lsp.stdout) if "id" in m}
    assert "capabilities" in answers[1]["result"] and answers[2]["result"] is None
    dap = mpc(tmp_path, "dap", stdin=b"".join(framed(m) for m in (
        {"seq": 1, "type": "request", "command": "initialize",
         "arguments": {"adapterID": "mpc", "linesStartAt1": True}},
        {"seq": 2, "type": "request", "command": "disconnect", "arguments": {}})))
    assert dap.returncode == EXIT_OK, dap.stderr
    answered = {m["command"]: m for m in replies(dap.stdout) if m["type"] == "response"}
    assert answered["initialize"]["success"] and answered["disconnect"]["success"]


def test_the_ci_workflow_covers_linux_windows_and_macos() -> None:
    """The workflow a public host runs: make test on Linux, the lint (mypy as on Windows too)
    and this file's tests on Windows and macOS."""
    workflow = (Path(__file__).parent.parent / ".github" / "workflows" / "ci.yml").read_text()
    assert "runs-on: ubuntu-latest" in workflow and "make test" in workflow
    assert "os: [windows-latest, macos-latest]" in workflow
    assert "mypy --platform win32" in workflow and "tests/test_windows_like.py" in workflow
    makefile = (Path(__file__).parent.parent / "Makefile").read_text()
    assert "$(BIN)/mypy --platform win32" in makefile


def test_output_survives_a_cp1252_pipe(tmp_path: Path) -> None:
    """Windows writes pipes in the ANSI code page: a source line quoted back with characters
    outside it comes out escaped, never as an internal error; JSON stays JSON."""
    (tmp_path / "axis.mp").write_bytes(
        "MP 1 a\r\n    FOO X  # Achse → 日本\r\nEND MP\r\n".encode())
    env = {**windows_like_env(), "PYTHONIOENCODING": "cp1252"}
    for args in (["lint", "axis.mp"], ["build", "axis.mp", "-o", "axis.json"],
                 ["lint", "axis.mp", "--format", "json"]):
        done = subprocess.run([sys.executable, "-m", "mplang", *args], cwd=tmp_path,
                              capture_output=True, timeout=WAIT_S, env=env)
        assert done.returncode == 1, (args, done.stderr)  # the unknown command FOO
        shown = (done.stdout + done.stderr).decode("cp1252")
        assert "internal error" not in shown and "Traceback" not in shown
        if "json" in args:
            (finding,) = json.loads(done.stdout)
            assert (finding["code"], finding["line"]) == ("E201", 2)
        else:
            assert "axis.mp:2:5: error[E201]" in shown
            assert "# Achse \\u2192 \\u65e5\\u672c" in shown  # the CRLF line, escaped

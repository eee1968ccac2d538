"""Issue 14 item 4: progress on long runs. On a terminal `mpc run` and `mpc plot` keep a
status line (simulated time, program and source line, wall time, Ctrl-C to stop) and erase
it at the end; in a pipe nothing is drawn. Ctrl-C ends the run with the state so far (exit
130); a default --max-time ends a run that never finishes (R202, exit 18).

The terminal is a real pseudo-terminal (`pty.openpty`) holding the command's standard
error; the command is a real `mpc` subprocess."""

from __future__ import annotations

import json
import os
import pty
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import main
from mplang.cli.runwatch import (
    CLEAR,
    DEFAULT_MAX_TIME_S,
    EXIT_OUT_OF_TIME,
    EXIT_SIGINT,
    RunWatch,
    parse_max_time,
)
from mplang.family.run_error import SourcePlace

LOOP = """ALIAS hits = VAR30
VAR rows_done @ VAR400

MP 1 spin
    hits = 0
    rows_done = 0
    LABEL top
    hits = hits + 1
    rows_done = rows_done + 1
    GOTO top
END MP
"""

WAITS = """MP 1 stuck
    SET_V X, 1000
    STOP_WAIT X
    FRNET_WAIT 8, 1, 1, 0
END MP
"""

DEADLINE_S = 60.0  # a guard against a hanging subprocess, never an assertion on speed


@pytest.fixture
def loop_file(tmp_path: Path) -> Path:
    path = tmp_path / "loop.mp"
    path.write_text(LOOP)
    return path


def read_until(fd: int, wanted: bytes, seen: bytearray) -> bool:
    """Read the pty into `seen` until `wanted` appears (or the guard deadline passes)."""
    end = time.monotonic() + DEADLINE_S
    while wanted not in seen and time.monotonic() < end:
        ready, _, _ = select.select([fd], [], [], 0.5)
        if ready:
            try:
                chunk = os.read(fd, 4096)
            except OSError:
                return wanted in seen
            if not chunk:
                break
            seen += chunk
    return wanted in seen


def drain(fd: int, proc: subprocess.Popen[str], seen: bytearray) -> None:
    """Everything the command still writes to the pty until it exits."""
    end = time.monotonic() + DEADLINE_S
    while time.monotonic() < end:
        ready, _, _ = select.select([fd], [], [], 0.2)
        if ready:
            try:
                chunk = os.read(fd, 4096)
            except OSError:
                break
            if not chunk:
                break
            seen += chunk
        elif proc.poll() is not None:
            break


def test_status_line_on_a_terminal_and_ctrl_c_reports_the_state_so_far(loop_file: Path
                                                                       ) -> None:
    master, slave = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "run", str(loop_file),
                             "--max-time", "none"], stdout=subprocess.PIPE,
                            stderr=slave, stdin=subprocess.DEVNULL, text=True)
    os.close(slave)
    seen = bytearray()
    try:
        assert read_until(master, b"Ctrl-C to stop", seen), bytes(seen[-300:])
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=DEADLINE_S)
        drain(master, proc, seen)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(master)
    err = seen.decode(errors="replace")
    status = err[err.index("mpc run: "):].split("\r")[0]
    assert " s simulated, " in status and " s wall | " in status
    assert "loop.mp:" in status and status.endswith(" | Ctrl-C to stop")
    assert proc.returncode == EXIT_SIGINT
    assert out.startswith("MP1: INTERRUPTED after ")
    assert "  hits (VAR30) = " in out and "  rows_done (VAR400) = " in out
    assert "note: interrupted (Ctrl-C) in MP1 spin after " in err
    assert "Traceback" not in err
    # the status line was erased before the note: the last redraw is followed by a clear
    last_status = err.rindex("Ctrl-C to stop")
    assert CLEAR in err[last_status:err.index("note: interrupted")]


def test_ctrl_c_json_marks_the_run_interrupted(loop_file: Path) -> None:
    master, slave = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "run", str(loop_file),
                             "--max-time", "0", "--json"], stdout=subprocess.PIPE,
                            stderr=slave, stdin=subprocess.DEVNULL, text=True)
    os.close(slave)
    seen = bytearray()
    try:
        assert read_until(master, b"Ctrl-C to stop", seen)
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=DEADLINE_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(master)
    summary = json.loads(out)
    assert proc.returncode == EXIT_SIGINT
    assert summary["error"] is None
    stop = summary["interrupted"]
    assert stop["program"] == "MP1 spin" and stop["file"].endswith("loop.mp")
    assert stop["line"] in (7, 8, 9, 10) and stop["time_ms"] == summary["time_ms"] > 0
    assert summary["vars"]["hits"] > 0


def test_no_status_line_in_a_pipe_and_the_default_max_time_ends_an_endless_loop(
        loop_file: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "mplang", "run", str(loop_file)],
                          capture_output=True, text=True, timeout=DEADLINE_S)
    assert proc.returncode == EXIT_OUT_OF_TIME
    assert "\r" not in proc.stderr and "\x1b" not in proc.stderr
    assert "Ctrl-C to stop" not in proc.stderr
    assert proc.stdout.startswith(f"MP1: FAILED after {DEFAULT_MAX_TIME_S * 1000:g}")
    lines = proc.stderr.splitlines()
    error = next(line for line in lines if "error[R202]" in line)
    assert "loop.mp:" in error and "in MP1 spin" in error
    assert any(f"--max-time {DEFAULT_MAX_TIME_S:g} s (the default)" in line
               and "--max-time none" in line for line in lines)


def test_an_explicit_max_time_is_named_without_the_default(loop_file: Path) -> None:
    result = CliRunner().invoke(main, ["run", str(loop_file), "--max-time", "0.5"])
    assert result.exit_code == EXIT_OUT_OF_TIME
    assert "--max-time 0.5 s of simulated time" in result.stderr
    assert "(the default)" not in result.stderr


def test_no_limit_still_ends_a_wait_for_ever(tmp_path: Path) -> None:
    path = tmp_path / "waits.mp"
    path.write_text(WAITS)
    for limit in ("none", "0"):
        result = CliRunner().invoke(main, ["run", str(path), "--max-time", limit, "--json"])
        summary = json.loads(result.stdout)
        assert result.exit_code == 5, result.stderr
        assert summary["error"]["code"] == "R201" and "interrupted" not in summary
        assert summary["time_ms"] < 1000


@pytest.mark.parametrize("text", ["-1", "soon", "nan"])
def test_bad_max_time_is_a_usage_error(loop_file: Path, text: str) -> None:
    result = CliRunner().invoke(main, ["run", str(loop_file), "--max-time", text])
    assert result.exit_code == 2 and "--max-time" in result.stderr


def test_max_time_forms() -> None:
    assert parse_max_time(None, None, "none") == float("inf")
    assert parse_max_time(None, None, "0") == float("inf")
    assert parse_max_time(None, None, "2.5") == 2.5


def test_plot_draws_the_status_line_on_a_terminal(loop_file: Path, tmp_path: Path) -> None:
    master, slave = pty.openpty()
    image = tmp_path / "loop.png"
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "plot", str(loop_file), "-o",
                             str(image), "--max-time", "none"], stdout=subprocess.PIPE,
                            stderr=slave, stdin=subprocess.DEVNULL, text=True)
    os.close(slave)
    seen = bytearray()
    try:
        assert read_until(master, b"Ctrl-C to stop", seen)
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=DEADLINE_S)
        drain(master, proc, seen)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(master)
    assert seen.decode(errors="replace").count("mpc plot: ") >= 1
    assert proc.returncode == EXIT_SIGINT and image.exists()
    assert "INTERRUPTED" in out


def test_the_watch_draws_only_on_a_terminal() -> None:
    import io

    place = SourcePlace("a.mp", 3, 5, "MP1 spin")
    for tty in (True, False):
        stream = io.StringIO()
        watch = RunWatch("mpc run", stream, tty=tty)
        watch.next_draw = 0.0
        assert watch(1.5, lambda: place) is False
        watch.clear()
        text = stream.getvalue()
        if tty:
            assert "1.500 s simulated, " in text and text.endswith(CLEAR)
            assert " | MP1 spin at a.mp:3 | Ctrl-C to stop" in text
        else:
            assert text == ""

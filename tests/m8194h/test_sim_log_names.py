"""`mpc sim -v` started with the sources logs in their words (issue 14 item 2): a program
slot with its name, a slot line with its source line, a declared variable by name with its
number. A real `mpc sim` subprocess is driven over Modbus TCP on loopback as a host would
(holding register 8: call MPn, ET/RS register map in docs/simulator.md)."""

from __future__ import annotations

import asyncio
import queue
import threading
import time
from pathlib import Path

from simproc import start_sim

from mplang.m8194h.compiler import compile_source
from mplang.m8194h.modbus import DeviceLink, Endpoint
from mplang.m8194h.simulate import LogNames

JOB = """ALIAS parts = VAR10
VAR rows_done @ VAR400

MP 100 job
    parts = 0
    rows_done = 10 / parts
END MP
"""

DEADLINE_S = 60.0  # a guard against a hanging subprocess, never an assertion on speed


VAR_BASE = 0x7FFF0000  # VARn as an operand (spec: 0x7FFF0000 + n)
WRITE_VAR = 0x0A25  # RSM_WRITE_VAR, a real-time command (RS 3.18.4)


def call_and_write(port: int, slot: int, variable: int, value: int) -> None:
    """Call MPn (holding register 8), then WRITE_VAR VARn = value (a frame at 8000)."""
    async def host() -> None:
        async with DeviceLink(Endpoint(host="127.0.0.1", port=port)) as link:
            await link.write_holding(8, [slot])
            operand = VAR_BASE + variable
            await link.write_frame([WRITE_VAR, operand >> 16, operand & 0xFFFF,
                                    value >> 16, value & 0xFFFF])

    asyncio.run(host())


def test_sim_log_names_the_program_its_source_line_and_variables(tmp_path: Path) -> None:
    source = tmp_path / "job.mp"
    source.write_text(JOB)
    proc, port = start_sim(str(source), "-v", "--duration", "60")
    lines: queue.Queue[str] = queue.Queue()
    assert proc.stdout is not None
    stdout = proc.stdout

    def pump() -> None:
        for line in stdout:
            lines.put(line.rstrip("\n"))

    threading.Thread(target=pump, daemon=True).start()
    seen: list[str] = []
    try:
        call_and_write(port, 100, 400, 7)
        end = time.monotonic() + DEADLINE_S
        while not any("WRITE_VAR" in line for line in seen) and time.monotonic() < end:
            try:
                seen.append(lines.get(timeout=0.5))
            except queue.Empty:
                continue
    finally:
        proc.terminate()
        proc.wait(DEADLINE_S)
        stdout.close()
    assert any(line.endswith(": MP100 job called") for line in seen), seen
    error = next(line for line in seen if "execution error" in line)
    assert "in MP100 job line 1 (" in error and f"{source}:6)" in error, error
    written = next(line for line in seen if "WRITE_VAR" in line)
    assert written.endswith("WRITE_VAR rows_done (VAR400) = 7"), written


def test_log_names_rewrite_programs_lines_and_variables() -> None:
    build = compile_source(JOB, "job.mp")
    names = LogNames(build)
    assert names("0.1000 s: MP100 called") == "0.1000 s: MP100 job called"
    assert names("execution error 0x03 in MP100 line 1") == \
        "execution error 0x03 in MP100 job line 1 (job.mp:6)"
    assert names("RSM_WRITE_VAR VAR400 = 3, VAR10 = 1, VAR7 = 2") == \
        "RSM_WRITE_VAR rows_done (VAR400) = 3, parts (VAR10) = 1, VAR7 = 2"
    assert names("ISR3 started, MP7 called") == "ISR3 started, MP7 called"  # not in the build

"""`mpc status` of a CSIM over its RS232 line (issue 17 item 6): the queries of CS 148-171
(?VER, ?ST, ?ERR, ?TM, ?PE, ?VM, ?IN n; ?MT, ?MD, ?ERC answered ERR by the virtual CSIM and
said so), and the program listed back with ULP (CS 119) and compared with the build. The
served CSIM is `mpc sim --target csim --serial pty` in a subprocess, and `mpc status` a
second one on the other end of the pty pair, as a host computer would be."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import serial  # type: ignore[import-untyped]

from mplang.cli.common import EXIT_NO_DEVICE, EXIT_OK, EXIT_OUT_OF_SYNC, EXIT_USAGE

PROGRAM = "MA 100\nDN\nOUT \"done\"\n"
LOOP = "$AGAIN\nOUT \"tick\"\nWT 20\nJP $AGAIN\n"


def mpc(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=60, cwd=cwd)


def test_cs_148_171_status_queries_and_the_listing_compared(served: str,
                                                            tmp_path: Path) -> None:
    (tmp_path / "p.csim").write_text(PROGRAM)
    (tmp_path / "q.csim").write_text(PROGRAM.replace("MA 100", "MA 200"))
    fresh = mpc(tmp_path, "status", "--serial", served, "p.csim", "--json")
    assert fresh.returncode == EXIT_OUT_OF_SYNC, fresh.stderr
    data = json.loads(fresh.stdout)
    assert data["slots"][0]["status"] == "missing" and data["in_sync"] is False
    queries = data["queries"]
    assert queries["version"]["value"] == "mplang virtual CSIM 1"
    assert queries["state"]["value"] == "IDLE" and queries["error"]["value"] == "0"
    assert queries["position"]["value"] == "0" and queries["speed"]["value"] == "1000"
    assert queries["mode"]["value"] is None and "ERR 7" in queries["mode"]["error"]
    assert [i["value"] for i in data["inputs"]] == ["0"] * 8
    assert data["manifest"] is None and data["not_readable"]

    assert mpc(tmp_path, "flash", "p.csim", "--serial", served).returncode == EXIT_OK
    same = mpc(tmp_path, "status", "--serial", served, "p.csim")
    assert same.returncode == EXIT_OK, same.stdout + same.stderr
    assert f"device      CSIM on {served} (115200 8N1)" in same.stdout
    assert "  in sync   p (p.csim): 3 line(s), identical" in same.stdout
    assert "version     mplang virtual CSIM 1  (?VER)" in same.stdout
    assert "mode        not answered (?MD: the device refused '?MD': ERR 7" in same.stdout
    other = mpc(tmp_path, "status", "--serial", served, "q.csim")
    assert other.returncode == EXIT_OUT_OF_SYNC
    assert "differs   q (q.csim): line 0: the device holds 'MA 100', the build has " \
        "'MA 200'" in other.stdout
    plain = mpc(tmp_path, "status", "--serial", served, "--target", "csim")
    assert plain.returncode == EXIT_OK and "3 line(s) listed back (ULP)" in plain.stdout


def test_cs_119_a_running_program_is_not_listed_but_queried(served: str,
                                                            tmp_path: Path) -> None:
    (tmp_path / "loop.csim").write_text(LOOP)
    assert mpc(tmp_path, "flash", "loop.csim", "--serial", served).returncode == EXIT_OK
    with serial.Serial(served, timeout=5.0) as host:  # G: run it (CS 76), then let go
        host.write(b"G\r")
        while not host.read_until(b"\r\n").startswith(b"OK"):
            pass
    running = mpc(tmp_path, "status", "--serial", served, "loop.csim", "--json")
    assert running.returncode == EXIT_OUT_OF_SYNC, running.stderr
    data = json.loads(running.stdout)
    assert data["queries"]["state"]["value"] in ("RUN", "WAIT")
    assert data["slots"][0]["status"] == "unknown"
    assert "ERR 4" in data["slots"][0]["detail"]


def test_status_of_a_csim_without_a_device_or_over_tcp(tmp_path: Path) -> None:
    (tmp_path / "p.csim").write_text(PROGRAM)
    gone = mpc(tmp_path, "status", "--serial", "/dev/does-not-exist", "p.csim")
    assert gone.returncode == EXIT_NO_DEVICE
    assert "cannot open serial port /dev/does-not-exist (CSIM RS232, 115200 8N1): no such " \
        "serial device" in gone.stderr
    tcp = mpc(tmp_path, "status", "--tcp", "127.0.0.1:9", "p.csim")
    assert tcp.returncode == EXIT_USAGE and "over its RS232 line" in tcp.stderr
    unit = mpc(tmp_path, "status", "--serial", "/dev/does-not-exist", "p.csim", "--unit", "3",
               "--no-identity")
    assert unit.returncode == EXIT_USAGE
    assert "--unit, --no-identity: M8194H option(s); a CSIM device has no such setting" \
        in unit.stderr

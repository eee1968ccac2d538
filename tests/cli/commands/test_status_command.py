"""`mpc status` and the build manifest `mpc flash` stores in machine data (RS-M8194H manual
3.19, MD at holding registers 3000 + 2n), against `mpc sim` in a subprocess over loopback
Modbus TCP, as a second computer would see the controller: from another folder with no flash
record, and after the virtual controller restarts on its memory file.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from pathlib import Path

from simproc import start_sim

from mplang.cli.commands.status import EXIT_OUT_OF_SYNC
from mplang.cli.common import EXIT_NO_DEVICE, EXIT_NO_INPUT, EXIT_OK, EXIT_USAGE

JOB = """VAR count
VAR limit @ VAR20

MP 3 first
    SET_V X, 1000
    FIXED_MOVE X, 100
END MP
MP 4 second
    count = count + 1
END MP
ISR 2 edge
    limit = 1
END ISR
"""


def mpc(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=60, cwd=cwd)


def folder(path: Path, source: str = JOB) -> Path:
    path.mkdir(parents=True, exist_ok=True)
    (path / "job.mp").write_text(source)
    return path


def test_manual_3_19_status_from_another_folder_and_after_a_restart(tmp_path: Path) -> None:
    first, second = folder(tmp_path / "first"), folder(tmp_path / "second")
    memory = tmp_path / "memory.json"
    proc, port = start_sim("--memory", str(memory), "--duration", "60")
    device = f"127.0.0.1:{port}"
    try:
        flashed = mpc(first, "flash", "job.mp", "--tcp", device, "--record", "r.json",
                      "--json")
        assert flashed.returncode == EXIT_OK, flashed.stderr
        report = json.loads(flashed.stdout)
        assert report["manifest"]["build_id"] == report["build_id"]
        assert "build manifest written to MD768-MD1023 and read back" in flashed.stderr

        status = mpc(second, "status", "--tcp", device, "job.mp", "--json")
        assert status.returncode == EXIT_OK, status.stderr
        data = json.loads(status.stdout)
        assert data["manifest"]["build_id"] == report["build_id"]
        assert [(p["slot"], p["name"]) for p in data["manifest"]["programs"]] == [
            ("MP3", "first"), ("MP4", "second"), ("ISR2", "edge")]
        assert [(s["slot"], s["status"]) for s in data["slots"]] == [
            ("MP3", "in sync"), ("MP4", "in sync"), ("ISR2", "in sync")]
        assert data["in_sync"] and data["identity"]["module_id"] == 0x44
        assert data["state"]["name"] == "ready" and data["word_order"] == 0
        places = {v["name"]: v["var"] for v in data["variables"]}
        assert set(places) == {"count", "limit"} and places["limit"] == 20
        assert [a["axis"] for a in data["axes"]] == ["X", "Y", "Z", "U"]

        again = mpc(second, "flash", "job.mp", "--tcp", device, "--record", "r.json",
                    "--json")  # a second computer: an empty record, the same sources
        assert again.returncode == EXIT_OK, again.stderr
        summary = json.loads(again.stdout)
        assert summary["written"] == 0 and summary["unchanged"] == 3
        assert summary["frames_written"] == 0

        folder(second, JOB.replace("count = count + 1", "count = count + 2"))
        text = mpc(second, "status", "--tcp", device, "job.mp")
        assert text.returncode == EXIT_OUT_OF_SYNC, text.stderr
        assert "out of sync" in text.stdout
        assert "  differs   MP4    second" in text.stdout
        assert "  in sync   MP3    first" in text.stdout
        changed = mpc(second, "flash", "job.mp", "--tcp", device, "--record", "r.json",
                      "--json")
        summary = json.loads(changed.stdout)
        assert [p["status"] for p in summary["programs"]] == [
            "unchanged", "verified", "unchanged"]
    finally:
        proc.terminate()
        proc.wait(10)

    proc, port = start_sim("--memory", str(memory), "--duration", "60")
    try:  # the controller restarted on its memory: the manifest is still there
        after = mpc(tmp_path, "status", "--tcp", f"127.0.0.1:{port}", "second/job.mp")
        assert after.returncode == EXIT_OK, after.stdout + after.stderr
        assert "slots       against build" in after.stdout and "in sync" in after.stdout
        plain = mpc(tmp_path, "status", "--tcp", f"127.0.0.1:{port}")  # nothing to compare
        assert plain.returncode == EXIT_OK
        assert "  MP4    second" in plain.stdout and "slots" not in plain.stdout
        old = mpc(first, "status", "--tcp", f"127.0.0.1:{port}", "job.mp", "--json")
        assert old.returncode == EXIT_OUT_OF_SYNC
        assert {s["slot"]: s["status"] for s in json.loads(old.stdout)["slots"]}["MP4"] \
            == "differs"
    finally:
        proc.terminate()
        proc.wait(10)


def test_manual_3_19_status_extra_missing_and_no_identity(tmp_path: Path) -> None:
    work = folder(tmp_path / "w")
    (work / "other.mp").write_text("MP 9 other\n    VAR2 = 1\nEND MP\n")
    proc, port = start_sim("--duration", "60")
    device = f"127.0.0.1:{port}"
    try:
        none = mpc(work, "status", "--tcp", device, "job.mp", "--json")
        assert none.returncode == EXIT_OUT_OF_SYNC  # a fresh device: no manifest
        data = json.loads(none.stdout)
        assert "no manifest" in data["manifest"]["error"]
        assert {s["status"] for s in data["slots"]} == {"unknown"}  # nothing to compare
        assert mpc(work, "flash", "job.mp", "--tcp", device, "--record", "r.json",
                   "--identity", "MD100-MD199").returncode == EXIT_OK
        other = mpc(work, "status", "--tcp", device, "other.mp", "--identity", "MD100-MD199",
                    "--json")
        rows = {s["slot"]: s["status"] for s in json.loads(other.stdout)["slots"]}
        assert rows == {"MP9": "missing", "MP3": "extra", "MP4": "extra", "ISR2": "extra"}
        off = mpc(work, "status", "--tcp", device, "--no-identity")
        assert off.returncode == EXIT_OK and "manifest    not read" in off.stdout
        small = mpc(work, "flash", "job.mp", "--tcp", device, "--identity", "MD0-MD8",
                    "--record", "r.json", "--force")
        assert small.returncode == 8 and "needs" in small.stderr and "MD0-MD8 holds 9" \
            in small.stderr
    finally:
        proc.terminate()
        proc.wait(10)


def test_status_and_flash_refuse_bad_identity_and_report_no_device(tmp_path: Path) -> None:
    work = folder(tmp_path / "w")
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        closed = probe.getsockname()[1]
    gone = mpc(work, "status", "--tcp", f"127.0.0.1:{closed}")
    assert gone.returncode == EXIT_NO_DEVICE and "mpc: error: no device" in gone.stderr
    bad = mpc(work, "flash", "job.mp", "--tcp", f"127.0.0.1:{closed}", "--identity", "MD0-MD3")
    assert bad.returncode == EXIT_USAGE and "at least 8" in bad.stderr
    csim = mpc(work, "status", "--serial", str(tmp_path / "tty"), "--target", "csim")
    assert csim.returncode == EXIT_NO_DEVICE and "no such serial device" in csim.stderr
    fatek = mpc(work, "status", "--serial", str(tmp_path / "tty"), "--target", "fbs-fun140")
    assert fatek.returncode == EXIT_USAGE
    assert "no FATEK FBs-PLC device to read: FB documents no way" in fatek.stderr
    both = mpc(work, "status", "--tcp", f"127.0.0.1:{closed}", "--identity", "MD0-MD9",
               "--no-identity")
    assert both.returncode == EXIT_USAGE
    (work / "mpc.toml").write_text('[project]\nsources = ["job.mp"]\n\n[flash]\n'
                                   'identity = "MD1000-MD1100"\n')
    wrong = mpc(work, "flash", "--tcp", f"127.0.0.1:{closed}")
    assert wrong.returncode == EXIT_NO_INPUT
    assert "mpc.toml:5: [flash] identity: MD1000-MD1100: the manifest goes in the long" \
        in wrong.stderr
    (work / "mpc.toml").write_text('[project]\nsources = ["job.mp"]\n\n[flash]\nidentity = 5\n')
    typed = mpc(work, "status", "--tcp", f"127.0.0.1:{closed}")
    assert typed.returncode == EXIT_NO_INPUT and "mpc.toml:5: [flash] identity" in typed.stderr


def test_manual_3_19_status_over_modbus_rtu(tmp_path: Path) -> None:
    """The RS-M8194H: the same status over a pty pair (`mpc sim --serial pty`)."""
    work = folder(tmp_path / "w")
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "sim", "--serial", "pty",
                             "--unit", "3", "--duration", "60"], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        assert "Modbus RTU on " in line, line
        port = line.split("Modbus RTU on ", 1)[1].split()[0]
        flashed = mpc(work, "flash", "job.mp", "--serial", port, "--unit", "3", "--record",
                      "r.json")
        assert flashed.returncode == EXIT_OK, flashed.stderr
        status = mpc(work, "status", "--serial", port, "--unit", "3", "job.mp")
        assert status.returncode == EXIT_OK, status.stdout + status.stderr
        assert port in status.stdout.splitlines()[0]
        assert "  in sync   ISR2   edge" in status.stdout
    finally:
        proc.terminate()
        proc.wait(10)

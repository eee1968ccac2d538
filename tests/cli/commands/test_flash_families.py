"""`mpc flash` for the other families: a CSIM program over a real pty pair to the virtual
CSIM, read back as sent; every download failure with its exit code; and the refusals (FATEK
has no transport, CSIM has no Modbus, M8194H-only options)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial  # type: ignore[import-untyped]
from click.testing import CliRunner

from mplang import csim
from mplang.cli import (
    EXIT_NO_DEVICE,
    EXIT_OK,
    EXIT_REJECTED,
    EXIT_SOURCE_ERRORS,
    EXIT_TRANSPORT,
    EXIT_UNVERIFIED,
    EXIT_USAGE,
    main,
)
from mplang.csim import flashing as csim_flashing
from mplang.csim.device import CsimServer, Reply, VirtualCsim
from mplang.csim.download import DownloadError
from mplang.family.ptylink import PtyLink
from mplang.m8194h.compiler import Options

ROOT = Path(__file__).resolve().parents[3]
SAMPLES = ROOT / "samples"
INDEXER = SAMPLES / "families" / "indexer.mp"
FLOW = SAMPLES / "csim" / "program_flow.csim"


def run(*args: str | Path) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


@pytest.fixture
def link() -> Iterator[PtyLink]:
    with PtyLink() as pair:
        yield pair


def listed_back(port_name: str) -> list[str]:
    """The program as the device lists it with ULP, read over the line like any host."""
    port = serial.Serial(port_name, timeout=2.0)
    try:
        port.write(b"ULP\r")
        raw = port.read_until(b"\r\nOK\r\n").decode("ascii")
    finally:
        port.close()
    lines: list[str] = raw.split("\r\n")
    assert lines[0] == "ULP" and lines[-2:] == ["OK", ""]
    return lines[1:-2]


def test_an_mp_job_flashed_into_the_virtual_csim_lists_back_as_built(link: PtyLink) -> None:
    built = csim.compile_mp([INDEXER], Options(), "csim").programs[0].lines
    with CsimServer(link.device_end, time_scale=50.0) as server:
        code, out, err = run("flash", INDEXER, "--target", "csim", "--serial",
                             link.client_end, "--json")
        assert code == EXIT_OK, err
        assert listed_back(link.client_end) == built
        assert server.device.machine.script.texts == built
    summary = json.loads(out)
    assert (summary["ok"], summary["outcome"], summary["verified"], summary["saved"]) == \
        (True, "verified", True, True)
    assert (summary["program"], summary["lines"], summary["target"]) == \
        ("indexer", len(built), "csim")
    assert f"mpc flash: CSIM on {link.client_end} (115200 8N1): program indexer" in err
    assert f"{len(built)} line(s) of indexer downloaded, listed back identical and saved" in err


def test_a_csim_listing_implies_the_target_and_line_settings_apply(link: PtyLink) -> None:
    with CsimServer(link.device_end, baudrate=9600, parity="E", stopbits=2):
        code, _, err = run("flash", FLOW, "--serial", link.client_end, "--baud", "9600",
                           "--parity", "E", "--stopbits", "2")
        assert code == EXIT_OK, err
        assert listed_back(link.client_end) == csim.check_native([FLOW]).programs[0].lines
    assert "(9600 8E2)" in err


def test_a_project_target_is_flashed_with_to(link: PtyLink, tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "flow.csim").write_text(FLOW.read_text())
    (tmp_path / "mpc.toml").write_text(
        f'[targets.drive]\nserial = "{link.client_end}"\ntarget = "csim"\n'
        'sources = ["flow.csim"]\ntimeout = 2.0\n'
        '[targets.cell]\ntcp = "127.0.0.1:1"\n')
    monkeypatch.chdir(tmp_path)
    with CsimServer(link.device_end):
        code, _, err = run("flash", "--to", "drive")
        assert code == EXIT_OK, err
        assert len(listed_back(link.client_end)) == len(FLOW.read_text().splitlines()) - \
            sum(1 for line in FLOW.read_text().splitlines()
                if not line.strip() or line.lstrip().startswith("#"))
    code, _, err = run("flash", "--to", "drive", "--target", "et")
    assert code == EXIT_USAGE and 'contradicts target = "csim" of [targets.drive]' in err
    code, _, err = run("flash", "--fleet", "mpc.toml")
    assert code == EXIT_USAGE and "drive (CSIM)" in err and "--fleet flashes M8194H" in err


class RefusingCsim(VirtualCsim):
    """Refuses every wait for time (WT) it is sent to store."""

    def handle(self, line: str) -> Reply:
        if self.mode == "edit" and line.startswith("WT"):
            return self.error(5, "not here")
        return super().handle(line)


class ForgetfulCsim(VirtualCsim):
    """Lists back one line less than it was sent."""

    def handle(self, line: str) -> Reply:
        reply = super().handle(line)
        if line == "ULP":
            reply.data = reply.data[:-1]
        return reply


def test_a_refused_line_exits_8_at_its_mp_line(link: PtyLink) -> None:
    with CsimServer(link.device_end, device=RefusingCsim()):
        code, out, err = run("flash", INDEXER, "--target", "csim", "--serial",
                             link.client_end, "--json")
    assert code == EXIT_REJECTED
    assert "indexer.mp:29: error: the device refused 'WT 200': ERR 5 not allowed here" in err
    summary = json.loads(out)
    assert (summary["ok"], summary["outcome"], summary["kind"]) == (False, "rejected",
                                                                     "device-error")
    assert summary["where"].endswith("samples/families/indexer.mp:29")


def test_a_listing_that_differs_exits_9(link: PtyLink) -> None:
    with CsimServer(link.device_end, device=ForgetfulCsim()):
        code, _, err = run("flash", FLOW, "--serial", link.client_end)
    assert code == EXIT_UNVERIFIED and "were sent" in err


def test_no_device_on_the_line_exits_7(link: PtyLink) -> None:
    code, _, err = run("flash", FLOW, "--serial", link.client_end, "--timeout", "0.2")
    assert code == EXIT_NO_DEVICE and "no answer from the device" in err


def test_a_port_that_cannot_be_opened_exits_6(tmp_path: Path) -> None:
    code, out, err = run("flash", FLOW, "--serial", tmp_path / "ttyNONE", "--json")
    assert code == EXIT_TRANSPORT and "cannot open" in err
    assert json.loads(out)["outcome"] == "no-port"


@pytest.mark.parametrize(("kind", "code", "outcome"), [
    ("port", EXIT_TRANSPORT, "no-port"), ("no-answer", EXIT_NO_DEVICE, "no-device"),
    ("device-error", EXIT_REJECTED, "rejected"), ("program", EXIT_REJECTED, "rejected"),
    ("echo", EXIT_UNVERIFIED, "unverified"), ("reply", EXIT_UNVERIFIED, "unverified"),
    ("mismatch", EXIT_UNVERIFIED, "unverified"),
])
def test_every_download_failure_has_its_exit_code(monkeypatch: pytest.MonkeyPatch, kind: str,
                                                  code: int, outcome: str) -> None:
    def failing(*_args: object, **_kwargs: object) -> None:
        raise DownloadError(kind, f"a {kind} failure", 0)

    monkeypatch.setattr(csim_flashing, "download", failing)
    result, out, err = run("flash", FLOW, "--serial", "/dev/null", "--json")
    assert result == code
    assert f"\n{FLOW}:5: error: a {kind} failure\n" in err  # the first line's place
    assert (json.loads(out)["outcome"], json.loads(out)["kind"]) == (outcome, kind)


def test_dry_run_shows_the_lines_and_touches_nothing() -> None:
    code, out, _ = run("flash", FLOW, "--dry-run")
    lines = csim.check_native([FLOW]).programs[0].lines
    assert code == EXIT_OK
    assert out.splitlines()[1:] == [f"{i:04d}  {text}" for i, text in enumerate(lines)]
    code, out, _ = run("flash", INDEXER, "--target", "csim", "--dry-run", "--json")
    assert code == EXIT_OK
    assert json.loads(out) == {"dry_run": True, "target": "csim", "program": "indexer",
                               "source": str(INDEXER),
                               "lines": csim.compile_mp([INDEXER], Options(),
                                                        "csim").programs[0].lines}


@pytest.mark.parametrize(("args", "words"), [
    ((SAMPLES / "fatek" / "feeder.mp", "--target", "fbs-fun140"),
     ["FATEK FBs-PLC (fbs-fun140) programs cannot be flashed", "WinProladder",
      "mpc build --target fbs-fun140 --format fbs"]),
    ((SAMPLES / "fatek" / "drvc_three_speeds.fbs", "--serial", "/dev/null"),
     ["cannot be flashed", "--target fbs-fun140 --format fbs"]),
    ((FLOW, "--tcp", "10.0.0.1"), ["a CSIM is reached over RS232: give --serial PORT"]),
    ((FLOW,), ["give the device"]),
    ((FLOW, "--serial", "/dev/null", "--unit", "3"), ["--unit: M8194H option"]),
    ((FLOW, "--serial", "/dev/null", "--record", "r.json"), ["--record: M8194H option"]),
    ((FLOW, "--serial", "/dev/null", "--set-word-order"), ["--set-word-order: M8194H"]),
    ((FLOW, "--serial", "/dev/null", "--retries", "1"), ["--retries: M8194H option"]),
    ((INDEXER, "--target", "csim", "--serial", "/dev/null", "--word-order", "1"),
     ["--word-order: M8194H option"]),
    ((FLOW, SAMPLES / "csim" / "jog.csim", "--serial", "/dev/null"),
     ["a CSIM holds one program, and these sources make 2"]),
    (("image.json", "--target", "csim", "--serial", "/dev/null"),
     ["an image JSON is an M8194H download image"]),
])
def test_refusals_are_usage_errors(args: tuple[str | Path, ...], words: list[str],
                                   tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # no mpc.toml around
    (tmp_path / "image.json").write_text("{}")
    code, _, err = run("flash", *args)
    flat = " ".join(err.split())
    assert code == EXIT_USAGE, err
    for word in words:
        assert word in flat, (word, err)


def test_a_build_with_errors_is_not_flashed(tmp_path: Path) -> None:
    bad = tmp_path / "bad.csim"
    bad.write_text("MA 1,2,3,4,5\n")
    code, _, err = run("flash", bad, "--serial", "/dev/null")
    assert code == EXIT_SOURCE_ERRORS and "error[E703]" in err


def test_project_targets_that_inherit_a_family_target(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "flow.csim").write_text(FLOW.read_text())
    (tmp_path / "feeder.mp").write_text((SAMPLES / "fatek" / "feeder.mp").read_text())
    (tmp_path / "mpc.toml").write_text('[project]\nsources = ["flow.csim"]\ntarget = "csim"\n'
                                       '[targets.drive]\nserial = "/dev/null"\nunit = 2\n')
    code, _, err = run("flash")
    assert code == EXIT_USAGE
    assert "mpc.toml:4: [targets.drive] sets unit: M8194H settings, and the target is CSIM" \
        in " ".join(err.split())
    (tmp_path / "mpc.toml").write_text('[project]\nsources = ["feeder.mp"]\n'
                                       'target = "fbs-fun147"\n'
                                       '[targets.plc]\nserial = "/dev/null"\n')
    for args in (("--fleet", "mpc.toml"), ("--to", "plc"), ()):
        code, _, err = run("flash", *args)
        assert code == EXIT_USAGE and "cannot be flashed" in err, args
        assert "--target fbs-fun147 --format fbs" in " ".join(err.split())

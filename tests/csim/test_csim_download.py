"""Download over a real pty pair: the round trip, and the faults (no device, garbled or
wrong replies, refusals, a listing that differs, no port)."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial  # type: ignore[import-untyped]

from mplang import csim
from mplang.csim.device import CsimServer, Reply, VirtualCsim
from mplang.csim.download import DownloadError, download
from mplang.family.ptylink import PtyLink

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def link() -> Iterator[PtyLink]:
    with PtyLink() as pair:
        yield pair


def test_round_trip_lists_back_exactly_what_was_downloaded(link: PtyLink) -> None:
    build = csim.compile_mp([ROOT / "samples" / "csim" / "cross_target.mp"],
                            csim_options(), "csim")
    program = build.programs[0]
    with CsimServer(link.device_end, time_scale=100.0) as server:
        report = download(program, link.client_end, timeout=2.0, save=True)
        assert report.verified and report.saved and report.lines == len(program.lines)
        assert report.listing == program.lines
        assert server.device.machine.script.texts == program.lines
        port = serial.Serial(link.client_end, timeout=2.0)
        port.write(b"G\r")
        assert port.read_until(b"OK\r\n") == b"G\r\nOK\r\n"
        port.close()


def csim_options():  # type: ignore[no-untyped-def]
    from mplang.m8194h.compiler import Options
    return Options()


def test_every_manual_sample_round_trips(link: PtyLink) -> None:
    with CsimServer(link.device_end):
        for path in sorted((ROOT / "samples" / "csim").glob("*.csim")):
            program = csim.check_native([path]).programs[0]
            assert download(program, link.client_end, timeout=2.0).listing == program.lines


def test_no_device_on_the_line(link: PtyLink) -> None:
    with pytest.raises(DownloadError) as caught:
        download(["MA 1"], link.client_end, timeout=0.3)
    assert caught.value.kind == "no-answer"
    assert "no answer from the device" in caught.value.message and "'DLP'" in caught.value.message


def fake_device(link: PtyLink, answer: bytes) -> threading.Thread:
    """A device that answers every line with the same bytes."""
    port = serial.Serial(link.device_end, timeout=0.05)
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            if port.read_until(b"\r").endswith(b"\r"):
                port.write(answer)
        port.close()

    thread = threading.Thread(target=serve, daemon=True)
    thread.stop = stop  # type: ignore[attr-defined]
    thread.start()
    return thread


# A full answer ends the wait at once, so its timeout can be generous; a cut answer waits
# the whole timeout, and must have arrived before it ends.
@pytest.mark.parametrize(("answer", "kind", "text", "timeout"), [
    (b"DLX\r\nOK\r\n", "echo", "wrong echo: sent 'DLP', the device echoed 'DLX'", 10.0),
    (b"DLP\r\n\xff\xfe\r\n", "reply", "garbled reply", 10.0),
    (b"DLP\r\nWHAT?\r\n", "reply", "unexpected reply to 'DLP'", 10.0),
    (b"DLP\r\nERR 4 busy\r\n", "device-error", "the device refused 'DLP': ERR 4 busy", 10.0),
    (b"DLP\r\nOK", "no-answer", "got 'OK' so far", 2.0),
])
def test_garbled_and_wrong_replies(link: PtyLink, answer: bytes, kind: str, text: str,
                                   timeout: float) -> None:
    thread = fake_device(link, answer)
    try:
        with pytest.raises(DownloadError) as caught:
            download(["MA 1"], link.client_end, timeout=timeout)
        assert caught.value.kind == kind and text in caught.value.message
    finally:
        thread.stop.set()  # type: ignore[attr-defined]
        thread.join(timeout=2)


def test_a_refused_line_is_reported(link: PtyLink) -> None:
    with CsimServer(link.device_end), pytest.raises(DownloadError) as caught:
        download(["MA 1", "MA 1,2"], link.client_end, timeout=2.0)
    assert caught.value.kind == "device-error" and "'MA 1,2'" in caught.value.message


class ForgetfulCsim(VirtualCsim):
    """Lists back one line less than it was sent."""

    def handle(self, line: str) -> Reply:
        reply = super().handle(line)
        if line == "ULP":
            reply.data = reply.data[:-1]
        return reply


def test_a_listing_that_differs_is_never_a_success(link: PtyLink) -> None:
    with CsimServer(link.device_end, device=ForgetfulCsim()), \
            pytest.raises(DownloadError) as caught:
        download(["MA 1", "MA 2"], link.client_end, timeout=2.0)
    assert caught.value.kind == "mismatch"
    assert "lists 1 lines, but 2 were sent" in caught.value.message


def test_bad_port_and_bad_program() -> None:
    with pytest.raises(DownloadError) as caught:
        download(["MA 1"], "/dev/no-such-port", timeout=0.2)
    assert caught.value.kind == "port"
    with pytest.raises(DownloadError) as bad:
        download(["MA 1", ""], "/dev/no-such-port", timeout=0.2)
    assert bad.value.kind == "program"


def test_errors_name_the_program_line_they_concern(link: PtyLink) -> None:
    with CsimServer(link.device_end), pytest.raises(DownloadError) as caught:
        download(["MA 1", "MA 2", "MA 1,2"], link.client_end, timeout=2.0)
    assert caught.value.line == 2
    with CsimServer(link.device_end, device=ForgetfulCsim()), \
            pytest.raises(DownloadError) as listed:
        download(["MA 1", "MA 2"], link.client_end, timeout=2.0)
    assert listed.value.line is None  # a missing line, not a different one
    with pytest.raises(DownloadError) as bad:
        download(["MA 1", "MA\u00e92"], "/dev/no-such-port", timeout=0.2)
    assert (bad.value.kind, bad.value.line) == ("program", 1)


def test_line_settings_reach_the_port(link: PtyLink) -> None:
    with CsimServer(link.device_end, baudrate=19200, parity="O", stopbits=2):
        report = download(["MA 1"], link.client_end, baud=19200, timeout=2.0, parity="O",
                          stopbits=2)
    assert report.verified

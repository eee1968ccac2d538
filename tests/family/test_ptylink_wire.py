"""The paced pty line (`ptylink.Wire`, Modbus over serial line: RTU framing, every byte 10
bits at 8N1, at least 3.5 characters of silence before a frame): what bench/flash.py measures
RTU flashing against. The timing is computed on the wire's own clock, so it is checked here
by its arithmetic, never by the wall clock."""

from __future__ import annotations

import os

import pytest

from mplang.family.ptylink import PtyLink, Wire

BAUD = 115200
CHAR = 10 / BAUD
GAP = 3.5 * CHAR


def test_a_frame_on_an_idle_line_takes_its_bytes_time() -> None:
    wire = Wire(BAUD)
    assert wire.deliver_at(1, 8, 5.0) == pytest.approx(5.0 + 8 * CHAR)


def test_the_answer_waits_for_the_silence_and_no_longer() -> None:
    """An answer written right after the request arrived starts 3.5 characters after the
    request's last byte; one written after that silence starts at once."""
    wire = Wire(BAUD)
    request_end = wire.deliver_at(1, 8, 0.0)
    quick = wire.deliver_at(2, 7, request_end + GAP / 3)
    assert quick == pytest.approx(request_end + GAP + 7 * CHAR)
    slow_start = quick + 2 * GAP
    assert wire.deliver_at(1, 8, slow_start) == pytest.approx(slow_start + 8 * CHAR)


def test_a_frame_written_in_pieces_pays_one_silence() -> None:
    """A sender's next chunk that arrives before the silence that would end its frame goes
    on the line right after the bytes before it (keeps the line busy)."""
    wire = Wire(BAUD)
    first = wire.deliver_at(1, 4, 0.0)
    assert wire.deliver_at(1, 4, first / 2) == pytest.approx(8 * CHAR)


def test_back_to_back_frames_cost_the_wire_limit() -> None:
    """Requests and answers sent as soon as allowed take bytes x 10 bits plus one silence
    between frames: the wire-time limit bench/flash.py divides by."""
    wire = Wire(BAUD)
    end = 0.0
    sizes = [8, 7, 17, 8, 8, 35]
    for k, size in enumerate(sizes):
        end = wire.deliver_at(k % 2, size, 0.0)
    assert end == pytest.approx(sum(sizes) * CHAR + (len(sizes) - 1) * GAP)


def test_a_paced_link_passes_every_byte_on_in_order() -> None:
    with PtyLink(Wire(BAUD)) as link:
        client = os.open(link.client_end, os.O_RDWR | os.O_NOCTTY)
        device = os.open(link.device_end, os.O_RDWR | os.O_NOCTTY)
        try:
            os.write(client, bytes(range(40)))
            got = b""
            while len(got) < 40:
                got += os.read(device, 64)
            assert got == bytes(range(40))
        finally:
            os.close(client)
            os.close(device)

"""Request faults for `mpc flash` (issue 19, findings 1-3): request frames delayed,
duplicated and reordered on their way to the device, a link that fails during the tidy-up,
a program that runs, a second client downloading at the same time.

The faults sit in a relay between the flasher and a served virtual M8194H: over TCP a real
proxy on a loopback port (`RequestFaultProxy`), over RTU a relay between two pty pairs
(`RtuRequestRelay`). Both keep the order of one connection (or line) unless told to
reorder, and deliver a request held on a connection the client has closed anyway, as a TCP
segment that was retransmitted late does after a graceful close: that is how a late line
frame lands inside a new download (finding 1).

The invariant (`assert_truthful`): either the flash says verified and the device holds
exactly the build, or the flash fails and its message says what the device may hold.
"""

from __future__ import annotations

import asyncio
import heapq
import os
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager, suppress
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from loopback import LoopbackServer
from test_flash_faults import (
    FRAME_WINDOW,
    MP41,
    WRITE_REGISTERS,
    Request,
    assert_runs,
    device,
    job_image,
    parse_request,
    rtu_request_length,
    stored,
)

from mplang.family.ptylink import PtyLink
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.flash import Flasher, FlashImage, FlashOptions, FlashReport, image_from_build
from mplang.m8194h.flash import flasher as flasher_module
from mplang.m8194h.flash.registers import state_name
from mplang.m8194h.modbus import DeviceLink, Endpoint
from mplang.m8194h.modbus_server import DeviceFace, serve_rtu, serve_tcp, stop

TIMEOUT = 0.1  # the client's answer timeout; a round trip takes about 1 ms here
MAX_DELAY = 1.5 * TIMEOUT  # the ratio: 0.75 s late at a 0.5 s timeout
SPACING = 0.005  # between requests a relay releases at the same moment

Action = tuple[str, float] | None
"""What a relay does to one request: None (pass it on), ("delay", s) (hold it and every
later request of the connection s seconds), ("dup", s) (pass it on twice, both after s),
("swap", s) (hold it s seconds and let later requests overtake it), ("pair", s) (pass it
on twice after s, both copies in one write, so the device reads them together), ("ride", _)
(pass it on, and a second copy in one write with the next request: a relay that repeats a
frame right before the next one), ("drop", _) (never deliver it)."""
Schedule = Callable[[Request], Action]


@dataclass
class Relay:
    """Request accounting shared by both relays: the requests seen, in order, and the
    actions taken; `held` counts requests not delivered yet."""

    schedule: Schedule
    requests: list[Request] = field(default_factory=list)
    fired: list[tuple[Action, Request]] = field(default_factory=list)
    frames: int = 0
    held: int = 0
    _seq: int = 0
    _riding: bool = False  # the request being planned sends a copy with the next one
    _rider: bytes = b""  # that copy, until the next request is pushed

    def plan(self, pdu: bytes, now: float, lane: list[float]) -> list[tuple[float, int]]:
        """The release times of the writes of one request, each with the number of copies
        it carries; `lane` holds the release time of the last request of its connection,
        which a delayed request holds up."""
        frame = None
        if pdu[0] == WRITE_REGISTERS and int.from_bytes(pdu[1:3], "big") == FRAME_WINDOW:
            frame, self.frames = self.frames, self.frames + 1
        request = parse_request(pdu, len(self.requests), frame)
        self.requests.append(request)
        action = self.schedule(request)
        if action is not None:
            self.fired.append((action, request))
        kind, delay = action if action is not None else ("pass", 0.0)
        if kind == "drop":  # lost on the way: the client's timeout, then a fence
            return []
        if kind == "swap":
            return [(now + delay, 1)]
        lane[0] = max(lane[0], now + (delay if kind in ("delay", "dup", "pair") else 0.0))
        if kind == "pair":
            return [(lane[0], 2)]
        self._riding = kind == "ride"
        return [(lane[0], 1)] * (2 if kind == "dup" else 1)

    def push(self, heap: list[tuple[float, int, bytes]], release: float, data: bytes) -> None:
        if self._rider:
            data, self._rider = self._rider + data, b""
        elif self._riding:
            self._rider, self._riding = data, False
        self._seq += 1
        self.held += 1
        heapq.heappush(heap, (release, self._seq, data))


async def deliver(relay: Relay, heap: list[tuple[float, int, bytes]], wake: asyncio.Event,
                  send: Callable[[bytes], None], done: Callable[[], bool]) -> None:
    """Send the held requests at their release times until `done()` and nothing is held.
    Requests due together go a few milliseconds apart, as separate frames on a line do
    ("pair" and "ride" put two in one write on purpose)."""
    loop = asyncio.get_running_loop()
    while heap or not done():
        wake.clear()
        if not heap:
            await wake.wait()
            continue
        release, _seq, data = heap[0]
        if release > loop.time():
            with suppress(TimeoutError):
                await asyncio.wait_for(wake.wait(), release - loop.time())
            continue
        heapq.heappop(heap)
        relay.held -= 1
        send(data)
        if heap and heap[0][0] <= loop.time() + SPACING:
            await asyncio.sleep(SPACING)


class RequestFaultProxy(LoopbackServer):
    """Modbus TCP on a loopback port, one device connection per client connection."""

    def __init__(self, device_port: int, schedule: Schedule) -> None:
        super().__init__()
        self.device_port = device_port
        self.relay = Relay(schedule)

    async def _serve(self, client_reader: asyncio.StreamReader,
                     client_writer: asyncio.StreamWriter) -> None:
        device_reader, device_writer = await asyncio.open_connection("127.0.0.1",
                                                                     self.device_port)
        heap: list[tuple[float, int, bytes]] = []
        wake = asyncio.Event()
        closed = [False]
        lane = [0.0]

        async def answers() -> None:
            try:
                while data := await device_reader.read(4096):
                    if not client_writer.is_closing():
                        client_writer.write(data)
            except ConnectionError:
                return

        answering = self._spawn(answers())
        sending = self._spawn(deliver(self.relay, heap, wake, device_writer.write,
                                      lambda: closed[0]))
        loop = asyncio.get_running_loop()
        try:
            while True:
                try:
                    header = await client_reader.readexactly(7)
                    adu = header + await client_reader.readexactly(
                        int.from_bytes(header[4:6], "big") - 1)
                except (asyncio.IncompleteReadError, ConnectionError):
                    break
                for release, copies in self.relay.plan(adu[7:], loop.time(), lane):
                    self.relay.push(heap, release, adu * copies)
                wake.set()
        finally:
            closed[0] = True
            wake.set()
            client_writer.close()
        await sending  # a request held on a closed connection still reaches the device
        await asyncio.sleep(TIMEOUT)  # its answer goes nowhere
        answering.cancel()
        device_writer.close()


class RtuRequestRelay:
    """Modbus RTU through a relay between two pty pairs: the client's line ends at the
    relay, the relay's second line at the device."""

    def __init__(self, schedule: Schedule) -> None:
        self.relay = Relay(schedule)

    @asynccontextmanager
    async def serving(self, face: DeviceFace) -> AsyncIterator[str]:
        loop = asyncio.get_running_loop()
        with PtyLink() as client_line, PtyLink() as device_line:
            server = await serve_rtu(face, device_line.device_end, unit=1)
            up = os.open(client_line.device_end, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
            down = os.open(device_line.client_end, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
            heap: list[tuple[float, int, bytes]] = []
            wake = asyncio.Event()
            stopped = [False]
            pending = [b""]
            lane = [0.0]

            def requests() -> None:
                try:
                    pending[0] += os.read(up, 4096)
                except BlockingIOError:
                    return
                while (length := rtu_request_length(pending[0])) is not None \
                        and len(pending[0]) >= length:
                    frame, pending[0] = pending[0][:length], pending[0][length:]
                    for release, copies in self.relay.plan(frame[1:-2], loop.time(), lane):
                        self.relay.push(heap, release, frame * copies)
                    wake.set()

            def answers() -> None:
                try:
                    os.write(up, os.read(down, 4096))
                except BlockingIOError:
                    return

            loop.add_reader(up, requests)
            loop.add_reader(down, answers)
            sending = asyncio.ensure_future(deliver(self.relay, heap, wake,
                                                    lambda data: os.write(down, data) and None,
                                                    lambda: stopped[0]))
            try:
                yield client_line.client_end
            finally:
                stopped[0] = True
                wake.set()
                await sending
                await asyncio.sleep(TIMEOUT)
                loop.remove_reader(up)
                loop.remove_reader(down)
                await stop(server)
                os.close(up)
                os.close(down)


@dataclass
class Outcome:
    report: FlashReport
    link: DeviceLink
    relay: Relay


def flash_relayed(transport: str, face: DeviceFace, schedule: Schedule, image: FlashImage,
                  options: FlashOptions | None = None, timeout: float = TIMEOUT,
                  retries: int = 3) -> Outcome:
    """Flash `image` into `face` through a relay; returns once every held request has
    reached the device, so the device is checked as it stays."""

    async def scenario() -> Outcome:
        if transport == "tcp":
            server, port = await serve_tcp(face, "127.0.0.1", 0)
            proxy = RequestFaultProxy(port, schedule)
            try:
                endpoint = Endpoint(host="127.0.0.1", port=await proxy.start(),
                                    timeout=timeout, retries=retries)
                link = DeviceLink(endpoint)
                report = await Flasher(image, link, options or FlashOptions()).run()
                while proxy.relay.held:
                    await asyncio.sleep(0.01)
                await asyncio.sleep(0.02)
                return Outcome(report, link, proxy.relay)
            finally:
                await proxy.close()
                await stop(server)
        relay = RtuRequestRelay(schedule)
        async with relay.serving(face) as port_name:
            link = DeviceLink(Endpoint(serial=port_name, timeout=timeout, retries=retries))
            report = await Flasher(image, link, options or FlashOptions()).run()
        return Outcome(report, link, relay.relay)

    return asyncio.run(scenario())


def messages(report: FlashReport) -> list[str]:
    return [str(report.error or ""), *report.notes,
            *(str(p.error or "") for p in report.programs)]


def assert_truthful(face: DeviceFace, image: FlashImage, report: FlashReport) -> None:
    """Verified means the device holds exactly the build; a failure says what it holds."""
    for text in messages(report):
        assert "None" not in text, text
    if report.ok:
        vc = face.controller
        assert vc.state == "ready" and vc.pending is None, f"left in {vc.state} state"
        for program in image.programs:
            assert stored(face, program.kind, program.slot) == program.frames[1:-1], \
                f"{program.label} is not what was verified"
        return
    assert report.outcome != "verified" and report.error
    for program, result in zip(image.programs, report.programs, strict=True):
        content = stored(face, program.kind, program.slot)
        if result.status == "verified" and report.outcome != "unverified":
            assert content == program.frames[1:-1], program.label
        elif result.status not in ("verified", "pending"):
            assert content in (None, [], program.frames[1:-1]) or "may hold" in \
                str(report.error), f"{program.label} holds {content}: {report.error}"


# -------------------------------------------------------------- finding 1: late frames
LONG = "MP 156 long\n" + "    VAR1 = VAR1 + 1\n" * 300 + "END MP\n"


def long_image() -> FlashImage:
    build = compile_source(LONG, "long.mp")
    assert build.ok, [d.render() for d in build.diagnostics]
    return image_from_build(build)


def late_line(frame: int, delay: float) -> Schedule:
    """One line frame `delay` seconds late, once (everything behind it waits too)."""
    return lambda request: ("delay", delay) if request.frame == frame else None


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
@pytest.mark.parametrize("late_by", [0.6, 0.75])
def test_line_frame_delayed_past_the_timeout_never_lands_in_the_new_download(
        transport: str, late_by: float) -> None:
    """Issue 19 finding 1 (ET 6801-6835, the download sequence): a line frame of a
    300-line program arrives 0.6 or 0.75 s late at a 0.5 s timeout (the issue's figures).
    Before, the flasher reconnected and downloaded again while the frame was still on its
    way; the device stored it as an extra line and the flash said verified. Now the link
    fences first: the barrier read behind the late frame is answered only after it, so the
    new download starts after it."""
    image = long_image()
    face = device()
    outcome = flash_relayed(transport, face, late_line(150, late_by), image, timeout=0.5)
    assert [action for action, _request in outcome.relay.fired] == [("delay", late_by)]
    assert outcome.report.ok, outcome.report.error
    # Downloaded again at least once (more if a loaded machine makes another answer late):
    # what counts is that the device holds exactly the program and the flash says so.
    assert outcome.report.programs[0].downloads >= 2
    assert outcome.link.fences + outcome.link.quiet_fences >= 1
    assert stored(face, "mp", 156) == image.programs[0].frames[1:-1]
    assert_truthful(face, image, outcome.report)


def test_a_request_held_past_a_closed_connection_is_fenced_by_a_quiet_period() -> None:
    """The barrier cannot get through (every barrier read is held long, so the link gives
    up on the connection): a fresh connection, and the device must stay unchanged for a
    quiet period before the program is downloaded again. The held line frame reaches the
    old download, which the flasher then closes and downloads again."""
    image = job_image()
    face = device()
    line = image.programs[MP41].frames[3]

    def schedule(request: Request) -> Action:
        if list(request.values) == line and request.frame is not None and \
                request.frame < 10:
            return ("swap", 2.5 * TIMEOUT)
        if (request.function_code, request.address) == (4, 100) and 2 <= request.count <= 9:
            return ("swap", 8 * TIMEOUT)  # every barrier read
        return None

    outcome = flash_relayed("tcp", face, schedule, image, retries=1)
    assert outcome.link.quiet_fences >= 1
    assert_truthful(face, image, outcome.report)
    assert outcome.report.ok, outcome.report.error


def test_duplicated_line_frame_is_downloaded_again() -> None:
    """A relay passes a line frame on twice: the device stores it twice and answers twice.
    The second answer (same transaction id) is one no request waited for: the program is
    downloaded again, and the device holds it once."""
    image = job_image()
    face = device()
    outcome = flash_relayed("tcp", face, lambda r: ("dup", 0.0) if r.frame == 7 else None,
                            image)
    assert outcome.link.anomalies == 1
    assert outcome.report.ok, outcome.report.error
    assert [p.downloads for p in outcome.report.programs] == [1, 2, 1]
    assert any("a delayed or duplicated request" in note for note in outcome.report.notes)
    assert_truthful(face, image, outcome.report)
    assert_runs(face)


def test_duplicated_line_frame_over_rtu_is_downloaded_again() -> None:
    """Over RTU the duplicate answer takes the place of the next frame's; the shift shows
    at the latest when the status read meets a write's answer."""
    image = job_image()
    face = device()
    outcome = flash_relayed("rtu", face, lambda r: ("dup", 0.0) if r.frame == 7 else None,
                            image)
    assert outcome.report.ok, outcome.report.error
    assert outcome.report.programs[MP41].downloads >= 2
    assert_truthful(face, image, outcome.report)
    assert_runs(face)


ACTIONS = st.one_of(
    st.none(),
    st.tuples(st.sampled_from(["delay", "dup", "swap", "pair", "ride", "drop"]),
              st.floats(0.0, MAX_DELAY, allow_nan=False)))

WIDE = (
    "MP 95 wide\n" + "".join(f"    VAR{n} = VAR{n} + {n}\n" for n in range(1, 25))
    + "END MP\nMP 22 pause\n    TIMER 10\n    VAR7 = 7\nEND MP\n"
    "ISR 7 on_edge\n    VAR5 = VAR5 + 1\n    VAR6 = 2\nEND ISR\n")
WIDE_REQUESTS = 43  # a clean flash of `wide_image` sends 43 requests; retries send more
WIDE_RTU_REQUESTS = WIDE_REQUESTS + 23  # over RTU, and a read between MP95's 24 lines


def wide_image() -> FlashImage:
    """Three programs, 26 + 4 + 4 frames: faults drawn over its whole download."""
    build = compile_source(WIDE, "wide.mp")
    assert build.ok, [d.render() for d in build.diagnostics]
    return image_from_build(build)


def scheduled(actions: dict[int, Action]) -> Schedule:
    return lambda request: actions.get(request.index)


def test_the_wide_image_sends_the_requests_the_schedules_are_drawn_over() -> None:
    outcome = flash_relayed("tcp", device(), lambda _request: None, wide_image())
    assert outcome.report.ok and len(outcome.relay.requests) == WIDE_REQUESTS


@settings(max_examples=30, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(actions=st.dictionaries(st.integers(0, WIDE_REQUESTS + 12), ACTIONS, max_size=4))
def test_any_schedule_of_late_duplicated_reordered_and_lost_requests_is_told_truthfully(
        actions: dict[int, Action]) -> None:
    """Generated schedules over TCP (hypothesis, 30): up to four requests anywhere in the
    download (and in the re-downloads and repairs it may cause) delayed, duplicated,
    reordered by up to 1.5 timeouts, or lost. Whatever happens, the report is the truth
    about the device."""
    image = wide_image()
    face = device()
    outcome = flash_relayed("tcp", face, scheduled(actions), image)
    assert_truthful(face, image, outcome.report)


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
@pytest.mark.parametrize("frame", [5, 15])
def test_a_frame_repeated_right_before_the_next_one_is_caught(transport: str,
                                                               frame: int) -> None:
    """The schedule that once ended verified with MP95 holding line 15 twice and line 16
    missing (over RTU, depending on timing), made deterministic: a relay passes a line frame
    of MP95 on, and a copy of it in one write with the next request. The device serves both
    requests of that read, so the copy's answer is one more than the requests sent: the
    program is downloaded again and the device holds it once."""
    image = wide_image()
    face = device()
    outcome = flash_relayed(transport, face,
                            lambda r: ("ride", 0.0) if r.frame == frame else None, image)
    assert [action for action, _request in outcome.relay.fired] == [("ride", 0.0)]
    assert_truthful(face, image, outcome.report)
    assert face.requests == len(outcome.relay.requests) + 1, "the device lost a request"
    assert outcome.report.ok, outcome.report.error
    assert outcome.link.anomalies + outcome.link.foreign_answers >= 1
    assert [(p.slot, p.downloads) for p in outcome.report.programs] == \
        [(22, 1), (95, 2), (7, 1)]


def repeated_then_lost(frame: int) -> Schedule:
    """Line frame `frame` passed on twice, and the request the client sends after it lost."""
    copied: list[int] = []

    def schedule(request: Request) -> Action:
        if request.frame == frame and not copied:
            copied.append(request.index)
            return ("dup", 0.0)
        if copied and request.index == copied[0] + 1:
            return ("drop", 0.0)
        return None

    return schedule


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
@pytest.mark.parametrize("frame", [5, 20])
def test_a_repeated_frame_and_the_next_request_lost_are_caught(transport: str,
                                                                frame: int) -> None:
    """A line frame of MP95 repeated by the link and the request after it lost. Over RTU
    the two FC16 answers of frames of one length are the same bytes, so the copy's answer
    stood in for the lost frame's: MP95 ended verified holding a line twice and missing
    the next (docs/flash-faults.md). Now a read goes between two such frames over RTU,
    whose answer the copy's cannot stand in for: the program is downloaded again. Over TCP
    the transaction ids tell the answers apart."""
    image = wide_image()
    face = device()
    outcome = flash_relayed(transport, face, repeated_then_lost(frame), image)
    assert [action for action, _request in outcome.relay.fired] == [("dup", 0.0),
                                                                     ("drop", 0.0)]
    assert_truthful(face, image, outcome.report)
    assert outcome.report.ok, outcome.report.error
    assert [(p.slot, p.downloads) for p in outcome.report.programs] == \
        [(22, 1), (95, 2), (7, 1)]


def test_over_rtu_two_frames_of_one_length_have_a_read_between_them() -> None:
    """The read `_separate` puts between them, and none between frames of two lengths: the
    three programs of `wide_image` have 23, 0 and 0 such pairs (MP95's 24 lines are of
    one length; the create and close frames are of other lengths than a line)."""
    outcome = flash_relayed("rtu", device(), lambda _request: None, wide_image())
    assert outcome.report.ok, outcome.report.error
    assert len(outcome.relay.requests) == WIDE_RTU_REQUESTS
    requests = outcome.relay.requests
    assert not any(a.function_code == b.function_code == WRITE_REGISTERS and
                   a.count == b.count for a, b in pairwise(requests))


@settings(max_examples=30, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(actions=st.dictionaries(st.integers(0, WIDE_RTU_REQUESTS + 12), ACTIONS, max_size=4))
def test_rtu_schedules_of_late_duplicated_reordered_and_lost_requests_are_told_truthfully(
        actions: dict[int, Action]) -> None:
    """The same over RTU (hypothesis, 30): up to four requests anywhere in the download of
    `wide_image`, every kind of request fault. Among them, once, {30: dup 0.017 s, 33: dup
    0.119 s, 52: dup 0.064 s}: the copy of request 52 and request 53 reached the device in
    one read, its RTU server used up the read for the copy and lost request 53, and the
    copy's answer stood in for it (docs/flash-faults.md)."""
    image = wide_image()
    face = device()
    outcome = flash_relayed("rtu", face, scheduled(actions), image)
    assert_truthful(face, image, outcome.report)


DEVICE_FAULTS = st.sampled_from(["busy", "dpram-full", "refused", "failure", "address"])
"""What a device may answer instead of carrying a request out: busy (exception 6), ILLEGAL
FUNCTION with cause 0xC1 (DPRAM full) or with a cause of refusal (0x02, parameter out of
range), SLAVE DEVICE FAILURE (4), ILLEGAL DATA ADDRESS (2)."""


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(faults=st.dictionaries(st.integers(0, WIDE_REQUESTS + 12), DEVICE_FAULTS,
                              max_size=4))
def test_any_schedule_of_device_refusals_is_told_truthfully(faults: dict[int, str]) -> None:
    """The device's own answers, drawn in process (the link is not the point: no relay,
    no timeouts): any request of the download answered busy, DPRAM full, refused, failed or
    with a bad address, up to four of them. The report is the truth about the device, and
    a request the device refused never counts as carried out."""
    seen = [0]
    refused_frames: list[int] = []  # frames (FC16 at 8000) refused, not just delayed
    face: DeviceFace

    def interpose(function_code: int, address: int, _values: list[int] | None) -> int | None:
        index, seen[0] = seen[0], seen[0] + 1
        fault = faults.get(index)
        if fault is None:
            return None
        if (function_code, address) == (WRITE_REGISTERS, FRAME_WINDOW) and \
                fault not in ("busy", "dpram-full"):
            refused_frames.append(index)
        if fault in ("dpram-full", "refused"):
            face.controller.illegal_cause = 0xC1 if fault == "dpram-full" else 0x02
            return 1
        return {"busy": 6, "failure": 4, "address": 2}[fault]

    face = device(interpose)
    image = wide_image()

    async def scenario() -> FlashReport:
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        try:
            link = DeviceLink(Endpoint(host="127.0.0.1", port=port, timeout=TIMEOUT))
            return await Flasher(image, link, FlashOptions(busy_timeout=2.0)).run()
        finally:
            await stop(server)

    report = asyncio.run(scenario())
    assert_truthful(face, image, report)
    assert not (report.ok and refused_frames), (faults, refused_frames)


# ------------------------------------------------------------ finding 2: no half program
def test_tidy_up_retries_until_the_slot_is_empty() -> None:
    """The link is lost beyond the retries on one line (exit 10), and the first tidy-up
    attempts meet a device that answers nothing: the tidy-up retries with growing pauses
    until the download is closed and the slot empty."""
    image = job_image()
    line = image.programs[MP41].frames[3]
    gave_up = [0]
    silent = [0]

    def interpose(function_code: int, _address: int, values: list[int] | None) -> int | None:
        if values == line:
            gave_up[0] += 1
            return 0x06  # busy for good: the flash gives up on the frame
        if gave_up[0] and silent[0] < 3 and function_code == WRITE_REGISTERS:
            silent[0] += 1
            return 0x04  # the tidy-up's first frames fail
        return None

    face = device(interpose)
    outcome = flash_relayed("tcp", face, lambda _r: None, image,
                            FlashOptions(busy_timeout=0.2))
    assert outcome.report.outcome == "interrupted", outcome.report.error
    assert silent == [3]
    assert face.controller.state == "ready"
    assert stored(face, "mp", 41) == []
    assert "tidy-up failed" not in str(outcome.report.error)
    assert_truthful(face, image, outcome.report)


def test_tidy_up_that_cannot_finish_says_what_the_slot_holds() -> None:
    """A device that refuses every tidy-up frame: the message names the slot, how many of
    its lines it may hold, and the repair (flash again)."""
    image = job_image()
    line = image.programs[MP41].frames[3]
    gave_up = [False]

    def interpose(function_code: int, _address: int, values: list[int] | None) -> int | None:
        if values == line:
            gave_up[0] = True
            return 0x06
        if gave_up[0] and function_code == WRITE_REGISTERS:
            return 0x04
        return None

    face = device(interpose)
    outcome = flash_relayed("tcp", face, lambda _r: None, image,
                            FlashOptions(busy_timeout=0.2))
    error = str(outcome.report.error)
    assert outcome.report.outcome == "interrupted"
    assert "the tidy-up failed" in error
    assert "MP41 may hold the first 2 of its 6 lines" in error, error
    assert "Repair: run the flash again" in error
    assert face.controller.state == "mp"  # what the message warns of
    assert_truthful(face, image, outcome.report)
    face.interpose = None  # the link is fine again: the next flash repairs everything
    again = flash_relayed("tcp", face, lambda _r: None, image)
    assert again.report.ok, again.report.error
    assert_truthful(face, image, again.report)
    assert_runs(face)


def running_device() -> DeviceFace:
    face = device()
    running = compile_source("MP 1\n    TIMER 100000\nEND MP\n", "running.mp")
    assert face.controller.load_frames("mp", 1, running.programs[0].frames) is None
    face.controller.call(1)
    return face


def test_running_program_is_stopped_only_with_consent() -> None:
    """RTC MP_TERMINATE (9.11) with `stop_running`: the flash notes it and verifies all."""
    image = job_image()
    face = running_device()
    outcome = flash_relayed("tcp", face, lambda _r: None, image,
                            FlashOptions(stop_running=True))
    assert outcome.report.ok, outcome.report.error
    assert "stopped MP1 (MP_TERMINATE), as asked" in outcome.report.notes
    assert not face.controller.running
    assert_truthful(face, image, outcome.report)


def test_program_started_mid_flash_blocks_the_tidy_up_and_the_message_says_so() -> None:
    """After exit 8 the download is closed (storing part of MP41) and the slot cannot be
    emptied because a program started meanwhile (cause 0xC3): the message says so, what
    MP41 may hold and how to repair it."""
    image = job_image()
    target = image.programs[MP41].frames[4]
    face = device()
    running = compile_source("MP 1\n    TIMER 100000\nEND MP\n", "running.mp")
    assert face.controller.load_frames("mp", 1, running.programs[0].frames) is None

    def interpose(function_code: int, _address: int, values: list[int] | None) -> int | None:
        if values == target and not face.controller.running:
            face.controller.stack.clear()
            face.controller.state, pending = "ready", face.controller.pending
            face.controller.call(1)  # another client starts MP1 ...
            face.controller.state, face.controller.pending = "mp", pending
            return 0x04  # ... and the frame is refused
        return None

    face.interpose = interpose
    outcome = flash_relayed("tcp", face, lambda _r: None, image)
    error = str(outcome.report.error)
    assert outcome.report.outcome == "rejected"
    assert "will not empty it while MP1 runs (cause 0xc3)" in error, error
    assert "MP41 may hold the first 3 of its 6 lines" in error
    assert_truthful(face, image, outcome.report)


# ------------------------------------------------------- finding 3: a second client
def test_two_flashers_at_once_the_loser_names_the_other_client() -> None:
    """Two flashers against one device (4.16.1: one download at a time): one verifies,
    the other stops saying that another client is downloading, naming its program, never
    blaming a source line; no message reads None."""
    image = job_image()
    face = device()

    async def scenario() -> tuple[FlashReport, FlashReport]:
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        try:
            def run() -> asyncio.Future[FlashReport]:
                link = DeviceLink(Endpoint(host="127.0.0.1", port=port, timeout=TIMEOUT))
                return asyncio.ensure_future(Flasher(image, link).run())

            first = run()
            while face.controller.pending is None or face.controller.pending.slot != 41:
                await asyncio.sleep(0)
            second = run()
            return await first, await second
        finally:
            await stop(server)

    first, second = asyncio.run(scenario())
    winner, loser = (first, second) if first.ok else (second, first)
    assert winner.ok, (first.error, second.error)
    assert loser.outcome == "interrupted" and loser.where is None
    assert "another client is downloading" in str(loser.error), loser.error
    assert "cause 0x00" not in str(loser.error)
    for report in (first, second):
        assert all("None" not in text for text in messages(report))
    assert_truthful(face, image, winner)


def test_create_refused_during_another_clients_download_names_it() -> None:
    """Another client opens a download of MP60 just before this flash's create frame
    (which the device then refuses: an RTC command inside an MP download, 4.16.1) and
    closes it a moment later. The flash waits for that close and names MP60; it neither
    blames a source line nor touches the other client's program (whose download the device
    fails, as the refused create frame counts as one of its lines)."""
    image = job_image()
    face = device()
    vc = face.controller
    other_line = image.programs[MP41].frames[1]  # SET_V: one line for MP60
    first_create = image.programs[0].frames[0]
    opened: list[bool] = []

    def other_client_closes() -> None:
        assert vc.write_subfunction(other_line) == 0
        assert vc.write_subfunction(vc.encoder.close_frame("mp")) == 0

    def interpose(function_code: int, _address: int, values: list[int] | None) -> int | None:
        if values == first_create and not opened:
            opened.append(True)
            assert vc.write_subfunction(vc.encoder.create_frame("mp", 60)) == 0
            asyncio.get_running_loop().call_later(2 * TIMEOUT, other_client_closes)
        return None

    face.interpose = interpose
    outcome = flash_relayed("tcp", face, lambda _r: None, image)
    error = str(outcome.report.error)
    assert outcome.report.outcome == "interrupted" and outcome.report.where is None
    assert error.startswith("MP22 pause: the device refused the create frame: another client "
                            "is downloading MP60"), error
    assert "cause" not in error
    # The refused create frame is a line of MP60's download to the device, which cannot tell
    # clients apart: under the profile's `refused_line = "fails"` (docs/device-choices.md)
    # that download fails at its close and leaves MP60 empty; the flash touched nothing.
    refused_line = vc.profile.raw["download"]["refused_line"]
    assert stored(face, "mp", 60) == (None if refused_line == "fails" else [other_line])
    assert stored(face, "mp", 22) is None
    assert_truthful(face, image, outcome.report)


def test_state_names_never_read_none() -> None:
    """Register 100 outside the manual's 0/1/2 (4.16.2) is named by its value, and every
    message of the flash package names a state through `state_name` (the issue's "the
    device stays in None state" came from a dictionary lookup in an f-string)."""
    assert [state_name(v) for v in (0, 1, 2, 7)] == ["ready", "MP download", "ISR download",
                                                     "unknown state 7"]
    package = Path(flasher_module.__file__).parent
    for path in package.glob("*.py"):
        if path.name == "registers.py":  # where state_name is defined
            continue
        source = path.read_text()
        assert "STATES.get(" not in source and "STATES[" not in source, path.name

"""`mpc flash` download speed (printed, never asserted). `bench/flash.py [tcp] [rtu] [fleet]`
runs the parts named (default: all three).

Targets (issues 4, 16 and 28), each a ratio to a baseline measured in the same run; parts 1
and 2 also print one `ROW <name> <figure> <target> met|MISSED` line for `make bench`:

1. A full-device image (every MP and ISR slot filled to its line budget) over loopback Modbus
   TCP: total time at most 1.02 x the round trips of its own requests (issue 28; 1.3
   before). The baseline is the flash's own mix: every request the flash makes (its frames
   and its status reads, recorded once) sent again, each as one round trip through the same
   client (`DeviceLink`) to the same virtual device, and the link's opening. The device
   does the same work per request in both, so the ratio is the flasher's own overhead. The
   image is flashed in `TCP_PARTS` parts, each between two replays of its own requests, so
   the machine's drift within a run falls on flash and baseline alike (the figure: the
   median of `TCP_REPEATS` runs). Until issue 28's third round the baseline was N times
   the mean round trip of one 5-word SET_VAR frame; the flash's lines cost the device more
   than that frame, and its status reads more again, so that ratio held the device's work
   per request as well.
2. The same image over Modbus RTU at 115200 baud 8N1: at most 1.08 x the wire-time limit
   (issue 28; 1.15 before), the bytes of every request and answer on the line (start bit,
   8 data bits, parity and stop bits) plus a 3.5-character silence before each frame.
   Ptys ignore the baud rate, so the line's time is computed (`ClockedLine`): the client
   (the real `DeviceLink` on one end of a pty pair) sends, the virtual device on the other
   end answers at once, and a clock of the line's own advances by each frame's bytes, the
   silence before it, and each end's measured time to answer where that is longer than the
   silence. Until issue 28's third round the line was waited out, on a relay thread that
   passed each chunk on when it would be through (`ptylink.Wire`): six wake-ups a request,
   each as late as a busy machine's run queue made it (the paced flash read 1.8-2.0x at a
   load average of 6-9, the computed line 1.12-1.16x in the same minutes). That flash is
   still run and printed, its relay in a process of its own with 1 ns timer slack.
3. Fleets of 20 and 100 devices served by one `mpc sim --devices 100` process, each
   flashed by one `mpc flash --fleet` command, against the same command for one device
   (issue 28): 20 devices at most 2x one, 100 at most 5x one (rows `fleet-20`, `fleet-100`).
   The image is the samples build (18 programs, 788 frames). Over loopback TCP nothing
   waits for a wire: every request costs CPU in the flashing process and in the serving
   one, so on 2 cores the ratio grows with the fleet's requests once they outweigh the
   command's fixed cost (start-up, build), whatever the flasher's concurrency. The CPU
   seconds of both processes per device are printed beside the figure: they say which side
   a miss is on.
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mplang.family.ptylink import PtyLink, Wire
from mplang.ir import catalogue
from mplang.m8194h.compiler import compile_paths, compile_source
from mplang.m8194h.flash import Flasher, FlashImage, FlashReport, flash, image_from_build
from mplang.m8194h.modbus import DeviceLink, Endpoint
from mplang.m8194h.modbus_server import (
    DeviceFace,
    DirectServe,
    SimClock,
    rtu_frame_size,
    serve_rtu,
    serve_tcp,
    stop,
)
from mplang.m8194h.sim.controller import VirtualController

ROOT = Path(__file__).resolve().parent.parent
BAUD = 115200
BITS_PER_CHAR = 10  # 8N1: start + 8 data + stop (parity or a second stop bit: 11)
GAP_CHARS = 3.5  # the silence that ends an RTU frame
REPEATS = 3  # the fleet's one device: the best of this many runs
TCP_REPEATS = 5  # TCP: the median of this many runs (a run takes 3 phases of about 1.5 s)
TCP_PARTS = 12  # TCP: a run flashes the image in this many parts, each between its replays
TCP_TARGET = 1.02  # flash / N x one frame's round trip (issue 28)
RTU_TARGET = 1.08  # flash / the wire-time limit at 115200 baud (issue 28)
FLEET = 20
# Body lines that run in MP and ISR slots alike, one slot line each, frames of 3 to 7 words.
BODY = ["  VAR{v} = VAR1 + {k}", "  SET_V X, {speed}", "  VAR{v} = {k}"]


# ---------------------------------------------------------------------------- the images
def row(name: str, ratio: float, target: float) -> None:
    """The figure in the one-line shape `make bench` collects."""
    print(f"ROW {name} {ratio:.3f}x <={target:g}x {'met' if ratio <= target else 'MISSED'}")


def full_device_source() -> str:
    """Every MP and ISR slot, each filled to its line budget (the close line included)."""
    profile = catalogue.load().profile
    out: list[str] = []
    k = 0
    for kind in ("mp", "isr"):
        for slot in profile.slot_numbers(kind):
            out.append(f"{kind.upper()} {slot}")
            for _ in range((profile.budget(kind, slot) or 0) - 1):
                out.append(BODY[k % 3].format(v=k % 400 + 2, k=k, speed=1000 + k % 5000))
                k += 1
            out.append(f"END {kind.upper()}")
    return "\n".join(out) + "\n"


def full_device_image() -> FlashImage:
    build = compile_source(full_device_source(), "full.mp")
    if not build.ok:
        raise SystemExit(f"the generated full-device source does not build: "
                         f"{build.diagnostics[0].render()}")
    image = image_from_build(build)
    profile = catalogue.load().profile
    slots = sum(len(profile.slot_numbers(kind)) for kind in ("mp", "isr"))
    lines = sum(profile.budget(p.kind, p.slot) or 0 for p in image.programs)
    assert len(image.programs) == slots and lines == sum(
        (profile.budget(kind, n) or 0) for kind in ("mp", "isr")
        for n in profile.slot_numbers(kind))
    return image


def samples_image() -> FlashImage:
    build = compile_paths(sorted((ROOT / "samples").glob("*.mp")))
    assert build.ok
    return image_from_build(build)


def frames_of(image: FlashImage) -> int:
    return sum(len(p.frames) for p in image.programs)


# --------------------------------------------------------------------------- the baseline
Request = tuple[str, tuple[int, ...]]  # ("frame", words) or ("input"/"holding", (address, count))


class RecordingLink(DeviceLink):
    """A `DeviceLink` that notes every request the flasher makes through it, in order: the
    flash's own mix of frames and reads, for the baseline to replay."""

    def __init__(self, endpoint: Endpoint) -> None:
        super().__init__(endpoint)
        self.requests: list[Request] = []

    async def write_frame(self, frame: list[int] | tuple[int, ...]) -> None:
        self.requests.append(("frame", tuple(frame)))
        await super().write_frame(frame)

    async def read_input(self, address: int, count: int) -> list[int]:
        self.requests.append(("input", (address, count)))
        return await super().read_input(address, count)

    async def read_holding(self, address: int, count: int) -> list[int]:
        self.requests.append(("holding", (address, count)))
        return await super().read_holding(address, count)

    async def write_holding(self, address: int, values: list[int]) -> None:
        raise AssertionError("the bench's flash writes no holding register but 8000")


async def flash_requests(parts: list[FlashImage]) -> list[list[Request]]:
    """The requests the flash of each part makes, in order, the parts flashed one after the
    other into one fresh device and recorded."""
    face = DeviceFace(VirtualController(), SimClock(1.0))
    server, port = await serve_tcp(face, "127.0.0.1", 0)
    recorded: list[list[Request]] = []
    try:
        for part in parts:
            link = RecordingLink(Endpoint(host="127.0.0.1", port=port))
            report = await Flasher(part, link).run()
            if not report.ok:
                raise SystemExit(f"the recorded flash failed: {report.error}")
            recorded.append(link.requests)
    finally:
        await stop(server)
    return recorded


@dataclass
class RoundTrip:
    seconds: float  # opening the link, and the requests' round trips, summed
    times: list[float]  # each request's round trip


async def replay(requests: list[Request], endpoint: Endpoint) -> RoundTrip:
    """The flash's own requests sent again through the same client (`DeviceLink`) to the
    same device, each a round trip timed on its own, and the link's opening (a flash opens
    its own): the device does the same work per request as in the flash (the same create,
    lines, close and status reads), so their sum is the flash's floor with nothing of the
    flasher's in it."""
    times: list[float] = []
    clock = time.perf_counter
    link = DeviceLink(endpoint)
    start = clock()
    await link.open()
    opened = clock() - start
    try:
        for kind, args in requests:
            if kind == "frame":
                start = clock()
                await link.write_frame(args)
            elif kind == "input":
                start = clock()
                await link.read_input(*args)
            else:
                start = clock()
                await link.read_holding(*args)
            times.append(clock() - start)
    finally:
        link.close()
    return RoundTrip(opened + sum(times), times)


@dataclass
class Timed:
    report: FlashReport
    seconds: float
    requests: int  # as the device counted them


async def timed_flash(image: FlashImage, endpoint: Endpoint, face: DeviceFace | None,
                      ) -> Timed:
    before = face.requests if face is not None else 0
    start = time.perf_counter()
    report = await flash(image, endpoint)
    seconds = time.perf_counter() - start
    if not report.ok:
        raise SystemExit(f"flash failed on {endpoint.describe()}: {report.error}")
    return Timed(report, seconds, (face.requests - before) if face is not None else 0)


def check_stored(face: DeviceFace, image: FlashImage) -> None:
    """The bench measures a correct download, not just a fast one."""
    for program in image.programs:
        table = face.controller.tables[(program.kind, program.slot)]
        assert [list(line.frame) for line in table.lines] == program.frames[1:-1]


# --------------------------------------------------------------------- 1: loopback TCP
def image_parts(image: FlashImage, count: int) -> list[FlashImage]:
    """`image` as `count` images of consecutive programs, together every program once."""
    size = -(-len(image.programs) // count)
    return [FlashImage(image.word_order, image.programs[k:k + size], image.build_id)
            for k in range(0, len(image.programs), size)]


async def over_tcp(image: FlashImage) -> None:
    """`TCP_REPEATS` runs, each on a fresh device. A run flashes the image in `TCP_PARTS`
    parts (consecutive programs), each part between two replays of its own requests, so a
    drift of the shared machine's speed falls on a part's flash and its baseline alike (a
    whole flash takes seconds, and the machine's speed moves within them); the run's ratio
    is its flashes' time against the mean of the replays around them, summed over the
    parts. The figure is the median run's."""
    parts = image_parts(image, TCP_PARTS)
    recorded = await flash_requests(parts)
    runs: list[tuple[float, float, float, list[float]]] = []  # ratio, flash, baseline, times
    requests = sum(len(r) for r in recorded)
    for _ in range(TCP_REPEATS):
        face = DeviceFace(VirtualController(), SimClock(1.0))
        server, port = await serve_tcp(face, "127.0.0.1", 0)
        endpoint = Endpoint(host="127.0.0.1", port=port)
        flashed = baseline = 0.0
        times: list[float] = []
        try:
            for part, part_requests in zip(parts, recorded, strict=True):
                before = await replay(part_requests, endpoint)
                run = await timed_flash(part, endpoint, face)
                after = await replay(part_requests, endpoint)
                if run.requests != len(part_requests):
                    raise SystemExit(f"the flash made {run.requests} requests, the recorded "
                                     f"one {len(part_requests)}: the replay is not its mix")
                flashed += run.seconds
                baseline += (before.seconds + after.seconds) / 2
                times += before.times + after.times
            check_stored(face, image)
        finally:
            await stop(server)
        runs.append((flashed / baseline, flashed, baseline, times))
    runs.sort(key=lambda r: r[0])
    ratio, flashed, baseline, times = runs[len(runs) // 2]
    frames = frames_of(image)
    print(f"full-device image over loopback TCP: {len(image.programs)} programs in "
          f"{len(parts)} flashes, {frames:,} frames and {requests - frames} reads = "
          f"{requests:,} requests in {flashed:.2f} s ({requests / flashed:,.0f} requests/s; "
          f"the median of {TCP_REPEATS} runs)")
    print(f"  baseline, each flash's own requests replayed through the same client, each a "
          f"round trip, before and after it: {baseline:.2f} s (median round trip "
          f"{statistics.median(times) * 1e6:.0f} us); flash = {ratio:.3f}x (target at most "
          f"{TCP_TARGET:g}x; the runs: {', '.join(f'{r[0]:.3f}x' for r in runs)})")
    row("flash-tcp", ratio, TCP_TARGET)


# ------------------------------------------------------------------------- 2: RTU wire
class TimedWire(Wire):
    """The paced line's timing (`ptylink.Wire`), also noting each end's answers: how long
    after the frame it answers was through (was due at the other end) it reached the line.
    That time holds the end's own work and its wake-ups, and the relay thread's lateness in
    handing the frame over; the line's silence before a frame hides the part up to it."""

    def __init__(self, baudrate: int) -> None:
        super().__init__(baudrate, BITS_PER_CHAR, GAP_CHARS)
        self.first_sender = -1  # the client speaks first
        self.answers: dict[str, list[float]] = {"client": [], "device": []}

    def deliver_at(self, sender: int, size: int, now: float) -> float:
        if self.first_sender < 0:
            self.first_sender = sender
        elif sender != self.last_sender:
            end = "client" if sender == self.first_sender else "device"
            self.answers[end].append(now - self.free_at)
        return super().deliver_at(sender, size, now)


def oversleep(seconds: float = 0.0015, samples: int = 200) -> float:
    """The median time a thread's `time.sleep(seconds)` overshoots here now: the relay
    hands each frame over that late, twice a request."""
    late: list[float] = []
    for _ in range(samples):
        start = time.monotonic()
        time.sleep(seconds)
        late.append(time.monotonic() - start - seconds)
    return statistics.median(late)


def precise_sleeps() -> None:
    """Let this process's sleeps end when asked: Linux wakes a sleeping thread up to its
    timer slack (50 us by default) late, on top of the scheduler's own lateness. Elsewhere,
    or without prctl, sleeps stay as they are (the figure says how late they wake)."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(29, 1, 0, 0, 0)  # PR_SET_TIMERSLACK: 1 ns
    except (OSError, AttributeError):
        pass


def relay(baud: int) -> None:
    """`bench/flash.py --relay BAUD`: a pty link in this process alone, paced as an RTU wire
    at BAUD (0: unpaced). Prints its two ends (device, client) on one line; when stdin
    closes, prints how late each end answered (`TimedWire.answers`) and how late this
    process's 1.5 ms sleeps wake, as JSON, and exits. In its own process the relay's
    wake-ups compete with neither the client's nor the device's Python for the GIL."""
    precise_sleeps()
    wire = TimedWire(baud) if baud else None
    line = PtyLink(wire)
    print(line.device_end, line.client_end, flush=True)
    sys.stdin.read()
    line.close()
    print(json.dumps({"answers": wire.answers if wire is not None else {},
                      "oversleep": oversleep()}), flush=True)


class RelayProcess:
    """A pty link served by `relay` in a process of its own: `device_end` and `client_end`
    as `PtyLink` has them; `close` ends it and returns what it measured."""

    def __init__(self, baud: int) -> None:
        self.proc = subprocess.Popen([sys.executable, __file__, "--relay", str(baud)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert self.proc.stdout is not None
        ends = self.proc.stdout.readline().split()
        if len(ends) != 2:
            self.proc.kill()
            raise SystemExit("the pty relay process did not start")
        self.device_end, self.client_end = ends

    def close(self) -> dict[str, Any]:
        out, _ = self.proc.communicate(timeout=30)
        measured: dict[str, Any] = json.loads(out)
        return measured


def rtu_request_bytes(registers: int) -> int:
    """FC16: address, function, start (2), count (2), byte count, data, CRC (2)."""
    return 9 + 2 * registers


def rtu_read_answer_bytes(registers: int) -> int:
    """FC3/FC4 answer: address, function, byte count, data, CRC (2)."""
    return 5 + 2 * registers


def wire_seconds(image: FlashImage, baud: int) -> tuple[float, int]:
    """The time the flash's requests and answers take on the wire, and their bytes: every
    frame (FC16 request, 8-byte answer); the word-order read and the running-program read
    at the start (holding registers 14 and 8); per program the state read before it
    (register 100), a read of register 100 between two frames of one length (the flasher's
    `_separate`) and the verification (registers 100-114); the final check (100-114)."""
    read_request = 8  # address, function, start (2), count (2), CRC (2)
    state = [read_request, rtu_read_answer_bytes(1)]
    status = [read_request, rtu_read_answer_bytes(15)]
    frames: list[int] = state * 2  # bytes of every frame on the line, requests and answers
    for program in image.programs:
        frames += state  # before the create
        for index, frame in enumerate(program.frames):
            if index and len(frame) == len(program.frames[index - 1]):
                frames += state
            frames += [rtu_request_bytes(len(frame)), 8]  # the FC16 answer: 8 bytes
        frames += status
    frames += status
    char_time = BITS_PER_CHAR / baud
    total_bytes = sum(frames)
    return (total_bytes + GAP_CHARS * len(frames)) * char_time, total_bytes


async def flash_over_rtu(image: FlashImage, line: RelayProcess) -> tuple[Timed,
                                                                          dict[str, Any]]:
    """The flash over `line`, on a fresh device; the run and what the relay measured."""
    face = DeviceFace(VirtualController(), SimClock(1.0))
    try:
        server = await serve_rtu(face, line.device_end, unit=1, baudrate=BAUD)
        try:
            run = await timed_flash(image, Endpoint(serial=line.client_end, baudrate=BAUD),
                                    face)
        finally:
            await stop(server)
    finally:
        measured = line.close()
    check_stored(face, image)
    return run, measured


class ClockedLine:
    """The virtual M8194H on the far side of one pty pair, with the line's time computed
    from the baud rate instead of waited out. Sleeps wake late on a busy machine (six
    wake-ups a request through a paced relay, each as late as the run queue makes it), and
    that lateness is the bench's, not the flash's. Here the device answers at once, and a
    clock of the line's own advances by what a real line takes: each frame's bytes, the
    3.5-character silence before it, and each end's own time to answer where it is longer
    than that silence, measured: the client's from the moment its answer was written to
    the moment its next request arrived, the device's from reading a whole request to
    having its answer. The device is `DirectServe.rtu`, the path `serve_rtu` serves a whole
    FC3, FC4 or FC16 request on, the same `DeviceFace.act`."""

    def __init__(self, face: DeviceFace, baud: int) -> None:
        import pty
        import tty

        self.master, self.slave = pty.openpty()
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        self.client_end = os.ttyname(self.slave)
        self.serve = DirectServe(face, 1)
        self.char = BITS_PER_CHAR / baud
        self.gap = GAP_CHARS * self.char
        self.buffer = b""
        self.line = 0.0  # the line's clock: when the last answer was through
        self.answered: float | None = None  # when the last answer was written (real time)
        self.first: float | None = None  # when the first request arrived (real time)
        self.answers: dict[str, list[float]] = {"client": [], "device": []}
        self.unserved = 0
        self.bytes = 0  # of every request and answer on the line
        asyncio.get_running_loop().add_reader(self.master, self._readable)

    def _readable(self) -> None:
        arrived = time.perf_counter()
        try:
            self.buffer += os.read(self.master, 4096)
        except BlockingIOError:
            return
        while (size := self._request_size()) and len(self.buffer) >= size:
            frame, self.buffer = self.buffer[:size], self.buffer[size:]
            answer = self.serve.rtu(frame)
            if answer is None:
                self.unserved += 1
                continue
            ready = time.perf_counter()
            client = 0.0 if self.answered is None else arrived - self.answered
            if self.first is None:
                self.first = arrived
            device = ready - arrived
            if self.answered is not None:
                self.answers["client"].append(client)
            self.answers["device"].append(device)
            self.line += max(client, self.gap) + len(frame) * self.char + \
                max(device, self.gap) + len(answer) * self.char
            self.bytes += len(frame) + len(answer)
            os.write(self.master, answer)
            self.answered = time.perf_counter()
            arrived = self.answered  # a second request of the same read waits for this one

    def _request_size(self) -> int:
        """The length of the request at the start of the buffer (0: not known yet)."""
        buffer = self.buffer
        if len(buffer) >= 2 and buffer[1] in (3, 4):
            return 8
        if len(buffer) >= 7 and buffer[1] == 16:
            return 9 + buffer[6]
        return rtu_frame_size(buffer)

    def close(self) -> None:
        asyncio.get_running_loop().remove_reader(self.master)
        os.close(self.master)
        os.close(self.slave)


async def flash_on_clocked_line(image: FlashImage) -> tuple[float, Timed, ClockedLine]:
    """The flash over a `ClockedLine`: its time with the line's clock in place of the
    wall clock between the first request and the last answer, the run and the line."""
    face = DeviceFace(VirtualController(), SimClock(1.0))
    line = ClockedLine(face, BAUD)
    try:
        run = await timed_flash(image, Endpoint(serial=line.client_end, baudrate=BAUD), face)
    finally:
        line.close()
    if line.unserved or line.first is None or line.answered is None:
        raise SystemExit(f"the clocked line left {line.unserved} requests unanswered")
    check_stored(face, image)
    seconds = run.seconds - (line.answered - line.first) + line.line
    return seconds, run, line


def percentiles(times: list[float]) -> str:
    times = sorted(times)
    n = len(times)
    return (f"median {times[n // 2] * 1e6:.0f} us, p10 {times[n // 10] * 1e6:.0f} us, p90 "
            f"{times[n * 9 // 10] * 1e6:.0f} us, p99 {times[n * 99 // 100] * 1e6:.0f} us")


async def over_rtu(image: FlashImage) -> None:
    limit, total_bytes = wire_seconds(image, BAUD)
    seconds, run, line = await flash_on_clocked_line(image)
    if line.bytes != total_bytes:
        raise SystemExit(f"the flash put {line.bytes} bytes on the line, the wire-time limit "
                         f"counts {total_bytes}")
    print(f"full-device image over Modbus RTU at {BAUD} baud 8N1 (a pty pair, the line's time "
          f"computed from the baud rate): {run.requests:,} requests in {seconds:.2f} s of "
          f"line time ({run.seconds:.2f} s of wall time, the line not waited out)")
    print(f"  wire-time limit: {total_bytes:,} bytes + 3.5-character gaps = {limit:.2f} s; "
          f"flash = {seconds / limit:.3f}x the wire time (target at most {RTU_TARGET:g}x)")
    row("flash-rtu-115200", seconds / limit, RTU_TARGET)
    gap = GAP_CHARS * BITS_PER_CHAR / BAUD
    print(f"  each end's time to answer (the line's {gap * 1e6:.0f} us silence hides what is "
          f"shorter; what is longer is the excess):")
    for end, times in line.answers.items():
        beyond = sum(max(0.0, t - gap) for t in times)
        print(f"    {end}: {percentiles(times)}; beyond the silence {beyond:.2f} s in all")
    paced, measured = await flash_over_rtu(image, RelayProcess(BAUD))
    print(f"  the same flash waited out on a paced pty relay (its own process): "
          f"{paced.seconds:.2f} s = {paced.seconds / limit:.3f}x; the relay's sleeps woke "
          f"{float(measured['oversleep']) * 1e6:.0f} us late (median), and each end answered "
          f"after what it answers was through:")
    for end, times in measured["answers"].items():
        print(f"    {end}: {percentiles(times)}")


# ---------------------------------------------------------------------------- 3: fleet
FLEET_TARGETS = {20: 2.0, 100: 5.0}  # N devices at most this many times one (issue 28)
FLEET_TIMEOUT = "10"  # seconds: one process serves every device, an answer may wait for N-1


def serve_fleet(count: int) -> tuple[subprocess.Popen[str], list[int]]:
    """`mpc sim --devices COUNT` (one process, consecutive ports from any free one): the
    process and the ports it prints."""
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "sim", "--tcp", "127.0.0.1:0",
                             "--devices", str(count)], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    ports: list[int] = []
    for line in proc.stdout:
        if "Modbus TCP on" in line:
            ports.append(int(line.rsplit(":", 1)[1].split()[0]))
            if len(ports) == count:
                return proc, ports
    raise SystemExit(f"mpc sim --devices {count} did not start")


@dataclass
class FleetRun:
    seconds: float  # wall, the whole command
    flash_cpu: float  # CPU seconds of the flashing process (0: not measured here)
    sim_cpu: float  # CPU seconds of the serving process meanwhile (0: not measured here)


def cpu_of(pid: int) -> float:
    """CPU seconds (user and system) process `pid` has used: /proc where there is one."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def children_cpu() -> float:
    """CPU seconds of this process's waited-for children (0 where `resource` is missing)."""
    try:
        import resource
    except ImportError:
        return 0.0
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def flash_fleet_process(ports: list[int], folder: Path, sim: int) -> FleetRun:
    """`mpc flash samples/*.mp --fleet FILE --force` over these devices, as a user runs it
    (the process, its build and its flashers on one asyncio loop), served by process
    `sim`: its wall seconds and both processes' CPU seconds."""
    fleet = folder / f"fleet-{len(ports)}.toml"
    fleet.write_text("".join(f'[targets.d{k}]\ntcp = "127.0.0.1:{port}"\n'
                             for k, port in enumerate(ports)))
    samples = sorted(str(p) for p in (ROOT / "samples").glob("*.mp"))
    flash_before, sim_before = children_cpu(), cpu_of(sim)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "mplang", "flash", *samples, "--fleet",
                           str(fleet), "--force", "--timeout", FLEET_TIMEOUT, "--record",
                           str(folder / "record.json")], capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"mpc flash --fleet ({len(ports)} devices) failed "
                         f"(exit {done.returncode}): {done.stderr[-2000:]}")
    return FleetRun(seconds, children_cpu() - flash_before, cpu_of(sim) - sim_before)


def over_a_fleet(image: FlashImage) -> None:
    """One `mpc sim --devices` process serves every device; `mpc flash --fleet` flashes the
    first N of them, after the same command for one device (both best of `REPEATS` for
    one and of one run for the fleets, the flash record forced off by --force)."""
    largest = max(FLEET_TARGETS)
    proc, ports = serve_fleet(largest)
    try:
        with tempfile.TemporaryDirectory() as folder:
            one = min((flash_fleet_process(ports[:1], Path(folder), proc.pid)
                       for _ in range(REPEATS)), key=lambda run: run.seconds)
            print(f"fleets flashed by `mpc flash --fleet` (samples image: "
                  f"{len(image.programs)} programs, {frames_of(image)} frames each), the "
                  f"devices served by one `mpc sim --devices {largest}` process; one device "
                  f"{one.seconds:.2f} s (the whole command, best of {REPEATS}; CPU "
                  f"{one.flash_cpu:.2f} s flashing, {one.sim_cpu:.2f} s serving):")
            for count, target in FLEET_TARGETS.items():
                many = flash_fleet_process(ports[:count], Path(folder), proc.pid)
                ratio = many.seconds / one.seconds
                extra = count - 1  # CPU per device beyond the first: what the fleet adds
                print(f"  {count} devices: {many.seconds:.2f} s = {ratio:.2f}x one (target at "
                      f"most {target:g}x); CPU per further device "
                      f"{(many.flash_cpu - one.flash_cpu) / extra * 1e3:.0f} ms flashing, "
                      f"{(many.sim_cpu - one.sim_cpu) / extra * 1e3:.0f} ms serving")
                print(f"ROW fleet-{count} {ratio:.2f}x <={target:g}x "
                      f"{'met' if ratio <= target else 'MISSED'}")
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=60)


async def main(parts: set[str]) -> None:
    if "tcp" in parts:
        await over_tcp(full_device_image())
    if "rtu" in parts:
        await over_rtu(full_device_image())
    if "fleet" in parts:
        over_a_fleet(samples_image())


if __name__ == "__main__":
    if sys.argv[1:2] == ["--relay"]:
        relay(int(sys.argv[2]))
        raise SystemExit(0)
    PARTS = {"tcp", "rtu", "fleet"}
    chosen = set(sys.argv[1:]) or PARTS
    if not chosen <= PARTS:
        raise SystemExit(f"usage: bench/flash.py [{' '.join(sorted(PARTS))}]")
    asyncio.run(main(chosen))

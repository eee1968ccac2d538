"""`mpc flash` against the virtual M8194H over real Modbus: loopback TCP and RTU over a pty
pair. Faults are injected where a real link has them: in the server's packet stream
(dropped answers, connection resets) and in the device's answers (busy, refusals)."""

from __future__ import annotations

import asyncio
import json
import signal
import socket
import subprocess
import sys
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path

import pytest
from click.testing import CliRunner
from simproc import start_sim

from mplang.cli import (
    EXIT_INTERRUPTED,
    EXIT_NO_DEVICE,
    EXIT_NO_INPUT,
    EXIT_OK,
    EXIT_REJECTED,
    EXIT_USAGE,
    main,
)
from mplang.family.ptylink import PtyLink
from mplang.m8194h.compiler import BuildResult, Options, compile_paths, compile_source
from mplang.m8194h.flash import (
    FlashImage,
    FlashOptions,
    FlashReport,
    ImageError,
    flash,
    image_from_build,
    image_from_json,
    load_image,
)
from mplang.m8194h.image import render_json
from mplang.m8194h.modbus import Endpoint
from mplang.m8194h.modbus_server import (
    DeviceFace,
    Interpose,
    PacketHook,
    Server,
    SimClock,
    drop_connections,
    serve_rtu,
    serve_tcp,
    stop,
)
from mplang.m8194h.run import run_build
from mplang.m8194h.sim.controller import VirtualController

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = sorted((ROOT / "samples").glob("*.mp"))
WRITE_REGISTERS = 16

# ARC_CW takes two slot lines, so the FOR sits on slot line 3 but is frame 3 of 1..n
ARCS = """MP 41 arcs
    SET_V XY, 1000
    ARC_CW 0, 1000, 0, 2000
    FOR 3
        VAR1 = VAR1 + 1
    NEXT
END MP
"""
ISR_JOB = """ISR 7 on_edge
    VAR5 = 1
    VAR6 = 2
END ISR
MP 22 pause
    TIMER 10
END MP
"""


@pytest.fixture(scope="module")
def samples_build() -> BuildResult:
    build = compile_paths(SAMPLES)
    assert build.ok and len(build.programs) == 18
    return build


def build_of(source: str, name: str = "job.mp") -> BuildResult:
    build = compile_source(source, name)
    assert build.ok, [d.render() for d in build.diagnostics]
    return build


def endpoint(port: int, **settings: float) -> Endpoint:
    timeout = float(settings.pop("timeout", 0.3))
    retries = int(settings.pop("retries", 3))
    return Endpoint(host="127.0.0.1", port=port, timeout=timeout, retries=retries)


@asynccontextmanager
async def tcp_device(face: DeviceFace, hook: PacketHook | None = None,
                     ) -> AsyncIterator[tuple[Server, int]]:
    server, port = await serve_tcp(face, "127.0.0.1", 0, trace_packet=hook)
    try:
        yield server, port
    finally:
        await stop(server)


def device(interpose: Interpose | None = None) -> DeviceFace:
    return DeviceFace(VirtualController(), SimClock(1.0), interpose)


def stored_frames(face: DeviceFace, kind: str, slot: int) -> list[list[int]]:
    return [list(line.frame) for line in face.controller.tables[(kind, slot)].lines]


def assert_all_stored(face: DeviceFace, image: FlashImage) -> None:
    """Exactly the image's lines are in every slot: none missing, none stored twice."""
    for program in image.programs:
        assert stored_frames(face, program.kind, program.slot) == program.frames[1:-1], \
            program.label
    assert face.controller.state == "ready"


def program_of(image: FlashImage, label: str) -> int:
    return next(n for n, p in enumerate(image.programs) if p.label.split()[-1] == label)


# ------------------------------------------------------------------------- success paths
def test_every_sample_downloads_verifies_and_runs_over_tcp(samples_build: BuildResult) -> None:
    image = image_from_build(samples_build)
    face = device()
    progress: list[str] = []

    async def scenario() -> FlashReport:
        async with tcp_device(face) as (_server, port):
            return await flash(image, endpoint(port), progress=progress.append)

    report = asyncio.run(scenario())
    assert report.ok and report.outcome == "verified", report.error
    assert [p.status for p in report.programs] == ["verified"] * 18
    assert all(p.download_status == [p.slot if p.kind == "mp" else 0,
                                     p.slot if p.kind == "isr" else 0, 0, 0, 0]
               for p in report.programs)
    assert progress[0] == f"{report.device}: 18 program(s), 788 frames"
    assert len(progress) == 19 and "MP156 nameplate_job: 413 frames verified" in progress[16]
    assert_all_stored(face, image)
    # the flashed device runs the job exactly as a directly loaded controller does
    expected = run_build(samples_build, "home_then_square").controller.snapshot()
    vc = face.controller
    slot = next(p.slot for p in image.programs if p.name == "home_then_square")
    vc.call(slot)
    outcome = vc.run()
    assert outcome.finished and outcome.error is None
    snapshot = vc.snapshot()
    assert snapshot["vars"] == expected["vars"] and snapshot["axes"] == expected["axes"]
    assert snapshot["vars"]


def test_every_sample_downloads_and_runs_over_rtu(samples_build: BuildResult) -> None:
    image = image_from_build(samples_build)
    face = device()

    async def scenario() -> FlashReport:
        with PtyLink() as link:
            server = await serve_rtu(face, link.device_end, unit=5)
            try:
                return await flash(image, Endpoint(serial=link.client_end, unit=5,
                                                   timeout=0.5))
            finally:
                await stop(server)

    report = asyncio.run(scenario())
    assert report.ok, report.error
    assert report.device.startswith("Modbus RTU") and "unit 5" in report.device
    assert_all_stored(face, image)
    expected = run_build(samples_build, "tour").controller.snapshot()
    vc = face.controller
    vc.call(next(p.slot for p in image.programs if p.name == "tour"))
    assert vc.run().finished
    assert vc.snapshot()["vars"] == expected["vars"] != {}


def test_image_json_round_trip_keeps_frames_and_source_lines(samples_build: BuildResult,
                                                              tmp_path: Path) -> None:
    path = tmp_path / "image.json"
    path.write_text(render_json(samples_build))
    loaded = load_image(path)
    direct = image_from_build(samples_build)
    assert loaded.word_order == 0 and loaded.build_id == samples_build.build_id()
    assert [(p.kind, p.slot, p.name, p.source, p.frames, p.lines) for p in loaded.programs] \
        == [(p.kind, p.slot, p.name, p.source, p.frames, p.lines) for p in direct.programs]


# ---------------------------------------------------------------------- device refusals
def test_download_error_names_the_source_line_and_nothing_is_stored() -> None:
    image = image_from_build(build_of(ARCS + ISR_JOB))
    arcs = image.programs[program_of(image, "arcs")]
    next_at = next(k for k, f in enumerate(arcs.frames) if f == [0x0CD6])  # NEXT
    del arcs.frames[next_at], arcs.lines[next_at]
    face = device()

    async def scenario() -> FlashReport:
        async with tcp_device(face) as (_server, port):
            return await flash(image, endpoint(port))

    report = asyncio.run(scenario())
    assert report.outcome == "rejected" and not report.ok
    assert report.where == "job.mp:4"  # the FOR that NEXT should have closed
    assert "download error 0x0a (FOR not closed by NEXT) at slot line 3 (FOR)" in \
        str(report.error)
    statuses = {p.label: p.status for p in report.programs}
    assert statuses["MP41 arcs"] == "rejected"
    assert ("mp", 41) not in face.controller.tables and face.controller.state == "ready"
    assert "pending" in statuses.values()  # programs after the refused one were not sent


def test_refused_frame_gives_the_cause_in_words_and_leaves_no_half_program() -> None:
    mp = image_from_build(build_of(ISR_JOB))
    isr = mp.programs[program_of(mp, "on_edge")]
    timer = mp.programs[program_of(mp, "pause")].frames[1]  # TIMER: MP only
    isr.frames[2] = timer  # VAR6 = 2 becomes a TIMER line
    face = device()

    async def scenario() -> FlashReport:
        async with tcp_device(face) as (_server, port):
            return await flash(mp, endpoint(port))

    report = asyncio.run(scenario())
    assert report.outcome == "rejected"
    assert report.where == "job.mp:3"
    assert "refused frame 2 (TIMER" in str(report.error)
    assert "ILLEGAL FUNCTION, cause 0x05 (MP-only command inside an ISR download)" in \
        str(report.error)
    # the download was closed and the slot emptied: VAR5 = 1 alone is not left behind
    assert face.controller.state == "ready"
    assert face.controller.tables[("isr", 7)].lines == []


def test_word_order_mismatch_is_refused_or_rebuilt_or_set() -> None:
    source = "MP 21\n    VAR1 = 123456\nEND MP\n"
    image = image_from_build(build_of(source))  # word order 0

    def rebuild(order: int) -> FlashImage:
        return image_from_build(compile_source(source, "job.mp", Options(word_order=order)))

    def run_mp21(vc: VirtualController) -> int:
        vc.call(21)
        assert vc.run().finished
        value, vc.vars[1] = vc.vars[1], 0
        return value

    async def scenario() -> tuple[list[FlashReport], list[int], VirtualController]:
        vc = VirtualController(word_order=1)
        async with tcp_device(DeviceFace(vc, SimClock(1.0))) as (_server, port):
            refused = await flash(image, endpoint(port))
            stored_after_refusal = len(vc.tables)
            rebuilt = await flash(image, endpoint(port), FlashOptions(rebuild=rebuild))
            value_rebuilt = run_mp21(vc)
            set_ = await flash(image, endpoint(port), FlashOptions(set_word_order=True))
            value_set = run_mp21(vc)
        return [refused, rebuilt, set_], [stored_after_refusal, value_rebuilt, value_set], vc

    (refused, rebuilt, set_), values, vc = asyncio.run(scenario())
    assert refused.outcome == "rejected" and "--set-word-order" in str(refused.error)
    assert rebuilt.ok and rebuilt.word_order == 1 and "built for it" in rebuilt.notes[0]
    assert set_.ok and vc.word_order == 0 and "from 1 to 0" in set_.notes[0]
    assert values == [0, 123456, 123456]


# ---------------------------------------------------------------------- recoverable faults
def test_device_left_in_download_state_is_closed_and_the_stray_slot_emptied() -> None:
    image = image_from_build(build_of(ARCS))
    face = device()
    vc = face.controller
    encoder = vc.encoder
    # an earlier session died inside MP5's download, after one line
    assert vc.write_subfunction(encoder.create_frame("mp", 5)) == 0
    assert vc.write_subfunction(image.programs[0].frames[1]) == 0
    assert vc.state == "mp"

    async def scenario() -> list[FlashReport]:
        async with tcp_device(face) as (_server, port):
            first = await flash(image, endpoint(port))
            # ... and one that died inside the very program being flashed
            assert vc.write_subfunction(image.programs[0].frames[0]) == 0
            assert vc.write_subfunction(image.programs[0].frames[1]) == 0
            second = await flash(image, endpoint(port))
            return [first, second]

    first, second = asyncio.run(scenario())
    assert first.ok and second.ok
    assert "the device was in MP download state" in first.notes[0] and "(MP5)" in first.notes[0]
    assert first.notes[1] == "MP5 held a truncated program: emptied it"
    assert vc.tables[("mp", 5)].lines == []
    assert len(second.notes) == 1 and "(MP41)" in second.notes[0]
    assert_all_stored(face, image)


def test_busy_device_gets_the_same_frame_again() -> None:
    image = image_from_build(build_of(ARCS))
    target = image.programs[0].frames[2]
    refusals = [0x06, 0x06, 0x06, 0x01, 0x01]  # busy, then "DPRAM full" (cause 0xC1)
    face: DeviceFace

    def busy(function_code: int, address: int, values: list[int] | None) -> int | None:
        if function_code == WRITE_REGISTERS and address == 8000 and values == target \
                and refusals:
            code = refusals.pop(0)
            if code == 0x01:
                face.controller.illegal_cause = 0xC1
            return code
        return None

    face = device(interpose=busy)

    async def scenario() -> FlashReport:
        async with tcp_device(face) as (_server, port):
            return await flash(image, endpoint(port))

    report = asyncio.run(scenario())
    assert report.ok, report.error
    assert report.programs[0].busy_waits == 5 and report.programs[0].downloads == 1
    assert refusals == [] and [r.code for r in face.refusals] == [6, 6, 6, 1, 1]
    assert_all_stored(face, image)


def test_device_that_stays_busy_interrupts_the_flash() -> None:
    image = image_from_build(build_of(ARCS))
    face = device(interpose=lambda fc, address, values: 0x06 if fc == WRITE_REGISTERS
                  and values and values[0] != 0x0AC9 else None)

    async def scenario() -> FlashReport:
        async with tcp_device(face) as (_server, port):
            return await flash(image, endpoint(port), FlashOptions(busy_timeout=0.3))

    report = asyncio.run(scenario())
    assert report.outcome == "interrupted" and "stayed busy" in str(report.error)
    assert report.programs[0].status == "interrupted"


class Faults:
    """A server packet hook: after `after` FC16 requests, hit the next answer once, either
    dropping it (the client times out) or also resetting the connection."""

    def __init__(self, after: int, rtu: bool = False, reset: bool = False) -> None:
        self.after, self.rtu, self.reset = after, rtu, reset
        self.seen = 0
        self.armed = False
        self.fired = 0
        self.server: Server | None = None

    def __call__(self, sending: bool, data: bytes) -> bytes:
        function_code = data[1] if self.rtu else data[7] if len(data) > 7 else 0
        if not sending and function_code == WRITE_REGISTERS:
            self.seen += 1
            self.armed = self.seen == self.after
        elif sending and self.armed:
            self.armed = False
            self.fired += 1
            if self.reset and self.server is not None:
                drop_connections(self.server)
            return b""
        return data


@pytest.mark.parametrize("reset", [False, True], ids=["dropped answer", "connection reset"])
def test_link_fault_mid_program_downloads_it_again(samples_build: BuildResult,
                                                   reset: bool) -> None:
    image = image_from_build(samples_build)
    big = program_of(image, "nameplate_job")
    before = sum(len(p.frames) for p in image.programs[:big])
    faults = Faults(after=before + 200, reset=reset)  # inside MP156, after frame 199
    face = device()

    async def scenario() -> FlashReport:
        async with tcp_device(face, faults) as (server, port):
            faults.server = server
            return await flash(image, endpoint(port))

    report = asyncio.run(scenario())
    assert faults.fired == 1
    assert report.ok, report.error
    result = report.programs[big]
    assert result.downloads == 2 and [p.downloads for p in report.programs].count(2) == 1
    assert "downloading it again from its create frame" in report.notes[0]
    assert "the device was in MP download state" in report.notes[1]
    assert ("connection lost" if reset else "no answer within 0.3 s") in report.notes[0]
    assert_all_stored(face, image)  # frame 199 is stored once, not twice


def test_dropped_answer_over_rtu_downloads_the_program_again() -> None:
    image = image_from_build(build_of(ARCS + ISR_JOB))
    faults = Faults(after=3, rtu=True)
    face = device()

    async def scenario() -> FlashReport:
        with PtyLink() as link:
            server = await serve_rtu(face, link.device_end, unit=1, trace_packet=faults)
            try:
                return await flash(image, Endpoint(serial=link.client_end, timeout=0.3))
            finally:
                await stop(server)

    report = asyncio.run(scenario())
    assert faults.fired == 1 and report.ok, report.error
    assert report.programs[0].downloads == 2
    assert_all_stored(face, image)


def test_status_for_another_slot_is_not_taken_for_verification() -> None:
    image = image_from_build(build_of(ARCS))
    armed = [False]
    face: DeviceFace

    def forge(function_code: int, address: int, values: list[int] | None) -> int | None:
        if function_code == WRITE_REGISTERS and values == [0x0CCA]:
            armed[0] = True
        elif function_code == 4 and address == 100 and armed[0]:
            face.controller.download_status = (99, 0, 0, 0, 0)
        return None

    face = device(interpose=forge)

    async def scenario() -> FlashReport:
        async with tcp_device(face) as (_server, port):
            return await flash(image, endpoint(port))

    report = asyncio.run(scenario())
    assert report.outcome == "unverified" and "MP99/ISR0" in str(report.error)
    assert report.programs[0].status == "unverified"


ISR_ONLY = """ISR 7 on_edge
    VAR5 = 1
END ISR
"""


@pytest.mark.parametrize(("source", "forged", "named"), [
    (ARCS, (41, 7, 0, 0, 0), "MP41/ISR7"),  # the MP number right, the ISR number not 0
    (ISR_ONLY, (0, 99, 0, 0, 0), "MP0/ISR99"),  # the MP number right (0), the ISR wrong
], ids=["mp", "isr"])
def test_verification_compares_the_isr_number_as_well_as_the_mp_number(
        source: str, forged: tuple[int, ...], named: str) -> None:
    """Input registers 110 and 111 both name the slot just written: a status whose MP number
    matches but whose ISR number does not is another download's, never this one's."""
    image = image_from_build(build_of(source))
    program = image.programs[0]
    close = program.frames[-1]
    armed = [False]
    face: DeviceFace

    def forge(function_code: int, address: int, values: list[int] | None) -> int | None:
        if function_code == WRITE_REGISTERS and values == close:
            armed[0] = True
        elif function_code == 4 and address == 100 and armed[0]:
            face.controller.download_status = forged  # type: ignore[assignment]
        return None

    face = device(interpose=forge)

    async def scenario() -> FlashReport:
        async with tcp_device(face) as (_server, port):
            return await flash(image, endpoint(port))

    report = asyncio.run(scenario())
    assert report.outcome == "unverified", report.error
    assert named in str(report.error) and "not for this program" in str(report.error)
    assert report.programs[0].status == "unverified"


def test_a_status_changed_after_the_last_verification_fails_the_final_check() -> None:
    """The final check after the last program: the device must still show the download
    status the last verification read. A late close that reached it in between (here
    MP22's status appearing after MP41 verified, state still ready) makes the flash
    unverified, never a success."""
    image = image_from_build(build_of(ARCS))
    close = image.programs[-1].frames[-1]
    reads_after_close = [0, False]
    face: DeviceFace

    def late_close(function_code: int, address: int, values: list[int] | None) -> int | None:
        if function_code == WRITE_REGISTERS and values == close:
            reads_after_close[1] = True
        elif function_code == 4 and address == 100 and reads_after_close[1]:
            reads_after_close[0] += 1
            if reads_after_close[0] == 2:  # after the verification, before the final check
                face.controller.download_status = (22, 0, 0, 0, 0)
        return None

    face = device(interpose=late_close)

    async def scenario() -> FlashReport:
        async with tcp_device(face) as (_server, port):
            return await flash(image, endpoint(port))

    report = asyncio.run(scenario())
    assert reads_after_close[0] == 2
    assert report.outcome == "unverified", report.error
    assert "after the last verification the device changed" in str(report.error)
    assert "[22, 0, 0, 0, 0]" in str(report.error) and "[41, 0, 0, 0, 0]" in str(report.error)


def test_no_device_at_the_address_or_the_unit() -> None:
    image = image_from_build(build_of(ARCS))
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        closed_port = probe.getsockname()[1]

    async def scenario() -> tuple[FlashReport, FlashReport]:
        refused = await flash(image, endpoint(closed_port))
        with PtyLink() as link:
            server = await serve_rtu(device(), link.device_end, unit=1)
            try:  # a real RTU slave stays silent for another address
                silent = await flash(image, Endpoint(serial=link.client_end, unit=2,
                                                     timeout=0.2, retries=0))
            finally:
                await stop(server)
        return refused, silent

    refused, silent = asyncio.run(scenario())
    assert refused.outcome == silent.outcome == "no-device"
    assert "cannot connect" in str(refused.error) and "no answer" in str(silent.error)
    assert refused.programs[0].status == silent.programs[0].status == "pending"


# ------------------------------------------------------------------------- image checks
@pytest.mark.parametrize(("mutate", "message"), [
    (lambda d: d.update(format="mplang-image/9"), "format: expected \"mplang-image/1\""),
    (lambda d: d["target"].update(word_order=2), "target.word_order: must be 0 or 1"),
    (lambda d: d.update(programs=[]), "programs: must be a non-empty list"),
    (lambda d: d["programs"][0].update(slot=158), "programs[0].slot: 158 is not a MP slot"),
    (lambda d: d["programs"][0]["frames"][1].__setitem__(1, -1),
     "programs[0].frames[1][1]: -1 is not a 16-bit register value"),
    (lambda d: d["programs"][0]["frames"].__setitem__(0, [2761, 22]),
     "programs[0].frames[0]: must be the create frame [2761, 41] of MP41"),
    (lambda d: d["programs"][0]["frames"].insert(2, [3274]),
     "programs[0].frames[2]: a close frame before the last frame"),
    (lambda d: d["programs"][0].update(frame_lines=[1]), "programs[0].frame_lines: must list"),
    (lambda d: d["programs"].append(dict(d["programs"][0])), "programs[1]: MP41 is also "
     "programs[0]"),
])
def test_bad_images_are_refused_with_their_place(mutate: Callable[[dict[str, object]], None],
                                                 message: str) -> None:
    data = json.loads(render_json(build_of(ARCS)))
    mutate(data)
    with pytest.raises(ImageError) as info:
        image_from_json(data, "image.json")
    assert str(info.value).startswith("image.json: ") and message in str(info.value)


# ---------------------------------------------------------------------------- the CLI
def mpc(*args: str, timeout: float = 30) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=ROOT)


def test_cli_flashes_samples_rejects_bad_input_and_reports_no_device(tmp_path: Path) -> None:
    proc, port = start_sim("--duration", "90")
    try:
        ok = mpc("flash", "samples/*.mp", "--tcp", f"127.0.0.1:{port}", "--json")
        assert ok.returncode == EXIT_OK, ok.stderr
        summary = json.loads(ok.stdout)
        assert summary["ok"] and len(summary["programs"]) == 18
        assert {p["status"] for p in summary["programs"]} == {"verified"}
        assert ok.stderr.count(" frames verified (") == 18
        assert "18 program(s) written and verified on Modbus TCP" in ok.stderr

        tampered = json.loads(render_json(build_of(ARCS)))
        frames = tampered["programs"][0]["frames"]
        at = frames.index([0x0CD6])
        del frames[at], tampered["programs"][0]["frame_lines"][at]
        image = tmp_path / "tampered.json"
        image.write_text(json.dumps(tampered))
        rejected = mpc("flash", str(image), "--tcp", f"127.0.0.1:{port}")
        assert rejected.returncode == EXIT_REJECTED
        assert "\njob.mp:4: error: MP41 arcs: the device refused the program: " \
               "download error 0x0a (FOR not closed by NEXT)" in rejected.stderr
    finally:
        proc.terminate()
        proc.wait(10)

    broken = tmp_path / "broken.json"
    broken.write_text('{"format": "mplang-image/1",\n "target": {"word_order": 0},\n'
                      ' "programs": [{"kind": "mp", "slot": 21, "frames": [[2761, 21], '
                      '[3274, "x"]]}]}')
    bad = mpc("flash", str(broken), "--tcp", "127.0.0.1:1")
    assert bad.returncode == EXIT_NO_INPUT
    assert "programs[0].frames[1][1]: 'x' is not a 16-bit register value" in bad.stderr
    broken.write_text('{"format": "mplang-image/1",\n  oops}')
    bad = mpc("flash", str(broken), "--tcp", "127.0.0.1:1")
    assert bad.returncode == EXIT_NO_INPUT and "broken.json:2:3: not JSON" in bad.stderr

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        closed_port = probe.getsockname()[1]
    nobody = mpc("flash", "samples/tour.mp", "--tcp", f"127.0.0.1:{closed_port}")
    assert nobody.returncode == EXIT_NO_DEVICE and "cannot connect" in nobody.stderr
    for result in (ok, rejected, bad, nobody):
        assert "Traceback" not in result.stdout + result.stderr


def test_cli_interrupted_by_sigterm_exits_with_its_own_code() -> None:
    with PtyLink() as link:  # nobody answers on the other end
        proc = subprocess.Popen([sys.executable, "-m", "mplang", "flash", "samples/tour.mp",
                                 "--serial", link.client_end, "--timeout", "30"], cwd=ROOT,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert proc.stderr is not None
        assert "Modbus RTU" in proc.stderr.readline()  # started: the first request waits
        time.sleep(0.2)
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=10)
    assert proc.returncode == EXIT_INTERRUPTED, err
    assert "interrupted" in err and "0 of 2 program(s) written and verified" in err
    assert "Traceback" not in out + err


def test_cli_dry_run_and_usage() -> None:
    runner = CliRunner()
    dry = runner.invoke(main, ["flash", str(ROOT / "samples/tour.mp"), "--dry-run"])
    assert dry.exit_code == EXIT_OK
    lines = dry.stdout.splitlines()
    assert lines[0].startswith("; mpc flash --dry-run: 2 programs, 21 frames")
    assert any("MP_CREATE            0AC9 0064" in line and line.endswith("tour.mp:6")
               for line in lines)
    plan = json.loads(runner.invoke(main, ["flash", str(ROOT / "samples/tour.mp"),
                                           "--dry-run", "--json"]).stdout)
    assert [p["slot"] for p in plan["programs"]] == [1, 100]
    assert runner.invoke(main, ["flash", str(ROOT / "samples/tour.mp")]).exit_code == EXIT_USAGE
    both = runner.invoke(main, ["flash", str(ROOT / "samples/tour.mp"), "--tcp", "h",
                                "--serial", "/dev/null"])
    assert both.exit_code == EXIT_USAGE
    port = runner.invoke(main, ["flash", str(ROOT / "samples/tour.mp"), "--tcp", "h:http"])
    assert port.exit_code == EXIT_USAGE and "HOST:PORT" in port.stderr

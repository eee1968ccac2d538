"""`mpc flash` of the configuration blocks against the virtual M8194H over real Modbus TCP:
the INIT block reaches the initial table and is loaded (input register 101 = 5), the
TRIGGERS block switches FRnet DI triggering on (holding register 9), refusals and a device
that never finishes loading are reported at the source line."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import pytest

from mplang.m8194h.compiler import BuildResult, compile_paths, compile_source
from mplang.m8194h.flash import (
    CHIP_STATE_REGISTER,
    FlashReport,
    ImageError,
    flash,
    image_from_build,
    image_from_json,
    plan_json,
    render_plan,
)
from mplang.m8194h.image import render_json
from mplang.m8194h.modbus import Endpoint
from mplang.m8194h.modbus_server import DeviceFace, Server, SimClock, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController

ROOT = Path(__file__).resolve().parents[2]
CONTROLLER_SAMPLE = ROOT / "samples" / "controller" / "controller.mp"


@pytest.fixture(scope="module")
def sample() -> BuildResult:
    build = compile_paths([CONTROLLER_SAMPLE])
    assert build.ok, [d.render() for d in build.diagnostics]
    return build


@asynccontextmanager
async def tcp_device(face: DeviceFace) -> AsyncIterator[tuple[Server, int]]:
    server, port = await serve_tcp(face, "127.0.0.1", 0)
    try:
        yield server, port
    finally:
        await stop(server)


def flash_to(face: DeviceFace, build: BuildResult) -> tuple[FlashReport, list[str]]:
    image = image_from_build(build)
    progress: list[str] = []

    async def scenario() -> FlashReport:
        async with tcp_device(face) as (_server, port):
            return await flash(image, Endpoint(host="127.0.0.1", port=port, timeout=0.5,
                                               retries=2), progress=progress.append)

    return asyncio.run(scenario()), progress


def test_init_and_triggers_are_downloaded_loaded_and_enabled(sample: BuildResult) -> None:
    face = DeviceFace(VirtualController(), SimClock(1.0))
    report, progress = flash_to(face, sample)
    assert report.ok, report.error
    assert report.init is not None and report.init.status == "verified"
    assert report.init.detail == f"input register {CHIP_STATE_REGISTER} = 5"
    assert report.triggers is not None and report.triggers.status == "verified"
    assert any(line.startswith("INIT: 9 frames written") for line in progress)
    assert any("FRnet DI triggering enabled" in line for line in progress)
    assert any("EzMove" in note for note in report.notes)
    data = report.to_json()
    assert data["init"]["status"] == "verified"  # type: ignore[index]
    assert data["triggers"]["status"] == "verified"  # type: ignore[index]
    registers = face.registers
    assert registers.read_input(CHIP_STATE_REGISTER, 1) == [5]
    assert registers.read_holding(9, 1) == [1]


def test_a_refused_init_frame_is_reported_at_its_source_line() -> None:
    build = compile_source("INIT\n    SET_MAX_V XY, 200000\n    SERVO_ON X\nEND INIT\n"
                           "MP 1\n    VAR1 = 1\nEND MP\n", "config.mp")
    def refuse_servo(function_code: int, address: int, values: list[int] | None) -> int | None:
        """SERVO_ON sent at 8000: exception 0x03 (illegal data value)."""
        if function_code == 16 and address == 8000 and values and values[0] == 0x0A15:
            return 0x03
        return None

    face = DeviceFace(VirtualController(), SimClock(1.0), refuse_servo)
    report, _progress = flash_to(face, build)
    assert not report.ok and report.outcome == "rejected"
    assert report.init is not None and report.init.status == "rejected"
    assert report.where == "config.mp:3"
    assert "INIT: the device refused frame 1" in (report.error or "")
    assert report.programs[0].status == "verified"


def test_image_json_round_trip_keeps_init_and_triggers(sample: BuildResult) -> None:
    image = image_from_json(json.loads(render_json(sample)), "image.json")
    direct = image_from_build(sample)
    assert image.init is not None and direct.init is not None
    assert image.init.frames == direct.init.frames and image.init.lines == direct.init.lines
    assert image.triggers is not None and direct.triggers is not None
    assert image.triggers.entries == direct.triggers.entries
    plan = render_plan(image)
    assert "\nINIT  (" in plan and "LOAD_INITIAL" in plan
    assert "TRIGGERS  write holding register 9 = 1" in plan
    as_json = plan_json(image)
    assert as_json["triggers"] == {"register": 9, "value": 1,  # type: ignore[comparison-overlap]
                                   "entries": direct.triggers.entries}


@pytest.mark.parametrize(("change", "message"), [
    (lambda d: d["init"].update(frames=[[0x0A4E, 0x11, 0], [0x0AC8]]),
     "init.frames[0]: 0x0a4e is not a command that writes the initial table"),
    (lambda d: d["init"].update(frames=[[0x0A0D, 0x03, 0, 8000], [0x0AC8]]),
     "init.frames[0][1]: must be an INITIAL_* axis code"),
    (lambda d: d["init"].update(frames=[[0x0A15, 0x11]]),
     "init.frames[0]: must be LOAD_INITIAL [2760]"),
    (lambda d: d["init"].update(frames=[[0x0A15, 0x11], [0x0AC8], [0x0A15, 0x11]]),
     "init.frames[1]: 0x0ac8 is not a command that writes the initial table"),
    (lambda d: d["init"].update(frames=[[0x0A15, 70000], [0x0AC8]]),
     "init.frames[0][1]: 70000 is not a 16-bit register value"),
    (lambda d: d["triggers"].update(enabled="yes"), "triggers.enabled: must be true or false"),
    (lambda d: d["triggers"].update(entries={}), "triggers.entries: must be a list of objects"),
])
def test_bad_configuration_in_an_image_is_named(sample: BuildResult, change: object,
                                                message: str) -> None:
    data = json.loads(render_json(sample))
    change(data)  # type: ignore[operator]
    with pytest.raises(ImageError) as caught:
        image_from_json(data, "image.json")
    assert message in str(caught.value)

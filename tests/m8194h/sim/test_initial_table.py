"""The initial parameter table of the virtual M8194H (manual chapter 8, Table 5, register 101).

Every expectation comes from the manual: Table 5 codes write the table "without changing
the current setting" (RS 983), LOAD_INITIAL applies it (RS 9733-9738), register 101 shows 4
while the table is called and 5 when it is done (RS 11368), MAX_V fixes the speed resolution
MAX_V / 8000 (RS 1146), and "the last setting will be retained" (RS 9725).
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable, Callable
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymodbus.client import AsyncModbusTcpClient
from simproc import start_sim

from mplang.ir import catalogue
from mplang.ir.catalogue import Command
from mplang.ir.macro import MacroLine, Operand, VarRef
from mplang.lang.diagnostics import Span
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.encode import Encoder
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.initial_table import (
    COLUMN_FIELDS,
    LIVE_UPDATES,
    UNMODELLED,
    UPDATES,
    AxisColumn,
    InitialTable,
    commands_for,
    live_columns,
)
from mplang.m8194h.sim.registers import ILLEGAL_FUNCTION, Refusal, RegisterMap
from mplang.m8194h.sim.service import (
    Endpoints,
    ServiceError,
    SimOptions,
    load_memory,
    preload,
    serve,
)

CAT = catalogue.load()
ENC = Encoder(CAT)
IT_COMMANDS = [c for c in CAT.commands if "it" in c.scope]
INITIAL = 0x10  # Table 5 = Table 4 + 0x10 (RS 981-988)
X, Y, XY, Z, U, XYZU = 1, 2, 3, 4, 8, 15


def rtc(name: str, *operands: Operand) -> list[int]:
    """The FC16 frame of a real-time command, built by the encoder from the catalogue."""
    return ENC.frame(MacroLine(CAT.by_vendor["RSM_" + name], operands, Span("test", 1)))


def settle(vc: VirtualController) -> None:
    """Run the controller until its FIFO and any table loading are done."""
    vc.advance(vc.clock + 1.0, until_idle=True)


def send(vc: VirtualController, *frames: list[int]) -> None:
    for frame in frames:
        assert vc.write_subfunction(frame) == 0, frame
    settle(vc)


def run_fifo(vc: VirtualController) -> None:
    """Run just past the due time of the last queued real-time command."""
    vc.advance(vc.fifo[-1].due + 1e-6)


def constant_move_seconds(vc: VirtualController, speed: int, pulses: int) -> float:
    """How long a constant-speed move (SV = V) of X takes now: it shows the speed
    resolution MAX_V / 8000 in force (RS 1146)."""
    send(vc, rtc("SET_SV", X, speed), rtc("SET_V", X, speed), rtc("FIXED_MOVE", X, pulses))
    start = vc.clock
    end = vc.motion.idle_at(X, vc.clock)
    assert end is not None
    vc.advance(end)
    return end - start


# ------------------------------------------------------------------------ factory table
def test_power_on_loads_the_factory_table_of_figure_3() -> None:
    vc = VirtualController()
    regs = RegisterMap(vc)
    factory = vc.initial_table.config.factory
    assert factory.max_v == 200_000  # the factory list's RSM_SET_MAX_V (RS 9705)
    assert (factory.slmt_enabled, factory.slmt_forward, factory.slmt_reverse) == \
        (0, 100_000, -100_000)  # software limits disabled, +-100000 on LP (RS 9681-9684)
    assert (factory.vring_enabled, factory.vring_max, factory.servo_on) == (0, 10_000, 0)
    assert vc.initial_table.columns == [factory] * 4
    assert live_columns(vc) == (factory,) * 4  # power on applied it (RS 9738)
    assert regs.read_input(101, 1) == [5]  # initialization finished (RS 11368)


def test_the_table_paths_cover_exactly_the_it_commands_of_table_1() -> None:
    assert set(UPDATES) == {c.short_name for c in IT_COMMANDS}
    assert all(c.params[0].kind == "axis_it" for c in IT_COMMANDS)
    updates = {**UPDATES, **LIVE_UPDATES}
    arity = {name: len(CAT.rtc_by_short[name].params) - 1 for name in updates}
    written = {field for name, update in updates.items() for field in update([0] * arity[name])}
    assert written == set(COLUMN_FIELDS)  # every setting has a command that writes it
    assert set(UNMODELLED) < set(COLUMN_FIELDS)
    assert not any("it" in CAT.rtc_by_short[name].scope for name in LIVE_UPDATES)


# ------------------------------------------------------------------- IT writes and load
def test_initial_x_max_speed_takes_effect_only_with_load_initial() -> None:
    vc = VirtualController()
    send(vc, rtc("SET_MAX_V", X, 8000))  # live: resolution 1 PPS
    slow = constant_move_seconds(vc, 1013, 10_130)
    assert slow == pytest.approx(10.0)  # 1013 PPS exactly
    send(vc, rtc("SET_MAX_V", INITIAL | X, 200_000))  # RSM_SET_MAX_V(hRsm, 1, INITIAL_X, ...)
    assert vc.initial_table.columns[0].max_v == 200_000
    assert vc.motion.settings[0].max_v == 8000  # "without changing the current setting"
    assert constant_move_seconds(vc, 1013, 10_130) == pytest.approx(slow)
    assert vc.write_subfunction(rtc("LOAD_INITIAL")) == 0
    run_fifo(vc)  # the command runs: the chip calls its table
    assert vc.chip_state == 4 and vc.motion.settings[0].max_v == 8000
    vc.advance(vc.clock + vc.initial_table.config.load_time)
    assert vc.chip_state == 5 and vc.motion.settings[0].max_v == 200_000
    # resolution 25 PPS now: 1013 runs as 1025 PPS, so the same move is shorter
    assert constant_move_seconds(vc, 1013, 10_130) == pytest.approx(10_130 / 1025)


def test_loading_disabled_software_limits_does_not_stop_an_axis_beyond_them() -> None:
    vc = VirtualController()
    send(vc, rtc("SET_SV", X, 1000), rtc("SET_V", X, 100_000),
         rtc("CONTINUE_MOVE", X, 100_000))
    vc.advance(2.0)
    assert vc.motion.lp(X, vc.clock) > 100_000  # past the factory forward limit (disabled)
    send(vc, rtc("LOAD_INITIAL"))
    vc.advance(vc.clock + 0.5)
    assert vc.motion.cv(X, vc.clock) == 100_000 and vc.motion.io.error_code(X, vc.clock) == 0
    send(vc, rtc("SET_SLMT", INITIAL | X, 100_000, -100_000, 0), rtc("LOAD_INITIAL"))
    vc.advance(vc.clock + 1.5)  # now the table enables them: the drive decelerates (3.9)
    assert vc.motion.cv(X, vc.clock) == 0 and vc.motion.io.error_code(X, vc.clock) == 1


def test_commands_queued_behind_load_initial_wait_and_the_last_setting_wins() -> None:
    vc = VirtualController()
    frames = [rtc("SET_MAX_V", INITIAL | XY, 400_000), rtc("LOAD_INITIAL"),
              rtc("SET_MAX_V", X, 8000)]
    for frame in frames:
        assert vc.write_subfunction(frame) == 0
    vc.advance(vc.clock + 4 * vc.rtc_time)  # past the due time of the third command
    assert vc.chip_state == 4 and len(vc.fifo) == 1  # it waits for the table
    settle(vc)
    assert [s.max_v for s in vc.motion.settings] == [8000, 400_000, 200_000, 200_000]


def test_load_initial_while_a_program_runs_goes_back_to_the_running_state() -> None:
    build = compile_source("MP 21\n TIMER 50\n VAR1 = 7\nEND MP\n")
    vc = VirtualController()
    preload(vc, build)
    vc.call(21)
    for frame in (rtc("SET_PULSE_MODE", INITIAL | XYZU, 3), rtc("LOAD_INITIAL")):
        assert vc.write_subfunction(frame) == 0
    run_fifo(vc)
    assert vc.chip_state == 4 and vc.running  # the table is called while MP21 runs
    vc.advance(vc.clock + 0.005)
    assert vc.chip_state == 8 and vc.running  # MP21 still waits in its TIMER
    assert vc.settings()["live"]["U"]["pulse_mode"] == 3  # type: ignore[index]
    assert vc.run().finished and vc.vars[1] == 7 and vc.chip_state == 9


def test_chapter_8_related_example_leaves_the_table_applied() -> None:
    vc = VirtualController()
    send(vc, rtc("SET_HLMT", XYZU, 1, 1), rtc("SET_NHOME", XYZU, 1),
         rtc("LIMITSTOP_MODE", X, 1), rtc("SET_FILTER", XYZU, 21, 3))
    send(vc, *chapter_8_example())
    assert live_columns(vc) == tuple(vc.initial_table.columns)
    assert vc.initial_table.columns == [vc.initial_table.config.factory] * 4


def chapter_8_example() -> list[list[int]]:
    """The related example of 8.1 (RS 9760-9785), as frames."""
    return [rtc("SET_PULSE_MODE", INITIAL | XYZU, 0), rtc("SET_MAX_V", INITIAL | XY, 200_000),
            rtc("SET_HLMT", INITIAL | XYZU, 0, 0), rtc("LIMITSTOP_MODE", INITIAL | X, 0),
            rtc("SET_NHOME", INITIAL | XY, 0), rtc("LOAD_INITIAL")]


def test_it_path_stores_and_live_path_records_settings_the_model_does_not_simulate() -> None:
    vc = VirtualController()
    send(vc, rtc("SET_ENCODER", INITIAL | Y, 2, 1, 1), rtc("VRING_ENABLE", INITIAL | Y, 5000))
    report = vc.settings()
    assert report["initial_table"]["Y"]["encoder_mode"] == 2  # type: ignore[index]
    assert report["live"]["Y"]["encoder_mode"] == 0  # type: ignore[index]
    build = compile_source("MP 21\n SET_FILTER XY, 21, 3\n AVTRI_ENABLE U\nEND MP\n")
    preload(vc, build)
    vc.call(21)
    assert vc.run().finished
    live = vc.settings()["live"]
    assert live["X"]["filter_inputs"] == 21 and live["Y"]["filter_time"] == 3  # type: ignore[index]
    assert live["U"]["avtri_enabled"] == 1 and live["Z"]["filter_inputs"] == 0  # type: ignore[index]


def test_reset_card_reloads_the_initial_table() -> None:
    vc = VirtualController()
    send(vc, rtc("SET_MAX_V", INITIAL | X, 8000), rtc("SERVO_ON", INITIAL | XY),
         rtc("SET_SLMT", INITIAL | Y, 5000, -5000, 1), rtc("SET_MAX_V", Y, 4_000_000))
    before = live_columns(vc)
    assert before[0].max_v == 200_000 and before[1].max_v == 4_000_000
    assert vc.write_subfunction(rtc("RESET_CARD")) == 0
    run_fifo(vc)
    assert vc.chip_state == 4
    settle(vc)
    assert vc.chip_state == 5 and live_columns(vc) == tuple(vc.initial_table.columns)
    assert live_columns(vc)[1].slmt_enabled == 1 and vc.motion.io.cfg[1].comp_ep


# ------------------------------------------------------------------------- refusals
def test_initial_codes_are_refused_outside_the_it_set_and_inside_macros() -> None:
    vc = VirtualController()
    regs = RegisterMap(vc)
    cause = vc.initial_table.config.refusal_cause
    assert cause == 0x02
    assert vc.write_subfunction(rtc("FIXED_MOVE", INITIAL | X, 5000)) == cause
    assert vc.write_subfunction(rtc("EXD_MP", INITIAL | X, 5)) == cause  # not IT (RS 410)
    assert vc.write_subfunction(rtc("SET_MAX_V", INITIAL, 8000)) == cause  # no axis at all
    assert vc.write_subfunction(rtc("SET_MAX_V", INITIAL | X, 7999)) == cause  # below range
    assert vc.write_subfunction(rtc("SET_PULSE_MODE", INITIAL | X, 6)) == cause  # not in Table 6
    assert vc.write_subfunction(rtc("SET_MAX_V", INITIAL | X, VarRef(3))) == cause
    refused = refusal(regs, rtc("SET_HLMT", INITIAL | XY, 2, 0))
    assert (refused.code, refused.cause) == (ILLEGAL_FUNCTION, cause)
    assert regs.read_input(102, 1) == [cause]
    # "IT table can not be used inside macro program (MP or ISR)" (RS 990)
    assert vc.write_subfunction([0x0AC9, 21]) == 0  # MP_CREATE 21
    macro = CAT.by_vendor["RSM_MACRO_SET_MAX_V"]
    line = ENC.frame(MacroLine(macro, (INITIAL | X, 8000), Span("test", 1)))
    assert vc.write_subfunction(line) == cause
    assert vc.write_subfunction([0x0CCA]) == 0
    assert not vc.fifo and vc.initial_table.columns[0].max_v == 200_000
    # the refused line fails the download (issue 13): nothing is stored, 110-114 say why
    assert ("mp", 21) not in vc.tables and vc.download_status == (21, 0, macro.code, 0, 0x0F)


def refusal(regs: RegisterMap, frame: list[int]) -> Refusal:
    with pytest.raises(Refusal) as caught:
        regs.write_holding(8000, frame)
    return caught.value


# ------------------------------------------------------------------ property tests
def operand_values(command: Command) -> st.SearchStrategy[tuple[int, ...]]:
    """Values within the command's section ranges (the catalogue's enums and limits)."""
    parts: list[st.SearchStrategy[int]] = []
    for param in command.params[1:]:
        if param.values:
            parts.append(st.sampled_from(param.values))
        else:
            assert param.min is not None and param.max is not None
            parts.append(st.integers(int(param.min), int(param.max)))
    return st.tuples(*parts)


WRITES = st.lists(st.sampled_from(IT_COMMANDS).flatmap(
    lambda c: st.tuples(st.just(c), st.integers(1, 15), operand_values(c))), max_size=20)


def frame_of(command: Command, mask: int, values: tuple[int, ...]) -> list[int]:
    return ENC.frame(MacroLine(command, (mask, *values), Span("test", 1)))


@settings(max_examples=60, deadline=None)
@given(WRITES)
def test_it_writes_then_load_initial_equal_the_same_settings_made_live(
        writes: list[tuple[Command, int, tuple[int, ...]]]) -> None:
    table, live = VirtualController(), VirtualController()
    send(table, *[frame_of(c, INITIAL | mask, values) for c, mask, values in writes])
    assert live_columns(table) == (table.initial_table.config.factory,) * 4  # untouched
    send(table, rtc("LOAD_INITIAL"))
    send(live, *[frame_of(c, mask, values) for c, mask, values in writes])
    assert live_columns(table) == live_columns(live) == tuple(table.initial_table.columns)
    assert table.chip_state == 5


COLUMNS = WRITES.map(lambda writes: column_after(writes))


def column_after(writes: list[tuple[Command, int, tuple[int, ...]]]) -> AxisColumn:
    scratch = InitialTable(CAT)
    for command, _mask, values in writes:
        scratch.write(command.short_name, X, values)
    return scratch.columns[0]


@given(COLUMNS, COLUMNS)
def test_commands_for_a_column_set_it_from_any_column(target: AxisColumn,
                                                      start: AxisColumn) -> None:
    scratch = InitialTable(CAT)
    scratch.columns[0] = start
    for name, values in commands_for(target):
        scratch.write(name, X, values)
    assert scratch.columns[0] == target
    assert scratch.column_problem(target) == ""


# ------------------------------------------------------------------ memory, preload
def test_memory_keeps_the_table_and_power_on_loads_it(tmp_path: Path) -> None:
    vc = VirtualController()
    send(vc, rtc("SET_MAX_V", INITIAL | Z, 8000), rtc("VRING_ENABLE", INITIAL | U, 4000))
    store = tmp_path / "fram.json"
    vc.save(store)
    saved = json.loads(store.read_text())
    assert saved["initial_table"]["Z"]["max_v"] == 8000
    again = VirtualController()
    again.restore(store)
    assert again.initial_table.columns == vc.initial_table.columns
    assert again.motion.settings[2].max_v == 8000  # loaded at "power on"
    assert live_columns(again)[3].vring_enabled == 1 and again.chip_state == 5


def test_old_memory_files_load_and_bad_tables_are_refused(tmp_path: Path) -> None:
    build = compile_source("MP 21\n VAR1 = 42\nEND MP\n")
    frames = build.programs[0].frames[1:-1]  # the stored lines, without create and close
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"format": "mpc-fram/1", "word_order": 0,
                               "programs": {"mp21": frames}}))
    vc = VirtualController()
    vc.restore(old)
    assert ("mp", 21) in vc.tables
    assert vc.initial_table.columns == [vc.initial_table.config.factory] * 4
    bad = tmp_path / "bad.json"
    table = {axis: dict(vc.settings()["initial_table"][axis])  # type: ignore[index]
             for axis in "XYZU"}
    table["Y"]["max_v"] = 5
    bad.write_text(json.dumps({"format": "mpc-fram/1", "word_order": 0, "programs": {},
                               "initial_table": table}))
    with pytest.raises(ServiceError, match="SET_MAX_V data = 5 is out of range") as caught:
        load_memory(VirtualController(), bad)
    assert caught.value.kind == "memory"
    del table["Y"]["max_v"]
    bad.write_text(json.dumps({"format": "mpc-fram/1", "word_order": 0, "programs": {},
                               "initial_table": table}))
    with pytest.raises(ValueError, match=r"initial_table\.Y must have exactly the fields"):
        VirtualController().restore(bad)


class WithInit:
    """A build whose image carries "init" frames, as the compiler's INIT block writes."""

    def __init__(self, source: str, init: object) -> None:
        self.build = compile_source(source)
        self.init = init

    def __getattr__(self, name: str) -> object:
        return getattr(self.build, name)

    def image(self) -> dict[str, object]:
        return {**self.build.image(), "init": self.init}


def test_preload_runs_the_images_init_frames() -> None:
    writes = [rtc("SET_MAX_V", INITIAL | mask, 8000 + mask) for mask in range(1, 16)] * 3
    init = {"frames": [*writes, rtc("SERVO_ON", INITIAL | XYZU), rtc("LOAD_INITIAL")]}
    vc = VirtualController()
    preload(vc, WithInit("MP 21\n VAR1 = 1\nEND MP\n", init))  # type: ignore[arg-type]
    assert ("mp", 21) in vc.tables and vc.chip_state == 5 and not vc.fifo
    assert [s.max_v for s in vc.motion.settings] == [8015, 8015, 8015, 8015]
    assert all(column.servo_on for column in live_columns(vc))


@pytest.mark.parametrize(("init", "message"), [
    ({"frames": [[0x0A48, INITIAL | X, 0, 5]]}, "init frame 0 .* cause 0x02"),
    ({"frames": [[0x0AC8, 70000]]}, "not a list of 16-bit register values"),
    ({"frame": []}, "must be an object with a \"frames\" list"),
])
def test_preload_refuses_bad_init_frames(init: object, message: str) -> None:
    with pytest.raises(ServiceError, match=message) as caught:
        preload(VirtualController(), WithInit("", init))  # type: ignore[arg-type]
    assert caught.value.kind == "program"


def test_preload_without_init_or_triggers_loads_programs_only() -> None:
    vc = VirtualController()
    preload(vc, compile_source("MP 21\n VAR1 = 1\nEND MP\n"))
    assert ("mp", 21) in vc.tables and vc.chip_state == 7
    assert not vc.triggers.entries and not vc.triggers.enabled


# ------------------------------------------------------------------- over Modbus TCP
async def until(predicate: Callable[[], Awaitable[bool]], timeout: float = 10.0) -> None:
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while not await predicate():
        assert loop.time() < end, "the condition never came true"
        await asyncio.sleep(0.005)


async def served(vc: VirtualController, speed: float,
                 scenario: Callable[[AsyncModbusTcpClient], Awaitable[None]]) -> None:
    """Run `mpc sim`'s service on a free loopback port and a client against it."""
    stop_event, endpoints = asyncio.Event(), Endpoints()
    options = SimOptions(tcp=("127.0.0.1", 0), speed=speed)
    task = asyncio.create_task(serve(options, vc, lambda _m: None, stop_event, endpoints))
    while endpoints.tcp is None:
        assert not task.done(), task.result()
        await asyncio.sleep(0.01)
    client = AsyncModbusTcpClient("127.0.0.1", port=endpoints.tcp[1])
    try:
        assert await client.connect()
        await scenario(client)
    finally:
        client.close()
        stop_event.set()
        await task


async def write(client: AsyncModbusTcpClient, frame: list[int]) -> None:
    reply = await client.write_registers(8000, frame, device_id=1)
    assert not reply.isError(), frame


async def cv_of_x(client: AsyncModbusTcpClient) -> int:
    reply = await client.read_input_registers(42, count=2, device_id=1)
    high, low = reply.registers
    return (high << 16) | low


def test_chapter_8_example_over_modbus_tcp_to_mpc_sim() -> None:
    vc = VirtualController()
    seen: list[int] = []

    async def scenario(client: AsyncModbusTcpClient) -> None:
        for frame in (rtc("SET_MAX_V", XY, 8000), rtc("SET_HLMT", XYZU, 1, 1),
                      rtc("LIMITSTOP_MODE", X, 1), rtc("SET_NHOME", XYZU, 1),
                      rtc("SET_PULSE_MODE", XYZU, 2), rtc("SET_SV", X, 1013),
                      rtc("SET_V", X, 1013), rtc("CONTINUE_MOVE", X, 1013)):
            await write(client, frame)

        async def speed_is(value: int) -> bool:
            return await cv_of_x(client) == value
        await until(lambda: speed_is(1013))  # MAX_V 8000: resolution 1 PPS
        await write(client, rtc("STOP_SUDDENLY", X))
        for frame in chapter_8_example():
            await write(client, frame)

        async def state() -> bool:
            reply = await client.read_input_registers(101, count=1, device_id=1)
            seen.append(reply.registers[0])
            return seen[-1] == 5 and 4 in seen
        await until(state)
        await write(client, rtc("CONTINUE_MOVE", X, 1013))
        await until(lambda: speed_is(1025))  # MAX_V 200000 again: resolution 25 PPS

    asyncio.run(served(vc, 0.005, scenario))
    assert seen[-1] == 5 and 4 in seen  # calling the table, then finished (RS 11368)
    assert live_columns(vc) == tuple(vc.initial_table.columns)
    assert vc.initial_table.columns == [vc.initial_table.config.factory] * 4


def test_mpc_sim_memory_keeps_the_table_across_a_restart(tmp_path: Path) -> None:
    memory = tmp_path / "fram.json"

    def table_saved() -> bool:
        try:
            data = json.loads(memory.read_text())
        except (OSError, ValueError):
            return False
        return bool(data["initial_table"]["X"]["max_v"] == 8000)

    async def first(port: int) -> None:
        client = AsyncModbusTcpClient("127.0.0.1", port=port)
        assert await client.connect()
        try:
            await write(client, rtc("SET_MAX_V", INITIAL | X, 8000))

            async def saved() -> bool:
                return table_saved()
            await until(saved)
        finally:
            client.close()

    async def second(port: int) -> None:
        client = AsyncModbusTcpClient("127.0.0.1", port=port)
        assert await client.connect()
        try:
            state = await client.read_input_registers(101, count=1, device_id=1)
            assert state.registers == [5]
            for frame in (rtc("SET_SV", X, 1013), rtc("SET_V", X, 1013),
                          rtc("CONTINUE_MOVE", X, 1013)):
                await write(client, frame)

            async def moving() -> bool:
                return await cv_of_x(client) != 0
            await until(moving)
            assert await cv_of_x(client) == 1013  # power on loaded MAX_V 8000
        finally:
            client.close()

    for scenario in (first, second):
        proc, port = start_sim("--memory", str(memory))
        try:
            asyncio.run(scenario(port))
        finally:
            proc.terminate()
            assert proc.wait(10) == 0


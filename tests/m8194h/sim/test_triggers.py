"""Stand-alone mode of the virtual M8194H: the FRnet DI trigger table (manual chapter 10).

What the manual states is tested as stated: a DI event starts its MP, only one program
runs at a time and a triggered one waits for the running one (RS 11112-11114), holding
register 9 enables triggering (5.4, RS 4618-4655), Hold Drive is DRV_HOLD (7.5.1). The
readings taken where it is silent are the `[stand_alone]` keys of the device profile, and
each test of one names the key.
"""

from __future__ import annotations

import asyncio
import itertools
import json
from collections.abc import Awaitable, Callable
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymodbus.client import AsyncModbusTcpClient

from mplang.ir import catalogue
from mplang.ir.macro import MacroLine, Operand
from mplang.lang.diagnostics import Span
from mplang.m8194h.compiler import BuildResult, compile_source
from mplang.m8194h.encode import Encoder
from mplang.m8194h.sim.axis_io import ERR_SOFT_STOP
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.registers import RegisterMap
from mplang.m8194h.sim.service import Endpoints, ServiceError, SimOptions, preload, serve
from mplang.m8194h.sim.triggers import CONDITIONS, fires, parse_entries

CAT = catalogue.load()
ENC = Encoder(CAT)
X, XY = 1, 3

PROGRAMS = """
MP 21
    VAR10 = VAR10 * 10 + 1
    TIMER 100
END MP

MP 22
    VAR10 = VAR10 * 10 + 2
    TIMER 100
END MP

MP 23
    VAR10 = VAR10 * 10 + 3
END MP

MP 24
    SET_SV X, 1000
    SET_V X, 10000
    SET_A X, 100000
    CONTINUE_MOVE X, 10000
    TIMER 500
    VAR11 = 1
END MP
"""
BUILD = compile_source(PROGRAMS)


def rtc(name: str, *operands: Operand) -> list[int]:
    return ENC.frame(MacroLine(CAT.by_vendor["RSM_" + name], operands, Span("test", 1)))


def entry(channel: int, condition: str, event: str, group: int = 8,
          **extra: int) -> dict[str, object]:
    return {"group": group, "channel": channel, "condition": condition, "event": event,
            **extra}


def controller(*entries: dict[str, object], enabled: bool = True) -> VirtualController:
    vc = VirtualController()
    preload(vc, BUILD)
    vc.load_trigger_table(list(entries))
    vc.set_triggering(enabled)
    return vc


def running(vc: VirtualController) -> int:
    """The MP at the bottom of the call stack (input register 24 shows the top), 0 if none."""
    return vc.stack[0].table.slot if vc.stack else 0


def finish(vc: VirtualController) -> None:
    vc.advance(vc.clock + 10.0, until_idle=True)
    assert vc.error is None, vc.error


# ------------------------------------------------------------------------ MP events
def test_an_mp_event_starts_its_program_at_the_time_of_the_change() -> None:
    vc = controller(entry(0, "off-to-on", "mp", mp=23))
    vc.advance(0.5)
    vc.set_di_group(8, 0b1)
    assert running(vc) == 23 and vc.chip_state == 8
    assert [(time, e.channel, kind) for time, e, kind in vc.triggers.fired] == \
        [(0.5, 0, "fire")]
    finish(vc)
    assert vc.vars[10] == 3


def test_triggered_programs_wait_for_the_running_one_and_start_in_order() -> None:
    vc = controller(entry(0, "off-to-on", "mp", mp=21), entry(1, "off-to-on", "mp", mp=22),
                    entry(2, "off-to-on", "mp", mp=23))
    vc.set_di_group(8, 0b001)
    vc.advance(0.01)
    vc.set_di_group(8, 0b111)  # DI 8.1 and 8.2 while MP21 runs
    assert running(vc) == 21 and list(vc.triggers.waiting) == [22, 23]
    vc.advance(0.099)
    assert running(vc) == 21
    vc.advance(0.1005)  # MP21's TIMER 100 ended: MP22 started the moment it finished
    assert running(vc) == 22
    finish(vc)
    assert vc.vars[10] == 123


def test_a_repeated_event_for_a_waiting_mp_is_ignored_and_the_running_one_queues_again() -> None:
    # profile stand_alone.repeat_while_waiting = "ignore"
    vc = controller(entry(0, "change", "mp", mp=21), entry(1, "change", "mp", mp=22))
    vc.set_di_group(8, 0b01)  # MP21 starts
    for value in (0b11, 0b01, 0b11):  # MP22 asked three times while MP21 runs
        vc.set_di_group(8, value)
    vc.set_di_group(8, 0b10)  # MP21 asked again while it runs: it waits behind MP22
    assert list(vc.triggers.waiting) == [22, 21]
    finish(vc)
    assert vc.vars[10] == 121


def test_an_event_for_an_empty_slot_is_dropped_and_logged() -> None:
    vc = controller(entry(5, "off-to-on", "mp", mp=99))
    vc.set_di_group(8, 1 << 5)
    assert not vc.running
    assert any("MP99 is empty" in line for line in vc.log)


# ---------------------------------------------------------------- the other events
def test_abort_macro_ends_the_running_program_and_drops_the_waiting_ones() -> None:
    # profile stand_alone.abort_macro_drops_waiting = true
    vc = controller(entry(0, "off-to-on", "mp", mp=21), entry(1, "off-to-on", "mp", mp=22),
                    entry(3, "on-to-off", "abort-macro"))
    vc.set_di_group(8, 0b1000)
    vc.set_di_group(8, 0b1001)
    vc.set_di_group(8, 0b1011)
    vc.advance(0.05)
    assert running(vc) == 21 and list(vc.triggers.waiting) == [22]
    vc.set_di_group(8, 0b0011)
    assert not vc.running and not vc.triggers.waiting and vc.chip_state == 9
    finish(vc)
    assert vc.vars[10] == 1


def test_abort_command_decelerates_every_axis_and_the_program_goes_on() -> None:
    # profile stand_alone.abort_command_stop = "decelerate"
    vc = controller(entry(4, "change", "abort-command"))
    vc.call(24)
    vc.advance(0.3)
    assert vc.motion.cv(X, vc.clock) == pytest.approx(10_000)
    vc.set_di_group(8, 1 << 4)
    vc.advance(0.3 + 0.05)  # decelerating at A = 100000 from 10000 towards SV 1000
    assert 0 < vc.motion.cv(X, vc.clock) < 10_000
    vc.advance(0.3 + 0.1)
    assert vc.motion.cv(X, vc.clock) == 0
    assert vc.motion.io.error_code(X, vc.clock) & ERR_SOFT_STOP  # a stop command's bit
    finish(vc)
    assert vc.vars[11] == 1  # MP24 ran to its end


def test_hold_drive_on_a_level_holds_while_the_input_stays_on() -> None:
    # profile stand_alone.release_hold_on_leaving_level = true
    vc = controller(entry(6, "on", "hold-drive", axes=X))
    vc.set_di_group(8, 1 << 6)
    assert vc.write_subfunction(rtc("FIXED_MOVE", X, 1000)) == 0
    vc.advance(1.0)
    assert vc.motion.lp(X, vc.clock) == 0  # the move is held (7.5.1)
    vc.set_di_group(8, 0)
    assert vc.triggers.fired[-1][2] == "release"
    vc.advance(vc.clock + 2.0)
    assert vc.motion.lp(X, vc.clock) == 1000


def test_hold_drive_on_an_edge_holds_until_drv_start() -> None:
    vc = controller(entry(7, "off-to-on", "hold-drive", axes=XY))
    vc.set_di_group(8, 1 << 7)
    vc.set_di_group(8, 0)  # leaving the edge's level releases nothing
    assert vc.write_subfunction(rtc("FIXED_MOVE", X, 1000)) == 0
    vc.advance(1.0)
    assert vc.motion.lp(X, vc.clock) == 0
    assert vc.write_subfunction(rtc("DRV_START", XY)) == 0
    vc.advance(vc.clock + 2.0)
    assert vc.motion.lp(X, vc.clock) == 1000


# ------------------------------------------------------------ enable and conditions
def test_enabling_fires_the_level_conditions_already_met_and_no_edges() -> None:
    # profile stand_alone.level_fires_on_enable = true
    table = [entry(0, "on", "abort-command", group=9), entry(1, "off-to-on", "abort-command",
                                                            group=9),
             entry(2, "off", "abort-command", group=9), entry(3, "on", "abort-command", group=9)]
    vc = controller(*table, enabled=False)
    vc.set_di_group(9, 0b0011)  # disabled: nothing fires
    assert not vc.triggers.fired
    RegisterMap(vc).write_holding(9, [1])
    assert sorted(e.channel for _t, e, _k in vc.triggers.fired) == [0, 2]  # ON on, OFF off
    assert RegisterMap(vc).read_holding(9, 1) == [1]
    vc.set_triggering(True)  # already enabled: nothing new
    assert len(vc.triggers.fired) == 2
    RegisterMap(vc).write_holding(9, [0])
    vc.set_di_group(9, 0b1111)
    assert len(vc.triggers.fired) == 2 and RegisterMap(vc).read_holding(9, 1) == [0]


def test_loading_a_table_while_enabled_checks_its_levels() -> None:
    vc = controller()
    vc.set_di_group(10, 1)
    vc.load_trigger_table([entry(0, "on", "mp", group=10, mp=23)])
    assert running(vc) == 23


def test_the_extension_registers_and_frnet_write_reach_the_trigger_table() -> None:
    vc = controller(entry(0, "off-to-on", "mp", mp=23), entry(6, "off-to-on", "mp", mp=21))
    regs = RegisterMap(vc)
    regs.write_holding(9008, [1])
    assert running(vc) == 23
    finish(vc)
    # a program cannot write a DI group: "Group number is between 0~7. Eight or above is
    # not defined" (RS 4427), so the device refuses the hand-made line (issue 13)
    write = CAT.by_vendor["RSM_MACRO_FRNET_WRITE"]
    frames = [[0x0AC9, 25], ENC.frame(MacroLine(write, (8, 6, 1), Span("test", 1))),
              [0x0CCA]]
    error = vc.load_frames("mp", 25, frames)
    assert error is not None and (error.code, error.line) == (0x0F, 0)
    assert ("mp", 25) not in vc.tables
    regs.write_holding(9008, [0x40])  # the simulator's DI register reaches the table
    assert running(vc) == 21


@pytest.mark.parametrize("condition", CONDITIONS)
def test_fires_on_exactly_the_edges_of_each_condition(condition: str) -> None:
    edges = {(old, new): fires(condition, old, new) for old in (0, 1) for new in (0, 1)}
    expected = {"on": (0, 1), "off-to-on": (0, 1), "off": (1, 0), "on-to-off": (1, 0)}
    if condition == "change":
        assert edges == {(0, 0): False, (0, 1): True, (1, 0): True, (1, 1): False}
    else:
        assert [e for e, fired in edges.items() if fired] == [expected[condition]]


def expected_fires(condition: str, start: int, bits: list[int]) -> int:
    """The manual's conditions counted independently: edges, plus one for a level already
    met at enable time (stand_alone.level_fires_on_enable)."""
    levels = [start, *bits]
    ups = sum(1 for pair in itertools.pairwise(levels) if pair == (0, 1))
    downs = sum(1 for pair in itertools.pairwise(levels) if pair == (1, 0))
    return {"off-to-on": ups, "on-to-off": downs, "change": ups + downs,
            "on": ups + (start == 1), "off": downs + (start == 0)}[condition]


@settings(max_examples=80, deadline=None)
@given(st.sampled_from(CONDITIONS), st.integers(0, 15), st.integers(0, 1),
       st.lists(st.integers(0, 0xFFFF), max_size=30))
def test_any_di_sequence_fires_exactly_what_the_condition_defines(
        condition: str, channel: int, start: int, values: list[int]) -> None:
    vc = controller(entry(channel, condition, "hold-drive", group=12, axes=X), enabled=False)
    vc.set_di_group(12, start << channel | (0x5A5A & ~(1 << channel)))
    vc.set_triggering(True)
    for value in values:
        vc.set_di_group(12, value)
    kinds = [kind for _t, _e, kind in vc.triggers.fired]
    bits = [value >> channel & 1 for value in values]
    assert kinds.count("fire") == expected_fires(condition, start, bits)
    if condition in ("on", "off"):  # a level holds while it lasts, then releases
        level = 1 if condition == "on" else 0
        assert kinds.count("release") == expected_fires(
            "on-to-off" if level else "off-to-on", start, bits)
        final = bits[-1] if bits else start
        assert (kinds[-1:] == ["fire"]) == (final == level)
    else:
        assert "release" not in kinds


# ------------------------------------------------------------------------ validation
@pytest.mark.parametrize(("entries", "message"), [
    ({"group": 8}, "must be a list"),
    ([7], "trigger entry 0: expected an object"),
    ([{"group": 8, "channel": 0, "event": "mp", "mp": 1}], "missing 'condition'"),
    ([entry(0, "on", "mp", group=7, mp=1)], "\"group\" must be an integer 8..15, got 7"),
    ([entry(16, "on", "mp", mp=1)], "\"channel\" must be an integer 0..15"),
    ([entry(True, "on", "mp", mp=1)], "\"channel\" must be an integer"),
    ([entry(0, "ON", "mp", mp=1)], "\"condition\" must be one of off, on"),
    ([entry(0, "on", "start")], "\"event\" must be one of mp, abort-command"),
    ([entry(0, "on", "mp")], "event \"mp\" needs \"mp\""),
    ([entry(0, "on", "mp", mp=158)], "\"mp\" must be an integer 1..157"),
    ([entry(0, "on", "hold-drive")], "needs \"axes\": a mask 1..15"),
    ([entry(0, "on", "hold-drive", axes=16)], "\"axes\" must be an integer 1..15"),
    ([entry(0, "on", "abort-macro", mp=3)], "unexpected 'mp' for event 'abort-macro'"),
    ([entry(0, "on", "abort-macro", line=4), entry(0, "off", "abort-command", line=9)],
     r"trigger entry 1 \(line 9\): DI 8.0 already has a trigger \(trigger entry 0 \(line 4\)\)"),
    ([{**entry(0, "on", "abort-macro"), "line": "4"}], "\"line\" must be an integer"),
])
def test_bad_entries_are_refused_with_the_reason(entries: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        parse_entries(entries, CAT.profile)
    vc = VirtualController()
    with pytest.raises(ValueError, match=message):
        vc.load_trigger_table(entries)
    assert vc.triggers.entries == ()


def test_good_entries_round_trip_in_group_and_channel_order() -> None:
    raw = [entry(3, "change", "abort-command", group=9, line=12),
           entry(0, "off-to-on", "mp", mp=157), entry(1, "on", "hold-drive", axes=15)]
    parsed = parse_entries(raw, CAT.profile)
    assert [(e.group, e.channel) for e in parsed] == [(8, 0), (8, 1), (9, 3)]
    assert sorted((e.to_json() for e in parsed), key=json.dumps) == \
        sorted(raw, key=json.dumps)


# ------------------------------------------------------------------- memory, preload
def test_memory_keeps_the_table_and_power_on_with_triggering_enabled(tmp_path: Path) -> None:
    # profile stand_alone.enabled_persists = true
    vc = controller(entry(0, "off", "mp", group=11, mp=23), enabled=False)
    vc.set_triggering(True)  # DI 11.0 is off: MP23 starts
    finish(vc)
    store = tmp_path / "fram.json"
    vc.save(store)
    saved = json.loads(store.read_text())["triggers"]
    assert saved == {"enabled": True, "entries": [entry(0, "off", "mp", group=11, mp=23)]}
    again = VirtualController()
    again.restore(store)  # power on: enabled, with DI 11.0 off
    assert again.triggers.enabled and running(again) == 23
    store.write_text(json.dumps({**json.loads(store.read_text()),
                                 "triggers": {"enabled": 1, "entries": []}}))
    with pytest.raises(ValueError, match=r"triggers\.enabled must be true or false"):
        VirtualController().restore(store)


class WithTriggers:
    """A build whose image carries "triggers", as the compiler's TRIGGERS block writes."""

    def __init__(self, build: BuildResult, triggers: object) -> None:
        self.build = build
        self.triggers = triggers

    def __getattr__(self, name: str) -> object:
        return getattr(self.build, name)

    def image(self) -> dict[str, object]:
        return {**self.build.image(), "triggers": self.triggers}


def test_preload_loads_and_enables_the_images_trigger_table() -> None:
    vc = VirtualController()
    image = {"enabled": True, "source": "t.mp", "line": 3,
             "entries": [entry(0, "off-to-on", "mp", mp=23, line=4)]}
    preload(vc, WithTriggers(BUILD, image))  # type: ignore[arg-type]
    assert vc.triggers.enabled and len(vc.triggers.entries) == 1
    vc.set_di_group(8, 1)
    assert running(vc) == 23
    off = VirtualController()
    preload(off, WithTriggers(BUILD, {**image, "enabled": False}))  # type: ignore[arg-type]
    assert not off.triggers.enabled and len(off.triggers.entries) == 1


@pytest.mark.parametrize(("triggers", "message"), [
    ({"enabled": True, "entries": [entry(0, "on", "mp", mp=0, line=7)]},
     r"the trigger table: trigger entry 0 \(line 7\): \"mp\" must be an integer 1..157"),
    ({"enabled": "yes", "entries": []}, "true/false \"enabled\""),
    ([], "must be an object"),
])
def test_preload_refuses_a_bad_trigger_table(triggers: object, message: str) -> None:
    with pytest.raises(ServiceError, match=message) as caught:
        preload(VirtualController(), WithTriggers(BUILD, triggers))  # type: ignore[arg-type]
    assert caught.value.kind == "program"


def test_the_compilers_init_and_triggers_blocks_preload_end_to_end() -> None:
    build = compile_source(PROGRAMS + """
INIT
    SET_MAX_V X, 8000
    SERVO_ON XY
END INIT

TRIGGERS
    ON DI 8.0 OFF_TO_ON CALL MP23
    ON DI 8.2 ON HOLD XY
END TRIGGERS
""")
    assert build.ok, [d.render() for d in build.diagnostics]
    vc = VirtualController()
    preload(vc, build)
    live = vc.settings()["live"]
    assert live["X"]["max_v"] == 8000 and live["Y"]["servo_on"] == 1  # type: ignore[index]
    assert vc.chip_state == 5 and vc.triggers.enabled
    vc.set_di_group(8, 1)
    assert running(vc) == 23


def test_reset_card_drops_the_programs_waiting_for_their_turn() -> None:
    vc = controller(entry(0, "off-to-on", "mp", mp=21), entry(1, "off-to-on", "mp", mp=22))
    vc.set_di_group(8, 0b11)
    assert running(vc) == 21 and list(vc.triggers.waiting) == [22]
    vc.advance(0.01)  # MP21 waits in its TIMER
    assert vc.write_subfunction(rtc("RESET_CARD")) == 0
    finish(vc)
    assert vc.vars[10] == 1 and vc.triggers.enabled  # the table outlives the reset


# ------------------------------------------------------------------- over Modbus TCP
async def until(predicate: Callable[[], Awaitable[bool]], timeout: float = 10.0) -> None:
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while not await predicate():
        assert loop.time() < end, "the condition never came true"
        await asyncio.sleep(0.005)


def test_a_di_written_over_modbus_tcp_starts_its_program_in_mpc_sim() -> None:
    vc = VirtualController()
    image = {"enabled": False, "entries": [entry(0, "off-to-on", "mp", mp=23),
                                           entry(1, "off-to-on", "mp", mp=22)]}
    preload(vc, WithTriggers(BUILD, image))  # type: ignore[arg-type]

    async def scenario(port: int) -> None:
        client = AsyncModbusTcpClient("127.0.0.1", port=port)
        assert await client.connect()
        try:
            assert not (await client.write_register(9, 1, device_id=1)).isError()
            assert (await client.read_holding_registers(9, count=1,
                                                        device_id=1)).registers == [1]
            assert not (await client.write_register(9008, 0b11, device_id=1)).isError()

            async def done() -> bool:
                reply = await client.read_holding_registers(320, count=2, device_id=1)
                return bool(reply.registers == [0, 32])  # VAR10: MP23, then MP22
            await until(done)
        finally:
            client.close()

    async def main() -> None:
        stop_event, endpoints = asyncio.Event(), Endpoints()
        task = asyncio.create_task(serve(SimOptions(tcp=("127.0.0.1", 0), speed=5.0), vc,
                                         lambda _m: None, stop_event, endpoints))
        while endpoints.tcp is None:
            assert not task.done(), task.result()
            await asyncio.sleep(0.01)
        try:
            await scenario(endpoints.tcp[1])
        finally:
            stop_event.set()
            await task

    asyncio.run(main())
    assert [e.channel for _t, e, _k in vc.triggers.fired] == [0, 1]

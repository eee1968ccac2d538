"""The virtual FBs-PLC: one EN=1 of one FUN140 or FUN147 table, step by step.

It keeps the registers the chapter documents (the table's work registers WR+0/WR+1, the
present positions DR4088-DR4094, the remaining pulses DR4072-DR4078, the step numbers
R4064-R4067, the error codes R4060-R4063 and D4060-D4063) and the completion relays
M1996-M1999 / M1934-M1935, and runs the steps with the rules of FB 863-1149 and 2181-2389.
Readings of what FB leaves open are the `[semantics]` choices of stdlib/fatek/device.toml.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from mplang.family.watch import Stopped
from mplang.fatek.contacts import Contacts
from mplang.fatek.model import (
    NEXT,
    Contact,
    ContactEvent,
    Drive,
    Home,
    Line,
    ParamTable,
    PositioningTable,
    Register,
    SimSetup,
    Step,
    Value,
    join32,
    split32,
)
from mplang.fatek.motion import INF, Leg, Segment, plan, round_half_up
from mplang.fatek.profile import Profile
from mplang.fatek.units import AxisParams

SAME_INSTANT_LIMIT = 10_000
"""Steps run without simulated time passing before the run is declared stuck in a loop."""


class PlcError(Exception):
    """The PLC sets ERR and an error code (FB 772-807) and stops the table."""

    def __init__(self, code: int, detail: str) -> None:
        super().__init__(detail)
        self.code = code
        self.detail = detail


class Stuck(Exception):
    """The run cannot go on: it waits for something that never comes, or time ran out."""

    code = "R201"  # the run-time finding (mplang.lang.runtime_rules)


class OutOfTime(Stuck):
    """Simulated time ran out (--max-time) before MEND."""

    code = "R202"


@dataclass
class Carry:
    """Speed kept after EXT/ACT ended a step with pulses left (see `cut_continuation`)."""

    axis: int
    direction: int
    speed: float


@dataclass
class Machine:
    profile: Profile
    table: PositioningTable
    params: dict[int, AxisParams]
    sim: SimSetup
    max_time: float
    registers: dict[Register, int] = field(default_factory=dict)
    relays: set[Contact] = field(default_factory=set)
    rest: list[float] = field(default_factory=lambda: [0.0] * 4)
    legs: list[Leg] = field(default_factory=list)
    time: float = 0.0
    carry: Carry | None = None
    steps_run: int = 0
    at_step: int | None = None  # the step running (where a run-time error is reported)
    log: list[str] = field(default_factory=list)
    wr_trace: list[tuple[float, int]] = field(default_factory=list)
    watch: Callable[[float], bool] | None = None  # between steps: True stops the run
    contacts: Contacts = field(init=False)

    def __post_init__(self) -> None:
        self.registers.update(self.sim.registers)
        self.contacts = Contacts(self.sim, self.rest)
        for axis in range(4):
            self.set32(Register("R", self.profile.register("position") + 2 * axis), 0)
        for axis in range(4):
            self.relays.add(Contact("M", self.profile.register("ready_flag") + axis))

    # ------------------------------------------------------------ registers
    def word(self, register: Register) -> int:
        return self.registers.get(register, 0)

    def set_word(self, register: Register, value: int) -> None:
        self.registers[register] = value & 0xFFFF

    def read32(self, register: Register) -> int:
        return join32(self.word(register), self.word(register.offset(1)))

    def set32(self, register: Register, value: int) -> None:
        low, high = split32(value)
        self.set_word(register, low)
        self.set_word(register.offset(1), high)

    def wr_bit(self, key: str) -> int:
        """The mask of one WR+1 status bit (FB 757-763; `[registers]` of the profile)."""
        return 1 << int(self.profile.raw["registers"][key])

    def set_flags(self, on: int = 0, off: int = 0) -> None:
        """Turn WR+1 status bits on and off at the present time. Every change is kept in
        `wr_trace`, because a run reports the registers only at its end, while the ladder
        reads B9 (waiting for the transition), B10 (continuous run) and B12 (pulsing) as
        they change."""
        if self.table.wr is None:
            return
        register = self.table.wr.offset(1)
        before = self.word(register)
        after = (before | on) & ~off & 0xFFFF
        if after != before:
            self.set_word(register, after)
            self.wr_trace.append((self.time, after))

    def value32(self, value: Value) -> int:
        return value if isinstance(value, int) else self.read32(value)

    def value16(self, value: Value) -> int:
        return value if isinstance(value, int) else self.word(value)

    @property
    def fun(self) -> int:
        return self.table.fun

    @property
    def axes(self) -> list[int]:
        """The axes this table drives: its Ps (FUN140), or all four (FUN147)."""
        return [self.table.unit] if self.fun == 140 else [0, 1, 2, 3]

    def system(self, key: str, index: int) -> Register:
        return Register("R", self.profile.register(key) + index)

    def error_register(self) -> Register:
        if self.fun == 140:
            return self.system("error", self.table.unit)
        return Register("D", self.profile.register("group_error") + self.table.unit)

    def record_positions(self) -> None:
        for axis in range(4):
            self.set32(self.system("position", 2 * axis), round_half_up(self.rest[axis]))

    def note(self, text: str) -> None:
        self.log.append(f"{self.time:.4f} s: {text}")

    # ------------------------------------------------------------ running
    def run(self, entry: int) -> None:
        """Run from step `entry` until MEND; raises PlcError or Stuck otherwise."""
        wr = self.table.wr
        count = len(self.table.steps)
        if wr is not None:
            self.set_word(wr, entry - 1)
            self.set_word(wr.offset(1), count & 0xFF)
            self.wr_trace.append((self.time, count & 0xFF))
        for axis in self.axes:
            self.relays.discard(Contact("M", self.profile.register("ready_flag") + axis))
        number = entry
        same_instant, last_time = 0, -1.0
        while True:
            if self.time > self.max_time:
                raise OutOfTime(f"stopped after {self.max_time:g} s of simulated time without "
                            "reaching MEND")
            same_instant = same_instant + 1 if self.time == last_time else 0
            last_time = self.time
            if same_instant > SAME_INSTANT_LIMIT:
                raise Stuck(f"{SAME_INSTANT_LIMIT} steps ran without time passing (a loop of "
                            "moves that go nowhere)")
            if self.watch is not None and self.watch(self.time):
                raise Stopped(f"stopped at step {number}")
            following = self.step(number)
            if following is None:
                self.finish(number)
                return
            number = following

    def finish(self, number: int) -> None:
        done = "done_flag" if self.fun == 140 else "group_done_flag"
        self.relays.add(Contact("M", self.profile.register(done) + self.table.unit))
        for axis in self.axes:
            self.relays.add(Contact("M", self.profile.register("ready_flag") + axis))
        self.note(f"MEND after step {number}")

    def step(self, number: int) -> int | None:
        """Run one step (a DRVC chain runs with its closing DRV); the next step or None."""
        steps = self.table.steps
        if not 1 <= number <= len(steps):
            raise PlcError(34, f"there is no step {number}")
        step = steps[number - 1]
        self.at_step = number
        self.steps_run += 1
        if self.table.wr is not None:
            self.set_word(self.table.wr, number)
        speed = self.speed(step)
        self.note(f"step {number}: {' / '.join(step.lines())}")
        motion = step.motion
        start = self.time
        pulsing, continuous = self.wr_bit("wr_pulsing_bit"), self.wr_bit("wr_continuous_bit")
        if isinstance(motion, Drive):
            last, leg, segment_start = self.drive(number, speed)
            self.set_flags(on=pulsing | (continuous if leg.profile.length == INF else 0))
        elif isinstance(motion, Line):
            last, leg, segment_start = number, self.line(step, speed), start
            self.set_flags(on=pulsing | (continuous if motion.op == "LINE" else 0))
        elif isinstance(motion, Home):
            self.set_flags(on=pulsing)
            self.home(step, speed)
            last, leg, segment_start = number, None, start
        else:
            raise PlcError(34, f"step {number} has no motion")
        closing = steps[last - 1]
        if self.table.wr is not None:
            self.set_word(self.table.wr, last)
        self.transition(closing, leg, segment_start)
        if closing.mend:
            return None
        return self.target(closing, last)

    def set_step_done(self, number: int) -> None:
        """The pulse output of a step is complete: its number, and DN (FB 604, 677-678)."""
        if self.fun == 140:
            self.set_word(self.system("step", self.table.unit), number)
        else:
            self.set_word(Register("D", self.profile.register("group_step") + self.table.unit),
                          number)
        self.set_flags(on=self.wr_bit("wr_done_bit"),
                       off=self.wr_bit("wr_pulsing_bit") | self.wr_bit("wr_continuous_bit"))

    def target(self, step: Step, number: int) -> int:
        count = len(self.table.steps)
        goto = step.goto
        if goto == NEXT:
            return number + 1 if number < count else 1
        if isinstance(goto, int):
            return goto
        assert isinstance(goto, Register)
        value = self.word(goto)
        if not 1 <= value <= count:
            raise PlcError(34, f"GOTO {goto}: {goto} holds {value}, not a step 1-{count}")
        return value

    # ------------------------------------------------------------ speed
    def speed(self, step: Step) -> float:
        if step.speed is None:
            raise PlcError(34, f"step {step.number} has no SPD")
        value = self.value32(step.speed)
        limits = self.profile.limits(self.fun)
        if value == 0:
            raise Stuck(f"step {step.number}: SPD {step.speed} is 0, so the step waits for a "
                        "speed (FB 885-887) that nothing sets")
        if not limits.speed_min <= value <= limits.speed_max:
            raise PlcError(31, f"step {step.number}: SPD {step.speed} = {value}")
        if self.fun == 147:
            return float(value)
        params = self.params[self.table.unit]
        return min(params.speed_hz(value), params.max_speed)

    # ------------------------------------------------------------ FUN140
    def chain(self, number: int) -> list[Step]:
        steps = self.table.steps
        chain = [steps[number - 1]]
        while isinstance(chain[-1].motion, Drive) and chain[-1].motion.op == "DRVC":
            following = chain[-1].number + 1
            if following > len(steps):
                raise PlcError(34, f"the DRVC chain of step {number} runs past the last step")
            nxt = steps[following - 1]
            if isinstance(nxt.motion, Home):
                raise PlcError(42, f"step {following} follows a DRVC with DRVZ")
            if not isinstance(nxt.motion, Drive):
                raise PlcError(34, f"the DRVC chain of step {number} has no closing DRV")
            if len(chain) >= self.profile.drvc_max_segments:
                raise PlcError(34, f"the DRVC chain of step {number} has more than "
                               f"{self.profile.drvc_max_segments} segments")
            chain.append(nxt)
        return chain

    def stroke(self, step: Step, motion: Drive) -> int:
        value = self.value32(motion.stroke)
        limits = self.profile.fun140
        if not limits.stroke_min <= value <= limits.stroke_max:
            raise PlcError(33, f"step {step.number}: stroke {motion.stroke} = {value}")
        return value

    def drive(self, number: int, speed: float) -> tuple[int, Leg, float]:
        axis = self.table.unit
        params = self.params[axis]
        chain = self.chain(number)
        here = self.rest[axis]
        segments: list[Segment] = []
        direction = 0
        for index, step in enumerate(chain):
            motion = step.motion
            assert isinstance(motion, Drive)
            if index and motion.coord == "ABS":
                raise PlcError(41, f"step {step.number}: ABS inside a DRVC chain")
            raw = self.stroke(step, motion)
            cap = speed if index == 0 else self.speed(step)
            if raw == 0 and self.profile.zero_runs_on(motion.coord):
                segments.append(Segment(INF, cap))
                if index == 0:
                    direction = -1 if motion.direction == "-" else 1
                break
            pulses = params.stroke_pulses(raw, motion.unit)
            if index == 0:
                if motion.coord == "ABS":
                    distance = pulses - round_half_up(here)
                    direction = 1 if distance >= 0 else -1
                    pulses = abs(distance)
                else:
                    direction = -1 if motion.direction == "-" or (
                        not motion.direction and pulses < 0) else 1
                    pulses = abs(pulses)
            else:
                pulses = abs(pulses)  # the chain keeps the first segment's direction (FB 979)
            segments.append(Segment(float(pulses), cap))
        entry = min(params.start_speed, segments[0].cap)
        if self.carry is not None:
            if self.carry.axis == axis and self.carry.direction == direction:
                entry = self.carry.speed
            self.carry = None
        exit_speed = min(params.start_speed, segments[-1].cap)
        profile, bounds = plan(segments, self.time, entry, exit_speed, params.acceleration,
                               params.deceleration)
        start = tuple(self.rest)
        targets = None
        if profile.length != INF:
            targets = {axis: round_half_up(here) + direction * int(profile.length)}
        leg = Leg(profile, start, {axis: float(direction)}, targets)
        leg.boundaries = [profile.time_at(b) for b in bounds[:-1]]
        for boundary, step in zip(leg.boundaries, chain, strict=False):
            self.log.append(f"{boundary:.4f} s: DRVC segment of step {step.number} done")
        self.legs.append(leg)
        self.set32(self.system("remaining", 2 * axis),
                   0 if profile.length == INF else int(profile.length))
        segment_start = leg.boundaries[-1] if leg.boundaries else self.time
        return chain[-1].number, leg, segment_start

    # ------------------------------------------------------------ FUN147
    def line(self, step: Step, speed: float) -> Leg:
        motion = step.motion
        assert isinstance(motion, Line)
        limits = self.profile.fun147
        moves: dict[int, float] = {}
        for axis, stroke in enumerate(motion.strokes):
            if stroke is None:
                continue
            value = self.value32(stroke)
            pulses = self.params[axis].stroke_pulses(value, motion.unit)
            if motion.op == "LIN" and motion.coord == "ABS":
                distance = pulses - round_half_up(self.rest[axis])
            else:
                distance = pulses
            if distance == 0:
                continue
            if motion.op == "LIN" and not limits.stroke_min <= distance <= limits.stroke_max:
                raise PlcError(40, f"step {step.number}: Ps{axis} would move {distance} Ps")
            moves[axis] = float(distance)
        self.carry = None
        length = math.sqrt(sum(d * d for d in moves.values()))
        if not moves:
            if motion.op == "LINE":
                raise PlcError(60, f"step {step.number}: LINE with no axis")
            leg = Leg(plan([Segment(0.0, speed)], self.time, 0.0, 0.0, INF, INF)[0],
                      tuple(self.rest), {}, {})
            self.legs.append(leg)
            return leg
        unit = {axis: d / length for axis, d in moves.items()}
        for axis, share in unit.items():
            if speed * abs(share) > self.profile.axis_frequency_max:
                raise PlcError(31, f"step {step.number}: Ps{axis} would need "
                               f"{speed * abs(share):.0f} Hz")
        slope = self.params[min(moves)].interpolation_slope(speed)
        segment = Segment(INF if motion.op == "LINE" else length, speed)
        profile, _ = plan([segment], self.time, 0.0, 0.0, slope, slope)
        targets = None
        if motion.op == "LIN":
            targets = {axis: round_half_up(self.rest[axis] + d) for axis, d in moves.items()}
        leg = Leg(profile, tuple(self.rest), unit, targets)
        self.legs.append(leg)
        return leg

    # ------------------------------------------------------------ transitions
    def transition(self, step: Step, leg: Leg | None, segment_start: float) -> None:
        """Wait for the step's condition; end the leg early on EXT/ACT; advance the clock."""
        condition = step.condition
        end = leg.t_end if leg is not None else self.time
        where = f"step {step.number}"
        self.at_step = step.number  # the chain's closing step waits: errors are reported there
        if condition is not None and condition.op in ("EXT", "ACT") and leg is not None:
            if condition.op == "EXT":
                assert condition.contact is not None
                trigger = self.contacts.next_on(condition.contact, segment_start, leg)
            else:
                assert condition.time is not None
                trigger = segment_start + self.value16(condition.time) / 100
            if trigger < end:
                self.check_time(trigger, leg, where)
                self.cut(leg, trigger)
                self.set_step_done(step.number)
                self.note(f"{where}: {condition.text()} ends the pulse output")
                return
        self.check_time(end, leg, where)
        self.settle(leg, end)
        self.set_step_done(step.number)
        if condition is None:
            return
        waiting = self.wr_bit("wr_waiting_bit")
        self.set_flags(on=waiting)
        if condition.time is not None:
            wait = self.value16(condition.time) / 100
            if condition.op == "ACT":
                self.advance(max(self.time, segment_start + wait))
            else:
                self.advance(self.time + wait)
            self.set_flags(off=waiting)
            return
        assert condition.contact is not None
        when = self.contacts.next_on(condition.contact, self.time, None)
        if when == INF:
            source = "" if self.contacts.has_source(condition.contact) else \
                " (no SIM line drives it)"
            raise Stuck(f"{where} waits for {condition.contact}, which never turns ON{source}")
        self.advance(when)
        self.set_flags(off=waiting)

    def check_time(self, when: float, leg: Leg | None, where: str) -> None:
        """Stop the run at max_time, or at once for a continuous run nothing can end."""
        if when <= self.max_time and when != INF:
            return
        # without a time limit (`--max-time none`) a run that never ends stops where it is
        stop = self.max_time if math.isfinite(self.max_time) else self.time
        if leg is not None:
            self.cut(leg, max(stop, leg.t0))
        self.time = max(self.time, stop)
        if when == INF:
            raise Stuck(f"{where} runs for ever: a continuous run ends only by EXT or ACT (or "
                        f"EN=0 in the ladder); stopped after {self.time:g} s")
        raise OutOfTime(f"stopped after {self.max_time:g} s of simulated time without reaching "
                    "MEND")

    def advance(self, when: float) -> None:
        if when > self.max_time:
            self.time = max(self.time, self.max_time)
            raise OutOfTime(f"stopped after {self.max_time:g} s of simulated time without "
                        "reaching MEND")
        self.time = max(self.time, when)

    def settle(self, leg: Leg | None, end: float) -> None:
        """The leg ran to its end: the axes stand on their targets."""
        if leg is not None:
            for axis in leg.unit:
                self.rest[axis] = leg.position(axis, end)
            for axis in leg.unit:
                self.set32(self.system("remaining", 2 * axis), 0)
        self.time = max(self.time, end)
        self.record_positions()

    def cut(self, leg: Leg, when: float) -> None:
        """EXT/ACT (or the end of the run) stops the pulse output at `when`."""
        speed = leg.speed(when)
        planned = leg.profile.length
        leg.stop_at(when)
        done = leg.profile.length
        for axis, share in leg.unit.items():
            self.rest[axis] = float(round_half_up(leg.position(axis, when)))
            left = 0 if planned == INF else max(round(abs(share) * (planned - done)), 0)
            self.set32(self.system("remaining", 2 * axis), left)
            if self.fun == 140:
                self.carry = Carry(axis, 1 if share > 0 else -1, speed)
        self.time = max(self.time, when)
        self.record_positions()

    # ------------------------------------------------------------ DRVZ
    def home(self, step: Step, speed: float) -> None:
        """DRVZ MD0-MD2 (FB 3256-3456); the ramps are the `drvz_edges` choice."""
        assert isinstance(step.motion, Home)
        mode = step.motion.mode
        axis = self.table.unit
        params = self.params[axis]
        limits = self.profile.drvz
        if not 0 <= mode <= 2:
            raise PlcError(50, f"step {step.number}: DRVZ MD{mode}")
        dog_raw, limit_raw = params.io_field(0), params.io_field(1)
        pg0_raw, clr_raw = params.io_field(2), params.io_field(3)
        if dog_raw == 0xFF or dog_raw & 0x7F > limits["dog_max"]:
            raise PlcError(51, f"step {step.number}: no DOG input in parameter 15")
        if mode == 2 and (pg0_raw == 0xFF or pg0_raw & 0x7F > limits["pg0_max"]):
            raise PlcError(52, f"step {step.number}: no PG0 input in parameter 15")
        if clr_raw != 0xFF and clr_raw > limits["clr_max"]:
            raise PlcError(53, f"step {step.number}: CLR output Y{clr_raw}")
        self.carry = None
        dog = _Input(Contact("X", dog_raw & 0x7F), bool(dog_raw & 0x80))
        limit = None if limit_raw == 0xFF else _Input(Contact("X", limit_raw & 0x7F),
                                                      bool(limit_raw & 0x80))
        toward = 1 if params.home_up else -1
        creep = min(params.creep_speed, params.max_speed)
        where = f"step {step.number}"
        if self.active(dog):
            if limit is None:
                raise Stuck(f"{where}: DRVZ starts on the DOG {dog.contact} without a limit "
                            "input; FB does not describe that case")
            self.run_until(axis, toward, speed, limit, True, "the limit input")
            self.run_until(axis, -toward, speed, dog, False, "leaving the DOG")
        for _ in range(3):
            hit, reached = self.run_until(axis, toward, speed, dog, True, "the DOG", also=limit)
            if hit == "dog":
                break
            # the limit came first: the start was past the DOG (FB 3446-3456)
            self.run_until(axis, -toward, speed, dog, True, "the DOG")
            self.run_until(axis, -toward, speed, dog, False, "leaving the DOG", start=speed)
        else:
            raise Stuck(f"{where}: DRVZ does not find the DOG {dog.contact} between the limits")
        if mode == 0:
            self.run_until(axis, toward, creep, dog, False, "leaving the DOG", start=creep)
        elif mode == 1:
            self.brake(axis, toward, reached, where)
            self.advance(self.time + limits["mode1_pause_ms"] / 1000)
            self.run_until(axis, -toward, creep, dog, False, "leaving the DOG", start=creep)
        else:
            if pg0_raw & 0x80:  # count from the DOG's trailing edge (FB 3397-3416)
                self.run_until(axis, toward, creep, dog, False, "leaving the DOG", start=creep)
            self.count_pg0(axis, toward, creep, Contact("X", pg0_raw & 0x7F), params[17], where)
        origin = params[16]
        self.rest[axis] = float(origin)
        self.record_positions()
        self.note(f"step {step.number}: home found, position set to {origin}")
        if clr_raw != 0xFF:
            output = Contact("Y", clr_raw)
            pulse = limits["creep_pulse_ms"] / 1000
            self.contacts.driven += [ContactEvent(output, self.time, True),
                                     ContactEvent(output, self.time + pulse, False)]
            self.advance(self.time + pulse)

    def active(self, sensor: _Input) -> bool:
        return self.contacts.is_on(sensor.contact, self.time, None) != sensor.normally_closed

    def continuous(self, axis: int, direction: int, speed: float, start: float | None) -> Leg:
        params = self.params[axis]
        entry = min(params.start_speed, speed) if start is None else start
        profile, _ = plan([Segment(INF, speed)], self.time, entry, 0.0, params.acceleration,
                          params.deceleration)
        leg = Leg(profile, tuple(self.rest), {axis: float(direction)})
        self.legs.append(leg)
        return leg

    def run_until(self, axis: int, direction: int, speed: float, sensor: _Input, state: bool,
                  what: str, start: float | None = None, also: _Input | None = None
                  ) -> tuple[str, float]:
        """Move on until `sensor` becomes active (state True) or inactive; with `also`, until
        that one becomes active if it comes first. Stops at once there; returns which sensor
        it was and the speed it had."""
        leg = self.continuous(axis, direction, speed, start)
        when = self.edge(sensor, state, leg)
        which = "dog"
        if also is not None:
            other = self.edge(also, True, leg)
            if other < when:
                when, which = other, "limit"
        if when == INF:
            self.cut(leg, max(leg.t0, min(self.max_time, self.time)))
            raise Stuck(f"DRVZ on Ps{axis} never reaches {what} ({sensor.contact}; check its "
                        "SIM line)")
        self.check_time(when, leg, f"DRVZ on Ps{axis}")
        reached = leg.speed(when)
        self.cut(leg, when)
        self.carry = None
        return which, reached

    def edge(self, sensor: _Input, active: bool, leg: Leg) -> float:
        want_on = active != sensor.normally_closed
        if want_on:
            return self.contacts.next_on(sensor.contact, self.time, leg, pulses=False)
        return self.contacts.next_off(sensor.contact, self.time, leg)

    def brake(self, axis: int, direction: int, speed: float, where: str) -> None:
        """MD1: decelerate to a stop with the parameter-8 slope (FB 3352-3354)."""
        params = self.params[axis]
        rate = params.deceleration
        distance = 0.0 if rate == INF else speed * speed / (2 * rate)
        profile, _ = plan([Segment(distance, speed)], self.time, speed, 0.0, INF, rate)
        leg = Leg(profile, tuple(self.rest), {axis: float(direction)})
        self.legs.append(leg)
        self.check_time(leg.t_end, leg, where)
        self.settle(leg, leg.t_end)
        self.rest[axis] = float(round_half_up(self.rest[axis]))

    def count_pg0(self, axis: int, direction: int, speed: float, pg0: Contact,
                  count: int, where: str) -> None:
        leg = self.continuous(axis, direction, speed, speed)
        sensors = self.contacts.pulses(pg0)
        if count == 0:
            self.cut(leg, self.time)
            return
        sensor = next((s for s in sensors if s.axis == axis), None)
        when = INF if sensor is None else self.contacts.next_pulse(sensor, self.time, leg, count)
        if when == INF:
            self.cut(leg, min(self.max_time, self.time))
            raise Stuck(f"DRVZ on Ps{axis} counts PG0 pulses on {pg0}, and no "
                        f"'SIM {pg0} PULSE Ps{axis} EVERY n' line gives any")
        self.check_time(when, leg, where)
        self.cut(leg, when)
        self.carry = None


@dataclass(frozen=True)
class _Input:
    """A FUN141 input: the contact and whether it is wired normally closed (b7/b15)."""

    contact: Contact
    normally_closed: bool


def axis_params(profile: Profile, tables: list[ParamTable]) -> dict[int, AxisParams]:
    by_axis = {t.axis: t for t in reversed(tables)}
    return {axis: AxisParams.of(profile, by_axis.get(axis)) for axis in range(4)}

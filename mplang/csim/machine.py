"""The virtual CSIM's interpreter: runs the stored program line by line over the state of
mplang/csim/machine_state.py, with the commands of mplang/csim/machine_motion.py,
machine_flow.py and machine_data.py, and answers the host's queries.

One `Machine` serves both `mpc run` (driven in simulated time as fast as it computes) and
the virtual device on a serial line (driven by the wall clock, see mplang/csim/device.py).
Program lines take `line_time_s` each; waits (DN, WT, WI, ...) let simulated time run to the
next moment something can change. Every reading of what the manual leaves open is in
stdlib/csim/device.toml and docs/csim.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from mplang.csim.machine_data import DataCommands
from mplang.csim.machine_flow import FlowCommands
from mplang.csim.machine_motion import MotionCommands
from mplang.csim.machine_state import (
    MOVE_AXIS,
    WAIT_AXIS,
    NotModelled,
    RunError,
    format_number,
)
from mplang.csim.motion import INF, MotionError
from mplang.csim.syntax import Operand, Statement
from mplang.family.watch import Stopped


class Machine(MotionCommands, FlowCommands, DataCommands):
    """The virtual CSIM: its state, its commands, and the interpreter that runs them."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self._handlers = self.handlers()
        self.watch: Callable[[float], bool] | None = None  # `mpc run`: True stops the run

    # ---------------------------------------------------------------------- running
    def run(self, max_time: float, max_steps: int = 5_000_000) -> None:
        """Run the started program until it ends, fails, or simulated time passes
        max_time; then let the motions in progress finish (within max_time)."""
        if self.sample_period is not None:
            self.sample()
        self.run_until(max_time, max_steps if math.isfinite(max_time) else None,
                       offline=True)
        if self.running:
            self.stop(f"still running after {max_time:g} s of simulated time", "R202",
                      max(self.pc - 1, 0))
            return
        self.settle(max_time)

    def run_until(self, until: float, max_steps: int | None = None,
                  offline: bool = False) -> None:
        """Execute lines and waits until simulated time reaches `until` or the program
        stops. Offline (mpc run) a wait that nothing can end is an error; on the device the
        host may still change an input, so time just runs on."""
        while self.running and self.clock < until:
            if self.watch is not None and self.watch(self.clock):
                raise Stopped(f"stopped at line {self.pc}")
            if max_steps is not None and self.steps >= max_steps:
                self.stop(f"more than {max_steps} lines executed: an endless loop?", "R202",
                          max(self.pc - 1, 0))
                return
            if self.wait is not None:
                if self.wait.done():
                    self.wait = None
                    continue
                wake = min(self.wait.wake(), self.motion.next_event(), self.pulse_wake())
                if wake == INF and offline:
                    self.stop(f"'{self.wait.line}' waits for ever: nothing in the run can "
                              "change what it waits for", "R201", self.wait_address)
                    return
                self.advance_to(min(max(wake, self.clock), until))
                continue
            self.step()
        if not self.running and not offline:
            self.advance_to(until)  # the motions go on without a program

    def settle(self, max_time: float) -> None:
        """After the program: let the buffered motions run out (not jogs)."""
        while self.motion.busy() and not self.error:
            due = self.motion.next_event()
            if due == INF:
                return
            if due > max_time:
                self.error = f"motion still running after {max_time:g} s of simulated time"
                self.error_code = "R202"
                self.finished = False
                return
            self.advance_to(due)
        if self.sample_period is not None:
            self.sample()

    def pulse_wake(self) -> float:
        pending = [t for t in self.pulse_until if t > self.clock]
        return min(pending, default=INF)

    def step(self) -> None:
        """Execute the line at pc (one line time)."""
        statements = self.script.statements
        if self.pc >= len(statements):
            self.stop()
            return
        statement = statements[self.pc]
        address = self.pc
        self.pc += 1
        self.steps += 1
        try:
            self.execute(statement, in_program=True)
        except (RunError, MotionError) as exc:
            self.stop(f"line {address} '{statement.text}': {exc}", address=address)
            return
        if self.wait is not None:
            self.wait_address = address
        self.check_events()
        self.advance_to(self.clock + self.line_time)

    # ------------------------------------------------------------------- dispatching
    def execute(self, st: Statement, in_program: bool) -> list[str]:
        """Run one statement; returns the lines it prints to the host (queries)."""
        if st.kind == "label":
            return []
        if st.kind == "assign":
            self.assign(st)
            return []
        if st.kind == "query":
            return [self.query(st)]
        name = st.name
        spec = self.profile.commands.get(name)
        if spec is not None and not spec.modelled:
            raise NotModelled(f"{name} is not modelled by the virtual CSIM")
        handler = self._handlers.get(name)
        if handler is None:
            raise RunError(f"{name} cannot run here")
        handler(st)
        return []

    def handlers(self) -> dict[str, Callable[[Statement], None]]:
        table: dict[str, Callable[[Statement], None]] = {
            "MA": self.single_move, "MR": self.single_move,
            "2MA": self.line_move, "2MR": self.line_move, "3MA": self.line_move,
            "3MR": self.line_move, "4MA": self.line_move, "4MR": self.line_move,
            "AA": self.arc_move, "AR": self.arc_move, "SAA": self.arc_move,
            "SAR": self.arc_move, "JGF": self.jog, "JGR": self.jog, "JG0": self.jog_stop,
            "H": self.home, "CS": self.coordinate_set, "HON": self.hold, "HOFF": self.hold,
            "IHON": self.hold, "IHOFF": self.hold, "RESET": self.reset_module,
            "SET": self.output, "CLR": self.output, "CHG": self.output, "ISET": self.output,
            "ICLR": self.output, "PLS": self.pulse, "OUTP": self.output_all,
            "JP": self.jump, "JI": self.jump_input, "JNI": self.jump_input,
            "JZ": self.jump_zero, "JNZ": self.jump_zero, "JE": self.jump_compare,
            "JNE": self.jump_compare, "JG": self.jump_compare, "JNG": self.jump_compare,
            "JTI": self.jump_timed, "JNTI": self.jump_timed, "CALL": self.call,
            "RET": self.ret, "WI": self.wait_input, "WNI": self.wait_input,
            "WT": self.wait_time, "DN": self.wait_done, "SET EV": self.set_event,
            "ON EV": self.on_event, "PZ": self.buffer_control, "REDO": self.buffer_control,
            "CLR BUF": self.buffer_control, "TAPZ": self.path_control,
            "TAREDO": self.path_control, "TAUPZ": self.path_control,
            "TASTOP": self.path_control, "CM": self.continuous_mode, "OUT": self.out,
            "DATA": self.data, "GETI": self.get_number, "GETR": self.get_number,
        }
        for name in MOVE_AXIS:
            table[name] = self.logical_move
        for name in WAIT_AXIS:
            table[name] = self.wait_logical
        return table

    # ---------------------------------------------------------------------- queries
    def query(self, st: Statement) -> str:
        name = st.name
        if name in ("NS", "RS") or (name[0] in "NR" and name[1:].isdigit()):
            if st.operands:
                return format_number(self.value(st.operands[0]))
            kind = "nvar" if name[0] == "N" else "rvar"
            return format_number(self.value(Operand(kind, name, st.span, int(name[1:]))))
        module = 0 if st.prefix is None else st.prefix
        if name == "PE":
            return format_number(self.motion.position(module))
        if name == "VM":
            return format_number(self.module_params[module]["VM"])
        if name == "IN":
            return "1" if self.input_on(st.operands[0]) else "0"
        if name == "ST":
            return self.status()
        if name == "VER":
            return "mplang virtual CSIM 1"
        if name == "ERR":
            return "0" if self.error is None else "1"
        if name in ("TM", "TIME"):
            return format_number(math.floor(self.clock - self.tm_base))
        raise NotModelled(f"?{name} is not modelled by the virtual CSIM")

    def status(self) -> str:
        if self.error is not None:
            return "ERROR"
        if self.motion.path_paused:
            return "PAUSE"
        if self.running:
            return "WAIT" if self.wait is not None else "RUN"
        return "MOVE" if self.motion.busy() else "IDLE"

    # --------------------------------------------------------------------- reports
    def variables(self) -> dict[str, float]:
        found: dict[str, float] = {}
        for i, value in enumerate(self.n):
            if value:
                found[f"N{i}"] = value
        for i, real in enumerate(self.r):
            if real:
                found[f"R{i}"] = _plain(real)
        for i, value in enumerate(self.ns):
            if value:
                found[f"NS({i})"] = value
        for i, real in enumerate(self.rs):
            if real:
                found[f"RS({i})"] = _plain(real)
        return found

    def axes(self) -> dict[str, dict[str, float]]:
        report = {}
        for module in self.reported_modules():
            position = _plain(self.motion.position(module))
            report[self.axis_name(module)] = {"lp": position, "ep": position}
        return report


def _plain(value: float) -> float:
    """A position or real for JSON: an int when whole (within 1e-6), else rounded to 6."""
    rounded = round(value, 6)
    if rounded == int(rounded):
        return int(rounded)
    return rounded

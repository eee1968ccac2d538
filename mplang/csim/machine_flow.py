"""The CSIM's program-flow commands: jumps, calls, waits and events.

A wait sets the `Wait` the interpreter of mplang/csim/machine.py holds the program on; mixed
into its `Machine`.
"""

from __future__ import annotations

from mplang.csim.machine_state import CLOSE, WAIT_AXIS, MachineState, RunError, Wait
from mplang.csim.motion import INF
from mplang.csim.syntax import Statement


class FlowCommands(MachineState):
    """Jumps, CALL/RET, waits on inputs, time and motion, and SET EV/ON EV."""

    def jump(self, st: Statement) -> None:
        self.pc = self.resolve(st.operands[-1])

    def jump_if(self, condition: bool, st: Statement) -> None:
        if condition:
            self.jump(st)

    def jump_input(self, st: Statement) -> None:
        on = self.input_on(st.operands[0])
        self.jump_if(on if st.name == "JI" else not on, st)

    def jump_zero(self, st: Statement) -> None:
        zero = self.value(st.operands[0]) == 0
        self.jump_if(zero if st.name == "JZ" else not zero, st)

    def jump_compare(self, st: Statement) -> None:
        c, var = self.value(st.operands[0]), self.value(st.operands[1])
        holds = {"JE": var == c, "JNE": var != c, "JG": var > c, "JNG": var <= c}[st.name]
        self.jump_if(holds, st)

    def jump_timed(self, st: Statement) -> None:
        """JTI/JNTI: jump if the input is (or becomes, within tm ms) on/off; else go on."""
        want_on = st.name == "JTI"
        unit = float(self.profile.fact("program", "timeout_unit_ms")) / 1000
        end = self.clock + self.value(st.operands[1]) * unit
        target = self.resolve(st.operands[2])

        def done() -> bool:
            if self.input_on(st.operands[0]) == want_on:
                self.pc = target
                return True
            return self.clock >= end - CLOSE

        self.wait = Wait(st.text, done, lambda: end)

    def call(self, st: Statement) -> None:
        target = self.resolve(st.operands[0])
        self.stack.append(self.pc)
        self.pc = target

    def ret(self, _st: Statement) -> None:
        if not self.stack:
            self.stop()
            return
        self.pc = self.stack.pop()
        for event in self.events:
            if event.depth is not None and len(self.stack) < event.depth:
                event.depth = None

    def wait_input(self, st: Statement) -> None:
        want_on = st.name == "WI"
        self.wait = Wait(st.text, lambda: self.input_on(st.operands[0]) == want_on,
                         lambda: INF)

    def wait_time(self, st: Statement) -> None:
        end = self.clock + self.value(st.operands[0]) / 1000
        self.wait = Wait(st.text, lambda: self.clock >= end - CLOSE, lambda: end)

    def wait_done(self, st: Statement) -> None:
        modules = None if st.prefix is None else (self.prefixed_module(st),)
        self.wait = Wait(st.text, lambda: not self.motion.busy(modules), self.motion.next_event)

    def wait_logical(self, st: Statement) -> None:
        module = self.logical_module(WAIT_AXIS[st.name])
        self.wait = Wait(st.text, lambda: not self.motion.busy((module,)),
                         self.motion.next_event)

    def set_event(self, st: Statement) -> None:
        event = self.events[st.operands[0].index - 1]
        event.variable = st.operands[2].index if st.operands[2].kind == "nvar" else None
        if st.operands[2].kind != "nvar":
            raise RunError("SET EV watches a scalar integer variable Nn")
        event.last = False

    def on_event(self, st: Statement) -> None:
        self.events[st.operands[0].index - 1].handler = self.resolve(st.operands[1])

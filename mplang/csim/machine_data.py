"""The CSIM's commands on data: assignments and arithmetic, parameters, outputs, and the
lines to and from the host (OUT, DATA, GETI/GETR).

Mixed into the `Machine` of mplang/csim/machine.py.
"""

from __future__ import annotations

from mplang.csim.machine_state import (
    MachineState,
    NotModelled,
    RunError,
    Wait,
    format_number,
)
from mplang.csim.motion import INF
from mplang.csim.syntax import Operand, Statement


class DataCommands(MachineState):
    """Variables, parameters, outputs and host lines."""

    def assign(self, st: Statement) -> None:
        if st.target is None:
            self.set_parameter(st)
            return
        values = [self.value(o) for o in st.operands]
        result = values[0]
        if st.operator is not None:
            result = self.arithmetic(st.operator, values[0], values[1],
                                     all(_integral_operand(o) for o in st.operands))
        self.store(st.target, result)
        self.check_events()

    def arithmetic(self, op: str, a: float, b: float, integers: bool) -> float:
        if op == "+":
            return a + b
        if op == "-":
            return a - b
        if op == "*":
            return a * b
        if b == 0:
            raise RunError("division by zero")
        if integers:
            quotient = abs(int(a)) // abs(int(b))
            return quotient if (a >= 0) == (b >= 0) else -quotient
        return a / b

    # ------------------------------------------------------------------ parameters
    def set_parameter(self, st: Statement) -> None:
        name = st.name
        value = self.value(st.operands[0])
        module = 0 if st.prefix is None else st.prefix
        if name in ("TX", "TY", "TZ", "TW"):
            axis = "XYZW".index(name[1])
            self.logical[axis] = int(value)
            if int(value) != int(self.profile.fact("logical_axes", "unassigned")):
                self.touched.add(int(value))
            return
        if name == "TVM":
            for m in self.linked_modules():
                self.module_params[m]["PR3"] = value
            self.motion.set_coordinated_speed(value)
            return
        if name in ("PR2", "PR3", "PR7", "VM", "VJ") or name.startswith(("PN", "PR")):
            if name == "PN50":
                self.params[name] = int(value) | 1
                return
            if name == "PN37":
                self.params[name] = int(value)
                return
            self.require_linked(module)
            self.module_params[module][name] = value
            return
        if name == "TM":
            self.tm_base = self.clock - value
            return
        if name == "AIN":
            raise NotModelled("AIN is not modelled by the virtual CSIM")
        self.params[name] = value

    # ---------------------------------------------------------------------- outputs
    def output(self, st: Statement) -> None:
        index = st.operands[0].index - 1
        if st.name in ("SET", "ISET"):
            self.outputs[index] = True
        elif st.name in ("CLR", "ICLR"):
            self.outputs[index] = False
            self.pulse_until[index] = 0.0
        else:
            self.outputs[index] = not self.output_level(index)
            self.pulse_until[index] = 0.0

    def output_level(self, index: int) -> bool:
        return self.outputs[index] or self.clock < self.pulse_until[index]

    def pulse(self, st: Statement) -> None:
        index = st.operands[0].index - 1
        unit = float(self.profile.fact("program", "pls_unit_ms")) / 1000
        self.pulse_until[index] = self.clock + self.value(st.operands[1]) * unit

    def output_all(self, st: Statement) -> None:
        mask = int(self.value(st.operands[0]))
        self.outputs = [bool(mask >> i & 1) for i in range(len(self.outputs))]

    # ------------------------------------------------------------------- host lines
    def out(self, st: Statement) -> None:
        operand = st.operands[0]
        text = operand.text[1:-1] if operand.kind == "string" else format_number(
            self.value(operand))
        self.printed.append(text)

    def data(self, st: Statement) -> None:
        self.store(st.operands[0], self.value(st.operands[1]))
        self.check_events()

    def get_number(self, st: Statement) -> None:
        target = st.operands[0]

        def done() -> bool:
            if not self.host_lines:
                return False
            text = self.host_lines.popleft().strip()
            try:
                number = float(text)
            except ValueError:
                raise RunError(f"{st.name} expected a number from the host, got {text!r}"
                               ) from None
            self.store(target, number)
            return True

        self.wait = Wait(st.text, done, lambda: INF)


def _integral_operand(operand: Operand) -> bool:
    return operand.is_integer_variable or operand.integral

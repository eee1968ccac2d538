"""The Modbus face of the virtual M8194H: the manual's register tables over the controller.

Pure Python, no Modbus library: `mplang.m8194h.modbus` serves this map over TCP and RTU, and tests
can read it directly. Addresses are the manual's zero-based ones (appendix 12, RS 11202ff).
Every read is computed from the controller at its present simulated time; every write goes
through the controller, so a register map and the interpreter can never disagree.

Choices where the manual is silent are in `stdlib/m8194h/device.toml` ([registers]) and in
docs/simulator.md; one is the U axis's DI signals at 280-287 rather than the printed 380-387
(profile key `registers.di_signal_u_first`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from mplang.ir.catalogue import Param
from mplang.m8194h.sim.axis_io import AxisReport
from mplang.m8194h.sim.controller import AXIS_NAMES, DeviceBusy, VirtualController

ILLEGAL_FUNCTION = 0x01
ILLEGAL_ADDRESS = 0x02
ILLEGAL_VALUE = 0x03
DEVICE_BUSY = 0x06

INPUT_SPAN = 200  # input registers 0..199 (undefined ones read 0)
HOLDING_SPAN = 1324  # holding registers 0..1323 (VAR511 ends at 1323)
SUBFUNCTION_FIRST = 8000
SUBFUNCTION_LAST = 8100
SIM_DI_FIRST = 9008  # simulator extension: FRnet DI groups 8..15, writable for tests
SIM_DI_LAST = 9015
# 32-bit values: a read or write must take both registers of each, starting at the first
# ("the start address ... must begin from the MSW ... Otherwise, the host will receive an
# exception error. This rule will be applied to other long, DWORD or float type values",
# RS 3108-3110). Half-open ranges of pairs.
INPUT_PAIRS = ((26, 58), (62, 70), (82, 86), (160, 168))
HOLDING_PAIRS = ((82, 122), (300, 1324))
COIL_SPAN = 132  # coils: FRnet DO 0..127, servo state 128..131
DISCRETE_SPAN = 288  # discrete inputs: FRnet DI, axis status, stop causes, DI signals


def _cuts_pair(pairs: tuple[tuple[int, int], ...], address: int, end: int) -> bool:
    """Whether an access [address, end) cuts a 32-bit value in half."""
    return any(low < edge < high and (edge - low) % 2
               for low, high in pairs for edge in (address, end))


@dataclass(frozen=True)
class Refusal(Exception):
    """The device answers with a Modbus exception; `cause` is register 102's value."""

    code: int
    cause: int = 0
    reason: str = ""


def _range_of(param: Param) -> range:
    """The values a catalogue parameter takes (its min..max)."""
    return range(int(param.min if param.min is not None else -(1 << 31)),
                 int(param.max if param.max is not None else (1 << 31) - 1) + 1)


class RegisterMap:
    """Reads and writes of the four Modbus tables of one virtual controller."""

    def __init__(self, controller: VirtualController) -> None:
        self.vc = controller
        raw = controller.profile.raw
        self.identity = raw["identity"]
        self.var_base = int(raw["variables"]["holding_base"])
        self.bvar_base = int(raw["variables"]["byte_holding_base"])
        self.call_register = int(raw["registers"]["call_mp"])
        self.word_order_register = int(raw["registers"]["word_order"])
        self.frnet_event_register = int(raw["registers"]["frnet_event"])
        self.connection_register = int(raw["registers"]["connection_count"])
        self.split_dword = (int(raw["registers"]["split_dword_exception"]),
                            int(raw["registers"]["split_dword_cause"]))
        self.md = controller.md
        self.md_first = self.md.holding_base  # MD0 .. MD2047 at 3000 + 2n (RS 2528)
        self.md_end = self.md_first + 2 * self.md.count
        self.unsupported_cause = int(raw["modbus"]["unsupported_cause"])
        registers = raw["registers"]
        self.holding_areas = tuple(range(int(first), int(last) + 1)
                                   for first, last in registers["holding_areas"])
        self.range_exception = int(registers["variable_range_exception"])
        by_short = controller.catalogue.rtc_by_short
        self.var_range = _range_of(by_short["WRITE_VAR"].params[1])
        self.bvar_range = _range_of(by_short["WRITE_BVAR"].params[1])
        # the number of connected Modbus TCP clients (ET input register 86, ET 18559): the
        # server that serves this map sets it
        self.connections: Callable[[], int] = lambda: 0

    # ----------------------------------------------------------------- helpers
    def _defined(self, register: int) -> bool:
        return any(register in area for area in self.holding_areas)

    def _check_ranges(self, address: int, values: list[int]) -> None:
        """Refuse a write that gives a variable a value its write command refuses
        (profile `registers.variable_range_*`): nothing of the request is written."""
        vc = self.vc
        for k, value in enumerate(values):
            register = address + k
            n = register - self.bvar_base
            if 0 <= n < len(vc.bvars) and value not in self.bvar_range:
                raise Refusal(self.range_exception, reason=f"bVAR{n} = {value} is outside "
                              f"{self.bvar_range.start}..{self.bvar_range.stop - 1}")
            n, half = divmod(register - self.var_base, 2)
            if 0 <= n < len(vc.vars) and half == 0 and k + 1 < len(values):
                joined = self._join(value, values[k + 1])
                if joined not in self.var_range:
                    raise Refusal(self.range_exception, reason=f"VAR{n} = {joined} is outside "
                                  f"{self.var_range.start}..{self.var_range.stop - 1}")

    def _check_pairs(self, pairs: tuple[tuple[int, int], ...], address: int, end: int) -> None:
        """Refuse an access that cuts a 32-bit value in half: exception 2 (RS 939) and
        register 102 = 0xC0 (profile `registers.split_dword_*`)."""
        if _cuts_pair(pairs, address, end):
            code, cause = self.split_dword
            self.vc.illegal_cause = cause
            raise Refusal(code, cause, "a 32-bit value takes two registers, the first first")

    def unsupported(self, function_code: int) -> Refusal:
        """A function code the manual does not document: exception 1, register 102 = 1."""
        self.vc.illegal_cause = self.unsupported_cause
        return Refusal(ILLEGAL_FUNCTION, self.unsupported_cause,
                       f"function code {function_code} is not supported")

    def _pair(self, value: int) -> list[int]:
        """A signed 32-bit value as two registers in the present word order."""
        value &= 0xFFFFFFFF
        high, low = value >> 16, value & 0xFFFF
        return [low, high] if self.vc.word_order else [high, low]

    def _join(self, first: int, second: int) -> int:
        high, low = (second, first) if self.vc.word_order else (first, second)
        value = (high << 16) | low
        return value - (1 << 32) if value & 0x80000000 else value

    def _axes_pairs(self, getter: str) -> list[int]:
        motion, now = self.vc.motion, self.vc.clock
        out: list[int] = []
        for i in range(len(AXIS_NAMES)):
            out += self._pair(round(getattr(motion, getter)(1 << i, now)))
        return out

    def _reports(self) -> list[AxisReport]:
        vc = self.vc
        return [vc.motion.axis_report(i, vc.clock) for i in range(len(AXIS_NAMES))]

    def _running_number(self) -> int:
        stack = self.vc.stack
        return stack[-1].table.slot if stack else 0

    # ------------------------------------------------------------ input registers
    # Each filler writes its own addresses of a full-size table; a read calls only the
    # fillers whose addresses it overlaps, so polling positions does not compute the rest.
    def _input_fillers(self) -> list[tuple[tuple[range, ...], Callable[[list[int]], None]]]:
        return [
            ((range(0, 16),), self._in_frnet),
            ((range(16, 24), range(25, 26), range(58, 70), range(88, 96)), self._in_axes),
            ((range(24, 25),), self._in_running),
            ((range(26, 58), range(160, 168)), self._in_motion),
            ((range(70, 71), range(130, 140)), self._in_io),
            ((range(71, 72),), self._in_fifo),
            ((range(81, 86),), self._in_identity),
            ((range(self.connection_register, self.connection_register + 1),),
             self._in_connections),
            ((range(100, 103), range(110, 120)), self._in_states),
        ]

    def _in_frnet(self, regs: list[int]) -> None:
        regs[0:16] = [g & 0xFFFF for g in self.vc.frnet]

    def _in_axes(self, regs: list[int]) -> None:
        for i, report in enumerate(self._reports()):
            regs[16 + i] = report.di_status & 0xFFFF
            regs[20 + i] = report.error_code & 0xFFFF
            regs[58 + i] = 1 if report.stopped else 0
            regs[62 + 2 * i:64 + 2 * i] = self._pair(report.latch)
            regs[88 + i] = report.di_signal & 0xFFFF
            regs[92 + i] = report.home_state & 0xFFFF
            regs[25] |= 1 if report.emergency else 0

    def _in_running(self, regs: list[int]) -> None:
        regs[24] = self._running_number()

    def _in_motion(self, regs: list[int]) -> None:
        regs[26:34] = self._axes_pairs("lp")
        regs[34:42] = self._axes_pairs("ep")
        regs[42:50] = self._axes_pairs("cv_reading")
        regs[50:58] = self._axes_pairs("ca_reading")
        regs[160:168] = regs[26:34]  # the absolute logical position is LP

    def _in_io(self, regs: list[int]) -> None:
        io, now = self.vc.motion.io, self.vc.clock
        regs[70] = io.error_state(now)
        regs[130:140] = [mask & 0xFFFF for mask in io.triggered_factors(now)]

    def _in_fifo(self, regs: list[int]) -> None:
        regs[71] = self.vc.fifo_capacity - len(self.vc.fifo)

    def _in_identity(self, regs: list[int]) -> None:
        regs[81] = int(self.identity["module_id"])
        regs[82:84] = self._pair(int(self.identity["rsm_firmware"]))
        regs[84:86] = self._pair(int(self.identity["i8094h_firmware"]))

    def _in_connections(self, regs: list[int]) -> None:
        regs[self.connection_register] = min(self.connections(), 0xFFFF)

    def _in_states(self, regs: list[int]) -> None:
        vc = self.vc
        regs[100] = {"ready": 0, "mp": 1, "isr": 2}[vc.state]
        regs[101] = vc.chip_state
        regs[102] = vc.illegal_cause
        regs[110:115] = list(vc.download_status)
        regs[115:120] = list(vc.execution_error)

    def read_input(self, address: int, count: int) -> list[int]:
        """FC4, as of the controller's present time."""
        end = address + count
        if address < 0 or end > INPUT_SPAN:
            raise Refusal(ILLEGAL_ADDRESS, reason=f"input registers end at {INPUT_SPAN - 1}")
        self._check_pairs(INPUT_PAIRS, address, end)
        regs = [0] * INPUT_SPAN
        for spans, fill in self._input_fillers():
            if any(span.start < end and address < span.stop for span in spans):
                fill(regs)
        return regs[address:end]

    # ---------------------------------------------------------- holding registers
    def read_holding(self, address: int, count: int) -> list[int]:
        """FC3; only the areas the request overlaps are computed."""
        end = address + count
        if address >= 0 and end <= HOLDING_SPAN:
            if not self._defined(address):
                raise Refusal(ILLEGAL_ADDRESS, reason=f"holding register {address} is reserved")
            self._check_pairs(HOLDING_PAIRS, address, end)
            return self._holding(address, end)
        if address >= self.md_first and end <= self.md_end:
            self._check_pairs(((self.md_first, self.md_end),), address, end)
            first = (address - self.md_first) // 2
            words = [self.md.word(n) for n in range(first, (end - self.md_first) // 2)]
            return [r for word in words for r in self._pair(word)]
        if address >= SUBFUNCTION_FIRST and end <= SUBFUNCTION_LAST + 1:
            return [0] * count  # the sub-function window is write-only: it reads as zeros
        if address >= SIM_DI_FIRST and end <= SIM_DI_LAST + 1:
            return self.vc.frnet[8 + address - SIM_DI_FIRST:8 + end - SIM_DI_FIRST]
        raise Refusal(ILLEGAL_ADDRESS, reason=f"no holding register {address}..{end - 1}")

    def _holding(self, address: int, end: int) -> list[int]:
        vc = self.vc
        regs = [0] * HOLDING_SPAN
        regs[0:8] = vc.frnet[0:8]
        # the MP called (by register 8 or MP_CALL), even while an ISR runs above it
        regs[self.call_register] = vc.stack[0].table.slot if vc.stack and \
            vc.stack[0].table.kind == "mp" else 0
        regs[self.frnet_event_register] = 1 if vc.triggers.enabled else 0
        regs[self.word_order_register] = vc.word_order
        if address < 122 and end > 82:
            regs[82:90] = self._axes_pairs("lp")
            regs[90:98] = regs[82:90]
            regs[98:106] = self._axes_pairs("ep")
            regs[106:114] = self._axes_pairs("cv_reading")
            regs[114:122] = self._axes_pairs("ca_reading")
        for n in range(max(address - self.bvar_base, 0),
                       min(end - self.bvar_base, len(vc.bvars))):
            regs[self.bvar_base + n] = vc.bvars[n] & 0xFF
        for n in range(max((address - self.var_base) // 2, 0),
                       min((end - self.var_base + 1) // 2, len(vc.vars))):
            regs[self.var_base + 2 * n:self.var_base + 2 * n + 2] = self._pair(vc.vars[n])
        return regs[address:end]

    def write_holding(self, address: int, values: list[int]) -> None:
        """FC6/FC16. Writes spanning several areas are taken area by area, in order."""
        end = address + len(values)
        if address == SUBFUNCTION_FIRST and end <= SUBFUNCTION_LAST + 1:
            self._subfunction(values)
            return
        if address >= SIM_DI_FIRST and end <= SIM_DI_LAST + 1:
            for k, value in enumerate(values):  # through the controller: triggers see it
                self.vc.set_di_group(8 + address - SIM_DI_FIRST + k, value)
            return
        if address >= self.md_first and end <= self.md_end:
            self._check_pairs(((self.md_first, self.md_end),), address, end)
            for k in range(0, len(values), 2):  # raw words: a float MD keeps any bits
                word = self._join(values[k], values[k + 1]) & 0xFFFFFFFF
                self.md.set_word((address + k - self.md_first) // 2, word)
            return
        if not (address >= 0 and end <= HOLDING_SPAN):
            raise Refusal(ILLEGAL_ADDRESS, reason=f"holding {address}..{end - 1} is not writable")
        self._check_pairs(HOLDING_PAIRS, address, end)
        self._check_ranges(address, values)
        k = 0
        while k < len(values):
            k += self._write_one(address + k, values, k)

    def _write_one(self, register: int, values: list[int], k: int) -> int:
        """Apply the write at `register` (values[k:]); return how many registers it used."""
        vc = self.vc
        value = values[k]
        if register < 8:
            vc.frnet[register] = value & 0xFFFF
            return 1
        if register == self.call_register:
            self._call(value)
            return 1
        if register == self.frnet_event_register:  # RSM_SET_FRNET_TRIGGER_EVENT (5.4)
            vc.set_triggering(bool(value))
            return 1
        if register == self.word_order_register:
            if value not in (0, 1):
                raise Refusal(ILLEGAL_VALUE, reason="word order is 0 or 1")
            vc.word_order = value
            return 1
        if 82 <= register < 106:
            axis = 1 << (((register - 82) // 2) % 4)
            position = self._join(values[k], values[k + 1])
            if register < 98:
                vc.motion.set_lp(axis, position, vc.clock)
            else:
                vc.motion.set_ep(axis, position, vc.clock)
            vc.touch()
            return 2
        if self.bvar_base <= register < self.bvar_base + len(vc.bvars):
            vc.bvars[register - self.bvar_base] = value  # in range: `_check_ranges`
            return 1
        if self.var_base <= register < self.var_base + 2 * len(vc.vars):
            n = (register - self.var_base) // 2
            vc.vars[n] = self._join(values[k], values[k + 1])
            return 2
        raise Refusal(ILLEGAL_ADDRESS, reason=f"holding register {register} is read-only "
                                              "or undefined")

    def _call(self, slot: int) -> None:
        vc = self.vc
        if vc.stack:
            vc.illegal_cause = int(vc.profile.raw["execution"]["busy_while_running"])
            raise Refusal(ILLEGAL_FUNCTION, vc.illegal_cause, "a macro program is running")
        if ("mp", slot) not in vc.tables:
            vc.illegal_cause = 0x02
            raise Refusal(ILLEGAL_FUNCTION, 0x02, f"MP{slot} is empty")
        vc.call(slot)

    def _subfunction(self, frame: list[int]) -> None:
        try:
            cause = self.vc.write_subfunction(frame)
        except DeviceBusy as busy:
            raise Refusal(DEVICE_BUSY, reason=str(busy)) from None
        if cause:
            reason = self.vc.profile.illegal_function_causes.get(cause, "")
            raise Refusal(ILLEGAL_FUNCTION, cause, reason)

    # ------------------------------------------------------------ coils, inputs
    def coils(self) -> list[bool]:
        bits = [bool((self.vc.frnet[n // 16] >> (n % 16)) & 1) for n in range(128)]
        return bits + [report.servo_on for report in self._reports()]

    def read_coils(self, address: int, count: int) -> list[bool]:
        if address < 0 or address + count > COIL_SPAN:
            raise Refusal(ILLEGAL_ADDRESS, reason=f"coils end at {COIL_SPAN - 1}")
        return self.coils()[address:address + count]

    def write_coils(self, address: int, values: list[bool]) -> None:
        if address < 0 or address + len(values) > 128:
            raise Refusal(ILLEGAL_ADDRESS, reason="only FRnet DO coils 0..127 are writable")
        for k, on in enumerate(values):
            n = address + k
            bit = 1 << (n % 16)
            group = self.vc.frnet[n // 16]
            self.vc.frnet[n // 16] = (group | bit) if on else (group & ~bit)

    def discrete_inputs(self) -> list[bool]:
        vc = self.vc
        bits = [bool((vc.frnet[8 + n // 16] >> (n % 16)) & 1) for n in range(128)]
        reports = self._reports()
        for word, width in (("di_status", 16), ("stop_causes", 16), ("di_signal", 8)):
            for report in reports:  # tables 25, 26, 27: one block of bits per axis
                value = getattr(report, word)
                bits += [bool((value >> n) & 1) for n in range(width)]
        return bits

    def read_discrete(self, address: int, count: int) -> list[bool]:
        if address < 0 or address + count > DISCRETE_SPAN:
            raise Refusal(ILLEGAL_ADDRESS, reason=f"discrete inputs end at {DISCRETE_SPAN - 1}")
        return self.discrete_inputs()[address:address + count]

"""The virtual M8194H: macro memory, download protocol, variables, FRnet and the interpreter.

The interpreter executes what the device stores, the decoded frames of each table, not the
compiler's AST, so encoder and interpreter check each other. Time is simulated: every line
costs the profile's line time, waits (TIMER, STOP_WAIT, FRNET_WAIT) jump the clock straight
to the moment they end, and motion is computed analytically by `mplang.m8194h.sim.motion`.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from mplang.ir import catalogue as catalogue_module
from mplang.ir.catalogue import Catalogue
from mplang.ir.lower import apply_operator, wrap32
from mplang.ir.macro import BVarRef, Operand, VarRef
from mplang.m8194h.encode import Encoder
from mplang.m8194h.sim import (
    axis_commands,
    blocks,
    download,
    frame_check,
    initial_table,
    interpolation_commands,
    lines,
    memory,
    precompile,
    unmodelled,
)
from mplang.m8194h.sim.failure import NOT_EXECUTABLE as NOT_EXECUTABLE
from mplang.m8194h.sim.failure import ExecutionError as ExecutionError
from mplang.m8194h.sim.failure import (
    Failure,
    located,
    record_error,
    watch_axis_stops,
)
from mplang.m8194h.sim.initial_table import AxisColumn, InitialTable
from mplang.m8194h.sim.machine_data import MachineData
from mplang.m8194h.sim.motion import MotionModel
from mplang.m8194h.sim.queues import DeviceBusy as DeviceBusy
from mplang.m8194h.sim.queues import QueuedCommand, QueueFull, Retry, requeue
from mplang.m8194h.sim.tables import DownloadError, MacroTable, decode_frame
from mplang.m8194h.sim.triggers import Triggers
from mplang.m8194h.sim.waits import LevelWait, StopWait

AXIS_NAMES = ("X", "Y", "Z", "U")
MAX_STEPS_DEFAULT = 50_000_000
LOG = logging.getLogger("mplang.sim")


Wait = Callable[[], float]
"""A pending wait: returns the simulated time it ends (inf: not foreseeable now)."""
Handler = Callable[["Frame", tuple[Operand, ...]], "Wait | None"]
"""Runs one stored line: gets the frame and the decoded operands, returns a wait (or None
to go straight on)."""
Program = list[tuple[Handler | None, tuple[Operand, ...], bool]]
"""A table's lines ready to run: handler, operands, and whether the line may change the
motion model (after such a line the interpreter looks again for due interrupts)."""

# Lines that only touch variables and control flow: the hot path never leaves for them.
PURE_COMMANDS = frozenset({
    "SET_VAR", "SET_RVAR", "VAR_CALCULATE", "FOR", "NEXT", "EXIT_FOR", "IF", "ELSE",
    "END_IF", "LABEL", "GOTO", "MP_CALL", "EXIT_MACRO", "MP_TERMINATE", "TIMER",
})


@dataclass
class Frame:
    """One level of the MP call stack."""

    table: MacroTable
    pc: int = 0
    loops: list[tuple[int, VarRef | None, list[int]]] = field(default_factory=list)
    # (FOR pc, the counted variable or None, internal counter for a constant count)
    wait: Callable[[], float] | None = None
    # a pending TIMER / STOP_WAIT / FRNET_WAIT: returns when it ends (inf: not foreseeable).
    # It is asked again whenever time moves, so a stop or an input change ends it early.
    program: precompile.Prepared | None = field(default=None, compare=False, repr=False)
    # the table's prepared lines, found once per frame (`VirtualController.prepared`)


@dataclass
class RunResult:
    finished: bool
    time_s: float
    steps: int
    error: str | None = None
    failure: Failure | None = None  # the error's code, program, slot line and call chain


class VirtualController:
    """One M8194H. Programs get in through the download protocol (`write_subfunction`) or
    `load_frames`; `call` starts an MP; `advance` runs everything (macro lines, real-time
    commands from the FIFO, waits, motion) up to a point of simulated time, `run` until the
    called program finishes."""

    def __init__(self, catalogue: Catalogue | None = None, word_order: int = 0) -> None:
        self.catalogue = catalogue or catalogue_module.load()
        self.profile = self.catalogue.profile
        self.encoders = (Encoder(self.catalogue, 0), Encoder(self.catalogue, 1))
        self.encoder = self.encoders[word_order]
        self.close_counts = self.profile.close_counts_as_line
        execution = self.profile.raw["execution"]
        self.line_time = int(execution["line_time_us"]) / 1e6
        self.rtc_time = int(execution["rtc_command_time_us"]) / 1e6
        self.fifo_capacity = self.profile.limit("command_fifo")
        self.isr_capacity = self.profile.limit("isr_queue")
        # operator code -> symbol, built once: VAR_CALCULATE and IF are the hot lines
        self.calc_symbols = {v: k for k, v in self.profile.calc_ops.items()}
        self.cmp_symbols = {v: k for k, v in self.profile.cmp_ops.items()}
        self.vars = [0] * self.profile.var("count")
        self.bvars = [0] * self.profile.var("byte_count")
        self.frnet = [0] * 16  # groups 0-7 DO, 8-15 DI (16 bits each)
        self.tables: dict[tuple[str, int], MacroTable] = {}
        self.motion = MotionModel.for_device(self.profile)
        self.stops: dict[tuple[str, int], Failure] = {}  # axes stopped on limits, alarms, EMG
        watch_axis_stops(self)
        self.clock = 0.0
        self.state = "ready"  # "ready" | "mp" | "isr" (input register 100: 0/1/2)
        self.chip_state = 3  # input register 101 (appendix table 12); power on makes it 5
        self.pending: download.Pending | None = None  # the open download, if any
        self.download_status = (0, 0, 0, 0, 0)  # registers 110-114
        self.execution_error = (0, 0, 0, 0, 0)  # registers 115-119
        self.illegal_cause = 0  # register 102
        self.stack: list[Frame] = []
        self._isr_at: tuple[int, Frame | None] = (0, None)  # the ISR frame's place (`_push`)
        self.fifo: deque[QueuedCommand] = deque()
        self.isr_queue: deque[tuple[int, bool]] = deque()  # (ISRn, from a call) waiting
        self.return_value = 0
        self.error: str | None = None  # why the last program stopped, if it failed
        self.failure: Failure | None = None  # the same, with its code and place
        self.log: deque[str] = deque(maxlen=200)  # what the device did, for `mpc sim -v`
        self.notices: dict[unmodelled.Notice, None] = {}  # unmodelled commands that ran
        self.handlers = self._handlers()
        self.programs: dict[tuple[str, int], precompile.Prepared] = {}
        self.memory_version = 0  # counts non-volatile changes: tells `mpc sim` to save FRAM
        self.epoch = 0  # counts changes made to the motion model from outside its own plan
        # chapter 8: the non-volatile initial table, and the live settings the motion model
        # does not simulate (only the `initial_table.UNMODELLED` fields of these columns
        # count; `initial_table.live_columns` reads the others from the model)
        self.initial_table = InitialTable(self.catalogue)
        self.unmodelled: list[AxisColumn] = [self.initial_table.config.factory] * 4
        self.loading_until: float | None = None  # register 101 shows 4 until then
        self.triggers = Triggers(self)  # chapter 10: the FRnet DI trigger table
        self.md = MachineData(self)  # MD0..MD2047 (3.19), non-volatile
        self.before_line: Callable[[Frame], bool] | None = None  # `mpc dap`: True stops
        # `advance` before the frame's line at `frame.pc` (or its closing line) runs
        self.machine: Callable[[VirtualController], None] | None = None  # re-applies it
        self.load_initial_now()  # "directly after power on" (RS 9738)

    @property
    def word_order(self) -> int:
        return self.encoder.word_order

    @word_order.setter
    def word_order(self, value: int) -> None:
        self.encoder = self.encoders[1 if value else 0]

    @property
    def running(self) -> bool:
        return bool(self.stack)

    # ------------------------------------------------------------------ download
    def write_subfunction(self, frame: list[int]) -> int:
        """One FC16 write at register 8000. Returns 0, or the register-102 cause of the
        ILLEGAL FUNCTION exception the device answers with; raises `DeviceBusy` when a
        real-time command finds the FIFO full. A close that finds the table wrong is
        acknowledged and leaves its cause in register 102 (`download.close`)."""
        self.illegal_cause = 0
        cause = self.md.subfunction(frame) if self.md.owns(frame) else self._write(frame)
        if cause:
            self.illegal_cause = cause
        return cause

    def _write(self, frame: list[int]) -> int:
        decoded = decode_frame(self.encoder, frame)
        if self.pending is not None:
            return download.line(self, frame, decoded)
        if decoded is None:
            return 0x03 if frame and frame[0] not in self.catalogue.by_code else 0x02
        command, operands = decoded
        name = command.short_name
        if name in ("MP_CREATE", "MP_ISR_CREATE"):
            return download.create(self, command, operands)
        if name == "MP_CLOSE":
            return download.stray_close(self)
        if command.is_macro:
            return 0x08
        bad = frame_check.check(command, operands, self.profile)
        if bad is not None:
            self.log.append(f"{self.clock:.4f} s: refused: {bad.describe(command)}")
            return frame_check.OUT_OF_RANGE
        cause = self.initial_table.refusal(command, operands)
        if cause:
            return cause
        if name == "MP_CALL" and self.stack:  # as holding 8 refuses it (busy_while_running)
            self.log.append(f"{self.clock:.4f} s: MP_CALL refused: a macro program is running")
            return int(self.profile.raw["execution"]["busy_while_running"])
        if len(self.fifo) >= self.fifo_capacity:
            raise DeviceBusy(f"{command.name}: the command FIFO is full")
        start = max(self.clock, self.fifo[-1].due if self.fifo else self.clock)
        self.fifo.append(QueuedCommand(command, operands, start + self.rtc_time))
        return 0

    def load_frames(self, kind: str, slot: int, frames: list[list[int]]) -> DownloadError | None:
        """Download one program (create ... close) and return its download error, if any;
        ValueError when a frame outside the download (the create) is refused."""
        for frame in frames:
            in_download = self.pending is not None
            cause = self.write_subfunction(frame)
            if cause and not in_download:  # refused lines fail the download: see its close
                reason = self.profile.illegal_function_causes.get(cause, "unknown cause")
                raise ValueError(f"{kind.upper()}{slot}: frame {frame} refused, cause "
                                 f"{cause:#04x} ({reason})")
        _mp, _isr, command, line, code = self.download_status
        return DownloadError(code, line, command) if code else None

    # -------------------------------------------------------------------- running
    def call(self, slot: int, kind: str = "mp") -> None:
        """Start MPn (or ISRn) now; the caller then advances time to run it."""
        table = self.tables.get((kind, slot))
        if table is None:
            raise ValueError(f"{kind.upper()}{slot} is empty")
        if self.stack:
            raise ValueError(f"cannot call {kind.upper()}{slot}: "
                             f"{self.stack[0].table.kind.upper()}{self.stack[0].table.slot} "
                             "is running")
        self.error = self.failure = None
        self._push(Frame(table))  # in place: `advance` holds this list
        self.chip_state = 8 if kind == "mp" else 10
        self.log.append(f"{self.clock:.4f} s: {kind.upper()}{slot} called")

    def _compiled(self, table: MacroTable) -> Program:
        """The table's lines as `Program` entries (`prepared`)."""
        return self.prepared(table).lines

    def prepared(self, table: MacroTable) -> precompile.Prepared:
        """The table ready to run, built once per table (the hot lines prepared by
        `precompile`)."""
        key = (table.kind, table.slot)
        built = self.programs.get(key)
        if built is not None and built.table is table:
            return built
        program: Program = [(precompile.prepare(self, table, pc, line.command.short_name,
                                                self.handlers.get(line.command.short_name)),
                             line.operands, line.command.short_name not in PURE_COMMANDS)
                            for pc, line in enumerate(table.lines)]
        prepared = precompile.Prepared(table, program)
        prepared.fused = blocks.fuse(self, table, prepared)
        prepared.fused_time = self.line_time
        self.programs[key] = prepared
        return prepared

    def request_isr(self, slot: int, call: bool = True) -> None:
        """Run ISRn as soon as possible: at once, above a running MP (which resumes where it
        was when the ISR ends), or after the ISR that runs now (ISRs do not nest).

        The waiting requests are bounded as on the device (profile `limits.isr_queue`): the
        chip's (`call` False) are taken only while no ISR runs, so a flood of them merges in
        the chip's flags; a call (MP_ISR_CALL) for an ISR whose call already waits merges
        into that one, as a flag that is set already."""
        if call and (slot, True) in self.isr_queue:
            self.log.append(f"{self.clock:.4f} s: ISR{slot} call merged into the waiting one")
            return
        if len(self.isr_queue) >= self.isr_capacity:
            self.log.append(f"{self.clock:.4f} s: ISR{slot} request dropped: "
                            f"{self.isr_capacity} requests wait")
            return
        self.isr_queue.append((slot, call))

    def _isr_running(self) -> bool:
        """An ISR frame is on the stack. There is at most one (ISRs do not nest), pushed by
        `_push` with its place; frames only come and go at the top, so it is there as long
        as that place holds that very frame."""
        at, isr = self._isr_at
        return len(self.stack) > at and self.stack[at] is isr

    def _push(self, frame: Frame) -> None:
        """Start running `frame` above the present ones."""
        if frame.table.kind == "isr":
            self._isr_at = (len(self.stack), frame)
        self.stack.append(frame)

    def _start_isr(self, slot: int) -> None:
        table = self.tables.get(("isr", slot))
        if table is None:
            self.log.append(f"{self.clock:.4f} s: ISR{slot} is empty: request ignored")
            return
        if not self.stack:
            self.error = self.failure = None
        self._push(Frame(table))
        self.chip_state = 10
        self.log.append(f"{self.clock:.4f} s: ISR{slot} started")

    def advance(self, until: float, max_steps: int = MAX_STEPS_DEFAULT,
                until_idle: bool = False) -> int:
        """Run the device up to simulated time `until` (or `max_steps` macro lines): macro
        lines at the profile's line time, queued real-time commands when they fall due,
        waits that end early when the state they wait for arrives. With `until_idle` it
        returns as soon as no program runs and no command is queued. Returns lines run.

        One loop over the events of the device in their order of precedence (the table's
        loading, the machine's inputs, the FIFO, interrupts, triggers, waits), each of which
        may end the slice of lines that `lines.run` runs; it is one function because every
        branch reads and moves the same clock and horizon."""
        steps = 0
        stack = self.stack
        fifo = self.fifo
        while True:
            motion = self.motion  # (RESET_CARD replaces it)
            loading = self.loading_until
            if loading is not None and loading <= self.clock:
                self._finish_loading()
                continue
            if self.machine:
                due = motion.io.script_due(self.clock)
                if motion.io.di_changes:
                    self.take_inputs()  # the machine file changed FRnet inputs
                    continue
            else:
                due = math.inf
            if fifo and fifo[0].due <= self.clock and loading is None:
                self._run_rtc(fifo.popleft())
                continue
            at, isr = self._isr_at  # (`_isr_running`, inline)
            isr_running = len(stack) > at and stack[at] is isr
            if self.isr_queue and not isr_running:
                self._start_isr(self.isr_queue.popleft()[0])
                continue
            if not stack and self.triggers.waiting:
                self.triggers.start_waiting()  # a DI-triggered MP waited for this moment
                continue
            if self.chip_state == 10 and stack and not isr_running:
                self.chip_state = 8  # the ISR returned to the program it interrupted
            if loading is not None:  # the chip loads its table: the FIFO waits (RS 11368)
                horizon = until if until < loading else loading
            else:
                horizon = until if not fifo or fifo[0].due > until else fifo[0].due
            if due < horizon:
                horizon = due
            # the chip's requests wait in its flags while an ISR runs (ISRs do not nest)
            interrupt = None if isr_running else motion.next_interrupt(self.clock)
            if interrupt is not None:
                if interrupt <= self.clock:
                    for _time, number in motion.take_interrupts(self.clock):
                        self.request_isr(number, call=False)
                    continue
                if interrupt < horizon:
                    horizon = interrupt
            if not stack:
                if self.chip_state in (8, 10):
                    self.chip_state += 1  # MP / ISR execution finished
                if until_idle and not fifo and interrupt is None and loading is None:
                    return steps
                if self.clock < horizon:
                    self.clock = horizon
                if horizon >= until:
                    return steps
                continue
            frame = stack[-1]
            if frame.wait is not None:
                end = frame.wait()
                if end > horizon:
                    if self.clock < horizon:
                        self.clock = horizon
                    if horizon >= until:
                        return steps
                    continue
                if end > self.clock:
                    self.clock = end
                if isinstance(frame.wait, Retry):
                    frame.pc -= 1
                frame.wait = None
                motion.settle(self.clock)
                continue
            if self.clock >= until or steps >= max_steps:
                return steps
            steps, stopped = lines.run(self, frame, horizon, steps, max_steps)
            if stopped:
                return steps

    def run(self, max_time: float = 3600.0, max_steps: int = MAX_STEPS_DEFAULT) -> RunResult:
        """Execute the called program until it (and its callees) finish."""
        limit = self.clock + max_time
        steps = self.advance(limit, max_steps, until_idle=True)
        outcome = self.outcome(limit, steps)
        if not outcome.finished:
            return outcome
        # let motion started by the program finish, as the machine would
        end = self.motion.idle_at(15, self.clock)
        if end is not None:
            self.clock = max(self.clock, end)
            self.motion.settle(self.clock)
        return RunResult(True, self.clock, steps)

    def outcome(self, limit: float, steps: int) -> RunResult:
        """What a run that advanced `steps` lines towards `limit` comes to: finished, failed
        with an execution error, waiting for ever, or out of time (motion still running
        after a finished program is left to the caller)."""
        if self.error is not None:
            return RunResult(False, self.clock, steps, self.error, self.failure)
        if self.stack:
            frame = self.stack[-1]
            if frame.wait is not None and frame.wait() == math.inf:
                line = frame.table.lines[frame.pc - 1]
                self.clock = limit
                error = (f"{line.command.short_name} at line {line.slot_line} of "
                         f"{frame.table.kind.upper()}{frame.table.slot} waits for ever")
                return RunResult(False, self.clock, steps, error, located(
                    self.stack, frame.pc - 1, "R201",
                    f"{line.command.short_name} waits for ever", self.clock))
            error = (f"stopped after {steps} lines and {self.clock:.3f} s of simulated time "
                     "without finishing")
            return RunResult(False, self.clock, steps, error, located(
                self.stack, frame.pc - 1, "R202", f"{error} (--max-time)", self.clock))
        return RunResult(True, self.clock, steps)

    # ------------------------------------------------------- real-time commands
    def _run_rtc(self, queued: QueuedCommand) -> None:
        """Execute one real-time command from the FIFO at its due time."""
        self.clock = max(self.clock, queued.due)
        self.epoch += 1
        name = queued.command.short_name
        values = [self.value(o) for o in queued.operands]
        try:
            if name == "MP_CALL":
                self.call(values[0])
            elif name == "MP_ISR_CALL":
                self.request_isr(values[0])
            elif name == "WRITE_VAR":
                self.vars[self._index(queued.operands[0])] = wrap32(values[1])
            elif name == "WRITE_BVAR":
                self.bvars[self._index(queued.operands[0])] = values[1] & 0xFF
            elif name == "CLEAR_CARD_BUFFER":
                self.fifo.clear()
            elif name == "RESET_CARD":
                self.reset()
            elif name == "LOAD_INITIAL":
                self._begin_loading()
            else:
                handler = self.handlers.get(name)
                if handler is not None:
                    handler(Frame(MacroTable("rtc", 0)), queued.operands)
        except QueueFull as full:
            requeue(self, queued, full)
            return
        except Exception as err:  # a real-time command fails alone: logged, never raised
            self.log.append(f"{self.clock:.4f} s: {queued.command.name} ignored: {err}")
            if not isinstance(err, (ValueError, ExecutionError)):
                LOG.warning("internal fault in %s: %r", queued.command.name, err, exc_info=err)
            return
        shown = f"VAR{self._index(queued.operands[0])} = {values[1]}" \
            if name == "WRITE_VAR" else values  # the variable by its name (mpc sim -v)
        self.log.append(f"{self.clock:.4f} s: {queued.command.name} {shown}")

    def fault(self, err: Exception) -> None:
        """A fault inside the device outside any one line or command: log it, stop the
        programs (recording an execution error at the running line, 115-119) and drop the
        FIFO, so the device answers on in a consistent state."""
        LOG.warning("internal fault at %.4f s: %r", self.clock, err, exc_info=err)
        if self.stack:
            frame = self.stack[-1]
            line = frame.table.lines[max(0, min(frame.pc, len(frame.table.lines)) - 1)] \
                if frame.table.lines else None
            if line is not None:
                record_error(self, frame, line, NOT_EXECUTABLE)
            self.error = f"internal fault: {err!r}"
            self.failure = located(self.stack, frame.pc - 1, "R309", self.error, self.clock)
        self.fifo.clear()
        self.terminate_programs(f"internal fault: {err!r}: programs stopped, FIFO cleared")

    def touch(self) -> None:
        """Say the motion model was changed from outside (a register write, a simulated
        input): pending waits predict their end again."""
        self.epoch += 1

    @staticmethod
    def _index(operand: Operand) -> int:
        """The variable number a WRITE_VAR / WRITE_bVAR names (sent as a variable operand)."""
        if isinstance(operand, (VarRef, BVarRef)):
            return operand.index
        return int(operand)  # type: ignore[arg-type]

    def reset(self) -> None:
        """RESET_CARD: stop every program and motion, clear the FIFO and the motion chip's
        settings; macro memory, the initial table, the trigger table and variables are kept
        (they live in FRAM and RAM). The power-on defaults are the initial table's, so the
        table is loaded again, as after power on (profile `initial_table.reset_card_reloads`)."""
        self.stack.clear()
        self.fifo.clear()
        self.isr_queue.clear()
        self.triggers.waiting.clear()
        self.motion = MotionModel.for_device(self.profile)
        watch_axis_stops(self)
        self.handlers = self._handlers()
        self.programs.clear()
        self.unmodelled = [self.initial_table.config.factory] * 4
        self.loading_until = None
        self.chip_state = 3
        if self.machine is not None:  # the machine keeps its switches and script
            self.machine(self)
        if self.initial_table.config.reset_card_reloads:
            self._begin_loading()

    # ------------------------------------------------------------ initial table
    def _begin_loading(self) -> None:
        """LOAD_INITIAL: register 101 shows 4 for the profile's loading time, then the
        table's settings take effect and it shows 5 (RS 11368)."""
        self.chip_state = 4
        self.loading_until = self.clock + self.initial_table.config.load_time
        self.log.append(f"{self.clock:.4f} s: calling the initial table")

    def _finish_loading(self) -> None:
        self.loading_until = None
        self.load_initial_now()
        if self.stack:
            self.chip_state = 10 if self._isr_running() else 8
        self.log.append(f"{self.clock:.4f} s: initial table loaded")

    def load_initial_now(self) -> None:
        """Apply the initial table to the live settings through the plain-axis handlers."""
        frame = Frame(MacroTable("rtc", 0))
        for name, operands in initial_table.load_commands(self.initial_table.columns):
            self.handlers[name](frame, operands)
        self.epoch += 1
        self.chip_state = 5

    def settings(self) -> dict[str, object]:
        """Every Figure 3 setting per axis: `live` (in force now) and `initial_table` (what
        LOAD_INITIAL and power on apply). Settings the motion model does not simulate are
        reported here like the others."""
        live = initial_table.live_columns(self)
        return {"live": {axis: dataclasses.asdict(column)
                         for axis, column in zip(AXIS_NAMES, live, strict=True)},
                "initial_table": self.initial_table.to_json()}

    # -------------------------------------------------------- stand-alone triggers
    def load_trigger_table(self, entries: object) -> None:
        """The FRnet DI trigger table, as image["triggers"]["entries"] holds it (what the
        vendor utility's "Send Table" stores). ValueError names a bad entry."""
        self.triggers.load(entries)

    def set_triggering(self, enabled: bool) -> None:
        """Holding register 9 (RSM_SET_FRNET_TRIGGER_EVENT): FRnet DI triggering on/off."""
        self.triggers.set_enabled(enabled)

    def set_di_group(self, group: int, value: int) -> None:
        """An FRnet DI group (8-15) changes now; every DI change goes through here, so the
        trigger table sees it. Writing `frnet` directly bypasses the triggers."""
        if not 8 <= group <= 15:
            raise ValueError(f"FRnet DI groups are 8..15, got {group}")
        old, new = self.frnet[group], value & 0xFFFF
        self.frnet[group] = new
        if old != new:
            self.triggers.di_changed(group, old, new)

    def take_inputs(self) -> None:
        """Apply the FRnet DI changes the machine file's script made (`scripted`)."""
        for t, group, mask, value in self.motion.io.di_changes:
            self.set_di_group(group, (self.frnet[group] & ~mask) | (value & mask))
            self.log.append(f"{t:.4f} s: machine: DI group {group} = {self.frnet[group]:#06x}")
        self.motion.io.di_changes.clear()
        self.touch()

    def terminate_programs(self, why: str) -> None:
        """End every running MP and ISR level now, as MP_TERMINATE does; motion goes on."""
        if self.stack:
            self.stack.clear()
            if self.chip_state in (8, 10):
                self.chip_state += 1
        self.log.append(f"{self.clock:.4f} s: {why}")

    def value(self, operand: Operand) -> int:
        """An operand's value now: a variable's, or the constant (most are plain ints)."""
        if operand.__class__ is int:
            return operand
        if isinstance(operand, VarRef):
            return self.vars[operand.index]
        if isinstance(operand, BVarRef):
            return self.bvars[operand.index]
        return int(operand)  # type: ignore[arg-type]

    # --------------------------------------------------------------- line handlers
    def _handlers(self) -> dict[str, Handler]:
        m = self.motion

        def setter(method: Callable[[int, int], None]) -> Callable[..., None]:
            def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
                first, second = ops[0], ops[1]  # (plain ints as `value` reads them)
                method(first if first.__class__ is int else self.value(first),
                       second if second.__class__ is int else self.value(second))
            return run

        def vsetter(method: Callable[[int], None]) -> Callable[..., None]:
            def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
                first = ops[0]
                method(first if first.__class__ is int else self.value(first))
            return run

        def returns(getter: Callable[[tuple[Operand, ...]], int]) -> Callable[..., None]:
            def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
                self.return_value = wrap32(int(getter(ops)))
            return run

        def plain_call(method: Callable[..., None]) -> Callable[..., None]:
            def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
                method(*[o if o.__class__ is int else self.value(o) for o in ops])
            return run

        def now_call(method: Callable[[int, int, float], None]) -> Callable[..., None]:
            """An axis mask and a value, then the present time (the moves and SET_LP)."""
            def run(_f: Frame, ops: tuple[Operand, ...]) -> None:
                first, second = ops[0], ops[1]  # (plain ints as `value` reads them)
                method(first if first.__class__ is int else self.value(first),
                       second if second.__class__ is int else self.value(second), self.clock)
            return run

        handlers: dict[str, Handler] = {
            "SET_VAR": self._set_var, "SET_RVAR": self._set_rvar,
            "VAR_CALCULATE": self._calculate, "FOR": self._for, "NEXT": self._next,
            "EXIT_FOR": self._exit_for, "IF": self._if, "ELSE": self._else,
            "END_IF": lambda f, o: None, "LABEL": lambda f, o: None, "GOTO": self._goto,
            "MP_CALL": self._mp_call, "EXIT_MACRO": self._exit_macro,
            "MP_TERMINATE": self._terminate, "TIMER": self._timer,
            "STOP_WAIT": self._stop_wait,
            "SET_MAX_V": setter(m.set_max_v), "NORMAL_SPEED": setter(m.set_speed_mode),
            "SET_SV": setter(m.set_sv), "SET_V": setter(m.set_v), "SET_A": setter(m.set_a),
            "SET_D": setter(m.set_d), "SET_K": setter(m.set_k), "SET_L": setter(m.set_l),
            "SET_AO": setter(m.set_ao),
            "SET_LP": now_call(m.set_lp), "SET_EP": now_call(m.set_ep),
            # "assigns the current position to a new logic position value" (RS 3012)
            "ABS_SET_POSITION": now_call(m.set_lp),
            "FIXED_MOVE": now_call(m.fixed_move), "ABS_FIXED_MOVE": now_call(m.abs_move),
            "CONTINUE_MOVE": now_call(m.continue_move),
            "AXIS_ASSIGN": plain_call(m.axis_assign),
            "VECTOR_SPEED": vsetter(m.set_vector_mode),
            "SET_VSV": vsetter(m.set_vsv), "SET_VV": vsetter(m.set_vv),
            "SET_VA": vsetter(m.set_va), "SET_VD": vsetter(m.set_vd),
            "SET_VK": vsetter(m.set_vk), "SET_VL": vsetter(m.set_vl),
            "SET_VAO": vsetter(m.set_vao),
            "GET_LP": returns(lambda o: m.lp(self.value(o[0]), self.clock)),
            "GET_EP": returns(lambda o: m.ep(self.value(o[0]), self.clock)),
            "ABS_GET_POSITION": returns(lambda o: m.lp(self.value(o[0]), self.clock)),
            "FRNET_IN": returns(lambda o: self.frnet[self.value(o[0])]),
            "FRNET_READ": returns(lambda o: (self.frnet[self.value(o[0])]
                                             >> self.value(o[1])) & 1),
            "FRNET_OUT": self._frnet_out, "FRNET_WRITE": self._frnet_write,
            "FRNET_WAIT": self._frnet_wait,
            **interpolation_commands.handlers(self),
            **axis_commands.handlers(self),
        }
        initial_table.wrap_handlers(self, handlers)
        unmodelled.fill(self, handlers)  # the rest warn when they run
        return handlers

    def _set_var(self, _f: Frame, ops: tuple[Operand, ...]) -> None:
        assert isinstance(ops[0], VarRef)
        self.vars[ops[0].index] = wrap32(self.value(ops[1]))

    def _set_rvar(self, _f: Frame, ops: tuple[Operand, ...]) -> None:
        assert isinstance(ops[0], VarRef)
        self.vars[ops[0].index] = self.return_value

    def _calculate(self, _f: Frame, ops: tuple[Operand, ...]) -> None:
        assert isinstance(ops[3], VarRef)
        symbol = self.calc_symbols[self.value(ops[1])]
        try:
            result = apply_operator(symbol, self.value(ops[0]), self.value(ops[2]))
        except ZeroDivisionError:
            raise ExecutionError(0x03, "division by zero in VAR_CALCULATE") from None
        self.vars[ops[3].index] = result

    def _for(self, frame: Frame, ops: tuple[Operand, ...]) -> None:
        start = frame.pc - 1
        count = self.value(ops[0])
        if count <= 0:  # nothing to count down: skip the body
            frame.pc = frame.table.for_end[start] + 1
            return
        ref = ops[0] if isinstance(ops[0], VarRef) else None
        frame.loops.append((start, ref, [count]))

    def _next(self, frame: Frame, _ops: tuple[Operand, ...]) -> None:
        start, ref, counter = frame.loops[-1]
        if ref is not None:
            self.vars[ref.index] -= 1
            remaining = self.vars[ref.index]
        else:
            counter[0] -= 1
            remaining = counter[0]
        if remaining > 0:
            frame.pc = start + 1
        else:
            frame.loops.pop()

    def _exit_for(self, frame: Frame, _ops: tuple[Operand, ...]) -> None:
        end = frame.table.exit_for_end[frame.pc - 1]
        frame.loops.pop()
        frame.pc = end + 1

    def _if(self, frame: Frame, ops: tuple[Operand, ...]) -> None:
        left, right = self.value(ops[0]), self.value(ops[2])
        code = self.value(ops[1])
        if code not in self.cmp_symbols:
            code = ((code & 0xFF) << 8) | (code >> 8)  # the example's byte order
        if not precompile.COMPARE[self.cmp_symbols[code]](left, right):
            frame.pc = frame.table.if_false[frame.pc - 1] + 1

    def _else(self, frame: Frame, _ops: tuple[Operand, ...]) -> None:
        frame.pc = frame.table.else_end[frame.pc - 1] + 1

    def _goto(self, frame: Frame, ops: tuple[Operand, ...]) -> None:
        frame.loops.clear()  # labels stand outside every block: the jump leaves all loops
        frame.pc = frame.table.labels[self.value(ops[0])] + 1

    def _mp_call(self, _f: Frame, ops: tuple[Operand, ...]) -> None:
        slot = self.value(ops[0])
        table = self.tables.get(("mp", slot))
        if table is None:
            raise ExecutionError(0x02, f"MP_CALL MP{slot}: the slot is empty")
        if len(self.stack) >= self.profile.limit("call_depth"):
            raise ExecutionError(0x01, f"MP_CALL MP{slot}: more than "
                                 f"{self.profile.limit('call_depth')} nested programs")
        self._push(Frame(table))

    def _exit_macro(self, _f: Frame, _ops: tuple[Operand, ...]) -> None:
        self.stack.pop()

    def _terminate(self, _f: Frame, _ops: tuple[Operand, ...]) -> None:
        self.stack.clear()

    def _timer(self, _f: Frame, ops: tuple[Operand, ...]) -> Wait:
        end = self.clock + self.value(ops[0]) / 1000
        return lambda: end

    def _stop_wait(self, _f: Frame, ops: tuple[Operand, ...]) -> Wait:
        mask = ops[0]  # (a plain int as `value` reads it: most jobs wait often)
        return StopWait(self, mask if mask.__class__ is int else self.value(mask))

    def _frnet_out(self, _f: Frame, ops: tuple[Operand, ...]) -> None:
        self.frnet[self.value(ops[0]) & 0x7] = self.value(ops[1]) & 0xFFFF

    def _frnet_write(self, _f: Frame, ops: tuple[Operand, ...]) -> None:
        group, channel, on = (self.value(o) for o in ops)
        bit = 1 << channel
        value = (self.frnet[group] | bit) if on else (self.frnet[group] & ~bit)
        if 8 <= group <= 15:
            self.set_di_group(group, value)  # a DI group: the trigger table sees it
        else:
            self.frnet[group] = value

    def _frnet_wait(self, _f: Frame, ops: tuple[Operand, ...]) -> Wait | None:
        group, channel, state, timeout = (self.value(o) for o in ops)
        if ((self.frnet[group] >> channel) & 1) == state:
            return None
        deadline = self.clock + timeout / 1000 if timeout > 0 else math.inf
        return LevelWait(self, group, channel, state, deadline)

    # --------------------------------------------------------------- inspection
    def snapshot(self) -> dict[str, object]:
        """The `mpc run --json` view: non-zero variables and every axis position."""
        self.motion.settle(self.clock)
        axes = {name: {"lp": self.motion.lp(1 << i, self.clock),
                       "ep": self.motion.ep(1 << i, self.clock)}
                for i, name in enumerate(AXIS_NAMES)}
        return {"vars": {f"VAR{i}": v for i, v in enumerate(self.vars) if v},
                "axes": axes, "time_ms": round(self.clock * 1000, 3)}

    def save(self, path: Path) -> None:
        """Persist macro memory (the device's non-volatile FRAM): `memory.save`."""
        memory.save(self, path)

    def restore(self, path: Path) -> None:
        """Power on with macro memory saved by `save` (`memory.restore`: ValueError with the
        reason if the file is not such a memory image)."""
        memory.restore(self, path)

"""A virtual CSIM on a serial line: the ASCII protocol, program editing and download
(PG/PA/DLP, PE/PI/PD), listing (PL/ULP), G/EXIT, queries, immediate commands, and the stored
program running on the interpreter of mplang/csim/machine.py in real time.

The reply format is mplang's reading of what the manual leaves open (device.toml
[protocol]): every line from the host (ended by CR; LF is ignored) is echoed with CR LF,
followed by any data lines and one status line, `OK` or `ERR <code> <text>`. Lines a running
program prints with OUT are sent as they happen.

Why a thread and not asyncio: pyserial is a blocking API (its asyncio adapter is a separate
package this project does not depend on), and a CSIM has exactly one line and one host. One
thread reads with a 10 ms timeout, answers whole lines, and between reads lets the simulated
clock catch up with the wall clock (times `time_scale`). `VirtualCsim` is the protocol
without any transport, so it is tested directly as well.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import serial  # type: ignore[import-untyped]  # pyserial ships no type hints

from mplang.csim import profile as profile_module
from mplang.csim.check import Checker, jump_targets
from mplang.csim.machine import Machine
from mplang.csim.machine_state import NotModelled, RunError, format_number
from mplang.csim.motion import MotionError
from mplang.csim.profile import Profile
from mplang.csim.syntax import Script, Statement, parse_line
from mplang.lang.diagnostics import DiagnosticSink

# Diagnostic codes of a refused line -> the device's error number (device.toml errors).
ERROR_OF_CODE = {"E701": 1, "E702": 2, "E703": 3, "E704": 3, "E705": 3, "E706": 3, "E707": 3,
                 "E712": 3, "E711": 5}
EDIT_COMMANDS = {"PG", "PA", "DLP"}
RUNNING_OK = {"EXIT"}
MOTION_COMMANDS = {"MA", "MR", "2MA", "2MR", "3MA", "3MR", "4MA", "4MR", "AA", "AR", "SAA", "SAR",
                   "JGF", "JGR", "H", "XMA", "YMA", "ZMA", "WMA", "XMR", "YMR", "ZMR", "WMR"}


@dataclass
class Reply:
    """What the device sends back for one host line: data lines, then the status line."""

    data: list[str]
    status: str


class VirtualCsim:
    """The CSIM protocol over a Machine, without a transport: `handle(line)` answers one
    host line, `tick()` lets time pass and returns what the program printed meanwhile."""

    def __init__(self, profile: Profile | None = None, time_scale: float = 1.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.profile = profile or profile_module.load()
        self.protocol = self.profile.section("protocol")
        self.errors = self.profile.error_texts
        self.time_scale = time_scale
        self.clock = clock
        self.machine = Machine(self.profile)
        self.mode = "command"  # command | edit | replace | insert
        self.edit_line = 0
        self.started = clock()
        self.printed_sent = 0
        self.lock = threading.Lock()
        self.paused_host_commands = frozenset(
            str(name) for name in self.protocol["paused_host_commands"])

    # ----------------------------------------------------------------------- time
    def simulated_now(self) -> float:
        return (self.clock() - self.started) * self.time_scale

    def tick(self) -> list[str]:
        """Run the program (and the motions) up to the present; lines printed by OUT."""
        with self.lock:
            machine = self.machine
            now = self.simulated_now()
            if machine.running:
                machine.run_until(now)
            elif now > machine.clock:
                machine.advance_to(now)
            fresh = machine.printed[self.printed_sent:]
            self.printed_sent = len(machine.printed)
            return list(fresh)

    # -------------------------------------------------------------------- replies
    def ok(self, data: list[str] | None = None) -> Reply:
        return Reply(data or [], str(self.protocol["ok"]))

    def error(self, code: int, detail: str = "") -> Reply:
        text = self.errors.get(code, "error")
        if detail:
            text = f"{text}: {detail}"
        return Reply([], f"{self.protocol['error_prefix']} {code} {text}")

    def wire(self, line: str, reply: Reply) -> bytes:
        """The bytes on the line for one host line: echo, data lines, status."""
        end = str(self.protocol["line_end_out"])
        parts = [line] if self.protocol["echo"] else []
        parts += [*reply.data, reply.status]
        return "".join(part + end for part in parts).encode("ascii", "replace")

    def preload(self, lines: list[str]) -> tuple[str, Reply] | None:
        """Store a program exactly as a DLP download would (the same checks, the same
        listing), for `mpc sim FILE`. Returns the first line refused and its reply, or None
        when every line and the end of edit mode were answered OK."""
        end = str(self.protocol["edit_end"])
        for text in ["DLP", *lines, end]:
            reply = self.handle(text)
            if reply.status != self.protocol["ok"]:
                if self.mode != "command":
                    self.handle(end)
                return text, reply
        return None

    # ---------------------------------------------------------------------- lines
    def handle(self, line: str) -> Reply:
        """Answer one line from the host (without its CR)."""
        self.tick()
        with self.lock:
            if self.mode != "command":
                return self.edit(line)
            return self.command(line)

    def parse(self, line: str, context: str) -> tuple[Statement | None, Reply | None]:
        sink = DiagnosticSink()
        statement = parse_line(line, "<host>", 1, sink)
        if statement is not None:
            Checker(self.profile, sink, context).statement(statement)
        for diagnostic in sink.sorted():
            if diagnostic.severity.value == "error":
                return None, self.error(ERROR_OF_CODE.get(diagnostic.code, 3),
                                        diagnostic.message)
        return statement, None

    def command(self, line: str) -> Reply:
        machine = self.machine
        if machine.running and machine.wait is not None and machine.wait.line.upper().startswith(
                ("GETI", "GETR")):
            machine.host_lines.append(line)
            return self.ok()
        if not line.strip():
            return self.ok()
        statement, refused = self.parse(line, "immediate")
        if refused is not None:
            return refused
        assert statement is not None
        if machine.running and not self.allowed_while_running(statement):
            return self.error(4, f"'{line.strip()}' while the program runs")
        if machine.motion.path_paused and self.is_motion(statement):
            return self.error(10)
        try:
            return self.run_command(statement)
        except NotModelled as exc:
            return self.error(7, str(exc))
        except (RunError, MotionError) as exc:
            return self.error(8, str(exc))

    def allowed_while_running(self, statement: Statement) -> bool:
        if statement.kind == "query":
            return True
        if statement.kind == "assign":
            return statement.target is not None or "external" in self.profile.parameters[
                statement.name].use
        spec = self.profile.commands.get(statement.name)
        if spec is None:
            return False
        if self.machine.motion.path_paused and statement.name in self.paused_host_commands:
            return True  # the pause state takes these from anyone (device.toml [protocol])
        return "external" in spec.use or statement.name in RUNNING_OK

    @staticmethod
    def is_motion(statement: Statement) -> bool:
        return statement.kind == "command" and statement.name in MOTION_COMMANDS

    def run_command(self, st: Statement) -> Reply:
        machine = self.machine
        script = machine.script
        name = st.name if st.kind == "command" else ""
        if name in EDIT_COMMANDS:
            if name != "PA":
                machine.script = Script("program", "<device>")
                machine.reset_run()
            self.mode = "edit"
            return self.ok()
        if name == "PL":
            return self.ok([f"{i:04d}  {text}" for i, text in enumerate(script.texts)])
        if name == "ULP":
            return self.ok(list(script.texts))
        if name in ("PE", "PI", "PD"):
            index = int(st.operands[0].value)
            limit = len(script.statements) + (1 if name == "PI" else 0)
            if index >= limit:
                return self.error(9, f"line {index} (the program has "
                                     f"{len(script.statements)} lines)")
            if name == "PD":
                del script.statements[index]
                return self.ok()
            self.mode = "replace" if name == "PE" else "insert"
            self.edit_line = index
            return self.ok()
        if name == "G":
            problem = self.undefined_label()
            if problem:
                return self.error(6, problem)
            address = machine.resolve(st.operands[0]) if st.operands else 0
            machine.start(address)
            # The program starts at the instant `handle` caught the machine up to (its
            # clock and the motions' clock are the same there); reading the wall clock again
            # here would start the program later than the motions it issues.
            self.printed_sent = len(machine.printed)
            return self.ok()
        if name == "EXIT":
            if machine.running:
                machine.stop()
            return self.ok()
        if name in ("SAVE D", "SAVE C", "SAVE P"):
            return self.ok()  # the virtual CSIM keeps everything for its lifetime
        if name == "DF":
            for params in machine.module_params:
                params.update(machine.defaults)
            return self.ok()
        if name == "RESET H":
            program = machine.script
            self.machine = Machine(self.profile, program)
            self.started = self.clock()
            self.printed_sent = 0
            return self.ok()
        if name == "ULC":
            return self.ok(self.parameters())
        data = machine.execute(st, in_program=False)
        return self.ok(data)

    def parameters(self) -> list[str]:
        machine = self.machine
        lines = [f"{name}={format_number(value)}" for name, value in sorted(machine.params.items())]
        for module in machine.linked_modules():
            prefix = "" if module == 0 else f"T{module}"
            lines += [f"{prefix}{name}={format_number(value)}"
                      for name, value in sorted(machine.module_params[module].items())]
        return lines

    def undefined_label(self) -> str:
        script = self.machine.script
        labels = script.labels
        for address, statement in enumerate(script.statements):
            for target in jump_targets(statement):
                if target.kind == "label" and target.text[1:].upper() not in labels:
                    return f"line {address} '{statement.text}': {target.text}"
                if target.kind == "number" and int(target.value) >= len(script.statements):
                    return f"line {address} '{statement.text}': address {target.text}"
        return ""

    def edit(self, line: str) -> Reply:
        """A line in program-edit mode: stored if it checks; the empty line ends the mode."""
        script = self.machine.script
        if self.mode == "edit" and line.strip() == str(self.protocol["edit_end"]):
            self.mode = "command"
            problem = self.undefined_label()
            return self.error(6, problem) if problem else self.ok()
        statement, refused = self.parse(line, "program")
        if statement is None:
            if refused is None:
                refused = self.error(1, "an empty line cannot be stored")
            if self.mode != "edit":
                self.mode = "command"
            return refused
        if self.mode == "replace":
            script.statements[self.edit_line] = statement
            self.mode = "command"
        elif self.mode == "insert":
            script.statements.insert(self.edit_line, statement)
            self.mode = "command"
        else:
            script.statements.append(statement)
        return self.ok()


class CsimServer:
    """Serves a VirtualCsim on a serial device (a pty end, /dev/ttyUSB0, ...) in a thread."""

    def __init__(self, port_path: str, *, baudrate: int = 9600, time_scale: float = 1.0,
                 device: VirtualCsim | None = None, parity: str = "N", stopbits: int = 1,
                 on_line: Callable[[str, Reply], None] | None = None) -> None:
        self.port_path = port_path
        self.baudrate = baudrate
        self.parity = parity
        self.stopbits = stopbits
        self.on_line = on_line  # told every host line and its reply (mpc sim -v)
        self.device = device or VirtualCsim(time_scale=time_scale)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._port: serial.Serial | None = None
        self.failure: str | None = None

    def start(self) -> CsimServer:
        self._port = serial.Serial(self.port_path, self.baudrate, parity=self.parity,
                                   stopbits=self.stopbits, timeout=0.01)
        self._thread = threading.Thread(target=self._serve, name="virtual-csim", daemon=True)
        self._thread.start()
        return self

    def _serve(self) -> None:
        assert self._port is not None
        port = self._port
        pending = bytearray()
        end_in = str(self.device.protocol["line_end_in"]).encode()
        try:
            while not self._stop.is_set():
                data = port.read(1)  # returns at the first byte, or after 10 ms
                if data and port.in_waiting:
                    data += port.read(port.in_waiting)
                for byte in data:
                    if bytes([byte]) == end_in:
                        line = pending.decode("ascii", "replace")
                        pending.clear()
                        reply = self.device.handle(line)
                        port.write(self.device.wire(line, reply))
                        if self.on_line is not None:
                            self.on_line(line, reply)
                    elif byte != 0x0A:
                        pending.append(byte)
                printed = self.device.tick()
                if printed:
                    end_out = str(self.device.protocol["line_end_out"])
                    port.write("".join(p + end_out for p in printed).encode("ascii", "replace"))
        except (OSError, serial.SerialException) as exc:
            self.failure = str(exc)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
        if self._port is not None:
            self._port.close()

    def __enter__(self) -> CsimServer:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.stop()


def serve_csim(port_path: str, *, baudrate: int = 9600, time_scale: float = 1.0,
               stop: threading.Event | None = None) -> None:
    """Serve a virtual CSIM on `port_path` until `stop` is set (or for ever)."""
    server = CsimServer(port_path, baudrate=baudrate, time_scale=time_scale).start()
    try:
        while not (stop.is_set() if stop else False):
            if server.failure:
                raise OSError(server.failure)
            time.sleep(0.1)
    finally:
        server.stop()

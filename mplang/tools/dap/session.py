"""One `mpc dap` session: DAP requests in, responses and events out.

The main thread reads requests and answers them; a resume (`continue`, `next`, `stepIn`,
`stepOut`, `configurationDone` without `stopOnEntry`) runs the debuggee on a worker thread,
which sends the `stopped` (or `exited` and `terminated`) event when it ends. `pause` sets a
flag the debuggee asks before every macro line. Inspection (`stackTrace`, `scopes`,
`variables`, `evaluate`) is answered while the program stands still; while it runs it is an
error response, as is everything malformed: the session never ends on bad input.

The simulated time of a stop is in the `stopped` event's `description` and `text`.
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from mplang.family.debug import Breakpoint, Debuggee, Item, Stopped
from mplang.tools.dap import expr
from mplang.tools.dap.framing import Dropped, Writer
from mplang.tools.dap.launch import LaunchError, json_kind, read_arguments, start

LOG = logging.getLogger("mplang.tools.dap")
THREAD_ID = 1  # one thread: the called program (an ISR is a frame on top of it)
EXIT_RUN_FAILED = 5  # the `exited` event's code for a failed program, as `mpc run` exits
CAPABILITIES = {
    "supportsConfigurationDoneRequest": True,
    "supportsConditionalBreakpoints": True,
    "supportsEvaluateForHovers": True,
    "supportsExceptionInfoRequest": True,
    "supportsTerminateRequest": True,
    "exceptionBreakpointFilters": [],  # a run-time finding always stops
}
REASONS = {"entry": "Entry", "breakpoint": "Breakpoint", "step": "Step", "pause": "Paused",
           "exception": "Run-time error"}


class RequestError(Exception):
    """A request that cannot be answered as asked: an error response with this message."""


class Session:
    """The adapter's state between requests."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.debuggee: Debuggee | None = None
        self.stop_on_entry = False
        self.worker: threading.Thread | None = None
        self.busy = False  # a resume runs (cleared before its stop is told)
        self.pause = threading.Event()
        self.pending: dict[str, dict[str, Any]] = {}  # setBreakpoints before the launch
        self.refs: dict[int, Sequence[Item]] = {}
        self.next_breakpoint = 1
        self.done = False
        self._resume: str | None = None
        self.handlers: dict[str, Callable[[dict[str, Any]], dict[str, Any] | None]] = {
            "initialize": self.initialize, "launch": self.launch,
            "attach": self.attach, "setBreakpoints": self.set_breakpoints,
            "setExceptionBreakpoints": lambda a: {"breakpoints": []},
            "setFunctionBreakpoints": lambda a: {"breakpoints": []},
            "configurationDone": self.configuration_done, "threads": self.threads,
            "continue": self.resumer("continue"), "next": self.resumer("next"),
            "stepIn": self.resumer("in"), "stepOut": self.resumer("out"),
            "pause": self.request_pause, "stackTrace": self.stack_trace,
            "scopes": self.scopes, "variables": self.variables, "evaluate": self.evaluate,
            "exceptionInfo": self.exception_info, "terminate": self.terminate,
            "disconnect": self.disconnect,
        }

    # ------------------------------------------------------------- messages
    def handle(self, message: bytes | Dropped) -> None:
        """Answer one message. Input that is no message is dropped with a line on stderr
        (there is no request to answer); a JSON object with a `seq` that is no request gets
        an error response too, as its sender may wait for one."""
        if isinstance(message, Dropped):
            LOG.warning("dropped input: %s", message.reason)
            return
        try:
            request = json.loads(message)
        except (ValueError, RecursionError) as exc:  # UnicodeDecodeError is a ValueError
            LOG.warning("dropped a message that is not JSON: %s: %s", type(exc).__name__, exc)
            return
        seq = request.get("seq") if isinstance(request, dict) else None
        if not isinstance(request, dict) or request.get("type") != "request" \
                or not isinstance(request.get("command"), str):
            problem = ("malformed message: not a DAP request (an object with \"type\": "
                       "\"request\" and a \"command\")")
            LOG.warning("dropped input: %s", problem)
            if isinstance(seq, int) and not isinstance(seq, bool):
                self._error(seq, "", problem)
            return
        seq = seq if isinstance(seq, int) and not isinstance(seq, bool) else 0
        command = request["command"]
        args = request.get("arguments", {})
        if not isinstance(args, dict):
            self._error(seq, command, f"the arguments of {command!r} must be an object, not "
                        f"{json_kind(args)}")
            return
        handler = self.handlers.get(command)
        if handler is None:
            self._error(seq, command, f"unknown request {command[:80]!r}")
            return
        self._resume = None
        try:
            body = handler(args)
        except RequestError as exc:
            self._error(seq, command, str(exc))
            return
        except (LookupError, TypeError, ValueError, AttributeError) as exc:
            LOG.debug("bad arguments to %s", command, exc_info=exc)
            self._error(seq, command, f"bad arguments to {command!r}: {exc}")
            return
        except Exception as exc:  # a fault of mpc: answered and logged, the session goes on
            LOG.exception("internal fault answering %s", command)
            self._error(seq, command, f"internal fault of mpc dap: {exc!r}")
            return
        self.writer.send({"type": "response", "request_seq": seq, "success": True,
                          "command": command, **({"body": body} if body is not None else {})})
        after, self._resume = self._resume, None
        if after == "entry":
            self._stopped(Stopped("entry", self._debuggee().time_s))
        elif after is not None:
            self._run(after)
        if command == "launch":
            self.event("initialized")  # ready for setBreakpoints and configurationDone

    def _error(self, seq: int, command: str, message: str) -> None:
        self.writer.send({"type": "response", "request_seq": seq, "success": False,
                          "command": command, "message": message,
                          "body": {"error": {"id": 1, "format": message,
                                             "showUser": True}}})

    def event(self, name: str, body: Mapping[str, Any] | None = None) -> None:
        self.writer.send({"type": "event", "event": name,
                          **({"body": dict(body)} if body is not None else {})})

    def _debuggee(self) -> Debuggee:
        if self.debuggee is None:
            raise RequestError("no program is launched (send 'launch' first)")
        return self.debuggee

    def _still(self) -> Debuggee:
        """The debuggee, if it stands still (inspection needs that)."""
        debuggee = self._debuggee()
        if self.running:
            raise RequestError("the program is running: pause it first")
        return debuggee

    @property
    def running(self) -> bool:
        return self.busy

    # ------------------------------------------------------------- requests
    def initialize(self, _args: dict[str, Any]) -> dict[str, Any]:
        return dict(CAPABILITIES)

    def launch(self, args: dict[str, Any]) -> None:
        if self.debuggee is not None:
            raise RequestError("a program is launched already: one per session")
        try:
            launch = read_arguments(args)
            self.debuggee = start(launch)
        except LaunchError as exc:
            raise RequestError(str(exc)) from None
        self.stop_on_entry = launch.stop_on_entry
        for arguments in self.pending.values():  # set before the launch: placed now
            for point in self.set_breakpoints(arguments)["breakpoints"]:
                self.event("breakpoint", {"reason": "changed", "breakpoint": point})
        self.pending.clear()
        self.event("process", {"name": self.debuggee.title, "startMethod": "launch",
                               "isLocalProcess": True})
        return None

    def attach(self, _args: dict[str, Any]) -> None:
        raise RequestError("mpc dap launches a program on the virtual controller; it cannot "
                           "attach to a device")

    def configuration_done(self, _args: dict[str, Any]) -> None:
        debuggee = self._debuggee()
        if not debuggee.finished and not self.running:
            self._resume = "entry" if self.stop_on_entry else "continue"

    def threads(self, _args: dict[str, Any]) -> dict[str, Any]:
        if self.debuggee is None or self.debuggee.finished:
            return {"threads": []}
        return {"threads": [{"id": THREAD_ID, "name": self.debuggee.title}]}

    def resumer(self, mode: str) -> Callable[[dict[str, Any]], dict[str, Any]]:
        def resume(_args: dict[str, Any]) -> dict[str, Any]:
            self._still()
            self._resume = mode
            return {"allThreadsContinued": True} if mode == "continue" else {}
        return resume

    def request_pause(self, _args: dict[str, Any]) -> None:
        self._debuggee()
        if self.running:
            self.pause.set()  # the debuggee stops before its next macro line

    def terminate(self, _args: dict[str, Any]) -> None:
        self._halt()
        self.event("terminated")

    def disconnect(self, _args: dict[str, Any]) -> None:
        self._halt()
        self.done = True

    def close(self) -> None:
        """The end of the session (disconnect, or the end of input): stop the program."""
        self._halt()

    def _halt(self) -> None:
        """Stop a running program and wait for its worker."""
        self.pause.set()
        worker = self.worker
        if worker is not None:
            worker.join()

    # ----------------------------------------------------------- breakpoints
    def set_breakpoints(self, args: dict[str, Any]) -> dict[str, Any]:
        source = args.get("source")
        if not isinstance(source, dict):
            raise RequestError("setBreakpoints needs a 'source' object")
        asked = args.get("breakpoints")
        if asked is None:
            asked = [{"line": line} for line in args.get("lines", [])]
        if not isinstance(asked, list) or not all(isinstance(b, dict) for b in asked):
            raise RequestError("'breakpoints' must be a list of objects with a 'line'")
        if self.debuggee is None:
            self.pending[json.dumps(source, sort_keys=True)] = args
            return {"breakpoints": [{"verified": False, "line": b.get("line"),
                                     "message": "set when the program is launched"}
                                    for b in asked]}
        file = self._file(source)
        answers: list[dict[str, Any]] = []
        placed: list[Breakpoint] = []
        lines = list(self.debuggee.stop_lines(file)) if file is not None else []
        for wanted in asked:
            line = wanted.get("line")
            if not isinstance(line, int) or isinstance(line, bool) or line < 1:
                raise RequestError(f"a breakpoint's 'line' must be a line number, not "
                                   f"{json_kind(line)}")
            answer: dict[str, Any] = {"id": self.next_breakpoint, "source": source}
            self.next_breakpoint += 1
            at = next((n for n in lines if n >= line), None)
            if file is None or at is None:
                answer.update(verified=False, line=line, message=(
                    "this file is not part of the launched build" if file is None
                    else f"no code on line {line} or below it"))
                answers.append(answer)
                continue
            condition, problem = self._condition(wanted.get("condition"))
            if problem is not None:
                answer.update(verified=False, line=at, message=problem)
            else:
                answer.update(verified=True, line=at)
                placed.append(Breakpoint(answer["id"], at, condition))
            answers.append(answer)
        if file is not None:
            self.debuggee.set_breakpoints(file, placed)
        return {"breakpoints": answers}

    def _condition(self, text: object) -> tuple[Callable[[], bool] | None, str | None]:
        """A breakpoint's condition as a test, or why it cannot be one."""
        if text is None or (isinstance(text, str) and not text.strip()):
            return None, None
        if not isinstance(text, str):
            return None, f"the condition must be a string, not {json_kind(text)}"
        debuggee = self._debuggee()
        try:
            tree = expr.parse(text)
        except expr.ExpressionError as exc:
            return None, f"condition: {exc}"
        unknown = [n for n in expr.names(tree) if debuggee.lookup(n) is None]
        if unknown:
            return None, (f"condition: no variable {unknown[0]!r} in this build (a declared "
                          "VAR or ALIAS name, or VARn)")
        return (lambda: expr.evaluate(tree, debuggee.lookup) != 0), None

    def _file(self, source: Mapping[str, Any]) -> str | None:
        """The build's name of the file a DAP source names (by path, else by name)."""
        debuggee = self._debuggee()
        path, name = source.get("path"), source.get("name")
        wanted = Path(path).resolve() if isinstance(path, str) and path else None
        for display, real in debuggee.files().items():
            if (wanted is not None and real.resolve() == wanted) or display in (name, path):
                return display
        return None

    # ------------------------------------------------------------- running
    def _run(self, mode: str) -> None:
        debuggee = self._debuggee()
        self.refs.clear()

        def work() -> None:
            try:
                stopped = debuggee.resume(mode, self.pause.is_set)
            except Exception as exc:  # a fault of the simulator: said, never a dead adapter
                LOG.exception("internal fault while running")
                self.busy = False
                self.event("output", {"category": "stderr",
                                      "output": f"mpc dap: internal fault: {exc!r}\n"})
                self.event("terminated")
                return
            self.pause.clear()
            self.busy = False
            self._stopped(stopped)

        self.pause.clear()
        self.busy = True
        self.worker = threading.Thread(target=work, name="mpc-dap-run", daemon=True)
        self.worker.start()

    def _stopped(self, stopped: Stopped) -> None:
        """The events of a stop: `stopped`, or `exited` and `terminated` at the end."""
        millis = f"{stopped.time_s * 1000:.3f} ms"
        debuggee = self._debuggee()
        if stopped.reason == "exited":
            outcome = "finished" if stopped.finished else "FAILED"
            for warning in debuggee.warnings():  # as `mpc run` prints them
                self.event("output", {"category": "stderr", "output": warning + "\n"})
            self.event("output", {"category": "console",
                                  "output": f"{debuggee.title}: {outcome} after {millis} "
                                  "simulated\n"})
            self.event("exited", {"exitCode": 0 if stopped.finished else EXIT_RUN_FAILED})
            self.event("terminated")
            return
        body: dict[str, Any] = {"reason": stopped.reason, "threadId": THREAD_ID,
                                "allThreadsStopped": True,
                                "description": f"{REASONS[stopped.reason]} at {millis} "
                                "simulated", "text": f"t = {millis} (simulated)"}
        if stopped.breakpoints:
            body["hitBreakpointIds"] = list(stopped.breakpoints)
        if stopped.error is not None:
            body["description"] = (f"{stopped.error.code}: {stopped.error.message} at "
                                   f"{millis} simulated")
            body["text"] = stopped.error.render()
            self.event("output", {"category": "stderr", "output": body["text"] + "\n"})
        self.event("stopped", body)

    # ---------------------------------------------------------- inspection
    def stack_trace(self, args: dict[str, Any]) -> dict[str, Any]:
        debuggee = self._still()
        files = debuggee.files()
        frames = []
        for number, entry in enumerate(debuggee.stack(), start=1):
            frame: dict[str, Any] = {"id": number, "name": entry.name,
                                     "line": entry.line or 0, "column": entry.column or 1}
            if entry.file is not None:
                real = files.get(entry.file)
                frame["source"] = {"name": entry.file,
                                   **({"path": str(real)} if real is not None else {})}
            if entry.kind == "isr":
                frame["presentationHint"] = "label"
            frames.append(frame)
        first = int(args.get("startFrame") or 0)
        levels = int(args.get("levels") or 0)
        shown = frames[first:first + levels] if levels > 0 else frames[first:]
        return {"stackFrames": shown, "totalFrames": len(frames)}

    def scopes(self, _args: dict[str, Any]) -> dict[str, Any]:
        debuggee = self._still()
        scopes = []
        for name, items in debuggee.scopes():
            scopes.append({"name": name, "variablesReference": self._ref(items),
                           "namedVariables": len(items), "expensive": False})
        return {"scopes": scopes}

    def _ref(self, items: Sequence[Item]) -> int:
        number = len(self.refs) + 1
        self.refs[number] = items
        return number

    def variables(self, args: dict[str, Any]) -> dict[str, Any]:
        self._still()
        reference = args.get("variablesReference")
        items = self.refs.get(reference) if isinstance(reference, int) else None
        if items is None:
            raise RequestError(f"no variables with reference {reference!r} (they last until "
                               "the program runs again)")
        return {"variables": [
            {"name": item.name, "value": item.value, "type": item.number or None,
             "evaluateName": item.name,
             "variablesReference": self._ref(item.children) if item.children else 0}
            for item in items]}

    def evaluate(self, args: dict[str, Any]) -> dict[str, Any]:
        debuggee = self._still()
        text = args.get("expression")
        if not isinstance(text, str):
            raise RequestError(f"'expression' must be a string, not {json_kind(text)}")
        try:
            value = expr.evaluate(expr.parse(text), debuggee.lookup)
        except expr.ExpressionError as exc:
            raise RequestError(str(exc)) from None
        return {"result": str(value), "variablesReference": 0}

    def exception_info(self, _args: dict[str, Any]) -> dict[str, Any]:
        debuggee = self._still()
        error = debuggee.error
        if error is None:
            raise RequestError("the program did not stop on a run-time error")
        return {"exceptionId": error.code, "description": error.message,
                "breakMode": "always",
                "details": {"message": error.render(), "typeName": error.code}}

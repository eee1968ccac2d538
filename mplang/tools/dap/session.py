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

import ast
import json
import logging
import re
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
    "supportsHitConditionalBreakpoints": True,
    "supportsLogPoints": True,
    "supportsFunctionBreakpoints": True,
    "supportsDataBreakpoints": True,
    "supportsBreakpointLocationsRequest": True,
    "supportsSetVariable": True,
    "supportsRestartRequest": True,
    "supportsEvaluateForHovers": True,
    "supportsExceptionInfoRequest": True,
    "supportsTerminateRequest": True,
    "exceptionBreakpointFilters": [],  # a run-time finding always stops
}
REASONS = {"entry": "Entry", "breakpoint": "Breakpoint", "function breakpoint":
           "Function breakpoint", "data breakpoint": "Data breakpoint", "step": "Step",
           "pause": "Paused", "exception": "Run-time error"}
_HIT = re.compile(r"\s*(==|>=|<=|>|<|%)?\s*(\d{1,9})\s*")
_HIT_TESTS: dict[str, Callable[[int, int], bool]] = {
    "==": lambda count, n: count == n, ">=": lambda count, n: count >= n,
    "<=": lambda count, n: count <= n, ">": lambda count, n: count > n,
    "<": lambda count, n: count < n, "%": lambda count, n: count % n == 0}
_PLACEHOLDER = re.compile(r"\{\{|\}\}|\{([^{}]*)\}")


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
        self.halting = False  # `_halt` stops the worker: its stop is not told
        self.launched: dict[str, Any] = {}  # the launch's arguments, for `restart`
        # the last setBreakpoints of each source, and the ids its breakpoints were given
        self.line_requests: dict[str, tuple[dict[str, Any], list[int]]] = {}
        self.function_request: tuple[list[Any], list[int]] = ([], [])
        self.data_request: tuple[list[Any], list[int]] = ([], [])
        self.refs: dict[int, tuple[str, ...]] = {}  # a variablesReference: its scope's path
        self.next_breakpoint = 1
        self.done = False
        self._resume: str | None = None
        self.handlers: dict[str, Callable[[dict[str, Any]], dict[str, Any] | None]] = {
            "initialize": self.initialize, "launch": self.launch,
            "attach": self.attach, "setBreakpoints": self.set_breakpoints,
            "setExceptionBreakpoints": lambda a: {"breakpoints": []},
            "setFunctionBreakpoints": self.set_function_breakpoints,
            "dataBreakpointInfo": self.data_breakpoint_info,
            "setDataBreakpoints": self.set_data_breakpoints,
            "breakpointLocations": self.breakpoint_locations,
            "setVariable": self.set_variable, "restart": self.restart,
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
            self._stopped(self._debuggee().resume("entry", self.pause.is_set))
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
        self._start(args)
        for point in self._place_all():  # set before the launch: placed now
            self.event("breakpoint", {"reason": "changed", "breakpoint": point})
        return None

    def _start(self, args: dict[str, Any]) -> None:
        """Build and load the program of a launch (or a restart)."""
        try:
            launch = read_arguments(args)
            self.debuggee = start(launch)
        except LaunchError as exc:
            raise RequestError(str(exc)) from None
        self.launched = args
        self.stop_on_entry = launch.stop_on_entry
        self.event("process", {"name": self.debuggee.title, "startMethod": "launch",
                               "isLocalProcess": True})

    def _place_all(self) -> list[dict[str, Any]]:
        """Place every breakpoint asked for so far (keeping their ids); their answers."""
        answers: list[dict[str, Any]] = []
        for arguments, ids in list(self.line_requests.values()):
            answers += self._place_lines(arguments, ids)
        answers += self._place_functions(*self.function_request)
        answers += self._place_data(*self.data_request)
        return answers

    def restart(self, args: dict[str, Any]) -> None:
        """Stop the program, build it again (from the launch's arguments, or the new ones
        the request brings) and run it as `configurationDone` does, keeping the
        breakpoints (their hit counts start again)."""
        arguments = args.get("arguments")
        if arguments is not None and not isinstance(arguments, dict):
            raise RequestError(f"the restart's 'arguments' must be an object, not "
                               f"{json_kind(arguments)}")
        self._debuggee()
        self._halt()
        self.debuggee, self.busy = None, False
        self.refs.clear()
        self._start(arguments if arguments is not None else self.launched)
        self._place_all()
        self._resume = self._first_resume()

    def _first_resume(self) -> str | None:
        """How the program starts: stopped on entry if asked, else running (a breakpoint on
        its first line or its entry stops it there)."""
        debuggee = self._debuggee()
        if debuggee.finished or self.running:
            return None
        return "entry" if self.stop_on_entry else "continue"

    def attach(self, _args: dict[str, Any]) -> None:
        raise RequestError("mpc dap launches a program on the virtual controller; it cannot "
                           "attach to a device")

    def configuration_done(self, _args: dict[str, Any]) -> None:
        self._resume = self._first_resume()

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
        """Stop a running program and wait for its worker (which then tells no stop: the
        program is ended or started again, not paused)."""
        self.halting = True
        self.pause.set()
        worker = self.worker
        if worker is not None:
            worker.join()
        self.halting = False

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
        for wanted in asked:
            line = wanted.get("line")
            if not isinstance(line, int) or isinstance(line, bool) or line < 1:
                raise RequestError(f"a breakpoint's 'line' must be a line number, not "
                                   f"{json_kind(line)}")
        arguments = {"source": source, "breakpoints": asked}
        ids = self._ids(len(asked))
        self.line_requests[json.dumps(source, sort_keys=True)] = (arguments, ids)
        return {"breakpoints": self._place_lines(arguments, ids)}

    def _ids(self, count: int) -> list[int]:
        first = self.next_breakpoint
        self.next_breakpoint += count
        return list(range(first, first + count))

    def _place_lines(self, args: dict[str, Any], ids: list[int]) -> list[dict[str, Any]]:
        """Place the breakpoints of one setBreakpoints (checked) with their ids; the
        answers."""
        source, asked = args["source"], args["breakpoints"]
        if self.debuggee is None:
            return [{**answer, "line": b["line"]}
                    for answer, b in zip(self._unplaced(ids), asked, strict=True)]
        file = self._file(source)
        answers: list[dict[str, Any]] = []
        placed: list[Breakpoint] = []
        lines = list(self.debuggee.stop_lines(file)) if file is not None else []
        for number, wanted in zip(ids, asked, strict=True):
            line = wanted["line"]
            answer: dict[str, Any] = {"id": number, "source": source}
            at = next((n for n in lines if n >= line), None)
            if file is None or at is None:
                answer.update(verified=False, line=line, message=(
                    "this file is not part of the launched build" if file is None
                    else f"no code on line {line} or below it"))
                answers.append(answer)
                continue
            answer.update(line=at, column=self.debuggee.column(file, at))
            point, problem = self._point(number, wanted, {"source": source, "line": at})
            if point is None:
                answer.update(verified=False, message=problem)
            else:
                point.line = at
                answer.update(verified=True)
                placed.append(point)
            answers.append(answer)
        if file is not None:
            self.debuggee.set_breakpoints(file, placed)
        return answers

    def _point(self, number: int, wanted: Mapping[str, Any], where: Mapping[str, Any]
               ) -> tuple[Breakpoint | None, str]:
        """A breakpoint from its `condition`, `hitCondition` and `logMessage` (its output
        names the place `where`: a source and line), or why it cannot be one."""
        condition, problem = self._condition(wanted.get("condition"))
        if problem is not None:
            return None, problem
        hit, problem = _hit_condition(wanted.get("hitCondition"))
        if problem is not None:
            return None, problem
        log, problem = self._logger(wanted.get("logMessage"), where)
        if problem is not None:
            return None, problem
        return Breakpoint(number, condition=condition, hit_condition=hit, log=log), ""

    def _condition(self, text: object) -> tuple[Callable[[], bool] | None, str | None]:
        """A breakpoint's condition as a test, or why it cannot be one."""
        if text is None or (isinstance(text, str) and not text.strip()):
            return None, None
        if not isinstance(text, str):
            return None, f"the condition must be a string, not {json_kind(text)}"
        debuggee = self._debuggee()
        try:
            tree = self._expression(text)
        except expr.ExpressionError as exc:
            return None, f"condition: {exc}"
        return (lambda: expr.evaluate(tree, debuggee.lookup) != 0), None

    def _expression(self, text: str) -> ast.expr:
        """An expression read, every name it uses known to the build."""
        debuggee = self._debuggee()
        tree = expr.parse(text)
        unknown = [n for n in expr.names(tree) if debuggee.lookup(n) is None]
        if unknown:
            raise expr.ExpressionError(f"no variable {unknown[0]!r} in this build (a "
                                       "declared VAR or ALIAS name, VARn, or an axis's "
                                       "X.LP, X.EP, X.CV)")
        return tree

    def _logger(self, text: object, where: Mapping[str, Any]
                ) -> tuple[Callable[[], None] | None, str | None]:
        """A logpoint's message as the output it sends (each `{expression}` replaced by its
        value, `{{` and `}}` by braces), or why it cannot be one."""
        if text is None or (isinstance(text, str) and not text.strip()):
            return None, None
        if not isinstance(text, str) or len(text) > expr.MAX_LENGTH:
            return None, (f"the log message must be a string of at most {expr.MAX_LENGTH} "
                          "characters")
        parts: list[str | ast.expr] = []
        end = 0
        for match in _PLACEHOLDER.finditer(text):
            parts.append(text[end:match.start()])
            end = match.end()
            if match.group(1) is None:
                parts.append(match.group(0)[0])
                continue
            try:
                parts.append(self._expression(match.group(1)))
            except expr.ExpressionError as exc:
                return None, f"log message {{{match.group(1)}}}: {exc}"
        parts.append(text[end:])
        debuggee = self._debuggee()

        def value(part: str | ast.expr) -> str:
            if isinstance(part, str):
                return part
            try:
                return str(expr.evaluate(part, debuggee.lookup))
            except expr.ExpressionError as exc:
                return f"<{exc}>"

        def log() -> None:
            self.event("output", {"category": "console",
                                  "output": "".join(value(p) for p in parts) + "\n",
                                  **{k: v for k, v in where.items() if v}})
        return log, None

    def _file(self, source: Mapping[str, Any]) -> str | None:
        """The build's name of the file a DAP source names (by path, else by name)."""
        debuggee = self._debuggee()
        path, name = source.get("path"), source.get("name")
        wanted = Path(path).resolve() if isinstance(path, str) and path else None
        for display, real in debuggee.files().items():
            if (wanted is not None and real.resolve() == wanted) or display in (name, path):
                return display
        return None

    def breakpoint_locations(self, args: dict[str, Any]) -> dict[str, Any]:
        """Where breakpoints can go on the lines asked: each statement's start."""
        source, line, last = args.get("source"), args.get("line"), args.get("endLine")
        if not isinstance(source, dict) or not isinstance(line, int):
            raise RequestError("breakpointLocations needs a 'source' object and a 'line'")
        last = last if isinstance(last, int) and last >= line else line
        debuggee = self._debuggee()
        file = self._file(source)
        lines = debuggee.stop_lines(file) if file is not None else ()
        return {"breakpoints": [{"line": n, "column": debuggee.column(file, n)}
                                for n in lines if file is not None and line <= n <= last]}

    def _request(self, args: Mapping[str, Any], key: str) -> tuple[list[Any], list[int]]:
        """The `breakpoints` of a setFunctionBreakpoints or setDataBreakpoints (objects
        with a string `key`), checked, and the ids they are given."""
        asked = args.get("breakpoints")
        if not isinstance(asked, list) or not all(isinstance(b, dict) and
                                                  isinstance(b.get(key), str) for b in asked):
            raise RequestError(f"'breakpoints' must be a list of objects with a '{key}'")
        return asked, self._ids(len(asked))

    @staticmethod
    def _unplaced(ids: list[int]) -> list[dict[str, Any]]:
        return [{"id": number, "verified": False, "message": "set when the program is "
                 "launched"} for number in ids]

    def set_function_breakpoints(self, args: dict[str, Any]) -> dict[str, Any]:
        self.function_request = self._request(args, "name")
        return {"breakpoints": self._place_functions(*self.function_request)}

    def _place_functions(self, asked: list[Any], ids: list[int]) -> list[dict[str, Any]]:
        """Breakpoints on programs' entries, by name; the answers."""
        if self.debuggee is None:
            return self._unplaced(ids)
        placed: dict[str, list[Breakpoint]] = {}
        answers: list[dict[str, Any]] = []
        for number, wanted in zip(ids, asked, strict=True):
            entry = self.debuggee.program(wanted["name"])
            if entry is None:
                answers.append({"id": number, "verified": False, "message":
                                f"no program {wanted['name'][:80]!r} in this build (MPn, "
                                "ISRn or a program's name)"})
                continue
            point, problem = self._point(number, wanted, {"source": self._source(entry.file),
                                                          "line": entry.line})
            answer: dict[str, Any] = {"id": number, "verified": point is not None,
                                      "line": entry.line, "column": entry.column,
                                      "source": self._source(entry.file)}
            if point is None:
                answer["message"] = problem
            else:
                placed.setdefault(entry.name, []).append(point)
            answers.append(answer)
        self.debuggee.set_function_breakpoints(placed)
        return answers

    def data_breakpoint_info(self, args: dict[str, Any]) -> dict[str, Any]:
        """A variable of the Variables scope (or a name typed) can be watched for writes."""
        name = args.get("name")
        if not isinstance(name, str):
            raise RequestError(f"'name' must be a string, not {json_kind(name)}")
        reference = args.get("variablesReference")
        path = self.refs.get(reference) if isinstance(reference, int) else ("Variables",)
        found = self._debuggee().variable(name) if path == ("Variables",) else None
        if found is None:
            return {"dataId": None, "description": "only a variable (VAR, ALIAS, VARn, "
                    "bVARn) can be watched for changes"}
        return {"dataId": found, "description": f"{name} ({found}) changes",
                "accessTypes": ["write"], "canPersist": True}

    def set_data_breakpoints(self, args: dict[str, Any]) -> dict[str, Any]:
        self.data_request = self._request(args, "dataId")
        return {"breakpoints": self._place_data(*self.data_request)}

    def _place_data(self, asked: list[Any], ids: list[int]) -> list[dict[str, Any]]:
        """Breakpoints on variables' changes; the answers."""
        if self.debuggee is None:
            return self._unplaced(ids)
        placed: dict[str, list[Breakpoint]] = {}
        answers: list[dict[str, Any]] = []
        for number, wanted in zip(ids, asked, strict=True):
            found = self.debuggee.variable(wanted["dataId"])
            point, problem = self._point(number, wanted, {})
            if wanted.get("accessType", "write") != "write":
                point, problem = None, "only a write (a change of the value) is watched"
            elif found is None:
                point, problem = None, f"no variable {wanted['dataId'][:80]!r} in this build"
            answer: dict[str, Any] = {"id": number, "verified": point is not None}
            if point is None:
                answer["message"] = problem
            else:
                placed.setdefault(found or "", []).append(point)
            answers.append(answer)
        self.debuggee.set_data_breakpoints(placed)
        return answers

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
            self.busy = False
            if not self.halting:
                self.pause.clear()
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
        frames: list[dict[str, Any]] = []
        for number, entry in enumerate(debuggee.stack(), start=1):
            frame: dict[str, Any] = {"id": number, "name": entry.name,
                                     "line": entry.line or 0, "column": entry.column or 1}
            if entry.file is not None:
                frame["source"] = self._source(entry.file, files)
            if entry.kind == "isr":
                frame["presentationHint"] = "label"
            frames.append(frame)
        first = int(args.get("startFrame") or 0)
        levels = int(args.get("levels") or 0)
        shown = frames[first:first + levels] if levels > 0 else frames[first:]
        return {"stackFrames": shown, "totalFrames": len(frames)}

    def _source(self, file: str | None,
                files: Mapping[str, Path] | None = None) -> dict[str, Any]:
        """A DAP source for a file of the build (with its path when it is on disk)."""
        if file is None:
            return {}
        real = (files if files is not None else self._debuggee().files()).get(file)
        return {"name": file, **({"path": str(real)} if real is not None else {})}

    def scopes(self, _args: dict[str, Any]) -> dict[str, Any]:
        debuggee = self._still()
        scopes = []
        for name, items in debuggee.scopes():
            scopes.append({"name": name, "variablesReference": self._ref((name,)),
                           "namedVariables": len(items), "expensive": False})
        return {"scopes": scopes}

    def _ref(self, path: tuple[str, ...]) -> int:
        """The variablesReference of a scope or an entry with parts, by its path (the same
        for the same path until the program runs again)."""
        for number, known in self.refs.items():
            if known == path:
                return number
        number = len(self.refs) + 1
        self.refs[number] = path
        return number

    def _items(self, reference: object) -> tuple[tuple[str, ...], Sequence[Item]]:
        """The path and entries (as they read now) of a variablesReference."""
        path = self.refs.get(reference) if isinstance(reference, int) else None
        if path is None:
            raise RequestError(f"no variables with reference {reference!r} (they last until "
                               "the program runs again)")
        items: Sequence[Item] = next((found for name, found in self._still().scopes()
                                      if name == path[0]), ())
        for name in path[1:]:
            items = next((item.children for item in items if item.name == name), ())
        return path, items

    def variables(self, args: dict[str, Any]) -> dict[str, Any]:
        path, items = self._items(args.get("variablesReference"))
        return {"variables": [
            {"name": item.name, "value": item.value,
             **({"type": item.number} if item.number else {}),
             "evaluateName": item.name,
             "variablesReference": self._ref((*path, item.name)) if item.children else 0}
            for item in items]}

    def set_variable(self, args: dict[str, Any]) -> dict[str, Any]:
        """Write a variable, or an axis's LP or EP, as a host can; the value may be an
        expression (`rows_done + 1`)."""
        path, items = self._items(args.get("variablesReference"))
        name, text = args.get("name"), args.get("value")
        if not isinstance(name, str) or not isinstance(text, str):
            raise RequestError("setVariable needs a 'name' and a 'value' (strings)")
        if not any(item.name == name for item in items):
            raise RequestError(f"no {name[:80]!r} in {' '.join(path)}")
        debuggee = self._still()
        try:
            value = expr.evaluate(self._expression(text), debuggee.lookup)
            item = debuggee.set_value(path, name, value)
        except (expr.ExpressionError, ValueError) as exc:
            raise RequestError(str(exc)) from None
        return {"value": item.value, **({"type": item.number} if item.number else {})}

    def evaluate(self, args: dict[str, Any]) -> dict[str, Any]:
        debuggee = self._still()
        text = args.get("expression")
        if not isinstance(text, str):
            raise RequestError(f"'expression' must be a string, not {json_kind(text)}")
        try:
            value = expr.evaluate(self._expression(text), debuggee.lookup)
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


def _hit_condition(text: object) -> tuple[Callable[[int], bool] | None, str | None]:
    """A hit condition as a test of the hit count: `3` or `==3` (the third hit), `>=3`,
    `>3`, `<3`, `<=3`, `%2` (every second hit); or why it cannot be one."""
    if text is None or (isinstance(text, str) and not text.strip()):
        return None, None
    match = _HIT.fullmatch(text) if isinstance(text, str) else None
    if match is None or (match.group(1) == "%" and int(match.group(2)) == 0):
        shown = text[:40] if isinstance(text, str) else json_kind(text)
        return None, (f"hit condition {shown!r}: write a count (3), a comparison (>=3, >3, "
                      "<3, <=3, ==3) or every n-th hit (%2)")
    test, number = _HIT_TESTS[match.group(1) or "=="], int(match.group(2))
    return (lambda count: test(count, number)), None

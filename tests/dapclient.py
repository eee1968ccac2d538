"""A Debug Adapter Protocol client for the tests: `mpc dap` as a subprocess over its stdio,
as an editor runs it. Every message it receives is checked against the protocol's JSON schema
(tests/data/debugAdapterProtocol.json, microsoft/debug-adapter-protocol) before a test sees it.
"""

from __future__ import annotations

import json
import queue
import subprocess
import sys
import threading
from functools import cache
from pathlib import Path
from typing import Any

import jsonschema

SCHEMA = Path(__file__).parent / "data" / "debugAdapterProtocol.json"
WAIT_S = 60.0  # a bound on a message that never comes (a hang fails instead of blocking)


class DapClient:
    """Requests in order; events are kept until a test asks for them."""

    def __init__(self, cwd: Path) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "mplang", "dap"], cwd=cwd,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE)
        self.incoming: queue.Queue[dict[str, Any] | None] = queue.Queue()
        self.events: list[dict[str, Any]] = []
        self.responses: list[dict[str, Any]] = []
        self.seq = 0
        self.disconnected = False
        self.stderr = bytearray()  # drained, so a chatty adapter never blocks on a full pipe
        self.stderr_grew = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()
        threading.Thread(target=self._drain, daemon=True).start()

    def _drain(self) -> None:
        stream = self.proc.stderr
        assert stream is not None
        while chunk := stream.read1(65536):
            with self.stderr_grew:
                self.stderr += chunk
                self.stderr_grew.notify_all()

    def logged(self, text: str) -> str:
        """Wait (bounded) until the adapter's stderr holds `text`; all of it."""
        with self.stderr_grew:
            if not self.stderr_grew.wait_for(lambda: text.encode() in self.stderr, WAIT_S):
                raise AssertionError(f"{text!r} not on stderr: {bytes(self.stderr[-2000:])!r}")
            return self.stderr.decode("utf-8", "replace")

    def _read(self) -> None:
        stream = self.proc.stdout
        assert stream is not None
        while True:
            header = stream.readline()
            if not header:
                self.incoming.put(None)
                return
            if not header.startswith(b"Content-Length:"):
                continue
            size = int(header.split(b":")[1])
            assert stream.readline() == b"\r\n"
            self.incoming.put(json.loads(stream.read(size)))

    def _next(self) -> dict[str, Any]:
        try:
            message = self.incoming.get(timeout=WAIT_S)
        except queue.Empty:
            raise AssertionError(f"mpc dap sent nothing for {WAIT_S} s; stderr: "
                                 f"{bytes(self.stderr[-2000:])!r}") from None
        if message is None:
            raise AssertionError(f"mpc dap closed its output; stderr: "
                                 f"{bytes(self.stderr[-2000:])!r}")
        check_schema(message)
        return message

    def send_raw(self, data: bytes) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(data)
        self.proc.stdin.flush()

    def send(self, message: dict[str, Any]) -> None:
        body = json.dumps(message).encode()
        self.send_raw(b"Content-Length: %d\r\n\r\n" % len(body) + body)

    def request(self, command: str, arguments: dict[str, Any] | None = None) -> dict[str, Any]:
        """Send a request and return its response (events meanwhile are kept)."""
        self.seq += 1
        message: dict[str, Any] = {"seq": self.seq, "type": "request", "command": command}
        if arguments is not None:
            message["arguments"] = arguments
        self.send(message)
        self.disconnected |= command == "disconnect"
        return self.response(self.seq)

    def response(self, seq: int) -> dict[str, Any]:
        """The response to request `seq` (0: to a message that was no request)."""
        for index, found in enumerate(self.responses):
            if found["request_seq"] == seq:
                return self.responses.pop(index)
        while True:
            message = self._next()
            if message["type"] == "event":
                self.events.append(message)
            elif message["request_seq"] == seq:
                return message
            else:
                self.responses.append(message)

    def event(self, name: str) -> dict[str, Any]:
        """The next event `name` (the others before it are kept)."""
        for index, found in enumerate(self.events):
            if found["event"] == name:
                return self.events.pop(index)
        while True:
            message = self._next()
            if message["type"] == "event" and message["event"] == name:
                return message
            if message["type"] == "event":
                self.events.append(message)
            else:
                self.responses.append(message)

    def close(self) -> int:
        """End the adapter (closing its input if it still runs); its exit code."""
        if self.proc.poll() is None and self.proc.stdin is not None:
            self.proc.stdin.close()
        try:
            return self.proc.wait(WAIT_S)
        finally:
            if self.proc.stdout is not None:
                self.proc.stdout.close()


@cache
def _schema() -> dict[str, Any]:
    schema: dict[str, Any] = json.loads(SCHEMA.read_text())
    return schema


def definition(message: dict[str, Any]) -> str:
    """The schema's definition of a message: `StoppedEvent`, `ThreadsResponse`,
    `ErrorResponse` for a failed request; the generic one for a name it does not define."""
    definitions = _schema()["definitions"]
    if message.get("type") == "event":
        name = str(message.get("event", ""))
        specific = name[:1].upper() + name[1:] + "Event"
        return specific if specific in definitions else "Event"
    if message.get("type") == "response":
        if not message.get("success"):
            return "ErrorResponse"
        name = str(message.get("command", ""))
        specific = name[:1].upper() + name[1:] + "Response"
        return specific if specific in definitions else "Response"
    return "ProtocolMessage"


def check_schema(message: dict[str, Any]) -> None:
    """Fail with the schema's words if `message` is not valid DAP."""
    schema = {**_schema(), "$ref": f"#/definitions/{definition(message)}"}
    errors = sorted(jsonschema.Draft4Validator(schema).iter_errors(message), key=str)
    if errors:
        raise AssertionError(f"not valid DAP ({definition(message)}): "
                             f"{[e.message for e in errors[:3]]} in {message}")

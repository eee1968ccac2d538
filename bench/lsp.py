"""The language server's figures of issue 28 (item 2), each printed with its target beside it;
never asserted, and never a test.

A real client: `mpc lsp` runs as a process and this script speaks JSON-RPC to it over its
stdio, as an editor does. For a 512-line file and for the full-device file (every MP and ISR
slot filled to its budget, as bench/compile.py builds it) it times

- didChange -> publishDiagnostics: one incremental edit (a number on the first program's
  second line), until the diagnostics of that version arrive;
- the same with a syntax error in the edited line (each edit a new text, as when typing);
- didChange -> diagnostics and the semantic tokens an editor asks for right after the edit
  (`semanticTokens/full/delta` against the tokens it got before), until that reply arrives;
- and, as prose without a target, an edit of the full device that inserts a line in its
  first program, moving every program below it.

Each edit is a new text, so no cache of a previous text answers it. Medians of BENCH_RUNS
edits (default 15) after two that warm the server, with Python's bytecode cache on. Beside
each row: the check alone (`analysis.analyse` of the same edits in this process, with what
the server keeps between edits: parsed lines, the build memo, the last analysis), so that
what the server adds around it shows, and the server's CPU time per
edit (its user and system time from /proc over the timed edits, everything it did for them
included: a figure that a loaded machine inflates less than the wall time).
"""

from __future__ import annotations

import json
import os
import queue
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from compile import full_device, program  # bench/compile.py: the same generated sources

from mplang.ir.reuse import BuildMemo
from mplang.lang.linecache import StatementCache
from mplang.tools.framing import Reader
from mplang.tools.lsp.analysis import analyse

SERVER = [sys.executable, "-m", "mplang", "lsp"]
EDITED_LINE = 1  # "  VAR1 = 0" of the first program


class Client:
    """A minimal LSP client over a server process's stdio."""

    def __init__(self, cwd: Path) -> None:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        self.process = subprocess.Popen(SERVER, cwd=cwd, env=env, stdin=subprocess.PIPE,
                                        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        self.messages: queue.Queue[dict[str, Any]] = queue.Queue()
        self.ids = iter(range(1, 1 << 30))
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        reader = Reader(self.process.stdout.read1, 1 << 26)
        while True:
            body = reader.next()
            if body is None:
                return
            if isinstance(body, bytes):
                self.messages.put(json.loads(body))

    def send(self, method: str, params: dict[str, Any], request: bool = False) -> int | None:
        message: dict[str, Any] = {"jsonrpc": "2.0", "method": method, "params": params}
        ident = next(self.ids) if request else None
        if ident is not None:
            message["id"] = ident
        body = json.dumps(message).encode()
        assert self.process.stdin is not None
        self.process.stdin.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)
        self.process.stdin.flush()
        return ident

    def wait(self, match: Any) -> dict[str, Any]:
        """The next message `match` accepts (others are dropped), within 60 s."""
        deadline = time.monotonic() + 60
        while True:
            message = self.messages.get(timeout=max(deadline - time.monotonic(), 0.001))
            if match(message):
                return message

    def request(self, method: str, params: dict[str, Any]) -> Any:
        ident = self.send(method, params, request=True)
        return self.wait(lambda m: m.get("id") == ident and "method" not in m).get("result")

    def close(self) -> None:
        self.request("shutdown", {})
        self.send("exit", {})
        self.process.wait(timeout=10)


def cpu_seconds(pid: int) -> float | None:
    """User and system CPU time of a process so far (Linux /proc; None elsewhere)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def diagnostics_of(uri: str, version: int) -> Any:
    return lambda m: m.get("method") == "textDocument/publishDiagnostics" and \
        m["params"]["uri"] == uri and m["params"].get("version") == version


def measure(client: Client, uri: str, text: str, runs: int, error: bool, tokens: bool,
            insert: bool = False) -> tuple[float, float | None]:
    """Median seconds from a didChange to its diagnostics (and the tokens' reply), and the
    server's mean CPU seconds per edit. `insert`: each edit inserts a line instead (every
    program below it moves)."""
    version = 1
    client.send("textDocument/didOpen", {"textDocument": {
        "uri": uri, "languageId": "mplang", "version": version, "text": text}})
    client.wait(diagnostics_of(uri, version))
    result_id = None
    if tokens:
        result_id = client.request("textDocument/semanticTokens/full",
                                   {"textDocument": {"uri": uri}})["resultId"]
    line = text.split("\n")[EDITED_LINE]
    times = []
    cpu_before = None
    for run in range(runs + 2):
        if run == 2:
            cpu_before = cpu_seconds(client.process.pid)
        version += 1
        new = f"  VAR1 = ({run} +" if error else f"  VAR1 = {run + 1}"
        change = {"range": {"start": {"line": EDITED_LINE, "character": 0},
                            "end": {"line": EDITED_LINE, "character": len(line)}},
                  "text": new}
        if insert:
            change = {"range": {"start": {"line": EDITED_LINE, "character": 0},
                                "end": {"line": EDITED_LINE, "character": 0}},
                      "text": f"  VAR2 = {run}\n"}
        else:
            line = new
        start = time.perf_counter()
        client.send("textDocument/didChange", {
            "textDocument": {"uri": uri, "version": version}, "contentChanges": [change]})
        client.wait(diagnostics_of(uri, version))
        if tokens:
            reply = client.request("textDocument/semanticTokens/full/delta", {
                "textDocument": {"uri": uri}, "previousResultId": result_id})
            result_id = reply["resultId"]
        if run >= 2:
            times.append(time.perf_counter() - start)
    cpu_after = cpu_seconds(client.process.pid)
    client.send("textDocument/didClose", {"textDocument": {"uri": uri}})
    cpu = (cpu_after - cpu_before) / runs if cpu_before is not None and \
        cpu_after is not None else None
    return statistics.median(times), cpu


def check_alone(path: Path, text: str, runs: int, error: bool, insert: bool = False) -> float:
    """Median seconds of the analysis behind the same edits, in this process, with what the
    server keeps between them (parsed lines, the document's build memo and last analysis)."""
    lines = text.split("\n")
    times = []
    statements, memo, previous = StatementCache(), BuildMemo(), None
    for run in range(runs + 2):
        if insert:
            lines.insert(EDITED_LINE, f"  VAR2 = {run}")
        else:
            lines[EDITED_LINE] = f"  VAR1 = ({run} +" if error else f"  VAR1 = {run + 1}"
        edited = "\n".join(lines)
        start = time.perf_counter()
        previous = analyse(path, edited, lines=statements, memo=memo, previous=previous)
        if run >= 2:
            times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    runs = int(os.environ.get("BENCH_RUNS", "15"))
    device, device_lines = full_device()
    mp512 = "\n".join(program("mp", 156, 512)) + "\n"
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        (work / ".git").mkdir()  # the workspace's root: no mpc.toml above it is read
        client = Client(work)
        client.request("initialize", {"processId": None, "rootUri": work.as_uri(),
                                      "capabilities": {}})
        client.send("initialized", {})
        for name, text, target in (("512", mp512, 0.010), ("full-device", device, 0.050)):
            for suffix, error, tokens in (("", False, False), ("-syntax-error", True, False),
                                          ("-semantic-tokens", False, True)):
                uri = (work / f"{name}{suffix}.mp").as_uri()
                figure, cpu = measure(client, uri, text, runs, error, tokens)
                alone = check_alone(work / f"alone-{name}{suffix}.mp", text, runs, error)
                rows.append((f"lsp-{name}{suffix}", figure, target, alone, cpu))
        moved = measure(client, (work / "inserted.mp").as_uri(), device, runs, False, False,
                        insert=True)
        moved_alone = check_alone(work / "alone-inserted.mp", device, runs, False, insert=True)
        client.close()
    print(f"mpc lsp over stdio, didChange -> publishDiagnostics (-semantic-tokens: and the "
          f"semanticTokens/full/delta reply after it); 512-line file and the full device "
          f"({device_lines} macro lines, {device.count(chr(10))} source lines); medians of "
          f"{runs} edits")
    for name, figure, _, alone, cpu in rows:
        used = f"{cpu * 1000:.1f} ms" if cpu is not None else "not known here"
        print(f"{name}: {figure * 1000:.1f} ms, of which the check alone {alone * 1000:.1f} ms;"
              f" the server's CPU time per edit {used}")
    used = f"{moved[1] * 1000:.1f} ms" if moved[1] is not None else "not known here"
    print(f"full device, each edit inserting a line above every program but the first (they "
          f"all move: their kept checks are shifted, their lines' statements copied with new "
          f"spans): {moved[0] * 1000:.1f} ms, of which the check alone "
          f"{moved_alone * 1000:.1f} ms; the server's CPU time per edit {used} (no target of "
          f"its own)")
    for name, figure, target, _, _ in rows:
        verdict = "met" if figure <= target else "MISSED"
        print(f"ROW {name} {figure * 1000:.1f}ms <={target * 1000:.0f}ms {verdict}")


if __name__ == "__main__":
    main()

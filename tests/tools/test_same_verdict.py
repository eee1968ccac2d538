"""One project, one verdict (issue 15, "done when"): the GitHub and GitLab CI formats, SARIF,
the pre-commit hook's entry, VS Code's server command and a second editor's (Neovim, as
docs/lsp.md configures it) all report the same findings for the same files, with the
project's `mpc.toml` (`[lint] ignore`) applied everywhere.

Each channel is run as its user runs it: `mpc lint` processes with the documented formats,
the hook's `entry` from `.pre-commit-hooks.yaml` with file names appended (as pre-commit
passes them), and the language server over stdio under the command line each editor's
set-up gives, as the editor's client drives it (initialize, didOpen, publishDiagnostics)."""

from __future__ import annotations

import json
import os
import queue
import re
import shlex
import subprocess
import sys
import threading
from pathlib import Path
from typing import IO, Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
MPC = str(Path(sys.executable).parent / "mpc")

FILES = {
    # W102 (FOR 0) is ignored by the project; the syntax error E101 on line 5 is not
    "job.mp": "MP 1 one\n    FOR 0\n        FIXED_MOVE X, 100\n    NEXT\n    FOR 3 (\n"
              "    NEXT\nEND MP\n",
    "other.mp": "MP 2 two\n    VAR1 = 1\n    FIXD_MOVE X, 10\nEND MP\n",  # E201 at 3
    "clean.mp": "MP 41 main\n    VAR1 = VAR2 + 1\nEND MP\n",  # W103 at 2
}
VERDICT = {("job.mp", 5, "E101"), ("other.mp", 3, "E201"), ("clean.mp", 2, "W103")}
"""What every channel must report: nothing more (no W102), nothing less."""

Finding = tuple[str, int, str]


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("verdict")
    (root / "mpc.toml").write_text('[lint]\nignore = ["W102"]\n')
    for name, text in FILES.items():
        (root / name).write_text(text)
    return root


def mpc(project: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "NO_COLOR"}
    return subprocess.run([MPC, *args], cwd=project, capture_output=True, text=True,
                          timeout=120, env=env)


def lint(project: Path, fmt: str) -> tuple[int, str]:
    result = mpc(project, "lint", "--format", fmt, *FILES)
    return result.returncode, result.stdout


def test_github_workflow_commands(project: Path) -> None:
    code, out = lint(project, "github")
    found = set()
    for line in out.splitlines():
        if line.startswith(("::error ", "::warning ")):
            fields = dict(part.split("=", 1) for part in
                          line.split(" ", 1)[1].split("::")[0].split(","))
            found.add((fields["file"], int(fields["line"]), fields["title"].split()[0]))
    assert code == 1 and found == VERDICT


def test_gitlab_code_quality(project: Path) -> None:
    code, out = lint(project, "gitlab")
    found = {(i["location"]["path"], i["location"]["lines"]["begin"], i["check_name"])
             for i in json.loads(out)}
    assert code == 1 and found == VERDICT


def test_sarif(project: Path) -> None:
    code, out = lint(project, "sarif")
    results = json.loads(out)["runs"][0]["results"]
    found = {(r["locations"][0]["physicalLocation"]["artifactLocation"]["uri"],
              r["locations"][0]["physicalLocation"]["region"]["startLine"], r["ruleId"])
             for r in results}
    assert code == 1 and found == VERDICT


def test_pre_commit_hook_entry(project: Path) -> None:
    hooks = (ROOT / ".pre-commit-hooks.yaml").read_text()
    entry = re.search(r"- id: mpc-lint\n(?:  .*\n)*?  entry: (.+)\n", hooks)
    assert entry is not None
    command = shlex.split(entry.group(1))
    assert command[0] == "mpc"
    result = mpc(project, *command[1:], *FILES)
    found = {(m[1], int(m[2]), m[3]) for m in
             re.finditer(r"^(\S+?):(\d+):\d+: (?:error|warning)\[(\w+)\]", result.stdout
                         + result.stderr, re.M)}
    found = {(Path(f).name, line, code) for f, line, code in found}
    assert result.returncode == 1 and found == VERDICT


class StdioClient:
    """The least of an editor's LSP client: framed JSON-RPC over the server's pipes."""

    def __init__(self, command: list[str], cwd: Path) -> None:
        self.process = subprocess.Popen(command, cwd=cwd, stdin=subprocess.PIPE,
                                        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        self.messages: queue.Queue[dict[str, Any]] = queue.Queue()
        assert self.process.stdout is not None
        threading.Thread(target=self._read, args=(self.process.stdout,), daemon=True).start()
        self.next_id = 0

    def _read(self, stream: IO[bytes]) -> None:
        while True:
            headers: dict[str, str] = {}
            while (line := stream.readline()) not in (b"\r\n", b""):
                name, _, value = line.decode().partition(":")
                headers[name.strip().lower()] = value.strip()
            if not headers:
                return
            self.messages.put(json.loads(stream.read(int(headers["content-length"]))))

    def send(self, method: str, params: Any, request: bool = False) -> None:
        message: dict[str, Any] = {"jsonrpc": "2.0", "method": method, "params": params}
        if request:
            self.next_id += 1
            message["id"] = self.next_id
        body = json.dumps(message).encode()
        assert self.process.stdin is not None
        self.process.stdin.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)
        self.process.stdin.flush()

    def wait(self, method: str) -> dict[str, Any]:
        while True:
            message = self.messages.get(timeout=60)
            if message.get("method") == method or (method == "response" and "id" in message
                                                   and "method" not in message):
                return message

    def close(self) -> None:
        self.send("shutdown", None, request=True)
        self.wait("response")
        self.send("exit", None)
        self.process.wait(timeout=30)


def editor_verdict(command: list[str], project: Path) -> set[Finding]:
    client = StdioClient(command, project)
    try:
        client.send("initialize", {"processId": os.getpid(), "rootUri": project.as_uri(),
                                   "capabilities": {}}, request=True)
        client.wait("response")
        client.send("initialized", {})
        found: set[Finding] = set()
        for name in FILES:
            uri = (project / name).as_uri()
            client.send("textDocument/didOpen", {"textDocument": {
                "uri": uri, "languageId": "mplang", "version": 1,
                "text": (project / name).read_text()}})
            while True:
                params = client.wait("textDocument/publishDiagnostics")["params"]
                if params["uri"] == uri:
                    break
            found |= {(name, d["range"]["start"]["line"] + 1, d["code"])
                      for d in params["diagnostics"]}
        client.close()
        return found
    finally:
        client.process.kill()


def documented_neovim_command() -> list[str]:
    """The `cmd` of docs/lsp.md's Neovim set-up."""
    text = (ROOT / "docs" / "lsp.md").read_text()
    match = re.search(r"cmd = \{ (.+?) \}", text)
    assert match is not None, "docs/lsp.md has no Neovim cmd"
    return [json.loads(word) for word in match.group(1).split(", ")]


def vscode_command() -> list[str]:
    """What editors/vscode/extension.js runs with its default settings: `mpc` with `lsp`."""
    text = (ROOT / "editors" / "vscode" / "extension.js").read_text()
    assert "args: ['lsp', ...options]" in text
    return ["mpc", "lsp"]


@pytest.mark.parametrize("command", [documented_neovim_command(), vscode_command()],
                         ids=["neovim", "vscode"])
def test_language_server_under_each_editor_s_command(project: Path,
                                                     command: list[str]) -> None:
    assert command[0] == "mpc"
    assert editor_verdict([MPC, *command[1:]], project) == VERDICT

"""`mpc dap` driven as an editor drives it: a real `mpc dap` subprocess, DAP messages over its
standard input and output (tests/dapclient.py). Test names follow the DAP specification's
requests and events (microsoft.github.io/debug-adapter-protocol/specification)."""

from __future__ import annotations

import json
import os
import pty
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from dapclient import DapClient

from mplang.lang.sources import library_files
from mplang.tools.dap.launch import ARGUMENTS

ROOT = Path(__file__).resolve().parents[2]

ROWS = """\
# rows.mp - a test program for mpc dap
CONST STD_HOME_LIMIT_DIR = 2
CONST STD_HOME_LIMIT_HV = 500
CONST STD_HOME_LIMIT_OFFSET = 100
INCLUDE "std:home_limit.mp"

VAR rows_done
VAR total

MP 10 add_row
    total = total + rows_done
END MP

MP 60 main
    rows_done = 0
    total = 0
    FOR 5
        rows_done = rows_done + 1
        CALL add_row
    NEXT
    std_home_limit_axes = 0
    CALL std_home_limit
    FIXED_MOVE X, 1000
    STOP_WAIT X
    total = total + 100
END MP
"""
DIVIDE = """\
VAR zero
VAR result

MP 30 divide
    zero = 0
    CALL share
END MP

MP 31 share
    result = 10 / zero
END MP
"""
FOREVER = """\
VAR spins

MP 40 forever
LABEL spin
    spins = spins + 1
    GOTO spin
END MP
"""
HOME_LIMIT = library_files()["home_limit.mp"]
HOME_LIMIT_FIRST = next(n for n, text in enumerate(HOME_LIMIT.read_text().splitlines(), 1)
                        if text.strip() == "std_home_limit_error = 0")


@pytest.fixture
def project(tmp_path: Path) -> Path:
    for name, text in (("rows.mp", ROWS), ("divide.mp", DIVIDE), ("forever.mp", FOREVER)):
        (tmp_path / name).write_text(text)
    return tmp_path


@pytest.fixture
def dap(project: Path) -> Iterator[DapClient]:
    client = DapClient(project)
    answer = client.request("initialize", {"adapterID": "mpc", "linesStartAt1": True})
    assert answer["success"] and answer["body"]["supportsConditionalBreakpoints"]
    yield client
    if not client.disconnected:
        ok(client.request("disconnect"))
    assert client.close() == 0


def ok(answer: dict[str, Any]) -> dict[str, Any]:
    assert answer["success"], answer.get("message")
    return dict(answer.get("body", {}))


def launch(dap: DapClient, **arguments: Any) -> None:
    ok(dap.request("launch", arguments))
    dap.event("initialized")


def frames(dap: DapClient) -> list[tuple[str, str, int]]:
    """(program, source name, line) of every stack frame, innermost first."""
    body = ok(dap.request("stackTrace", {"threadId": 1}))
    return [(f["name"], f["source"]["name"], f["line"]) for f in body["stackFrames"]]


def variables(dap: DapClient, scope: str) -> list[dict[str, Any]]:
    scopes = ok(dap.request("scopes", {"frameId": 1}))["scopes"]
    reference = next(s["variablesReference"] for s in scopes if s["name"] == scope)
    return list(ok(dap.request("variables", {"variablesReference": reference}))["variables"])


def resume(dap: DapClient, command: str) -> dict[str, Any]:
    """Run (continue, next, stepIn, stepOut) and return the body of the stop it ends in."""
    ok(dap.request(command, {"threadId": 1}))
    return dict(dap.event("stopped")["body"])


def set_lines(dap: DapClient, path: Path, *points: dict[str, Any]) -> list[dict[str, Any]]:
    body = ok(dap.request("setBreakpoints", {"source": {"path": str(path)},
                                             "breakpoints": list(points)}))
    return list(body["breakpoints"])


def test_launch_stop_on_entry_then_breakpoints_stack_scopes_and_steps(
        dap: DapClient, project: Path) -> None:
    launch(dap, program="rows.mp", call="main", stopOnEntry=True)
    rows = project / "rows.mp"
    placed = set_lines(dap, rows, {"line": 9})  # blank before `MP 10`: moved to its body
    assert placed[0]["verified"] and placed[0]["line"] == 11
    library = set_lines(dap, Path(str(HOME_LIMIT)), {"line": HOME_LIMIT_FIRST})
    assert library[0]["verified"] and library[0]["line"] == HOME_LIMIT_FIRST
    ok(dap.request("configurationDone"))
    entry = dap.event("stopped")["body"]
    assert entry["reason"] == "entry" and "ms simulated" in entry["description"]
    threads = ok(dap.request("threads"))["threads"]
    assert [t["id"] for t in threads] == [1] and "MP60 main" in threads[0]["name"]
    assert frames(dap) == [("MP60 main", "rows.mp", 15)]

    stop = resume(dap, "continue")  # into add_row, called from main's line 19
    assert stop["reason"] == "breakpoint" and stop["hitBreakpointIds"] == [placed[0]["id"]]
    assert "0.500 ms simulated" in stop["description"]
    assert frames(dap) == [("MP10 add_row", "rows.mp", 11), ("MP60 main", "rows.mp", 19)]
    body = ok(dap.request("stackTrace", {"threadId": 1}))
    assert body["stackFrames"][0]["source"]["path"] == str(rows.resolve())
    named = variables(dap, "Variables")
    assert [(v["name"], v["value"], v["type"]) for v in named[:2]] == [
        ("rows_done", "1", "VAR400"), ("total", "0", "VAR401")]
    axes = variables(dap, "Axes")
    assert [a["name"] for a in axes] == ["X", "Y", "Z", "U"]
    parts = ok(dap.request("variables", {"variablesReference":
                                         axes[0]["variablesReference"]}))["variables"]
    assert [p["name"] for p in parts][:4] == ["LP", "EP", "CV", "state"]
    inputs = [i["name"] for i in variables(dap, "Inputs")]
    assert "X DI" in inputs and "FRnet DI8" in inputs
    assert ok(dap.request("evaluate", {"expression": "rows_done + 1",
                                       "context": "watch"}))["result"] == "2"
    assert ok(dap.request("evaluate", {"expression": "VAR400",
                                       "context": "hover"}))["result"] == "1"

    assert resume(dap, "stepOut")["reason"] == "step"  # back in main, after the CALL
    assert frames(dap) == [("MP60 main", "rows.mp", 20)]
    resume(dap, "next")  # NEXT goes round the loop
    assert frames(dap)[0][2] == 18
    resume(dap, "next")
    assert frames(dap)[0][2] == 19
    resume(dap, "stepIn")  # into the CALL
    assert frames(dap) == [("MP10 add_row", "rows.mp", 11), ("MP60 main", "rows.mp", 19)]
    resume(dap, "stepOut")
    set_lines(dap, rows)  # no breakpoints in rows.mp: `next` steps over the CALL
    resume(dap, "next")
    resume(dap, "next")
    assert frames(dap)[0][2] == 19
    resume(dap, "next")
    assert frames(dap) == [("MP60 main", "rows.mp", 20)]

    stop = resume(dap, "continue")  # the library's routine
    assert stop["reason"] == "breakpoint"
    assert frames(dap) == [("MP131 std_home_limit", "std:home_limit.mp", HOME_LIMIT_FIRST),
                           ("MP60 main", "rows.mp", 22)]
    body = ok(dap.request("stackTrace", {"threadId": 1}))
    assert body["stackFrames"][0]["source"]["path"] == str(HOME_LIMIT)

    ok(dap.request("continue", {"threadId": 1}))
    assert dap.event("exited")["body"]["exitCode"] == 0
    dap.event("terminated")


def test_set_breakpoints_condition_on_declared_names_and_var_numbers(dap: DapClient,
                                                                     project: Path) -> None:
    launch(dap, program=["rows.mp"], call="MP60", stopOnEntry=False)
    placed = set_lines(dap, project / "rows.mp", {"line": 11, "condition": "rows_done > 3"},
                       {"line": 25, "condition": "VAR401 == 15 && rows_done == 5"},
                       {"line": 16, "condition": "nosuch == 1"},
                       {"line": 18, "condition": "rows_done >"})
    assert [p["verified"] for p in placed] == [True, True, False, False]
    assert "no variable 'nosuch'" in placed[2]["message"]
    assert "cannot read" in placed[3]["message"]
    ok(dap.request("configurationDone"))
    assert dap.event("stopped")["body"]["reason"] == "breakpoint"
    assert ok(dap.request("evaluate", {"expression": "rows_done"}))["result"] == "4"
    assert resume(dap, "continue")["hitBreakpointIds"] == [placed[0]["id"]]
    assert ok(dap.request("evaluate", {"expression": "rows_done"}))["result"] == "5"
    resume(dap, "continue")
    assert frames(dap) == [("MP60 main", "rows.mp", 25)]
    assert ok(dap.request("evaluate", {"expression": "total"}))["result"] == "15"
    bad = dap.request("evaluate", {"expression": "nosuch + 1"})
    assert not bad["success"] and "no variable 'nosuch'" in bad["message"]
    bad = dap.request("evaluate", {"expression": "__import__('os')"})
    assert not bad["success"] and "not a variable" in bad["message"]


def test_stopped_exception_at_the_run_time_error_line(dap: DapClient) -> None:
    launch(dap, program="divide.mp")
    ok(dap.request("configurationDone"))
    stop = dap.event("stopped")["body"]
    assert stop["reason"] == "exception"
    assert stop["description"].startswith("R103: division by zero")
    assert "divide.mp:10:" in stop["text"] and "error[R103]" in stop["text"]
    assert "called from divide.mp:6" in stop["text"]
    assert frames(dap) == [("MP31 share", "divide.mp", 10), ("MP30 divide", "divide.mp", 6)]
    info = ok(dap.request("exceptionInfo", {"threadId": 1}))
    assert info["exceptionId"] == "R103" and info["breakMode"] == "always"
    assert [v["value"] for v in variables(dap, "Variables")] == ["0", "0"]
    ok(dap.request("continue", {"threadId": 1}))
    assert dap.event("exited")["body"]["exitCode"] == 5
    dap.event("terminated")


def test_output_events_give_mpc_runs_warnings_at_the_end(dap: DapClient,
                                                         project: Path) -> None:
    """An axis stop that does not end the program (R312) is told, as `mpc run` tells it."""
    (project / "soft.mp").write_text("MP 50 limits\n    SET_MAX_V X, 8000\n"
                                     "    SET_V X, 8000\n    SET_SLMT X, 100, -100, 0\n"
                                     "    FIXED_MOVE X, 5000\n    STOP_WAIT X\nEND MP\n")
    launch(dap, program="soft.mp")
    ok(dap.request("configurationDone"))
    assert dap.event("exited")["body"]["exitCode"] == 0
    told = [dap.event("output")["body"]["output"] for _ in range(2)]
    assert any("soft.mp:6:5: warning[R312]" in text for text in told)
    assert any("MP50 limits (soft.mp): finished after" in text for text in told)


def test_pause_a_program_that_loops_for_ever(dap: DapClient) -> None:
    launch(dap, program="forever.mp")
    ok(dap.request("configurationDone"))
    busy = dap.request("stackTrace", {"threadId": 1})
    if not busy["success"]:  # it runs: inspection waits for a stop
        assert "running" in busy["message"]
    ok(dap.request("pause", {"threadId": 1}))
    stop = dap.event("stopped")["body"]
    assert stop["reason"] == "pause" and "ms simulated" in stop["description"]
    assert frames(dap)[0][:2] == ("MP40 forever", "forever.mp")
    assert frames(dap)[0][2] in (5, 6)
    assert ok(dap.request("evaluate", {"expression": "spins > 0"}))["result"] == "1"
    ok(dap.request("continue", {"threadId": 1}))
    ok(dap.request("disconnect", {"terminateDebuggee": True}))


def test_set_breakpoints_in_an_included_file(dap: DapClient, project: Path) -> None:
    (project / "parts").mkdir()
    (project / "parts" / "helper.mp").write_text(
        "VAR helped\n\nMP helper\n    helped = helped + 1\nEND MP\n")
    (project / "uses.mp").write_text(
        'INCLUDE "parts/helper.mp"\n\nMP 70 uses\n    CALL helper\n    CALL helper\n'
        "END MP\n")
    launch(dap, program="uses.mp", call="uses")
    placed = set_lines(dap, project / "parts" / "helper.mp", {"line": 2})
    assert placed[0]["verified"] and placed[0]["line"] == 4
    ok(dap.request("configurationDone"))
    dap.event("stopped")
    assert [(name, line) for name, _, line in frames(dap)] == [("MP1 helper", 4),
                                                              ("MP70 uses", 4)]
    body = ok(dap.request("stackTrace", {"threadId": 1}))
    assert body["stackFrames"][0]["source"]["path"] == \
        str((project / "parts" / "helper.mp").resolve())
    resume(dap, "continue")
    assert [(name, line) for name, _, line in frames(dap)] == [("MP1 helper", 4),
                                                              ("MP70 uses", 5)]
    assert ok(dap.request("evaluate", {"expression": "helped"}))["result"] == "1"


def test_stack_trace_shows_an_isr_as_its_own_frame(dap: DapClient) -> None:
    """samples/compare_isr.mp: ISR3 fires at X = 120 mm while MP93 waits in STOP_WAIT."""
    sample = ROOT / "samples" / "compare_isr.mp"
    lines = sample.read_text().splitlines()
    first = lines.index("ISR 3 glue_valve_open") + 2  # its first command line (1-based)
    waits = [n for n, text in enumerate(lines, 1) if text.strip() == "STOP_WAIT X"]
    launch(dap, program=str(sample), call="glue_bead")
    placed = set_lines(dap, sample, {"line": first - 1})  # the ISR header: moved down
    assert placed[0]["verified"] and placed[0]["line"] == first
    ok(dap.request("configurationDone"))
    stop = dap.event("stopped")["body"]
    assert stop["reason"] == "breakpoint"
    (isr, interrupted) = frames(dap)
    assert isr[0] == "ISR3 glue_valve_open (interrupt)" and isr[2] == first
    assert interrupted[0] == "MP93 glue_bead" and interrupted[2] == waits[1]
    body = ok(dap.request("stackTrace", {"threadId": 1}))
    assert body["stackFrames"][0]["presentationHint"] == "label"
    assert ok(dap.request("evaluate", {"expression": "glue_on_at"}))["result"] == "0"
    assert resume(dap, "next")["reason"] == "step"
    assert frames(dap)[0][2] == first + 1
    resume(dap, "stepOut")  # back in the program the ISR interrupted, still waiting
    assert frames(dap)[0][0] == "MP93 glue_bead"
    assert int(ok(dap.request("evaluate", {"expression": "glue_on_at"}))["result"]) >= 120000


def test_launch_an_mpc_toml_project(dap: DapClient, project: Path) -> None:
    """Breakpoints set before the launch are placed by it (a `breakpoint` event each)."""
    (project / "mpc.toml").write_text('[project]\nsources = ["rows.mp"]\n')
    early = set_lines(dap, project / "rows.mp", {"line": 16})
    assert not early[0]["verified"] and "when the program is launched" in early[0]["message"]
    launch(dap, program="mpc.toml", call="main")
    changed = dap.event("breakpoint")["body"]
    assert changed["reason"] == "changed"
    assert changed["breakpoint"]["verified"] and changed["breakpoint"]["line"] == 16
    ok(dap.request("configurationDone"))
    assert dap.event("stopped")["body"]["reason"] == "breakpoint"
    assert frames(dap) == [("MP60 main", "rows.mp", 16)]
    ok(dap.request("terminate"))
    dap.event("terminated")


HOME_Z = """\
CONST STD_HOME_LIMIT_DIR    = 2
CONST STD_HOME_LIMIT_HV     = 5000
CONST STD_HOME_LIMIT_OFFSET = 1000
INCLUDE "std:home_limit.mp"

MP 100 home_z
    SET_MAX_V Z, 80000
    SET_SV Z, 1000
    SET_V Z, 20000
    SET_A Z, 200000
    std_home_limit_axes = 4
    CALL std_home_limit
END MP
"""
HOMING_MACHINE = ROOT / "docs" / "machines" / "homing.toml"


@pytest.mark.parametrize("given", ["file", "project"])
def test_launch_machine_homes_on_the_machine_s_limit_switch(dap: DapClient, project: Path,
                                                             given: str) -> None:
    """docs/stdlib.md's home_limit example: on the default machine it waits for ever; on
    docs/machines/homing.toml (a machine file, or the [machine] of the project launched)
    the Z axis finds LIMIT- and the routine ends with error 0."""
    (project / "home_z.mp").write_text(HOME_Z)
    if given == "file":
        launch(dap, program="home_z.mp", machine=str(HOMING_MACHINE))
    else:
        (project / "mpc.toml").write_text('[project]\nsources = ["home_z.mp"]\n\n'
                                          + HOMING_MACHINE.read_text())
        launch(dap, program="mpc.toml")
    line = next(n for n, text in enumerate(HOME_LIMIT.read_text().splitlines(), 1)
                if "std_home_limit_error = 0" in text)
    ok(dap.request("setBreakpoints", {"source": {"path": str(HOME_LIMIT)},
                                      "breakpoints": [{"line": line}]}))
    ok(dap.request("configurationDone"))
    assert dap.event("stopped")["body"]["reason"] == "breakpoint"
    ok(dap.request("setBreakpoints", {"source": {"path": str(HOME_LIMIT)}, "breakpoints": []}))
    ok(dap.request("continue", {"threadId": 1}))
    assert dap.event("exited")["body"]["exitCode"] == 0
    dap.event("terminated")


def test_launch_with_an_empty_call_runs_the_first_mp_of_the_first_file(dap: DapClient) -> None:
    launch(dap, program="rows.mp", call="  ", stopOnEntry=True)
    ok(dap.request("configurationDone"))
    dap.event("stopped")
    assert frames(dap) == [("MP10 add_row", "rows.mp", 11)]


@pytest.mark.parametrize(("arguments", "message"), [
    ({}, "'program' is missing"),
    ({"program": 5}, "must be a path or a non-empty list"),
    ({"program": "nosuch.mp"}, "nosuch.mp: no such file"),
    ({"program": "rows.mp", "call": "nosuch"}, "no MP named 'nosuch'"),
    ({"program": "rows.mp", "stopOnEntry": "yes"}, "'stopOnEntry' must be true or false"),
    ({"program": "rows.mp", "machine": "nosuch.toml"}, "no such file"),
    ({"program": "rows.mp", "machine": "divide.mp"}, "divide.mp:1:"),
    ({"program": "rows.mp", "target": "fbs-fun140"}, "FATEK"),
    ({"program": "rows.mp", "maxTime": -1}, "'maxTime' must be a number"),
])
def test_launch_errors_are_error_responses(dap: DapClient, arguments: dict[str, Any],
                                           message: str) -> None:
    answer = dap.request("launch", arguments)
    assert not answer["success"] and message in answer["message"], answer


def test_launch_of_a_build_with_errors_names_the_line(dap: DapClient, project: Path) -> None:
    (project / "broken.mp").write_text("MP 5 broken\n    NOSUCH_COMMAND 1\nEND MP\n")
    answer = dap.request("launch", {"program": "broken.mp"})
    assert not answer["success"] and "broken.mp:2:" in answer["message"]


def test_hostile_input_is_answered_without_a_crash(dap: DapClient) -> None:
    for data, logged in ((b"garbage without a colon\r\n\r\n", "not a header line"),
                         (b"Content-Length: nope\r\n\r\n", "not a byte count"),
                         (b"Content-Length: 9\r\n\r\n{not json", "not JSON")):
        dap.send_raw(data)  # dropped, with a line on stderr; the next request is answered
        assert ok(dap.request("threads")) == {"threads": []}
        dap.logged(logged)
    dap.send({"seq": 90, "type": "event", "event": "x"})
    assert "not a DAP request" in dap.response(90)["message"]
    dap.send({"seq": 91, "type": "request", "command": "launch", "arguments": [1]})
    assert "must be an object" in dap.response(91)["message"]
    for command, arguments, message in (
            ("nosuchCommand", {}, "unknown request 'nosuchCommand'"),
            ("stackTrace", {"threadId": 1}, "no program is launched"),
            ("attach", {}, "cannot attach"),
            ("setBreakpoints", {"source": 3}, "needs a 'source' object")):
        answer = dap.request(command, arguments)
        assert not answer["success"] and message in answer["message"], answer
    launch(dap, program="rows.mp", call="main", stopOnEntry=True)
    ok(dap.request("configurationDone"))
    dap.event("stopped")
    for command, arguments, message in (
            ("variables", {"variablesReference": 999}, "no variables with reference 999"),
            ("setBreakpoints", {"source": {"path": "/nowhere.mp"}, "breakpoints": [{}]},
             "'line' must be a line number"),
            ("evaluate", {"expression": 7}, "'expression' must be a string"),
            ("evaluate", {"expression": "1 / 0"}, "division by zero"),
            ("exceptionInfo", {"threadId": 1}, "did not stop on a run-time error"),
            ("launch", {"program": "rows.mp"}, "one per session"),
            ("setVariable", {"variablesReference": 999, "name": "x", "value": "1"},
             "no variables with reference 999"),
            ("breakpointLocations", {"source": 3, "line": 1}, "needs a 'source' object"),
            ("setFunctionBreakpoints", {"breakpoints": [{"name": 5}]},
             "list of objects with a 'name'"),
            ("setDataBreakpoints", {"breakpoints": "VAR1"}, "list of objects with a 'dataId'"),
            ("dataBreakpointInfo", {"name": 7}, "'name' must be a string"),
            ("restart", {"arguments": [1]}, "'arguments' must be an object")):
        answer = dap.request(command, arguments)
        assert not answer["success"] and message in answer["message"], answer
    elsewhere = set_lines(dap, Path("/nowhere.mp"), {"line": 3})
    assert not elsewhere[0]["verified"] and "not part of the launched build" in \
        elsewhere[0]["message"]
    assert frames(dap) == [("MP60 main", "rows.mp", 15)]  # the session goes on


def test_vscode_extension_contributes_the_mpc_debugger() -> None:
    """The debugger type `mpc` of the VS Code extension takes exactly the launch arguments
    `mpc dap` reads, and docs/debug.md describes each."""
    manifest = json.loads((ROOT / "editors" / "vscode" / "package.json").read_text())
    (debugger,) = [d for d in manifest["contributes"]["debuggers"] if d["type"] == "mpc"]
    launch_schema = debugger["configurationAttributes"]["launch"]
    assert set(launch_schema["properties"]) == set(ARGUMENTS)
    assert launch_schema["required"] == ["program"]
    assert debugger["initialConfigurations"][0]["request"] == "launch"
    assert {"language": "mplang"} in manifest["contributes"]["breakpoints"]
    guide = (ROOT / "docs" / "debug.md").read_text()
    assert all(f"`{name}`" in guide for name in ARGUMENTS)


def test_mpc_dap_in_a_terminal_says_how_to_use_it() -> None:
    """Started by hand, it explains itself and exits 2 instead of waiting for DAP input."""
    controller, terminal = pty.openpty()
    try:
        result = subprocess.run([sys.executable, "-m", "mplang", "dap"], stdin=terminal,
                                capture_output=True, text=True, timeout=60)
    finally:
        os.close(controller)
        os.close(terminal)
    assert result.returncode == 2
    assert "start it from an editor" in result.stderr and result.stdout == ""


# ------------------------------------------------ the conventions of debugpy and CodeLLDB
def test_initialize_advertises_each_capability(project: Path) -> None:
    client = DapClient(project)
    try:
        body = ok(client.request("initialize", {"adapterID": "mpc"}))
        for capability in ("supportsSetVariable", "supportsLogPoints",
                           "supportsHitConditionalBreakpoints", "supportsDataBreakpoints",
                           "supportsFunctionBreakpoints", "supportsRestartRequest",
                           "supportsBreakpointLocationsRequest", "supportsConditionalBreakpoints",
                           "supportsConfigurationDoneRequest", "supportsTerminateRequest"):
            assert body[capability] is True, capability
        ok(client.request("disconnect"))
    finally:
        assert client.close() == 0


def test_statement_start_columns_and_breakpoint_locations(dap: DapClient,
                                                          project: Path) -> None:
    """`total = total + rows_done` is reported at `total`, not at its right-hand side."""
    launch(dap, program="rows.mp", call="main")
    placed = set_lines(dap, project / "rows.mp", {"line": 11})
    assert (placed[0]["line"], placed[0]["column"]) == (11, 5)
    where = ok(dap.request("breakpointLocations", {"source": {"path": str(project / "rows.mp")},
                                                   "line": 8, "endLine": 16}))
    assert where["breakpoints"] == [{"line": 11, "column": 5}, {"line": 12, "column": 1},
                                    {"line": 15, "column": 5}, {"line": 16, "column": 5}]
    ok(dap.request("configurationDone"))
    dap.event("stopped")
    body = ok(dap.request("stackTrace", {"threadId": 1}))
    assert [(f["line"], f["column"]) for f in body["stackFrames"]] == [(11, 5), (19, 9)]


def test_set_variable_in_variables_and_axes(dap: DapClient, project: Path) -> None:
    launch(dap, program="rows.mp", call="main")
    set_lines(dap, project / "rows.mp", {"line": 25})
    ok(dap.request("configurationDone"))
    dap.event("stopped")
    scopes = {s["name"]: s["variablesReference"]
              for s in ok(dap.request("scopes", {"frameId": 1}))["scopes"]}
    answer = ok(dap.request("setVariable", {"variablesReference": scopes["Variables"],
                                            "name": "total", "value": "rows_done * 200"}))
    assert answer == {"value": "1000", "type": "VAR401"}
    assert [v["value"] for v in variables(dap, "Variables") if v["name"] == "total"] == ["1000"]
    axes = variables(dap, "Axes")
    assert all("type" not in a for a in axes)  # no `"type": null`
    x = axes[0]["variablesReference"]
    assert ok(dap.request("setVariable", {"variablesReference": x, "name": "LP",
                                          "value": "-2500"}))["value"] == "-2500"
    assert ok(dap.request("setVariable", {"variablesReference": x, "name": "EP",
                                          "value": "77"}))["value"] == "77"
    parts = ok(dap.request("variables", {"variablesReference": x}))["variables"]
    assert [(p["name"], p["value"]) for p in parts[:2]] == [("LP", "-2500"), ("EP", "77")]
    assert ok(dap.request("evaluate", {"expression": "X.LP + X.EP"}))["result"] == "-2423"
    for reference, name, value, message in (
            (x, "CV", "5", "read only"),
            (x, "LP", "3000000000", "out of the device's range"),
            (scopes["Axes"], "X", "1", "read only"),
            (scopes["Inputs"], "X DI", "1", "read only"),
            (scopes["Variables"], "total", "nosuch + 1", "no variable 'nosuch'"),
            (scopes["Variables"], "nosuch", "1", "no 'nosuch' in Variables")):
        answer = dap.request("setVariable", {"variablesReference": reference, "name": name,
                                             "value": value})
        assert not answer["success"] and message in answer["message"], answer
    resume(dap, "next")  # the program goes on from the values set
    assert ok(dap.request("evaluate", {"expression": "total"}))["result"] == "1100"


def test_logpoints_interpolate_names_and_never_stop(dap: DapClient, project: Path) -> None:
    launch(dap, program="rows.mp", call="main")
    placed = set_lines(dap, project / "rows.mp",
                       {"line": 11, "logMessage": "row {rows_done}: {{total}} = {total}, "
                        "X at {X.LP}, VAR400 {VAR400 * 10}"},
                       {"line": 12, "logMessage": "{nosuch}"})
    assert placed[0]["verified"]
    assert not placed[1]["verified"] and "no variable 'nosuch'" in placed[1]["message"]
    ok(dap.request("configurationDone"))
    assert dap.event("exited")["body"]["exitCode"] == 0
    told = [dap.event("output")["body"] for _ in range(5)]
    assert [t["output"] for t in told] == [
        f"row {n}: {{total}} = {sum(range(n))}, X at 0, VAR400 {n * 10}\n" for n in range(1, 6)]
    assert (told[0]["line"], told[0]["source"]["path"]) == (11, str(project / "rows.mp"))
    assert not any(e["event"] == "stopped" for e in dap.events)


@pytest.mark.parametrize(("condition", "rows"), [("3", [3]), ("==2", [2]), (">=4", [4, 5]),
                                                 ("%2", [2, 4]), ("<2", [1])])
def test_hit_conditions_count_the_hits(dap: DapClient, project: Path, condition: str,
                                       rows: list[int]) -> None:
    launch(dap, program="rows.mp", call="main")
    set_lines(dap, project / "rows.mp", {"line": 11, "hitCondition": condition})
    ok(dap.request("configurationDone"))
    seen = []
    for _ in rows:
        assert dap.event("stopped")["body"]["reason"] == "breakpoint"
        seen.append(int(ok(dap.request("evaluate", {"expression": "rows_done"}))["result"]))
        ok(dap.request("continue", {"threadId": 1}))
    assert dap.event("exited")["body"]["exitCode"] == 0
    assert seen == rows


def test_hit_condition_that_is_no_count_is_said(dap: DapClient, project: Path) -> None:
    launch(dap, program="rows.mp", call="main")
    placed = set_lines(dap, project / "rows.mp", {"line": 11, "hitCondition": "%0"},
                       {"line": 16, "hitCondition": "often"},
                       {"line": 18, "condition": "rows_done > 1", "hitCondition": "2"})
    assert [p["verified"] for p in placed] == [False, False, True]
    assert "hit condition '%0'" in placed[0]["message"]
    ok(dap.request("configurationDone"))
    dap.event("stopped")  # the second time rows_done > 1 holds there: rows_done is 3
    assert ok(dap.request("evaluate", {"expression": "rows_done"}))["result"] == "3"


def test_data_breakpoints_stop_when_a_variable_changes(dap: DapClient, project: Path) -> None:
    launch(dap, program="rows.mp", call="main", stopOnEntry=True)
    ok(dap.request("configurationDone"))
    dap.event("stopped")
    scopes = {s["name"]: s["variablesReference"]
              for s in ok(dap.request("scopes", {"frameId": 1}))["scopes"]}
    info = ok(dap.request("dataBreakpointInfo", {"variablesReference": scopes["Variables"],
                                                 "name": "total"}))
    assert info["dataId"] == "VAR401" and info["accessTypes"] == ["write"]
    axis = ok(dap.request("dataBreakpointInfo", {"variablesReference": scopes["Axes"],
                                                 "name": "X"}))
    assert axis["dataId"] is None and "only a variable" in axis["description"]
    placed = ok(dap.request("setDataBreakpoints", {"breakpoints": [
        {"dataId": "VAR401", "accessType": "write", "hitCondition": ">=2"},
        {"dataId": "VAR999999"}, {"dataId": "VAR400", "accessType": "read"}]}))["breakpoints"]
    assert [p["verified"] for p in placed] == [True, False, False]
    assert "only a write" in placed[2]["message"]
    totals = []
    for _ in range(4):  # total changes in add_row from the second row on (0 + 1 is 1...)
        stop = resume(dap, "continue")
        assert stop["reason"] == "data breakpoint" and stop["hitBreakpointIds"] == \
            [placed[0]["id"]]
        totals.append(int(ok(dap.request("evaluate", {"expression": "total"}))["result"]))
        assert frames(dap)[0][2] == 12  # before the line after the write: END MP
    assert totals == [3, 6, 10, 15]
    ok(dap.request("setDataBreakpoints", {"breakpoints": []}))
    ok(dap.request("continue", {"threadId": 1}))
    assert dap.event("exited")["body"]["exitCode"] == 0


def test_function_breakpoints_stop_on_entry_to_a_program(dap: DapClient) -> None:
    launch(dap, program="rows.mp", call="main")
    placed = ok(dap.request("setFunctionBreakpoints", {"breakpoints": [
        {"name": "main"}, {"name": "MP10", "hitCondition": "5"},
        {"name": "nosuch"}]}))["breakpoints"]
    assert [p["verified"] for p in placed] == [True, True, False]
    assert (placed[0]["line"], placed[0]["source"]["name"]) == (15, "rows.mp")
    assert "no program 'nosuch'" in placed[2]["message"]
    ok(dap.request("configurationDone"))
    stop = dap.event("stopped")["body"]  # the launched program itself, on entry
    assert stop["reason"] == "function breakpoint" and stop["hitBreakpointIds"] == \
        [placed[0]["id"]]
    assert frames(dap) == [("MP60 main", "rows.mp", 15)]
    stop = resume(dap, "continue")
    assert stop["reason"] == "function breakpoint"
    assert frames(dap) == [("MP10 add_row", "rows.mp", 11), ("MP60 main", "rows.mp", 19)]
    assert ok(dap.request("evaluate", {"expression": "rows_done"}))["result"] == "5"


def test_restart_runs_the_program_again_with_its_breakpoints(dap: DapClient,
                                                             project: Path) -> None:
    launch(dap, program="rows.mp", call="main")
    placed = set_lines(dap, project / "rows.mp", {"line": 11, "hitCondition": "2"})
    ok(dap.request("configurationDone"))
    dap.event("stopped")
    assert ok(dap.request("evaluate", {"expression": "rows_done"}))["result"] == "2"
    ok(dap.request("restart", {"arguments": {"program": "rows.mp", "call": "main"}}))
    assert "MP60 main" in dap.event("process")["body"]["name"]
    stop = dap.event("stopped")["body"]  # the hit count starts again
    assert stop["hitBreakpointIds"] == [placed[0]["id"]]
    assert ok(dap.request("evaluate", {"expression": "rows_done"}))["result"] == "2"
    ok(dap.request("restart"))  # the launch's arguments again
    dap.event("stopped")
    assert frames(dap)[0] == ("MP10 add_row", "rows.mp", 11)
    bad = dap.request("restart", {"arguments": {"program": "nosuch.mp"}})
    assert not bad["success"] and "nosuch.mp: no such file" in bad["message"]


def test_restart_a_program_that_runs(dap: DapClient) -> None:
    """The running program is stopped without a `stopped` event and started again."""
    launch(dap, program="forever.mp")
    ok(dap.request("configurationDone"))
    ok(dap.request("restart"))
    assert not any(e["event"] in ("stopped", "exited") for e in dap.events)
    ok(dap.request("pause", {"threadId": 1}))
    assert dap.event("stopped")["body"]["reason"] == "pause"
    assert frames(dap)[0][:2] == ("MP40 forever", "forever.mp")


def test_function_breakpoint_on_an_isr_stops_when_it_fires(dap: DapClient) -> None:
    sample = ROOT / "samples" / "compare_isr.mp"
    lines = sample.read_text().splitlines()
    first = lines.index("ISR 3 glue_valve_open") + 2  # its first command line (1-based)
    launch(dap, program=str(sample), call="glue_bead")
    placed = ok(dap.request("setFunctionBreakpoints", {"breakpoints": [
        {"name": "glue_valve_open"}]}))["breakpoints"]
    assert placed[0]["verified"] and placed[0]["line"] == first
    ok(dap.request("configurationDone"))
    assert dap.event("stopped")["body"]["reason"] == "function breakpoint"
    (isr, interrupted) = frames(dap)
    assert isr == ("ISR3 glue_valve_open (interrupt)", str(sample), first)
    assert interrupted[0] == "MP93 glue_bead"


@pytest.mark.parametrize("stop_on_entry", [False, True])
def test_a_breakpoint_on_the_first_line_of_the_called_program(dap: DapClient, project: Path,
                                                              stop_on_entry: bool) -> None:
    """Without stopOnEntry it stops there; after an entry stop it is not hit a second time
    at the same place (the line runs when the program continues)."""
    launch(dap, program="rows.mp", call="main", stopOnEntry=stop_on_entry)
    placed = set_lines(dap, project / "rows.mp", {"line": 15}, {"line": 25})
    ok(dap.request("configurationDone"))
    stop = dap.event("stopped")["body"]
    assert stop["reason"] == ("entry" if stop_on_entry else "breakpoint")
    assert frames(dap) == [("MP60 main", "rows.mp", 15)]
    stop = resume(dap, "continue")
    assert stop["hitBreakpointIds"] == [placed[1]["id"]]
    assert frames(dap) == [("MP60 main", "rows.mp", 25)]

"""`mpc status` for a CSIM: what the controller says about itself over its RS232 line, read
with its query commands only (CS 148-171), and its stored program listed back with ULP
(CS 119) and compared line by line with what `mpc flash` would download.

What the list documents as readable is asked: `?VER` firmware version, `?MT` motor version,
`?ST` status, `?MD` mode, `?ERR` current error, `?ERC` error history, `?TM` seconds since
power-up, `?PE` position and `?VM` working speed of the host module T0, `?IN 1`..`?IN 8`
the inputs. A query the device answers with ERR (the virtual CSIM does not model `?MT`,
`?MD`, `?ERC`) is shown as not answered, with the device's reply. A CSIM has no build
manifest (no identity store is documented) and no declared variables to read by name: the
listing itself is what is compared, which is exact. While a program runs the CSIM refuses
ULP (the protocol reading of stdlib/csim/device.toml [protocol] running_choice), so the
program cannot be compared then, and that counts as out of sync.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

import serial  # type: ignore[import-untyped]  # pyserial ships no type hints

from mplang.csim.build import CsimProgram
from mplang.csim.download import DownloadError, SerialLine, open_port
from mplang.csim.flashing import build_program
from mplang.family.face import CommandError, StatusJob, StatusUI

QUERIES = (("version", "?VER", "version"), ("motor", "?MT", "motor"), ("state", "?ST", "state"),
           ("mode", "?MD", "mode"), ("error", "?ERR", "error"),
           ("error_history", "?ERC", "errors"), ("uptime_s", "?TM", "uptime s"),
           ("position", "?PE", "position"), ("speed", "?VM", "speed"))
"""What `mpc status` asks a CSIM: the key of its JSON, the query (CS 148-171) and the
label of the text, in order."""
INPUTS = 8  # ?IN 1..8 (CS 149; device.toml [device] inputs)


def status(job: StatusJob, ui: StatusUI) -> str:
    """The family face's `status_device`: query the CSIM, list its program, compare it with
    the build if one is given, print it; "in-sync", "out-of-sync" or "no-device"."""
    if job.fleet:
        raise CommandError("usage", "--fleet reads M8194H devices: read a CSIM on its own "
                           "(--to NAME, or --serial PORT --target csim)")
    device = job.device
    if device.serial is None:
        raise CommandError("usage", "a CSIM is read over its RS232 line: give --serial PORT "
                           "(--tcp is Modbus TCP, for the ET-M8194H)")
    paths = [device.image] if device.image is not None else list(device.sources) or job.paths
    if any(p.suffix.lower() == ".json" for p in paths):
        raise CommandError("usage", "an image JSON is an M8194H download image; a CSIM "
                           "program is compared from a .csim listing or .mp sources")
    program = build_program(paths, job.options, ui.checked, "compare") if paths else None
    where = f"{device.serial} ({device.baud} 8{device.parity}{device.stopbits})"
    try:
        data = read(device.serial, device.baud, device.parity, device.stopbits, job.timeout)
    except DownloadError as exc:
        ui.say(f"error: no device: {exc.message}")
        return "no-device"
    data["device"] = f"CSIM on {where}"
    if program is not None:
        data.update(compare(data["program"], program))
    ui.out(json.dumps(data, indent=1) + "\n" if job.as_json else render(data))
    return "out-of-sync" if data.get("in_sync") is False else "in-sync"


def read(port: str, baud: int, parity: str, stopbits: int, timeout: float) -> dict[str, Any]:
    """Everything the status shows, as data; DownloadError ("port", or "no-answer" when the
    first query meets silence) when there is no device to read."""
    link = open_port(port, baud, parity, stopbits, timeout)
    try:
        link.reset_input_buffer()
        line = SerialLine(link, port)
        answers: dict[str, Any] = {}
        for number, (key, query, _label) in enumerate(QUERIES):
            answers[key] = _ask(line, query, first=number == 0)
        inputs = [_ask(line, f"?IN {n}") for n in range(1, INPUTS + 1)]
        listing = _ask(line, "ULP", many=True)
    except (serial.SerialException, OSError) as exc:
        raise DownloadError("port", f"{port}: {exc}") from None
    finally:
        link.close()
    return {"family": "csim", "queries": answers, "inputs": inputs, "program": listing,
            "manifest": None, "not_readable": [
                "build manifest: a CSIM has no documented identity store (its program "
                "listing is compared instead)",
                "variables by declared name: .mp names are not kept on a CSIM (mpc var "
                "reads them through the build's names)"]}


def _ask(line: SerialLine, text: str, first: bool = False, many: bool = False
         ) -> dict[str, Any]:
    """One query: its value (the data line, or every line with `many`), or the device's
    refusal. Silence on the first query means no device; later, it is one more refusal."""
    try:
        data = line.send(text, answers=True)
    except DownloadError as exc:
        if first and exc.kind == "no-answer":
            raise
        return {"query": text, "value": None, "error": exc.message}
    value: Any = data if many else (data[0] if data else "")
    return {"query": text, "value": value, "error": None}


def compare(listed: dict[str, Any], program: CsimProgram) -> dict[str, Any]:
    """The stored program against the build's: `in sync` (the same lines), `differs` (the
    first line that does not match), `missing` (the device holds no program); unknown
    (not in sync) when the device would not list it."""
    row: dict[str, Any] = {"slot": "program", "name": program.name, "source": program.source}
    lines: list[str] | None = listed["value"]
    if lines is None:
        row.update(status="unknown", detail=f"not listed: {listed['error']}")
    elif not lines:
        row.update(status="missing", detail="the device holds no program")
    elif lines == program.lines:
        row.update(status="in sync", detail=f"{len(lines)} line(s), identical")
    else:
        row.update(status="differs", detail=first_difference(program.lines, lines))
    return {"build": program.name, "slots": [row], "in_sync": row["status"] == "in sync"}


def first_difference(built: Sequence[str], listed: Sequence[str]) -> str:
    """Where a listing differs from a build's lines (`mpc status`, `mpc call`'s check)."""
    for index, (mine, there) in enumerate(zip(built, listed, strict=False)):
        if mine != there:
            return f"line {index}: the device holds {there!r}, the build has {mine!r}"
    return f"the device holds {len(listed)} line(s), the build has {len(built)}"


def render(data: dict[str, Any]) -> str:
    """The text `mpc status` prints for a CSIM."""
    def shown(answer: dict[str, Any]) -> str:
        if answer["error"] is not None:
            return f"not answered ({answer['query']}: {answer['error']})"
        return f"{answer['value']}  ({answer['query']})"

    lines = [f"device      {data['device']}"]
    for key, _query, label in QUERIES:
        lines.append(f"{label:<11} {shown(data['queries'][key])}")
    states = [f"IN{n}={a['value']}" if a["error"] is None else f"IN{n}=?"
              for n, a in enumerate(data["inputs"], start=1)]
    lines.append(f"inputs      {' '.join(states)}  (?IN n)")
    listing = data["program"]
    lines.append("program     " + (f"not listed ({listing['error']})" if listing["error"]
                                   else f"{len(listing['value'])} line(s) listed back (ULP)"))
    for row in data.get("slots", []):
        lines.append(f"  {row['status']:<9} {row['name']} ({row['source']}): {row['detail']}")
    lines += [f"not read    {text}" for text in data["not_readable"]]
    return "\n".join(lines) + "\n"

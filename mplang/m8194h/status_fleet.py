"""`mpc status --fleet FILE`: every device of a fleet file (the `[targets.NAME]` tables that
`mpc flash --fleet` reads) read at once, one row each: reachable or not, firmware, the build
id and flash time of its build manifest, the running program, and the verdict against what
`mpc flash` would write there (`in sync`, `differs (n slots)`, `missing`: no manifest,
`extra (n slots)`: only slots the build has not).

At most `StatusJob.jobs` devices are read at once (one connection each); devices on one
serial port share one RS-485 bus and take turns. The outcome puts an unreachable device
first (exit 7: a device not read cannot be called in sync), then any device out of sync
(exit 16), else in sync (exit 0).
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
from collections.abc import Sequence
from datetime import UTC, datetime
from typing import Any

from mplang.family.face import FlashTarget, StatusJob, StatusUI
from mplang.m8194h.flash import manifest as mf
from mplang.m8194h.flashing import identity_range
from mplang.m8194h.status import Builds, endpoint_of, probe

COLUMNS = (("device", "DEVICE"), ("address", "ADDRESS"), ("reachable", "REACHABLE"),
           ("firmware", "FIRMWARE"), ("build_id", "BUILD"), ("flashed", "FLASHED"),
           ("running", "RUNNING"), ("sync", "SYNC"))


def status(job: StatusJob, ui: StatusUI) -> str:
    """Read every device of the job's fleet, print the table (or the JSON list); the
    outcome: "no-device" if any device is unreachable, else "out-of-sync" if any is, else
    "in-sync"."""
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    identity = identity_range(job.identity, job.identity_where)
    builds = Builds(job, ui)
    results = asyncio.run(read_all(job, identity, builds))
    rows = [row(device, data) for device, data in zip(job.devices, results, strict=True)]
    ui.out(json.dumps(rows, indent=1) + "\n" if job.as_json else table(rows))
    if any(not r["reachable"] for r in rows):
        return "no-device"
    if any(r["sync"] not in (None, "in sync") for r in rows):
        return "out-of-sync"
    return "in-sync"


async def read_all(job: StatusJob, identity: mf.MdRange | None, builds: Builds
                   ) -> list[dict[str, Any] | str]:
    """Every device of the job read (`status.probe`), at most `job.jobs` at once, devices of
    one serial port one after another; in the job's order."""
    gate = asyncio.Semaphore(max(1, job.jobs))
    buses: dict[str, asyncio.Lock] = {}

    async def one(device: FlashTarget) -> dict[str, Any] | str:
        endpoint = endpoint_of(device, device.timeout or job.timeout,
                               device.retries if device.retries is not None else job.retries)
        bus = os.path.realpath(device.serial) if device.serial is not None else None
        async with gate:
            if bus is None:
                return await probe(endpoint, identity, lambda order: builds.get(device, order))
            async with buses.setdefault(bus, asyncio.Lock()):
                return await probe(endpoint, identity, lambda order: builds.get(device, order))

    return list(await asyncio.gather(*(one(device) for device in job.devices)))


def verdict(data: dict[str, Any]) -> str | None:
    """One device against its build: None when there is nothing to compare."""
    if "slots" not in data:
        return None
    if data["in_sync"]:
        return "in sync"
    manifest = data.get("manifest")
    if manifest is None or "error" in manifest:
        return "unknown (no manifest)"
    slots: Sequence[dict[str, Any]] = data["slots"]
    differ = sum(1 for s in slots if s["status"] in ("differs", "missing"))
    extra = sum(1 for s in slots if s["status"] == "extra")
    if differ:
        return f"differs ({differ} slot{'s' if differ != 1 else ''})"
    if extra:
        return f"extra ({extra} slot{'s' if extra != 1 else ''})"
    return "differs (downloaded since the manifest)"


def row(device: FlashTarget, data: dict[str, Any] | str) -> dict[str, Any]:
    """One device's line of the table, and its object in the JSON list."""
    base: dict[str, Any] = {"device": device.name, "address": device.address()}
    if isinstance(data, str):
        return {**base, "reachable": False, "error": data, "firmware": None,
                "build_id": None, "flashed": None, "running": None, "sync": "unreachable",
                "slots": None}
    manifest: dict[str, Any] = data.get("manifest") or {"error": "not read (--no-identity)"}
    held = "error" not in manifest
    run = data["running"]
    running = f"MP{run['mp']}" if run["mp"] else f"ISR{run['top']}" if run["top"] else None
    return {**base, "reachable": True, "error": None,
            "firmware": f"{data['identity']['rsm_firmware']:#010x}",
            "build_id": manifest["build_id"] if held else None,
            "flashed": datetime.fromtimestamp(manifest["flashed_at"], UTC).isoformat(
                timespec="seconds") if held else None,
            "running": running, "sync": verdict(data), "slots": data.get("slots"),
            "manifest_error": None if held else manifest["error"]}


def table(rows: list[dict[str, Any]]) -> str:
    """The text table, then one line per unreachable device saying why."""
    def cell(r: dict[str, Any], key: str) -> str:
        value = r[key]
        if key == "reachable":
            return "yes" if value else "no"
        if key == "build_id" and value:
            return str(value)[:12]
        return "-" if value is None or value == "" else str(value)

    cells = [[title for _, title in COLUMNS]] + [[cell(r, key) for key, _ in COLUMNS]
                                                 for r in rows]
    widths = [max(len(line[i]) for line in cells) for i in range(len(COLUMNS))]
    lines = ["  ".join(text.ljust(width) for text, width in zip(line, widths, strict=True))
             .rstrip() for line in cells]
    lines += [f"{r['device']}: {r['error']}" for r in rows if not r["reachable"]]
    return "\n".join(lines) + "\n"

"""Incremental flashing (`FlashRecord`): after each verified program, a local record keeps the
program's content hash under the device's address, with the device's identity (input registers
81-85: module id and both firmware versions) and its download status (110-114) as the last
verification left it. The next run trusts the record only if identity, word order and download
status still match and the device is ready: any download by another tool since changes 110-114.
Then programs whose hash is recorded are not written. A program's entry is removed before its
download starts, so a cut-short download is never taken for a recorded one.

This module holds the record file; `Flasher` consults and updates it.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

from mplang.lang.limits import load_json

RECORD_FORMAT = "mpc-flash-record/1"


def default_record_path() -> Path:
    """Without a project: the user's state directory (XDG), one record for every device."""
    state = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(state) / "mpc" / "flash-record.json"


class FlashRecord:
    """What mpc last verified in which device: a JSON file, `{"format", "devices": {address:
    {"identity", "word_order", "last_status", "slots": {"MP3": {"hash", "name", "source",
    "build_id", "at"}}}}}`. Written (atomically) after every change, so an interrupted run
    keeps what it verified. A record that cannot be read is replaced, with a note: flashing
    everything is always correct, only slower."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.devices: dict[str, dict[str, Any]] = {}
        self.problem: str | None = None
        try:
            data = load_json(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            return
        except (OSError, ValueError) as exc:  # undecodable, not JSON, nested too deep
            self.problem = f"the flash record {path} cannot be read ({exc}): starting afresh"
            return
        devices = data.get("devices") if isinstance(data, dict) else None
        if not isinstance(data, dict) or data.get("format") != RECORD_FORMAT or \
                not isinstance(devices, dict):
            self.problem = f"{path} is not an mpc flash record: starting afresh"
            return
        self.devices = {key: entry for key, entry in devices.items()
                        if isinstance(entry, dict) and isinstance(entry.get("slots"), dict)}

    def entry(self, address: str) -> dict[str, Any] | None:
        return self.devices.get(address)

    def recorded_slots(self, address: str) -> frozenset[str]:
        entry = self.devices.get(address)
        return frozenset(entry["slots"]) if entry else frozenset()

    def save(self) -> None:
        """Write the file atomically (a crash leaves the old or the new record, never half)."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        text = json.dumps({"format": RECORD_FORMAT, "devices": self.devices}, indent=1,
                          sort_keys=True)
        handle, temporary = tempfile.mkstemp(prefix=".flash-record.", dir=self.path.parent)
        try:
            with os.fdopen(handle, "w", encoding="utf-8") as out:
                out.write(text + "\n")
            os.replace(temporary, self.path)
        except BaseException:
            Path(temporary).unlink(missing_ok=True)
            raise

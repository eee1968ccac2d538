"""Incremental flashing (`FlashRecord`): for each verified program, a local record keeps the
program's content hash under the device's address, with the device's identity (input registers
81-85: module id and both firmware versions) and its download status (110-114) as the last
verification left it. The next run trusts the record only if identity, word order and download
status still match and the device is ready: any download by another tool since changes 110-114.
Then programs whose hash is recorded are not written. The entries of the programs a run will
write are removed (and the file saved) before the first of them starts, so a cut-short
download is never taken for a recorded one; what the run verifies is saved once, at its end,
not after every program (a fleet of N devices rewrote the whole file N x programs times).

This module holds the record file; `Flasher` consults and updates it.
"""

from __future__ import annotations

import copy
import json
import os
import stat
import tempfile
from pathlib import Path
from typing import Any

from filelock import FileLock, Timeout

from mplang.lang.limits import MAX_JSON_BYTES, load_json
from mplang.lang.userdirs import state_home

RECORD_FORMAT = "mpc-flash-record/1"
LOCK_TIMEOUT_S = 30.0  # another mpc holds the lock only while it merges and writes


def default_record_path() -> Path:
    """Without a project: the user's state directory (mplang.lang.userdirs), one record for every
    device."""
    return (state_home() or Path.home()) / "mpc" / "flash-record.json"


class FlashRecord:
    """What mpc last verified in which device: a JSON file, `{"format", "devices": {address:
    {"identity", "word_order", "last_status", "slots": {"MP3": {"hash", "name", "source",
    "build_id", "at"}}}}}`, written atomically: when a run starts if the file vouches for a
    slot the run will write, and once at the end of each device's run with what it verified
    (`start_run`), so the file never vouches for what is not there. Only a flash record
    (its format tag) or an empty file is ever replaced: anything else at the path (a file
    that is not a record, a damaged record, a FIFO, a directory) is left as it is, with a
    note, and this run records nothing. Flashing everything is always correct, only
    slower.

    Several mpc processes may share one record (flashes of different devices at once):
    each save takes the lock file beside it (`filelock`, which works on Windows as on
    POSIX), reads the file again and replaces only the entries of the devices this process
    flashed, so every other device's entry is kept."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.devices: dict[str, dict[str, Any]] = {}
        self._seen: dict[str, dict[str, Any]] = {}  # the entries as last read or written
        self.problem: str | None = None
        self.refused: str | None = None
        """Why the file at `path` is not replaced (None: it may be)."""
        data = _existing(path)
        if isinstance(data, str):
            self._refuse(data)
            return
        if data is None:
            return
        self.devices = _entries(data)
        self._seen = copy.deepcopy(self.devices)

    def _refuse(self, reason: str) -> None:
        self.refused = reason
        self.problem = f"{self.path} {reason}: it is left as it is and this flash records " \
            "nothing, so the next one writes every program again (remove the file, or name " \
            "another with --record FILE)"

    def entry(self, address: str) -> dict[str, Any] | None:
        return self.devices.get(address)

    def recorded_slots(self, address: str) -> frozenset[str]:
        entry = self.devices.get(address)
        return frozenset(entry["slots"]) if entry else frozenset()

    def start_run(self, address: str, old: dict[str, Any] | None, fresh: dict[str, Any],
                  writing: list[str]) -> bool:
        """A device's run begins with `fresh` as its entry (`old`: what the file held), and
        will write the slots `writing`: they are no longer vouched for. If the file vouched
        for one of them it is saved now, before any is written; otherwise the file claims
        nothing beyond the truth and the entry waits for the end of the run, saved once
        with the programs verified (a run killed before that leaves a record that is only
        behind). Returns whether the entry still has to be saved."""
        slots = fresh["slots"]
        for label in writing:
            slots.pop(label, None)
        self.devices[address] = fresh
        if old is not None and any(label not in slots for label in old.get("slots", {})):
            self.save()
            return False
        return old != fresh

    def save(self) -> None:
        """Merge this process's entries into the file under its lock and write it
        atomically (a crash leaves the old or the new record, never half), unless what is
        there now is not a flash record: that is never replaced."""
        if self.refused is not None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        lock = FileLock(self.path.with_name(self.path.name + ".lock"),
                        timeout=LOCK_TIMEOUT_S)
        try:
            with lock:
                self._merge_and_write()
        except Timeout:
            self._refuse(f"is locked by another mpc for more than {LOCK_TIMEOUT_S:g} s "
                         f"({lock.lock_file})")

    def _merge_and_write(self) -> None:
        """Under the lock: the file as it is now, with this process's entries in it."""
        found = _existing(self.path)  # again: another mpc may have written it since
        if isinstance(found, str):
            self._refuse(found)
            return
        devices = {} if found is None else _entries(found)
        for address in {*self._seen, *self.devices}:  # what this process changed, only
            mine = self.devices.get(address)
            if mine == self._seen.get(address):
                continue
            if mine is None:
                devices.pop(address, None)
            else:
                devices[address] = mine
        self.devices = devices
        self._seen = copy.deepcopy(devices)
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


def _entries(data: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {key: entry for key, entry in data["devices"].items()
            if isinstance(entry, dict) and isinstance(entry.get("slots"), dict)}


def _existing(path: Path) -> dict[str, Any] | str | None:
    """The flash record at `path` (its JSON object), None if there is nothing to keep there
    (no file, or an empty one), or why what is there is not a flash record. A special file is
    judged by os.stat and never opened."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        return f"cannot be checked ({exc.strerror or exc})"
    if not stat.S_ISREG(info.st_mode):
        return "is not a regular file"
    if info.st_size == 0:
        return None
    if info.st_size > MAX_JSON_BYTES:
        return (f"is not an mpc flash record ({info.st_size:,} bytes, more than the "
                f"{MAX_JSON_BYTES:,} mpc reads of a JSON file)")
    try:
        data = load_json(path.read_bytes().decode("utf-8"))
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    except (UnicodeDecodeError, ValueError) as exc:  # not JSON, or nested too deep
        return f"is not an mpc flash record (not JSON: {exc})"
    if not isinstance(data, dict) or data.get("format") != RECORD_FORMAT or \
            not isinstance(data.get("devices"), dict):
        return f"is not an mpc flash record (no \"format\": \"{RECORD_FORMAT}\")"
    return data

"""Incremental flashing (`FlashRecord`): for each verified program, a local record keeps the
program's content hash under the device's address, with the device's identity (input registers
81-85: module id and both firmware versions) and its download status (110-114) as the last
verification left it. The next run trusts the record only if identity, word order and download
status still match and the device is ready: any download by another tool since changes 110-114.
Then programs whose hash is recorded are not written. The entries of the programs a run will
write are removed (and saved) before the first of them starts, so a cut-short download is
never taken for a recorded one; what the run verifies is saved once, at its end.

The record is a JSON file (`RECORD`) and, beside it, an append-only journal (`RECORD.journal`,
one JSON line per changed device entry). A save appends the entries this process changed to
the journal; the file itself is rewritten (compacted: the file with the journal applied) only
once the journal has grown as large as the file, and at the end of a command. A fleet of N
devices therefore writes O(N) bytes in all, where rewriting the whole file at each device's
end wrote O(N squared). Every read applies the journal to the file, so readers see the same
facts either way; a line cut short by a killed process is not yet a fact, and is dropped.

This module holds the record files; `Flasher` consults and updates it.
"""

from __future__ import annotations

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
JOURNAL_FORMAT = "mpc-flash-journal/1"
_HEADER = (json.dumps({"format": JOURNAL_FORMAT}) + "\n").encode()
LOCK_TIMEOUT_S = 30.0  # another mpc holds the lock only while it merges and writes

Entries = dict[str, dict[str, Any]]
FileId = tuple[int, int, int]  # inode, modification time (ns), size


def default_record_path() -> Path:
    """Without a project: the user's state directory (mplang.lang.userdirs), one record for every
    device."""
    return (state_home() or Path.home()) / "mpc" / "flash-record.json"


def journal_path(path: Path) -> Path:
    """The journal beside the record `path`."""
    return path.with_name(path.name + ".journal")


class FlashRecord:
    """What mpc last verified in which device: a JSON file, `{"format", "devices": {address:
    {"identity", "word_order", "last_status", "slots": {"MP3": {"hash", "name", "source",
    "build_id", "at"}}}}}`, with its journal (`RECORD.journal`: a header line `{"format":
    "mpc-flash-journal/1"}`, then one line `{"address", "entry"}` per saved change, `entry`
    null for a device forgotten). Saved when a run starts if the file vouches for a slot the
    run will write, and once at the end of each device's run with what it verified
    (`start_run`), so the record never vouches for what is not there. Only a flash record
    (its format tag) or an empty file is ever replaced, and only a journal is appended to:
    anything else at either path (a file that is not a record, a damaged record, a FIFO, a
    directory) is left as it is, with a note, and this run records nothing. Flashing
    everything is always correct, only slower.

    Several mpc processes may share one record (flashes of different devices at once):
    each save takes the lock file beside it (`filelock`, which works on Windows as on
    POSIX) and appends only the entries this process changed since its last save; a
    compaction reads the file and the journal again under the lock, so every other
    process's entries are kept."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.devices: Entries = {}
        self._seen: Entries = {}  # the entries as last read or written (never the live ones)
        self.problem: str | None = None
        self.refused: str | None = None
        """Why the files at `path` are not written (None: they may be)."""
        self._file_entries = 0  # devices in the file when last read: the compaction's cue
        self._checked: FileId | None = None  # the file as last found to be a record
        data = _read(path)
        if isinstance(data, str):
            self._refuse(data)
            return
        self.devices, self._file_entries, self._checked = data
        self._seen = _copy(self.devices)

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
        """Append the entries this process changed since it last saved to the journal under
        the lock (compacting when the journal has grown as large as the file), unless what
        is there now is not a flash record: that is never replaced."""
        self._locked(self._append)

    def close(self) -> None:
        """The end of a command: save what is left and fold the journal into the file, so
        the record is one file again (a kill before this leaves the journal, which every
        reader applies)."""
        self._locked(lambda: self._append(compact=True))

    def _locked(self, work: Any) -> None:
        if self.refused is not None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        lock = FileLock(self.path.with_name(self.path.name + ".lock"),
                        timeout=LOCK_TIMEOUT_S)
        try:
            with lock:
                work()
        except Timeout:
            self._refuse(f"is locked by another mpc for more than {LOCK_TIMEOUT_S:g} s "
                         f"({lock.lock_file})")

    def _changes(self) -> list[str]:
        """One journal line per entry this process changed since it last read or wrote it."""
        lines = []
        for address in {*self._seen, *self.devices}:
            mine = self.devices.get(address)
            if mine != self._seen.get(address):
                lines.append(json.dumps({"address": address, "entry": mine},
                                        sort_keys=True) + "\n")
        return lines

    def _append(self, compact: bool = False) -> None:
        """Under the lock: this process's changes appended to the journal (its header checked
        first, and a line a killed writer cut short cut off); then, once the journal holds
        as many entries as the file (so rewrites cost O(N) in all) or if `compact`, the file
        rewritten with the journal applied."""
        journal = journal_path(self.path)
        lines = self._changes()
        now = _identity(self.path)
        if now is not None and now != self._checked:  # replaced since: parsed again
            base = _base(self.path)
            if isinstance(base, str):
                self._refuse(base)
                return
            self._checked = now
        held = _journal_lines(journal)
        if isinstance(held, str):
            self._refuse(held)
            return
        if lines:
            with open(journal, "a" if held else "w", encoding="utf-8", newline="\n") as out:
                if not held:
                    out.write(json.dumps({"format": JOURNAL_FORMAT}) + "\n")
                    held = 1
                out.write("".join(lines))
            for line in lines:  # what the journal now holds for each address
                written = json.loads(line)
                self._seen[written["address"]] = written["entry"]
            held += len(lines)
        if held and (compact or held - 1 >= self._file_entries):
            self._compact()

    def _compact(self) -> None:
        """Under the lock: the file and the journal as they are now (another mpc may have
        written since), merged and written atomically (a crash leaves the old or the new
        file, never half; the journal, removed after, is applied again harmlessly)."""
        found = _read(self.path)
        if isinstance(found, str):
            self._refuse(found)
            return
        merged = found[0]
        handle, temporary = tempfile.mkstemp(prefix=".flash-record.", dir=self.path.parent)
        try:
            with os.fdopen(handle, "w", encoding="utf-8", newline="\n") as out:
                out.write(render(merged))
            os.replace(temporary, self.path)
        except BaseException:
            Path(temporary).unlink(missing_ok=True)
            raise
        self._checked = _identity(self.path)
        journal_path(self.path).unlink(missing_ok=True)
        for address, entry in merged.items():  # what another process wrote, for `entry`
            mine = self.devices.get(address)  # (a run's own entry object stays its own)
            if mine is None or (mine == self._seen.get(address) and mine != entry):
                self.devices[address] = entry
        self._seen = _copy(merged)
        self._file_entries = len(merged)


def render(devices: Entries) -> str:
    """The record file's text: one line per device, keys sorted (the C encoder: the
    indented form goes through the pure-Python one, which cost a fleet seconds)."""
    lines = [f" {json.dumps(address)}: {json.dumps(entry, sort_keys=True)}"
             for address, entry in sorted(devices.items())]
    body = "{\n" + ",\n".join(lines) + "\n }" if lines else "{}"
    return f'{{"format": "{RECORD_FORMAT}",\n "devices": {body}}}\n'


def _copy(devices: Entries) -> Entries:
    """A deep copy through the C decoder and encoder (`copy.deepcopy` is pure Python)."""
    copied: Entries = json.loads(json.dumps(devices))
    return copied


def _read(path: Path) -> tuple[Entries, int, FileId | None] | str:
    """The record's entries (the journal applied to the file), how many the file itself
    holds and which file it was; or why it is not a record. Read again if the file was
    replaced meanwhile (a compaction: its journal is gone, the old file alone is behind)."""
    for _ in range(10):
        before = _identity(path)
        found = _read_once(path)
        if isinstance(found, str) or _identity(path) == before:
            break
    return found if isinstance(found, str) else (*found, before)


def _read_once(path: Path) -> tuple[Entries, int] | str:
    base = _base(path)
    if isinstance(base, str):
        return base
    changes = _journal(journal_path(path))
    if isinstance(changes, str):
        return changes
    return _applied({} if base is None else _entries(base), changes)


def _applied(devices: Entries, changes: list[tuple[str, dict[str, Any] | None]]
             ) -> tuple[Entries, int]:
    """The file's entries with the journal's changes applied in order, and how many the
    file held."""
    in_file = len(devices)
    for address, entry in changes:
        if entry is None:
            devices.pop(address, None)
        else:
            devices[address] = entry
    return devices, in_file


def _identity(path: Path) -> FileId | None:
    """Which file is at `path` now (None: none): a replacement or a write changes it."""
    try:
        info = os.stat(path)
    except OSError:
        return None
    return info.st_ino, info.st_mtime_ns, info.st_size


def _entries(data: dict[str, Any]) -> Entries:
    return {key: entry for key, entry in data["devices"].items() if _is_entry(entry)}


def _is_entry(entry: Any) -> bool:
    return isinstance(entry, dict) and isinstance(entry.get("slots"), dict)


def _regular(path: Path, what: str) -> os.stat_result | str | None:
    """os.stat of `path` (None: no file), or why it cannot be taken for `what`: a special
    file is judged by os.stat and never opened."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        return f"cannot be checked ({exc.strerror or exc})"
    if not stat.S_ISREG(info.st_mode):
        return "is not a regular file" if what == "record" else \
            f"has a {path.name} that is not a regular file"
    if info.st_size > MAX_JSON_BYTES:
        return (f"is not an mpc flash {what} ({info.st_size:,} bytes, more than the "
                f"{MAX_JSON_BYTES:,} mpc reads of a JSON file)")
    return info


def _base(path: Path) -> dict[str, Any] | str | None:
    """The flash record at `path` (its JSON object), None if there is nothing to keep there
    (no file, or an empty one), or why what is there is not a flash record."""
    info = _regular(path, "record")
    if info is None or isinstance(info, str):
        return info
    if info.st_size == 0:
        return None
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


def _journal_lines(journal: Path) -> int | str | None:
    """Before appending (under the lock): how many lines the journal holds, its header
    included (None: there is none), a final line cut short by a killed writer cut off
    first; or why it is not a journal (someone's file is never appended to)."""
    info = _regular(journal, "journal")
    if info is None or isinstance(info, str):
        return info
    try:
        with open(journal, "rb+") as handle:
            data = handle.read()
            if data and not (data.startswith(_HEADER) or _HEADER.startswith(data)):
                return f"has a damaged journal ({journal.name}): no \"format\": " \
                    f"\"{JOURNAL_FORMAT}\" on line 1"
            end = data.rfind(b"\n") + 1
            if end != len(data):
                handle.truncate(end)
    except OSError as exc:
        return f"cannot be read ({journal.name}: {exc.strerror or exc})"
    return data.count(b"\n", 0, end)


def _journal(journal: Path) -> list[tuple[str, dict[str, Any] | None]] | str:
    """The changes the journal holds, in order; a last line without its newline is a write
    still under way or cut short by a kill, not yet a fact. Anything else that is not a
    journal line makes the whole record untrusted (a damaged journal could hide the line
    that took a slot out of the record)."""
    info = _regular(journal, "journal")
    if info is None or isinstance(info, str):
        return [] if info is None else info
    try:
        data = journal.read_bytes()
    except OSError as exc:
        return f"cannot be read ({journal.name}: {exc.strerror or exc})"
    lines = data.split(b"\n")[:-1]  # the part after the last newline is not a line yet
    changes: list[tuple[str, dict[str, Any] | None]] = []
    damaged = f"has a damaged journal ({journal.name})"
    for number, raw in enumerate(lines, 1):
        try:
            item = load_json(raw.decode("utf-8"))
        except (UnicodeDecodeError, ValueError):
            return f"{damaged}: line {number} is not JSON"
        if number == 1:
            if not isinstance(item, dict) or item.get("format") != JOURNAL_FORMAT:
                return f"{damaged}: no \"format\": \"{JOURNAL_FORMAT}\" on line 1"
            continue
        if not isinstance(item, dict) or not isinstance(item.get("address"), str) or \
                not (item.get("entry") is None or _is_entry(item.get("entry"))):
            return f"{damaged}: line {number} is not an entry"
        changes.append((item["address"], item["entry"]))
    return changes

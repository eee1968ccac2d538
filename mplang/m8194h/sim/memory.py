"""The macro memory file of the virtual M8194H (`mpc sim --memory`): the device's
non-volatile FRAM as JSON. Every stored table is kept as the frames that downloaded it, with
the word order they were written in, beside the initial parameter table, the FRnet DI
trigger table and the machine data; loading validates every table like a download."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

from mplang.m8194h.sim.machine_data import JSON_KEY as MD_JSON_KEY

if TYPE_CHECKING:
    from mplang.m8194h.sim.controller import VirtualController

MEMORY_FORMAT = "mpc-fram/1"


def save(vc: VirtualController, path: Path) -> None:
    """Persist macro memory (the device's non-volatile FRAM): every stored table as the
    frames that downloaded it, with the word order they were written in, the initial
    parameter table, the FRnet DI trigger table and the machine data."""
    programs = {f"{kind}{slot}": [list(line.frame) for line in table.lines]
                for (kind, slot), table in sorted(vc.tables.items())}
    data = {"format": MEMORY_FORMAT, "word_order": vc.word_order, "programs": programs,
            "initial_table": vc.initial_table.to_json(),
            "triggers": vc.triggers.to_json(), MD_JSON_KEY: vc.md.to_json()}
    write_atomically(path, json.dumps(data, indent=1))


def write_atomically(path: Path, text: str) -> None:
    """Replace `path` with `text` so that a kill or a power cut at any moment leaves the old
    file or the new one, never half of one, and the new one is on disk when this returns:
    a temporary file beside it, flushed to disk, renamed over it, and the directory flushed
    too where the system lets a directory be opened (POSIX; Windows does not)."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as out:
        out.write(text)
        out.flush()
        os.fsync(out.fileno())
    os.replace(tmp, path)
    if os.name == "posix":
        directory = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(directory)
        finally:
            os.close(directory)

def restore(vc: VirtualController, path: Path) -> None:
    """Load macro memory saved by `save`, validating every table like a download, and
    power on with it: a saved initial table is loaded into the live settings, a saved
    trigger table (and its enable flag) is in force, the machine data are the file's (0
    where it has none); files without the first two keys keep the controller's. Raises
    ValueError with the reason if the file is not such a memory image."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"not JSON: {exc}") from None
    if not isinstance(data, dict) or data.get("format") != MEMORY_FORMAT:
        raise ValueError(f"no \"format\": \"{MEMORY_FORMAT}\" key")
    programs = data.get("programs")
    word_order = data.get("word_order")
    if not isinstance(programs, dict) or word_order not in (0, 1):
        raise ValueError("\"programs\" must be an object and \"word_order\" 0 or 1")
    current = vc.word_order
    vc.word_order = word_order
    try:
        for name, frames in programs.items():
            match = re.fullmatch(r"(mp|isr)(\d+)", str(name))
            if match is None or not isinstance(frames, list) or not all(
                    isinstance(f, list) and all(isinstance(w, int) for w in f)
                    for f in frames):
                raise ValueError(f"{name!r}: expected mpN/isrN with a list of frames")
            kind, slot = match.group(1), int(match.group(2))
            if vc.profile.budget(kind, slot) is None:
                raise ValueError(f"{name}: no such slot")
            create = vc.encoder.create_frame(kind, slot)
            error = vc.load_frames(kind, slot,
                                     [create, *frames, vc.encoder.close_frame(kind)])
            if error is not None:
                raise ValueError(f"{name}: download error {error.code:#04x} at line "
                                 f"{error.line}")
    finally:
        vc.word_order = current
    if "initial_table" in data:
        vc.initial_table.from_json(data["initial_table"])
        vc.load_initial_now()
    if "triggers" in data:
        vc.triggers.from_json(data["triggers"])
    vc.md.from_json(data.get(MD_JSON_KEY, {}))

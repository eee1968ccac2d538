"""Lowerings kept on disk between runs (mplang.ir.persist): a build that reads them gives
exactly what a build with every cache off gives, after any sequence of edits, in process
and as `mpc build` processes; an edit of one program makes that program's entry alone (its
file's pack written again, the others' entries byte for byte as they were); damaged,
truncated and foreign packs and entries are ignored and made again; the store stays
bounded. Entries are told by their packs' contents, never by time."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from pathlib import Path

import pytest
from sourceedits import ROOT, changed, edit_sequences, seen

from mplang.ir import persist
from mplang.lang import caches
from mplang.m8194h.compiler import BuildResult, compile_paths

MPC = [sys.executable, "-c", "import sys; from mplang.cli import main; sys.exit(main())"]

THREE = "\n".join(["CONST FAST = 2000", "MP 1 first", "  SET_V X, FAST", "  SET_A X, 5000",
                   "  VAR3 = VAR4 + 1", "END MP", "MP 2 second", "  VAR1 = 5", "  CALL first",
                   "END MP", "MP 3 third", "  SET_V Y, 300", "END MP", ""])


def _fresh(path: Path, text: str) -> BuildResult:
    """The build with every cache off."""
    caches.turn_off(True)
    try:
        return compile_paths([path], texts={path: text})
    finally:
        caches.turn_off(False)


def _stored(path: Path, text: str) -> BuildResult:
    """The build of a command: lowerings read from and written to the store."""
    return compile_paths([path], texts={path: text})


def _packs(cache: Path) -> dict[str, dict[str, bytes]]:
    """Each pack's entries, by the pack's name."""
    folder = cache / "lowered"
    found = {p.name: persist.read_pack(p) for p in folder.glob("*.pack")} \
        if folder.is_dir() else {}
    return {name: pack for name, pack in found.items() if pack is not None}


def _entries(cache: Path) -> set[str]:
    """The keys of every entry kept."""
    return {key for pack in _packs(cache).values() for key in pack}


@pytest.fixture
def cache_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    directory = tmp_path / "cache"
    monkeypatch.setenv("MPLANG_CACHE", str(directory))
    return directory


@edit_sequences
def test_random_edits_build_from_the_store_as_with_caches_off(
        path: Path, steps: list[tuple[int, int, int]]) -> None:
    text = path.read_text(encoding="utf-8").split("\n")
    for step in [None, *steps]:
        if step is not None:
            text = changed(text, step)
        joined = "\n".join(text)
        fresh = seen(_fresh(path, joined))
        assert seen(_stored(path, joined)) == fresh  # entries made (or found)
        assert seen(_stored(path, joined)) == fresh  # every entry found


def test_an_edit_writes_the_entry_of_the_program_it_changed_alone(tmp_path: Path,
                                                                 cache_dir: Path) -> None:
    path = tmp_path / "three.mp"
    first = seen(_stored(path, THREE))
    before = _entries(cache_dir)
    assert len(before) == 3
    assert seen(_stored(path, THREE)) == first
    assert _entries(cache_dir) == before
    (kept,) = _packs(cache_dir).values()
    edited = THREE.replace("VAR1 = 5", "VAR1 = 6")
    assert seen(_stored(path, edited)) == seen(_fresh(path, edited))
    assert len(_entries(cache_dir) - before) == 1
    (pack,) = _packs(cache_dir).values()  # one file, one pack, written again
    assert set(pack) >= before  # the entry before the edit is kept, to undo it
    assert sum(pack[key] == held for key, held in kept.items()) == 3
    assert seen(_stored(path, THREE)) == first  # undone: nothing to write
    assert _packs(cache_dir) == {name: pack for name in _packs(cache_dir)}
    # a CONST is read by every program: changing it makes every entry again
    again = THREE.replace("2000", "2500")
    now = _entries(cache_dir)
    assert seen(_stored(path, again)) == seen(_fresh(path, again))
    assert len(_entries(cache_dir) - now) == 3


def test_caches_off_writes_no_entry(tmp_path: Path, cache_dir: Path,
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    _fresh(tmp_path / "three.mp", THREE)
    monkeypatch.setenv("MPLANG_CACHE", "off")
    _stored(tmp_path / "three.mp", THREE)
    assert not cache_dir.exists()


@pytest.mark.parametrize("damage", ["truncated", "garbage", "foreign", "empty", "shape",
                                    "command", "entry", "entries"])
def test_a_damaged_entry_is_ignored_and_made_again(tmp_path: Path, cache_dir: Path,
                                                   damage: str) -> None:
    path = tmp_path / "three.mp"
    expected = seen(_fresh(path, THREE))
    _stored(path, THREE)
    for entry in (cache_dir / "lowered").iterdir():
        data = entry.read_bytes()
        head, _, body = data.partition(b"\n")
        if damage == "truncated":
            entry.write_bytes(data[:len(data) // 2])
        elif damage == "garbage":
            entry.write_bytes(head + b"\n" + bytes(range(256)) * 4)
        elif damage == "foreign":
            entry.write_bytes(b"0" * 64 + b"\n" + body)
        elif damage == "empty":
            entry.write_bytes(b"")
        elif damage == "shape":  # the right key over a value of another shape
            caches.store(entry, head.decode(), {"not": "a pack"})
        elif damage == "entries":  # a pack of entries not of an entry's shape
            caches.store(entry, head.decode(), {key: pickle.dumps({"not": "an entry"})
                                                for key in persist.read_pack(entry) or {}})
        elif damage == "entry":  # each entry cut short in a pack that reads
            caches.store(entry, head.decode(), {key: held[:len(held) // 2] for key, held
                                                in (persist.read_pack(entry) or {}).items()})
        else:  # a catalogue command that does not exist
            at = ("three.mp", 2, 1, None)
            flat = (("mp", 1, "first", "three.mp", at, at, [(99_999, (), at)], []), [], {})
            caches.store(entry, head.decode(), {key: pickle.dumps(flat) for key
                                                in persist.read_pack(entry) or {}})
    damaged = {p.name: p.read_bytes() for p in (cache_dir / "lowered").iterdir()}
    assert seen(_stored(path, THREE)) == expected
    remade = {p.name: p.read_bytes() for p in (cache_dir / "lowered").iterdir()}
    if damage != "foreign":  # a foreign entry is another key's: this build's is made
        assert set(remade) == set(damaged)
        assert all(remade[name] != damaged[name] for name in damaged)
    assert seen(_stored(path, THREE)) == expected


def test_the_store_stays_bounded(tmp_path: Path, cache_dir: Path,
                                 monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(persist, "LIMIT", 8)
    path = tmp_path / "three.mp"
    (cache_dir / "lowered").mkdir(parents=True)
    for number in range(6):  # left by writers killed before they renamed them, and
        # an earlier mpc's entries
        for name in (f".left{number}.tmp", f"{number}.pickle"):
            (cache_dir / "lowered" / name).write_bytes(b"half")
            os.utime(cache_dir / "lowered" / name, (1, 1))
    for number in range(12):  # a pack each file; a pack holds at most twice its programs
        text = THREE.replace("VAR1 = 5", f"VAR1 = {number}").replace("300", f"3{number}")
        for each in (path, tmp_path / f"other{number}.mp"):
            assert seen(_stored(each, text)) == seen(_fresh(each, text))
        assert len(list((cache_dir / "lowered").iterdir())) <= 8
        assert all(len(pack) <= 6 for pack in _packs(cache_dir).values())
    assert not list((cache_dir / "lowered").glob("*.tmp"))
    assert not list((cache_dir / "lowered").glob("*.pickle"))
    # what the last build used is kept: building it again writes nothing
    kept = {p.name: p.read_bytes() for p in (cache_dir / "lowered").iterdir()}
    _stored(path, text)
    assert {p.name: p.read_bytes() for p in (cache_dir / "lowered").iterdir()} == kept


def _mpc(cwd: Path, cache: Path, *args: str) -> subprocess.CompletedProcess[bytes]:
    env = {k: v for k, v in os.environ.items() if k != "MPLANG_CACHE"}
    env["MPLANG_CACHE"] = str(cache)
    return subprocess.run([*MPC, *args], cwd=cwd, env=env, capture_output=True, check=False)


def test_mpc_build_with_the_store_gives_what_no_cache_gives(tmp_path: Path) -> None:
    """A sequence of edits as a person makes them (a number, a CONST every program reads,
    a line inserted above every program), each built by `mpc build` with the store and with
    --no-cache: the same image (and at the end listing), diagnostics and exit code."""
    lines = (ROOT / "samples" / "pick_and_place.mp").read_text(encoding="utf-8").split("\n")
    assert any(line.startswith("CONST") for line in lines)
    cache = tmp_path / "cache"
    edits = [None, (0, 40, 1), (5, 0, 0), (3, 0, 7)]
    for number, step in enumerate(edits):
        if step is not None:
            lines = changed(lines, step)
        (tmp_path / "pp.mp").write_text("\n".join(lines), encoding="utf-8")
        for fmt in ("json", "listing") if number == len(edits) - 1 else ("json",):
            stored = _mpc(tmp_path, cache, "build", "pp.mp", "--format", fmt, "-o", "a.out")
            image = (tmp_path / "a.out").read_bytes() if stored.returncode == 0 else b""
            kept = {p.name: p.stat().st_mtime_ns for p in (cache / "lowered").iterdir()}
            fresh = _mpc(tmp_path, cache, "build", "--no-cache", "pp.mp", "--format", fmt,
                         "-o", "a.out")
            # --no-cache writes no entry (nor changes one)
            assert {p.name: p.stat().st_mtime_ns for p in (cache / "lowered").iterdir()} == kept
            assert b"Traceback" not in stored.stderr
            assert (stored.returncode, stored.stderr) == (fresh.returncode, fresh.stderr)
            if fresh.returncode == 0:
                assert image == (tmp_path / "a.out").read_bytes()
    assert _entries(cache)


def test_mpc_build_over_damaged_entries_says_nothing_of_them(tmp_path: Path) -> None:
    (tmp_path / "three.mp").write_text(THREE, encoding="utf-8")
    cache = tmp_path / "cache"
    first = _mpc(tmp_path, cache, "build", "three.mp", "-o", "a.json")
    image = (tmp_path / "a.json").read_bytes()
    for entry in (cache / "lowered").iterdir():
        entry.write_bytes(entry.read_bytes()[:-7])
    again = _mpc(tmp_path, cache, "build", "three.mp", "-o", "a.json")
    assert (again.returncode, again.stderr) == (first.returncode, first.stderr)
    assert (tmp_path / "a.json").read_bytes() == image

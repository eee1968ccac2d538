"""`mpc.toml`: the loader's checks (each names file:line), and build/lint/flash reading it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import EXIT_NO_INPUT, EXIT_OK, EXIT_USAGE, main
from mplang.cli.common import EXIT_NO_DEVICE, expand_inputs
from mplang.tools.project import ProjectError, find_project, load_fleet, load_project

FEEDER = """MP feeder
    VAR1 = VAR1 + 1
END MP
"""
MOVER = """MP mover
    SET_V X, 1000
    FIXED_MOVE X, 500
END MP
"""


def project(tmp_path: Path, toml: str, files: dict[str, str] | None = None) -> Path:
    for name, text in (files or {"src/feeder.mp": FEEDER, "src/mover.mp": MOVER}).items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    path = tmp_path / "mpc.toml"
    path.write_text(toml)
    return path


def test_a_full_project_file_is_read(tmp_path: Path) -> None:
    path = project(tmp_path, """
[project]
sources = ["src"]
target = "rs"
word-order = 1
temp-vars = "VAR480-VAR495"
werror = true

[slots]
mover = "MP20"

[targets.cell1]
tcp = "192.168.0.16"
[targets.line2]
serial = "/dev/ttyUSB0"
unit = 3
baud = 57600
parity = "E"
stopbits = 2
timeout = 2.5
sources = "src/feeder.mp"

[flash]
record = "state/record.json"
retries = 5

[fmt]
indent = 2
""")
    loaded = load_project(path)
    assert [p.name for p in loaded.sources] == ["feeder.mp", "mover.mp"]
    assert (loaded.target, loaded.word_order, loaded.werror) == ("rs", 1, True)
    assert loaded.temp_vars == range(480, 496)
    assert [(p.name, p.kind, p.slot, p.span.line) for p in loaded.pins] == \
        [("mover", "mp", 20, 10)]
    cell, line = loaded.targets["cell1"], loaded.targets["line2"]
    assert (cell.host, cell.port, cell.address()) == ("192.168.0.16", 502,
                                                      "tcp://192.168.0.16:502/1")
    assert (line.serial, line.unit, line.baud, line.parity, line.stopbits, line.timeout) == \
        ("/dev/ttyUSB0", 3, 57600, "E", 2, 2.5)
    assert [p.name for p in line.sources] == ["feeder.mp"]
    assert loaded.flash.record == tmp_path / "state" / "record.json"
    assert loaded.flash.retries == 5 and loaded.fmt == {"indent": 2}
    assert [t.name for t in load_fleet(path)] == ["cell1", "line2"]


@pytest.mark.parametrize(("toml", "message"), [
    ("[project]\nsources = [\"src\"\n", ":2: not valid TOML"),
    ("[project]\nsource = \"src\"\n", ":2: [project] source: unknown key"),
    ("[projects]\n", ":1: unknown table [projects]"),
    ("[project]\nsources = \"nowhere/*.mp\"\n", ":2: [project] sources: no files match"),
    ("[project]\nsources = \"missing.mp\"\n", ":2: [project] sources: missing.mp: no such"),
    ("[project]\ntarget = \"xx\"\n", ":2: [project] target: must be one of \"et\" "
     "(ET-M8194H), \"rs\" (RS-M8194H), \"fbs-fun140\", \"fbs-fun147\", \"csim\", not 'xx'"),
    ("[project]\ntarget = 5\n", ":2: [project] target: must be one of"),
    ("[targets.x]\nserial = \"/dev/x\"\n\ntarget = \"csi\"\n", ":4: [targets.x] target: must "
     "be one of"),
    ("[targets.x]\ntcp = \"10.0.0.2\"\ntarget = \"csim\"\n", ":2: [targets.x] tcp: a CSIM "
     "device (csim) is reached over a serial line"),
    ("[targets.x]\nserial = \"/dev/x\"\ntarget = \"fbs-fun140\"\n", ":3: [targets.x] target: "
     "fbs-fun140: FB documents no way to write positioning tables"),
    ("[targets.x]\nserial = \"/dev/x\"\ntarget = \"csim\"\nunit = 2\n", ":4: [targets.x] unit: "
     "does not apply to a CSIM device (csim)"),
    ("[targets.x]\nserial = \"/dev/x\"\nword-order = 1\ntarget = \"csim\"\n", ":3: [targets.x] "
     "word-order: does not apply"),
    ("[project]\n\nword-order = 2\n", ":3: [project] word-order: must be a whole number"),
    ("[project]\ntemp-vars = \"500-600\"\n", ":2: [project] temp-vars: the pool must lie"),
    ("[slots]\nfeeder = \"MP\"\n", ":2: [slots] feeder: write the slot as"),
    ("[slots]\na = \"MP3\"\nb = \"mp 3\"\n", ":3: [slots] b: MP3 is also the pin of a"),
    ("[targets.x]\nunit = 3\n", ":1: [targets.x]: give the device as tcp"),
    ("[targets.x]\ntcp = \"h:99999\"\n", ":2: [targets.x] tcp: 'h:99999'"),
    ("[targets.x]\nserial = \"/dev/x\"\nparity = \"Q\"\n", ":3: [targets.x] parity"),
    ("[targets.x]\nserial = \"/dev/x\"\nspeed = 9600\n", ":3: [targets.x] speed: unknown"),
    ("[flash]\nretries = -1\n", ":2: [flash] retries: must be a whole number in 0..100"),
    ("[flash]\nset-word-order = \"yes\"\n", ":2: [flash] set-word-order: must be true"),
])
def test_bad_project_files_name_the_line(tmp_path: Path, toml: str, message: str) -> None:
    path = project(tmp_path, toml)
    with pytest.raises(ProjectError) as caught:
        load_project(path)
    assert str(caught.value).startswith(str(path)) and message in str(caught.value)


def test_fleet_file_without_devices_is_refused(tmp_path: Path) -> None:
    path = project(tmp_path, "[project]\nsources = \"src\"\n")
    with pytest.raises(ProjectError, match="no devices"):
        load_fleet(path)


def test_the_project_file_is_found_from_a_subdirectory(tmp_path: Path) -> None:
    path = project(tmp_path, "[project]\nsources = \"src\"\n")
    (tmp_path / "a" / "b").mkdir(parents=True)
    assert find_project(tmp_path / "a" / "b") == path.resolve()
    assert find_project(tmp_path.parent / "elsewhere-not-there") is None or \
        find_project(tmp_path.parent) != path


def build_json(runner: CliRunner, *args: str) -> dict[str, object]:
    result = runner.invoke(main, ["build", *args])
    assert result.exit_code == EXIT_OK, result.output
    data: dict[str, object] = json.loads(result.stdout)
    return data


def slots(image: dict[str, object]) -> dict[str, int]:
    programs = image["programs"]
    assert isinstance(programs, list)
    return {p["name"]: p["slot"] for p in programs}


def test_build_and_lint_read_the_project_when_no_files_are_given(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    project(tmp_path, "[project]\nsources = [\"src\"]\nword-order = 1\n\n[slots]\n"
            "feeder = \"MP30\"\n")
    (tmp_path / "deep").mkdir()
    monkeypatch.chdir(tmp_path / "deep")
    runner = CliRunner()
    image = build_json(runner)
    assert slots(image) == {"feeder": 30, "mover": 1}
    assert image["target"] == {"word_order": 1, "family": "M8194H", "variant": "et"}
    # the command line wins over the file
    assert build_json(runner, "--word-order", "0")["target"]["word_order"] == 0  # type: ignore[index]
    # FILE... given: the project is not read (no pins, its options not applied)
    explicit = build_json(runner, str(tmp_path / "src" / "feeder.mp"))
    assert slots(explicit) == {"feeder": 1}
    # --project applies the file's options and pins to the files given
    pinned = build_json(runner, "--project", str(tmp_path / "mpc.toml"),
                        str(tmp_path / "src" / "feeder.mp"))
    assert slots(pinned) == {"feeder": 30}
    assert runner.invoke(main, ["lint"]).exit_code == EXIT_OK


def test_pins_keep_a_program_in_its_slot_when_another_grows(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Why pins exist: without them, growth moves programs (and an incremental flash then
    rewrites them all)."""
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    small = "MP a\n    VAR1 = 1\nEND MP\n"
    big = "MP a\n" + "".join(f"    VAR{n} = {n}\n" for n in range(1, 70)) + "END MP\n"
    other = "MP b\n    VAR2 = 2\nEND MP\n"
    project(tmp_path, "[project]\nsources = [\"a.mp\", \"b.mp\"]\n",
            {"a.mp": small, "b.mp": other})
    before = slots(build_json(runner))
    (tmp_path / "a.mp").write_text(big)
    after = slots(build_json(runner))
    assert before["b"] != after["b"]  # unpinned: b moved
    project(tmp_path, f"[project]\nsources = [\"a.mp\", \"b.mp\"]\n[slots]\nb = "
            f"\"MP{before['b']}\"\n", {"a.mp": big, "b.mp": other})
    assert slots(build_json(runner))["b"] == before["b"]


def test_project_errors_and_missing_sources_exit_cleanly(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    nothing = runner.invoke(main, ["build"])
    assert nothing.exit_code == EXIT_USAGE and "mpc.toml" in nothing.output
    project(tmp_path, "[project]\nsources = \"nope.mp\"\n")
    bad = runner.invoke(main, ["build"])
    assert bad.exit_code == EXIT_NO_INPUT and "mpc.toml:2:" in bad.output
    project(tmp_path, "[targets.x]\ntcp = \"127.0.0.1\"\n")
    empty = runner.invoke(main, ["build"])
    assert empty.exit_code == EXIT_USAGE and "lists no sources" in empty.output
    flash = runner.invoke(main, ["flash", "--to", "y", "--dry-run"])
    assert flash.exit_code == EXIT_USAGE and "no [targets.y]" in flash.output


def test_the_other_families_targets_are_project_and_device_targets(tmp_path: Path) -> None:
    path = project(tmp_path, """
[project]
sources = ["src"]
target = "fbs-fun147"

[targets.drive]
serial = "/dev/ttyUSB1"
target = "csim"
baud = 9600
[targets.cell]
tcp = "10.0.0.9"
target = "rs"
""")
    loaded = load_project(path)
    assert loaded.target == "fbs-fun147"
    drive, cell = loaded.targets["drive"], loaded.targets["cell"]
    assert (drive.target, drive.serial, drive.baud) == ("csim", "/dev/ttyUSB1", 9600)
    assert (cell.target, cell.host) == ("rs", "10.0.0.9")
    assert [t.target for t in load_fleet(path)] == ["csim", "rs"]


def test_a_device_target_builds_its_m8194h_image(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """A device's own target = "rs" builds its image for the RS-M8194H (RS-only commands)."""
    monkeypatch.chdir(tmp_path)
    project(tmp_path, "[project]\nsources = [\"rs_only.mp\"]\n[targets.cell]\n"
            "tcp = \"127.0.0.1:1\"\ntarget = \"rs\"\n",
            {"rs_only.mp": "MP 1\n    INTP_END 0\nEND MP\n"})
    runner = CliRunner()
    assert runner.invoke(main, ["build"]).exit_code == 1  # et: INTP_END is RS-only
    dry = runner.invoke(main, ["flash", "--dry-run", "--json"])
    assert dry.exit_code == EXIT_OK, dry.output
    assert json.loads(dry.stdout)["programs"][0]["slot"] == 1


def test_windows_serial_port_names_are_taken_as_written(tmp_path: Path) -> None:
    """COM3, and the device path form above COM9, reach pyserial unchanged; mpc status names
    the port as given when it cannot be opened (on this machine, none of them exists: 7)."""
    path = project(tmp_path, "[project]\nsources = \"src\"\n\n[targets.small]\n"
                   "serial = \"COM3\"\n\n[targets.big]\nserial = '\\\\.\\COM12'\n")
    targets = load_project(path).targets
    assert (targets["small"].serial, targets["big"].serial) == ("COM3", "\\\\.\\COM12")
    assert targets["big"].address().endswith("COM12/1")
    done = subprocess.run([sys.executable, "-m", "mplang", "status", "--to", "big"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == EXIT_NO_DEVICE, done.stderr
    assert "\\\\.\\COM12" in done.stderr and "Traceback" not in done.stderr


@pytest.mark.parametrize(("record", "message"), [
    ("../victim.txt", "../victim.txt leads out of the project"),
    ("state/../../victim.txt", "leads out of the project"),
    ("{outside}/victim.txt", "victim.txt is outside the project"),
    ("link/victim.txt", "link/victim.txt leads out of the project ({root}) through a "
     "symbolic link, to {outside}/victim.txt"),
    ("victim-link.json", "through a symbolic link, to {outside}/victim.txt"),
    (".", "'.' is a directory: name a file"),
])
def test_a_flash_record_outside_the_project_is_refused_at_its_line(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, record: str, message: str) -> None:
    """Issue 19 item 6: `[flash] record = "../victim.txt"` once replaced that file with JSON
    on the next flash. Every path the project file names for writing stays inside the project
    (symlinks followed) or the user's state or cache directory."""
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "xdg-state"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg-cache"))
    root, outside = tmp_path / "cell", tmp_path / "elsewhere"
    root.mkdir()
    outside.mkdir()
    victim = outside / "victim.txt"
    victim.write_text("someone's file\n")
    (tmp_path / "victim.txt").write_text("someone's file\n")
    (root / "link").symlink_to(outside)
    (root / "victim-link.json").symlink_to(victim)
    path = project(root, f"[project]\nsources = \"src\"\n\n[flash]\n# where\nrecord = "
                   f"\"{record.format(outside=outside)}\"\n")
    settings = load_project(path).flash  # loading is fine: only a flash writes the record
    with pytest.raises(ProjectError) as caught:
        settings.writable_record()
    text = str(caught.value)
    assert text.startswith(f"{path}:6: [flash] record: "), text
    assert message.format(root=root.resolve(), outside=outside.resolve()) in text, text
    monkeypatch.chdir(root)
    result = CliRunner().invoke(main, ["flash", "--dry-run", "--tcp", "127.0.0.1"])
    assert result.exit_code == EXIT_NO_INPUT and "mpc.toml:6: [flash] record:" in result.output
    assert "Traceback" not in result.output
    assert victim.read_text() == (tmp_path / "victim.txt").read_text() == "someone's file\n"


def test_lint_and_build_do_not_refuse_over_a_flash_record_they_never_write(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 23 item 8: a `.mpc` folder that is a symbolic link leading out of the project
    made `mpc lint` and `mpc build` refuse (exit 3) over the default flash record inside
    it. Only `mpc flash`, which writes it, refuses, at the [flash] table's place; naming
    another record on the command line is taken."""
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "xdg-state"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg-cache"))
    root, outside = tmp_path / "cell", tmp_path / "elsewhere"
    root.mkdir()
    outside.mkdir()
    (root / ".mpc").symlink_to(outside, target_is_directory=True)
    project(root, "[project]\nsources = \"src\"\n")
    monkeypatch.chdir(root)
    runner = CliRunner()
    lint = runner.invoke(main, ["lint"])
    assert lint.exit_code == EXIT_OK, lint.output
    build = runner.invoke(main, ["build", "-o", str(tmp_path / "out.json")])
    assert build.exit_code == EXIT_OK, build.output
    assert (tmp_path / "out.json").is_file()
    flash = runner.invoke(main, ["flash", "--dry-run", "--tcp", "127.0.0.1"])
    assert flash.exit_code == EXIT_NO_INPUT, flash.output
    assert "[flash] record: '.mpc/flash-record.json' leads out of the project" in \
        flash.output or ".mpc/flash-record.json leads out of the project" in flash.output
    assert "Traceback" not in flash.output
    named = runner.invoke(main, ["flash", "--dry-run", "--tcp", "127.0.0.1", "--record",
                                 str(tmp_path / "record.json")])
    assert named.exit_code == EXIT_OK, named.output
    assert list(outside.iterdir()) == []


def test_a_flash_record_inside_the_project_or_the_users_directories_is_taken(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "xdg-state"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg-cache"))
    root = tmp_path / "cell"
    root.mkdir()
    (root / "inner").mkdir()
    (root / "via-link").symlink_to(root / "inner")  # a link that stays inside is fine
    for record, expected in (
            ("state/record.json", root / "state" / "record.json"),
            ("via-link/record.json", root / "via-link" / "record.json"),
            (f"{tmp_path}/xdg-state/mpc/cell.json", tmp_path / "xdg-state/mpc/cell.json"),
            (f"{tmp_path}/xdg-cache/cell.json", tmp_path / "xdg-cache/cell.json")):
        path = project(root, f"[project]\nsources = \"src\"\n[flash]\nrecord = \"{record}\"\n")
        assert load_project(path).flash.record == expected
    path = project(root, "[project]\nsources = \"src\"\n")  # the default record
    assert load_project(path).flash.record == root / ".mpc" / "flash-record.json"


def test_mpc_fmt_rewrites_no_project_source_outside_the_project(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`mpc fmt` without FILE rewrites the sources mpc.toml lists: only those inside the
    project (a symlink leading out is followed and refused); --check reads them all, and a
    file named on the command line is formatted wherever it is."""
    root, outside = tmp_path / "cell", tmp_path / "elsewhere"
    (root / "src").mkdir(parents=True)
    outside.mkdir()
    ugly = "mp 1 a\nvar1=1\nend mp\n"
    (outside / "shared.mp").write_text(ugly)
    (root / "src" / "own.mp").write_text(ugly)
    (root / "src" / "linked.mp").symlink_to(outside / "shared.mp")
    project(root, "[project]\n# the sources\nsources = [\"src/own.mp\", \"src/linked.mp\"]\n",
            {})
    monkeypatch.chdir(root)
    runner = CliRunner()
    refused = runner.invoke(main, ["fmt"])
    assert refused.exit_code == EXIT_NO_INPUT, refused.output
    assert "mpc.toml:3: [project] sources: src/linked.mp is outside the project" in \
        refused.output
    assert (outside / "shared.mp").read_text() == (root / "src" / "own.mp").read_text() == ugly
    assert runner.invoke(main, ["fmt", "--check"]).exit_code == 12  # would reformat both
    named = runner.invoke(main, ["fmt", "src/linked.mp"])
    assert named.exit_code == EXIT_OK and (outside / "shared.mp").read_text() != ugly


def test_a_fifo_in_a_source_directory_is_not_a_source(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 19 item 7: a directory contributes its regular .mp files; a FIFO among them
    would hang the build that opens it."""
    path = project(tmp_path, "[project]\nsources = \"src\"\n")
    os.mkfifo(tmp_path / "src" / "pipe.mp")
    assert [p.name for p in load_project(path).sources] == ["feeder.mp", "mover.mp"]
    monkeypatch.chdir(tmp_path)
    assert [p.name for p in expand_inputs(("src",))] == ["feeder.mp", "mover.mp"]

"""`mpc.toml`: a project's sources, build options, slot pins and flash targets in one file.

`mpc build`, `mpc lint`, `mpc run` and `mpc flash` read it when they are given no files; the
file is found in the current directory or the nearest parent (as git finds `.git`). Paths in it
are relative to its own directory. Command-line options win over the file. The same `[targets]`
tables make a fleet file for `mpc flash --fleet FILE`. docs/project.md describes every key.

Every problem names the file and the line of the key (tomllib reports syntax errors with their
line; for values, the line is found by reading the file's table and key lines).
"""

from __future__ import annotations

import errno
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mplang.family.registry import family_of_target, known_targets, target_title
from mplang.ir.unit import SlotPin
from mplang.lang.diagnostics import Span
from mplang.lang.record import FrozenRecord
from mplang.lang.tomlfile import TomlFileError, TomlLines, read_toml
from mplang.lang.userdirs import cache_home, state_home

PROJECT_FILE = "mpc.toml"
DEFAULT_RECORD = ".mpc/flash-record.json"
TARGET_KEYS = frozenset({"tcp", "serial", "unit", "baud", "parity", "stopbits", "timeout",
                         "retries", "sources", "image", "word-order", "target"})
MODBUS_ONLY_KEYS = ("unit", "word-order", "image", "retries")
"""[targets.NAME] keys that only an M8194H (a Modbus device taking image frames) uses."""
"""The other controller families (issue 7). Each package names its own targets (`TARGETS`)
and source suffixes (`SUFFIXES`); nothing here repeats them."""
SECTIONS = frozenset({"project", "slots", "targets", "flash", "fmt", "lint", "machine"})
LINT_KEYS = frozenset({"ignore"})
"""`[machine]` is the simulated machine: the family that runs the build reads and checks it
(`Family.load_machine`, docs/machine.md)."""
PROJECT_KEYS = frozenset({"sources", "target", "word-order", "temp-vars", "var-pool",
                          "allow-outside-includes", "werror"})
FLASH_KEYS = frozenset({"record", "timeout", "retries", "set-word-order", "identity"})
SLOT_TEXT = re.compile(r"(MP|ISR)\s*(\d+)", re.IGNORECASE)


class ProjectError(ValueError):
    """A project or fleet file that cannot be used; the message starts with file:line."""


class Target(FrozenRecord):
    """One device to flash: `[targets.NAME]`. Exactly one of `tcp` / `serial`."""

    name: str
    host: str | None
    port: int
    serial: str | None
    unit: int
    baud: int
    parity: str
    stopbits: int
    timeout: float | None  # None: the command line's or [flash]'s
    retries: int | None
    sources: tuple[Path, ...]  # this device's own program set, if not the project's
    image: Path | None
    word_order: int | None
    span: Span | None
    target: str | None  # the device's controller, if the table names it
    _fields = __match_args__ = ("name", "host", "port", "serial", "unit", "baud", "parity",
                                "stopbits", "timeout", "retries", "sources", "image",
                                "word_order", "span", "target")

    def __init__(self, name: str, host: str | None = None, port: int = 502,
                 serial: str | None = None, unit: int = 1, baud: int = 115200,
                 parity: str = "N", stopbits: int = 1, timeout: float | None = None,
                 retries: int | None = None, sources: tuple[Path, ...] = (),
                 image: Path | None = None, word_order: int | None = None,
                 span: Span | None = None, target: str | None = None) -> None:
        self.__dict__.update(name=name, host=host, port=port, serial=serial, unit=unit,
                             baud=baud, parity=parity, stopbits=stopbits, timeout=timeout,
                             retries=retries, sources=sources, image=image,
                             word_order=word_order, span=span, target=target)

    def address(self) -> str:
        """Where the device is, as the incremental record keys it."""
        if self.host is not None:
            return f"tcp://{self.host}:{self.port}/{self.unit}"
        return f"rtu://{self.serial}/{self.unit}"


class FlashSettings(FrozenRecord):
    record: Path
    timeout: float | None
    retries: int | None
    set_word_order: bool
    identity: str | bool | None
    """The machine-data range of the build manifest ("MD960-MD1023"), False for none, None
    for the family's default; the family checks the range itself."""
    identity_where: str  # "FILE:LINE: [flash] identity" for messages about it
    record_refusal: str | None
    """Why `record` may not be written ("FILE:LINE: [flash] record: ..."), None if it may.
    Only a command that writes the record refuses over it (`mpc flash`, `writable_record`):
    lint and build never touch it, so a `.mpc` folder leading out of the project is none
    of their business."""
    _fields = __match_args__ = ("record", "timeout", "retries", "set_word_order", "identity",
                                "identity_where", "record_refusal")

    def __init__(self, record: Path, timeout: float | None = None, retries: int | None = None,
                 set_word_order: bool = False, identity: str | bool | None = None,
                 identity_where: str = "", record_refusal: str | None = None) -> None:
        self.__dict__.update(record=record, timeout=timeout, retries=retries,
                             set_word_order=set_word_order, identity=identity,
                             identity_where=identity_where, record_refusal=record_refusal)

    def writable_record(self) -> Path:
        """The record, if mpc may write it on the project file's word; else ProjectError."""
        if self.record_refusal is not None:
            raise ProjectError(self.record_refusal)
        return self.record


class Project(FrozenRecord):
    path: Path  # the mpc.toml file
    sources: tuple[Path, ...]
    target: str | None  # "et" / "rs", or a family target (known_targets())
    word_order: int | None
    temp_vars: range | None
    var_pool: range | None
    allow_outside_includes: bool | None
    werror: bool | None
    pins: tuple[SlotPin, ...]
    targets: dict[str, Target]
    flash: FlashSettings
    fmt: Mapping[str, Any]
    ignore: frozenset[str]
    """`[lint] ignore`: warning codes silenced in every file of the project, as a
    `# mpc: ignore[CODE]` on each line would."""
    machine: bool  # the file has a [machine] table (read by the family)

    sources_line: int  # the line of [project] sources, for messages about them
    _fields = __match_args__ = ("path", "sources", "target", "word_order", "temp_vars",
                                "var_pool", "allow_outside_includes", "werror", "pins",
                                "targets", "flash", "fmt", "ignore", "machine", "sources_line")

    def __init__(self, path: Path, sources: tuple[Path, ...] = (), target: str | None = None,
                 word_order: int | None = None, temp_vars: range | None = None,
                 var_pool: range | None = None, allow_outside_includes: bool | None = None,
                 werror: bool | None = None, pins: tuple[SlotPin, ...] = (),
                 targets: dict[str, Target] | None = None, flash: FlashSettings | None = None,
                 fmt: Mapping[str, Any] | None = None, ignore: frozenset[str] = frozenset(),
                 machine: bool = False, sources_line: int = 1) -> None:
        self.__dict__.update(path=path, sources=sources, target=target, word_order=word_order,
                             temp_vars=temp_vars, var_pool=var_pool,
                             allow_outside_includes=allow_outside_includes, werror=werror,
                             pins=pins, targets={} if targets is None else targets,
                             flash=FlashSettings(Path(DEFAULT_RECORD)) if flash is None else flash,
                             fmt={} if fmt is None else fmt, ignore=ignore, machine=machine,
                             sources_line=sources_line)

    @property
    def root(self) -> Path:
        return self.path.parent

    def may_write(self, path: Path) -> bool:
        """Whether mpc may write `path` on this file's word (not the command line's): inside
        the project or the user's state or cache directory, symlinks followed."""
        return write_refusal(self.root, str(path)) is None


def user_directories() -> tuple[Path, ...]:
    """The user's state and cache directories (mplang.lang.userdirs), where mpc keeps what
    belongs to no project (the default flash record); a project file may name paths there
    too."""
    return tuple(folder for folder in (state_home(), cache_home()) if folder is not None)


def write_refusal(root: Path, value: str) -> str | None:
    """Why mpc will not write `value` (a path in the project file, relative to its folder
    `root`), or None if it may. Allowed: inside the project or the user's state or cache
    directory, after following every symlink on the way, so that `../victim.txt`, `/etc/x`
    and a link leading out are all refused. The command line may name any path."""
    target = root / value
    try:
        resolved = target.resolve()
        project = root.resolve()
        allowed = [project, *(folder.resolve() for folder in user_directories())]
    except (OSError, RuntimeError, ValueError) as exc:
        return f"{value!r} cannot be resolved ({exc})"
    if resolved.is_dir():
        return f"{value!r} is a directory: name a file"
    if any(resolved.is_relative_to(folder) for folder in allowed):
        return None
    if os.path.isabs(value):
        where = f"{value} is outside the project ({project})"
    elif Path(os.path.normpath(project / value)).is_relative_to(project):  # by its text
        where = f"{value} leads out of the project ({project}) through a symbolic link, to " \
            f"{resolved}"
    else:
        where = f"{value} leads out of the project ({project})"
    return f"{where}: a project file names files to write only inside its project or the " \
        "user's state or cache directory; give any other path on the command line"


def describe_targets() -> str:
    return ", ".join(f'"{name}"' + (f" ({target_title(name).split(',')[0]})"
                                    if target_title(name) else "") for name in known_targets())


def find_project(start: Path) -> Path | None:
    """The nearest `mpc.toml` in `start` or above it, or None."""
    here = start.resolve()
    for folder in (here, *here.parents):
        candidate = folder / PROJECT_FILE
        if candidate.is_file():
            return candidate
    return None


class _Locator(TomlLines):
    """Finds the line of `[table]` / `key =` in the TOML text, for messages."""

    def __init__(self, path: Path, text: str) -> None:
        super().__init__(text)
        self.path = path

    def span(self, table: str, key: str | None = None) -> Span:
        return Span(str(self.path), self.line(table, key))

    def error(self, table: str, key: str | None, message: str) -> ProjectError:
        where = f"[{table}] {key}" if key else f"[{table}]"
        return ProjectError(f"{self.path}:{self.line(table, key)}: {where}: {message}")


def _read(path: Path) -> tuple[dict[str, Any], _Locator]:
    try:
        data, text = read_toml(path)
    except TomlFileError as exc:
        raise ProjectError(str(exc)) from None
    return data, _Locator(path, text)


def _check_keys(table: Mapping[str, Any], allowed: frozenset[str], name: str,
                where: _Locator) -> None:
    for key in table:
        if key not in allowed:
            raise where.error(name, key, f"unknown key; expected one of "
                              f"{', '.join(sorted(allowed))}")


def _string_list(value: object, table: str, key: str, where: _Locator) -> list[str]:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list) or not value or \
            not all(isinstance(v, str) and v for v in value):
        raise where.error(table, key, "must be a file, directory or glob, or a list of them")
    return list(value)


def _expand(patterns: list[str], root: Path, table: str, key: str,
            where: _Locator) -> tuple[Path, ...]:
    """Files, directories (every .mp below) and globs, relative to the project file (an
    absolute name or glob stands for itself). A name or pattern the system or pathlib
    refuses (too long, a NUL, `**` inside a component) is an error at the key's line."""
    found: list[Path] = []
    for pattern in patterns:
        shown = pattern if len(pattern) <= 80 else f"{pattern[:40]}...{pattern[-20:]}"
        try:
            matches = _matches(pattern, root)
        except (OSError, ValueError) as exc:
            why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
            raise where.error(table, key, f"{shown!r} cannot be used: {why}") from None
        if matches is None:
            raise where.error(table, key, f"{shown}: no such file")
        if not matches:
            raise where.error(table, key, f"no .mp files in directory {shown}"
                              if (root / pattern).is_dir() else f"no files match {shown}")
        found += [m for m in matches if m not in found]
    return tuple(found)


def _matches(pattern: str, root: Path) -> list[Path] | None:
    """What one sources entry names: None if it names nothing and is no glob."""
    if "\0" in pattern:
        raise ValueError("a file name cannot hold a NUL character")
    path = root / pattern
    try:
        path.stat()
    except OSError as exc:
        if exc.errno not in (errno.ENOENT, errno.ENOTDIR):
            raise
    if path.is_dir():
        return sorted(p for p in path.rglob("*.mp") if p.is_file())  # no FIFOs
    if path.is_file():
        return [path]
    if not any(ch in pattern for ch in "*?["):
        return None
    written = Path(pattern)
    if written.is_absolute():  # pathlib globs only relative patterns: start at the anchor
        base, relative = Path(written.anchor), str(written.relative_to(written.anchor))
    else:
        base, relative = root, pattern
    return sorted(p for p in base.glob(relative) if p.is_file())  # `relative` has no anchor


def _int(value: object, low: int, high: int, table: str, key: str, where: _Locator) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not low <= value <= high:
        raise where.error(table, key, f"must be a whole number in {low}..{high}, "
                          f"not {value!r}")
    return value


def _number(value: object, low: float, high: float, table: str, key: str,
            where: _Locator) -> float:
    if not isinstance(value, int | float) or isinstance(value, bool) or \
            not low <= value <= high:
        raise where.error(table, key, f"must be a number in {low:g}..{high:g}, not {value!r}")
    return float(value)


def _bool(value: object, table: str, key: str, where: _Locator) -> bool:
    if not isinstance(value, bool):
        raise where.error(table, key, f"must be true or false, not {value!r}")
    return value


def _table(data: Mapping[str, Any], name: str, where: _Locator) -> Mapping[str, Any]:
    value = data.get(name, {})
    if not isinstance(value, dict):
        raise where.error(name, None, "must be a table")
    return value


def parse_temps(text: str) -> range:
    """`FIRST-LAST` (e.g. `496-511`, `VAR496-VAR511`): a range of VARs (the pool of
    temporaries, or of declared variables)."""
    try:
        low_text, high_text = text.upper().replace("VAR", "").split("-")
        low, high = int(low_text), int(high_text)
    except ValueError:
        raise ValueError("write the pool as FIRST-LAST, e.g. 496-511") from None
    if low > high and high >= 0 and low <= 511:
        raise ValueError(f"{text}: the range is reversed (FIRST after LAST): write "
                         f"{high}-{low}")
    if not 0 <= low <= high <= 511:
        raise ValueError("the pool must lie within VAR0..VAR511")
    return range(low, high + 1)


LOOPBACK = "127.0.0.1"
"""The host of an address that names only a port (`1502`, `:1502`)."""


def parse_address(text: str, default_port: int | None = 502, *,
                  any_port: bool = False) -> tuple[str, int]:
    """One convention for every `--tcp` option and `tcp =` key: `HOST:PORT`, `PORT` alone (a
    bare number is a port, never a host name; the host is 127.0.0.1, as for `:PORT`),
    `HOST` (the command's `default_port`; None: the port must be given), `[IPv6]:PORT` or a
    bare IPv6 address. `any_port` admits port 0 (a server's "any free port"). ValueError with
    a hint otherwise."""
    low = 0 if any_port else 1
    if default_port is None:
        forms = "write PORT or HOST:PORT (a bare number is a port on 127.0.0.1), e.g. 2087"
    else:
        forms = f"write HOST:PORT, PORT (on 127.0.0.1) or HOST (port {default_port}), e.g. " \
            f"192.168.0.16:{default_port}"
    host, port_text = text, ""
    if text.isdigit():
        host, port_text = "", text
    elif text.startswith("["):
        host, closed, rest = text[1:].partition("]")
        if not closed or (rest and not rest.startswith(":")):
            raise ValueError(f"{text!r}: {forms}")
        port_text = rest[1:]
    elif text.count(":") == 1:
        host, port_text = text.split(":")
        if not port_text:
            raise ValueError(f"{text!r}: {forms}")
    # no colon: a host name; two or more (outside brackets): a bare IPv6 address
    if not port_text:
        if default_port is None:
            raise ValueError(f"{text!r}: {forms}")
        port = default_port
    elif not port_text.isdigit() or not port_text.isascii():
        raise ValueError(f"{text!r}: {forms}")
    else:
        port = int(port_text)
    if not low <= port <= 65535:
        raise ValueError(f"{text!r}: the port must be in {low}..65535")
    if host.strip() != host or (text.startswith("[") and not host):
        raise ValueError(f"{text!r}: {forms}")
    return host or LOOPBACK, port


def _pins(table: Mapping[str, Any], where: _Locator) -> tuple[SlotPin, ...]:
    pins: list[SlotPin] = []
    taken: dict[tuple[str, int], str] = {}
    for name, value in table.items():
        match = SLOT_TEXT.fullmatch(value.strip()) if isinstance(value, str) else None
        if match is None:
            raise where.error("slots", name, f"write the slot as \"MP3\" or \"ISR2\", not "
                              f"{value!r}")
        kind, slot = match.group(1).lower(), int(match.group(2))
        if (kind, slot) in taken:
            raise where.error("slots", name, f"{kind.upper()}{slot} is also the pin of "
                              f"{taken[(kind, slot)]}")
        taken[(kind, slot)] = name
        pins.append(SlotPin(name, kind, slot, where.span("slots", name)))
    return tuple(pins)


def _controller(value: object, table: str, where: _Locator) -> str:
    """A `target =` value: one of known_targets()."""
    if not isinstance(value, str) or value not in known_targets():
        raise where.error(table, "target", f"must be one of {describe_targets()}, "
                          f"not {value!r}")
    return value


def _device_controller(raw: Mapping[str, Any], table: str, where: _Locator) -> str | None:
    """The `target` of a [targets.NAME] device, checked against what that controller can be
    reached by and what it takes."""
    if "target" not in raw:
        return None
    target = _controller(raw["target"], table, where)
    family = family_of_target(target)
    assert family is not None  # a known target
    title = family.TITLE
    transports = family.TRANSPORTS
    if not transports:
        raise where.error(table, "target", f"{target}: {family.NO_TRANSPORT}, so a "
                          f"{title} program is not a device to flash")
    if "tcp" in raw and "tcp" not in transports:
        raise where.error(table, "tcp", f"a {title} device ({target}) is reached over a "
                          "serial line: give serial = \"PORT\"")
    for key in MODBUS_ONLY_KEYS:
        if key in raw and family.PROTOCOL != "modbus":
            raise where.error(table, key, f"does not apply to a {title} device ({target}): "
                              f"it is for M8194H devices")
    return target


def _target(name: str, raw: object, root: Path, where: _Locator) -> Target:
    table = f"targets.{name}"
    if not isinstance(raw, dict):
        raise where.error("targets", name, "must be a table: [targets.NAME]")
    _check_keys(raw, TARGET_KEYS, table, where)
    if ("tcp" in raw) == ("serial" in raw):
        raise where.error(table, None, "give the device as tcp = \"HOST[:PORT]\" or "
                          "serial = \"PORT\" (one of them)")
    controller = _device_controller(raw, table, where)
    host: str | None = None
    port = 502
    serial: str | None = None
    if "tcp" in raw:
        if not isinstance(raw["tcp"], str):
            raise where.error(table, "tcp", "must be a string \"HOST[:PORT]\"")
        try:
            host, port = parse_address(raw["tcp"])
        except ValueError as exc:
            raise where.error(table, "tcp", str(exc)) from None
    else:
        if not isinstance(raw["serial"], str) or not raw["serial"]:
            raise where.error(table, "serial", "must be the serial port, e.g. \"/dev/ttyUSB0\" "
                              "or \"COM3\"")
        serial = raw["serial"]
    parity = raw.get("parity", "N")
    if parity not in ("N", "E", "O"):
        raise where.error(table, "parity", f"must be \"N\", \"E\" or \"O\", not {parity!r}")
    sources: tuple[Path, ...] = ()
    image: Path | None = None
    if "sources" in raw and "image" in raw:
        raise where.error(table, "image", "give sources or an image, not both")
    if "sources" in raw:
        sources = _expand(_string_list(raw["sources"], table, "sources", where), root, table,
                          "sources", where)
    if "image" in raw:
        if not isinstance(raw["image"], str) or not raw["image"]:
            raise where.error(table, "image", "must be the path of an image JSON")
        image = root / raw["image"]
    return Target(
        name=name, host=host, port=port, serial=serial,
        unit=_int(raw.get("unit", 1), 1, 247, table, "unit", where),
        baud=_int(raw.get("baud", 115200), 50, 4_000_000, table, "baud", where),
        parity=parity,
        stopbits=_int(raw.get("stopbits", 1), 1, 2, table, "stopbits", where),
        timeout=None if "timeout" not in raw else
        _number(raw["timeout"], 0.01, 60, table, "timeout", where),
        retries=None if "retries" not in raw else
        _int(raw["retries"], 0, 100, table, "retries", where),
        sources=sources, image=image,
        word_order=None if "word-order" not in raw else
        _int(raw["word-order"], 0, 1, table, "word-order", where),
        span=where.span(table), target=controller)


def _targets(data: Mapping[str, Any], root: Path, where: _Locator) -> dict[str, Target]:
    table = _table(data, "targets", where)
    return {name: _target(name, raw, root, where) for name, raw in table.items()}


def load_project(path: Path) -> Project:
    """Read and check `mpc.toml`. Sources must exist when listed; ProjectError otherwise."""
    data, where = _read(path)
    root = path.parent
    for name in data:
        if name not in SECTIONS:
            raise ProjectError(f"{path}:{where.line(name)}: unknown table [{name}]; expected "
                               f"{', '.join(f'[{s}]' for s in sorted(SECTIONS))}")
    project = _table(data, "project", where)
    _check_keys(project, PROJECT_KEYS, "project", where)
    sources: tuple[Path, ...] = ()
    if "sources" in project:
        sources = _expand(_string_list(project["sources"], "project", "sources", where), root,
                          "project", "sources", where)
    target = None if "target" not in project else \
        _controller(project["target"], "project", where)
    temps: range | None = None
    if "temp-vars" in project:
        try:
            temps = parse_temps(str(project["temp-vars"]))
        except ValueError as exc:
            raise where.error("project", "temp-vars", str(exc)) from None
    pool: range | None = None
    if "var-pool" in project:
        try:
            pool = parse_temps(str(project["var-pool"]))
        except ValueError as exc:
            raise where.error("project", "var-pool", str(exc)) from None
    flash = _table(data, "flash", where)
    _check_keys(flash, FLASH_KEYS, "flash", where)
    record = flash.get("record", DEFAULT_RECORD)
    if not isinstance(record, str) or not record:
        raise where.error("flash", "record", "must be a file path")
    refusal = write_refusal(root, record)
    if refusal is not None:  # refused by the command that would write it, not here
        refusal = str(where.error("flash", "record", refusal))
    identity = flash.get("identity")
    if identity is not None and identity is not False and not isinstance(identity, str):
        raise where.error("flash", "identity", "must be a machine-data range such as "
                          "\"MD960-MD1023\", or false to never write the build manifest")
    fmt = _table(data, "fmt", where)
    return Project(
        path=path, sources=sources, target=target, sources_line=where.line("project", "sources"),
        word_order=None if "word-order" not in project else
        _int(project["word-order"], 0, 1, "project", "word-order", where),
        temp_vars=temps,
        var_pool=pool,
        allow_outside_includes=None if "allow-outside-includes" not in project else
        _bool(project["allow-outside-includes"], "project", "allow-outside-includes", where),
        werror=None if "werror" not in project else
        _bool(project["werror"], "project", "werror", where),
        pins=_pins(_table(data, "slots", where), where),
        targets=_targets(data, root, where),
        flash=FlashSettings(
            record=root / record, record_refusal=refusal,
            timeout=None if "timeout" not in flash else
            _number(flash["timeout"], 0.01, 60, "flash", "timeout", where),
            retries=None if "retries" not in flash else
            _int(flash["retries"], 0, 100, "flash", "retries", where),
            set_word_order=_bool(flash.get("set-word-order", False), "flash",
                                 "set-word-order", where),
            identity=identity,
            identity_where=f"{path}:{where.line('flash', 'identity')}: [flash] identity"),
        fmt=dict(fmt), ignore=_ignore(data, where), machine="machine" in data)


def _ignore(data: Mapping[str, Any], where: _Locator) -> frozenset[str]:
    """`[lint] ignore = ["W102", ...]`: known warning codes. Errors cannot be ignored (the
    device would refuse the program), as with `# mpc: ignore` on a line."""
    from mplang.lang.rules import RULES
    from mplang.lang.severity import Severity

    table = _table(data, "lint", where)
    _check_keys(table, LINT_KEYS, "lint", where)
    value = table.get("ignore", [])
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise where.error("lint", "ignore", "must be a list of warning codes, e.g. "
                          "[\"W102\", \"W107\"]")
    codes = frozenset(v.strip().upper() for v in value)
    for code in sorted(codes):
        rule = RULES.get(code)
        if rule is None:
            warnings = sorted(c for c, r in RULES.items() if r.severity is Severity.WARNING)
            raise where.error("lint", "ignore", f"{code!r} is no check code; the warnings "
                              f"are {', '.join(warnings)} (docs/checks/)")
        if rule.severity is not Severity.WARNING:
            raise where.error("lint", "ignore", f"{code} is an error, and errors cannot be "
                              "ignored (the controller would refuse the program): fix it")
    return codes


def load_fleet(path: Path) -> list[Target]:
    """The `[targets.NAME]` tables of a fleet file (an mpc.toml serves as one too), in file
    order. ProjectError if there are none or one is malformed."""
    data, where = _read(path)
    targets = _targets(data, path.parent, where)
    if not targets:
        raise ProjectError(f"{path}: no devices: a fleet file lists [targets.NAME] tables")
    return list(targets.values())


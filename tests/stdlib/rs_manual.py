"""The RS-M8194H API manual's (v3.1) tables that the command catalogue is checked against.

The manual is not part of the repository: it lies in `shared/manuals/` beside it (or in
the directory `MPLANG_MANUALS` names), where a clone may not have it. So what the catalogue
tests need from it is extracted once into `tests/data/rs-manual-tables.json`, each row with
the manual's line number, and the tests run from that table in every clone. Where the
manual is, `test_catalogue.py::test_the_stored_tables_are_the_manual_s` extracts them again
and compares, so the table cannot drift from the manual. A clone without the manuals
beside it skips that one test (saying so); a directory named by MPLANG_MANUALS that does not
hold the manual fails it, since whoever named it meant the re-read to run.

The manual is parsed with regular expressions over its tab-separated tables and its C
prototypes. Regenerate the table after a change to the parsing or to the catalogue's
example lines with:  python tests/stdlib/rs_manual.py
"""

from __future__ import annotations

import json
import os
import re
import sys
import tomllib
from functools import cache
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve()
REPO = HERE.parents[2]
# where the manuals are: the directory $MPLANG_MANUALS names, else shared/manuals beside the
# repository (as .ci/run has them)
MANUALS = Path(os.environ.get("MPLANG_MANUALS") or REPO.parent / "shared/manuals")
MANUAL = MANUALS / "001_404865bff90dda3e.txt"
CATALOGUE = REPO / "stdlib/m8194h/commands.toml"
TABLES = REPO / "tests/data/rs-manual-tables.json"
FORMAT = "mplang-rs-manual-tables/1"

# the window after a prototype in which a VAR operand's range is written (9.x sections)
VAR_WINDOW = 60
VAR_DOCUMENTED = re.compile(r"VAR0 ~ VAR511|use VARn")


def _block(lines: list[str], start_pat: str, end_pat: str) -> list[tuple[int, str]]:
    start = next(i for i, text in enumerate(lines) if re.search(start_pat, text))
    end = next(i for i in range(start + 1, len(lines)) if re.search(end_pat, lines[i]))
    return [(i + 1, lines[i]) for i in range(start, end)]


def table1(lines: list[str]) -> dict[str, dict[str, Any]]:
    """Table 1 (RS ~366-666): section, scope (RTC, MP, ISR, IT cells) and xN line cost."""
    rows = {}
    row_re = re.compile(r"^(\d+(?:\.\d+)*)\t(RSM_\w+)\t([^\t]*)\t([^\t]*)\t([^\t]*)\t([^\t]*)$")
    start, end = r"^Table 1: Command types and command scope", r"^1\.3 API Command Modbus Setup"
    for no, line in _block(lines, start, end):
        m = row_re.match(line.rstrip("\r"))
        if not m:
            continue
        cells = m.group(3, 4, 5, 6)
        scope = [s for s, c in zip(("rtc", "mp", "isr", "it"), cells, strict=True) if c.strip()]
        costs = {int(x) for c in cells for x in re.findall(r"x(\d)", c)}
        assert len(costs) <= 1, line
        cost = costs.pop() if costs else 1
        rows[m.group(2)] = dict(section=m.group(1), scope=scope, cost=cost, line=no)
    return rows


def appendix(lines: list[str]) -> list[dict[str, Any]]:
    """Appendix table 21 (RS ~11502-11820): section, name, sub-function code, registers."""
    rows = []
    row_re = re.compile(r"^(\d+(?:\.\d+)*)\t(RSM_\w+)\t(\S+)\t(\S+)\t(\S+)\s*$")
    start, end = r"^Appendix table 21: Sub Function Code mapping table", r"^12\.4 MODBUS Coil Table"
    for no, line in _block(lines, start, end):
        m = row_re.match(line)
        if not m:
            continue
        hexcode, deccode, regs = m.group(3, 4, 5)
        code = int(hexcode, 16) if hexcode.lower().startswith("0x") else None
        if code is not None:
            assert int(deccode) == code, f"hex/dec columns disagree at RS {no}"
        rows.append(dict(section=m.group(1), name=m.group(2), code=code,
                         registers=int(regs) if regs.isdigit() else None, line=no))
    return rows


def rvar_list(lines: list[str]) -> dict[str, Any]:
    """Commands whose result SET_RVAR reads (9.3.2, RS ~10183-10195)."""
    marker = "reads the return values of the following commands"
    start = next(i for i, text in enumerate(lines) if marker in text)
    names = []
    for text in lines[start + 1:]:
        if text.startswith("Category"):
            break
        m = re.match(r"^\s*-\s*(RSM_\w+)\s*$", text)
        if m:
            names.append(m.group(1))
    return dict(line=start + 1, names=names)


def prototypes(lines: list[str]) -> dict[str, dict[str, Any]]:
    """name -> the first C prototype's line, its (type, param, is_pointer) arguments, and
    whether the text after it gives a VAR operand's range."""
    text = [re.sub(r"<[^>]+>", "", raw) for raw in lines]
    head = re.compile(r"(?:eRTU|HANDLE|WORD|eCOM_PORT)\**\s+\**(RSM_\w+?)\**\s*\(")
    protos: dict[str, dict[str, Any]] = {}
    for i, line in enumerate(text):
        for m in head.finditer(line):
            name = m.group(1)
            if name in protos:
                continue
            rest, j = line[m.end():], i
            while ")" not in rest:
                j += 1
                rest += " " + text[j]
            args = []
            for raw in rest[:rest.index(")")].split(","):
                a = re.sub(r"\*\*(\w+)\*\*", r"\1", raw.strip())
                a = re.sub(r"\*(\w+)\*", r"\1", a)
                if not a or a == "void":
                    continue
                typ, pname = re.findall(r"\w+", a)
                args.append([typ, pname, "*" in a])
            window = "\n".join(lines[i:i + VAR_WINDOW + 1])
            protos[name] = dict(line=i + 1, args=args,
                                var_documented=bool(VAR_DOCUMENTED.search(window)))
    return protos


def example_lines(lines: list[str], catalogue: list[dict[str, Any]]) -> dict[str, str]:
    """The text of every line the catalogue names as a command's worked example."""
    wanted = sorted({c["lines"]["example"] for c in catalogue if c["lines"].get("example")})
    return {str(no): lines[no - 1].rstrip("\r") for no in wanted}


def extract(manual: Path = MANUAL, catalogue_path: Path = CATALOGUE) -> dict[str, Any]:
    """Every table the catalogue tests read, from the manual itself."""
    lines = manual.read_text(encoding="utf-8").split("\n")
    with catalogue_path.open("rb") as fh:
        catalogue = tomllib.load(fh)["command"]
    return {
        "format": FORMAT,
        "manual": f"shared/manuals/{manual.name}",
        "table1": table1(lines),
        "appendix": appendix(lines),
        "rvar": rvar_list(lines),
        "prototypes": prototypes(lines),
        "examples": example_lines(lines, catalogue),
    }


def render(tables: dict[str, Any]) -> str:
    """The stored form: stable key order and one row per line, so diffs stay readable."""
    def row(value: Any) -> str:
        return json.dumps(value, sort_keys=True, ensure_ascii=False)

    parts = []
    for key in sorted(tables):
        value = tables[key]
        if isinstance(value, list) and value:
            body = ",\n".join(f"  {row(v)}" for v in value)
            parts.append(f" {row(key)}: [\n{body}\n ]")
        elif isinstance(value, dict) and value and key != "rvar":
            body = ",\n".join(f"  {row(k)}: {row(value[k])}" for k in sorted(value))
            parts.append(f" {row(key)}: {{\n{body}\n }}")
        else:
            parts.append(f" {row(key)}: {row(value)}")
    return "{\n" + ",\n".join(parts) + "\n}\n"


def absent() -> str | None:
    """Why the manual cannot be read again (None: it is there)."""
    if MANUAL.is_file():
        return None
    return (f"the manual is not at {MANUAL} (shared/manuals beside the repository, or the "
            "directory MPLANG_MANUALS names)")


def required() -> bool:
    """Whether the manual must be there: when MPLANG_MANUALS names its directory. A clone
    without shared/ beside it is a supported way to run the suite (the checks then run from
    the stored table), so the default location may be missing; a named one may not."""
    return bool(os.environ.get("MPLANG_MANUALS"))


@cache
def stored() -> dict[str, Any]:
    """The extracted tables as committed in tests/data."""
    tables: dict[str, Any] = json.loads(TABLES.read_text(encoding="utf-8"))
    assert tables["format"] == FORMAT, f"{TABLES}: unknown format {tables['format']!r}"
    return tables


def main() -> int:
    why = absent()
    if why is not None:
        print(f"rs_manual: {why}", file=sys.stderr)
        return 1
    TABLES.write_text(render(extract()), encoding="utf-8")
    print(f"wrote {TABLES.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

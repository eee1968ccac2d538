"""`make bench`: every bench script in turn, each one's prose as it prints it, then one
summary of the target rows they printed (lines of the fixed shape
`ROW <name> <figure> <target> met|MISSED`, bench/README.md), in the order of issue 28's table,
with a row no script printed named as such. `bench/run.py [SCRIPT...]` runs the scripts named
(`flash`, `compile.py`, ...; default: all).

Figures are printed, never asserted: the exit status is non-zero only when a script itself
failed. The scripts run as an installed mpc runs, with Python's bytecode cache on.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCRIPTS = ("compile.py", "lsp.py", "interp.py", "modbus.py", "flash.py", "soak.py")
ROW = re.compile(r"^ROW (\S+) (\S+) (\S+) (met|MISSED)\s*$")
TABLE = (  # issue 28's rows: the name each script prints, and which script measures it
    ("full-device-compile", "compile.py"),
    ("build-after-edit", "compile.py"),
    ("lint-512", "compile.py"),
    ("lsp-512", "lsp.py"),
    ("lsp-512-syntax-error", "lsp.py"),
    ("lsp-512-semantic-tokens", "lsp.py"),
    ("lsp-full-device", "lsp.py"),
    ("lsp-full-device-syntax-error", "lsp.py"),
    ("lsp-full-device-semantic-tokens", "lsp.py"),
    ("interp-4axis", "interp.py"),
    ("flash-tcp", "flash.py"),
    ("flash-rtu-115200", "flash.py"),
    ("fleet-20", "flash.py"),
    ("fleet-100", "flash.py"),
)


@dataclass
class Row:
    name: str
    figure: str
    target: str
    verdict: str
    script: str


def run(script: str) -> tuple[int, list[Row]]:
    """Run one script, passing its output on line by line; its exit status and ROW lines."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    print(f"== bench/{script}", flush=True)
    rows: list[Row] = []
    with subprocess.Popen([sys.executable, str(HERE / script)], stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, env=env) as proc:
        assert proc.stdout is not None
        for line in proc.stdout:
            print(line, end="", flush=True)
            match = ROW.match(line)
            if match:
                name, figure, target, verdict = match.groups()
                rows.append(Row(name, figure, target, verdict, script))
    return proc.returncode, rows


def summary(rows: list[Row], ran: list[str], failed: dict[str, int]) -> list[str]:
    """The table's rows in its order (then any other ROW printed), each with its figure,
    target and verdict; a row of a script that ran but printed none says so."""
    by_name = {row.name: row for row in rows}
    known = {name for name, _ in TABLE}
    lines: list[tuple[str, ...]] = [("ROW", "FIGURE", "TARGET", "RESULT", "SCRIPT")]
    for name, script in TABLE:
        row = by_name.get(name)
        if row is not None:
            lines.append((name, row.figure, row.target, row.verdict, f"bench/{script}"))
        elif script in ran:
            why = f"failed (exit {failed[script]})" if script in failed else "no ROW line"
            lines.append((name, "-", "-", why, f"bench/{script}"))
    lines += [(row.name, row.figure, row.target, row.verdict, f"bench/{row.script}")
              for row in rows if row.name not in known]
    widths = [max(len(line[i]) for line in lines) for i in range(len(lines[0]))]
    text = ["  ".join(cell.ljust(width) for cell, width in zip(line, widths, strict=True))
            .rstrip() for line in lines]
    met = sum(1 for row in rows if row.verdict == "met")
    return ["== summary", *text, f"{met} of {len(rows)} target(s) met"]


def main(names: list[str]) -> int:
    chosen = [name if name.endswith(".py") else f"{name}.py" for name in names] or list(SCRIPTS)
    unknown = [name for name in chosen if name not in SCRIPTS]
    if unknown:
        print(f"usage: bench/run.py [{' '.join(SCRIPTS)}] (not: {', '.join(unknown)})",
              file=sys.stderr)
        return 2
    rows: list[Row] = []
    ran: list[str] = []
    failed: dict[str, int] = {}
    for script in chosen:
        if not (HERE / script).exists():
            print(f"== bench/{script}: not in this tree, skipped", flush=True)
            continue
        status, found = run(script)
        ran.append(script)
        rows += found
        if status != 0:
            failed[script] = status
    print("\n".join(summary(rows, ran, failed)))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Mutation testing of the modules that guard correctness (`make mutate`), with mutmut.

mutmut reads its settings from the `[tool.mutmut]` table of the pyproject.toml in the
directory it runs in, and runs the tests there (in a copy, `mutants/`). One table cannot
say "this module against these tests", so each group of `[tool.mplang.mutation.groups]` in
the repository's pyproject.toml gets a directory of its own, build/mutation/GROUP/: links
to the source, the tests and the data files, and a pyproject.toml that is the repository's
plus a `[tool.mutmut]` table naming the group's modules and its own test files. Each group
is run and cached there, apart from the others: mutmut keeps every mutant's result in
`mutants/`, and a group whose modules and tests are unchanged since its last complete run
is not run again at all.

A group may name mutant patterns (`functions`): only those functions of a large module are
mutated, the ones that hold its checks. docs/testing.md says what each group covers and
why each surviving mutant is equivalent or harmless.

    python -m mplang.tools.mutate [GROUP ...]      run (all groups by default), then report
    python -m mplang.tools.mutate --report         only report the stored results
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tomllib
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
WORK = ROOT / "build" / "mutation"

# mutmut's exit codes of a mutant's test run (mutmut/stats.py), by what they mean here
STATUS = {1: "killed", 3: "killed", 37: "killed", 0: "survived", 5: "no tests",
          33: "no tests", 34: "skipped", 36: "timeout", 24: "timeout", -24: "timeout",
          152: "timeout", 255: "timeout", -9: "timeout", None: "not run"}


@dataclass(frozen=True)
class Group:
    """Modules mutated against their own tests."""

    name: str
    modules: tuple[str, ...]
    tests: tuple[str, ...]
    functions: tuple[str, ...]  # mutant name patterns; empty: every function

    @property
    def work(self) -> Path:
        return WORK / self.name


def load_groups(pyproject: Path = ROOT / "pyproject.toml") -> tuple[dict[str, Any],
                                                                    list[Group]]:
    """The common settings and the groups, in file order."""
    with pyproject.open("rb") as fh:
        table = tomllib.load(fh)["tool"]["mplang"]["mutation"]
    groups = [Group(name, tuple(g["modules"]), tuple(g["tests"]), tuple(g.get("functions", ())))
              for name, g in table["groups"].items()]
    return table, groups


def _toml_list(values: list[str] | tuple[str, ...]) -> str:
    return json.dumps(list(values))  # a JSON list of strings is a TOML array


def prepare(group: Group, common: dict[str, Any]) -> None:
    """build/mutation/GROUP: links to the tree, and the pyproject mutmut reads."""
    group.work.mkdir(parents=True, exist_ok=True)
    for name in ["mplang", "tests", *common["also_copy"]]:
        link = group.work / name
        if not link.is_symlink():
            link.symlink_to(os.path.relpath(ROOT / name, group.work))
    table = "\n".join([
        "", "[tool.mutmut]",
        'source_paths = ["mplang"]',
        f"only_mutate = {_toml_list(group.modules)}",
        f"also_copy = {_toml_list(common['also_copy'])}",
        f"pytest_add_cli_args_test_selection = {_toml_list(group.tests)}",
        f"pytest_add_cli_args = {_toml_list(common['pytest_args'])}",
        # mutmut's own figures (15 x the tests' time, + 1 s): loaded CI machines need more
        f"timeout_multiplier = {float(common['timeout_multiplier'])}",
        ""])
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8") + table
    target = group.work / "pyproject.toml"
    if not target.exists() or target.read_text(encoding="utf-8") != text:
        target.write_text(text, encoding="utf-8")


def fingerprint(group: Group, common: dict[str, Any]) -> str:
    """What a group's results depend on, a line each: its modules and settings (a change
    makes mutmut start afresh), then the contents of its test files."""
    # the common settings without the groups table: editing one group restarts only that one
    settings = {key: value for key, value in common.items() if key != "groups"}
    sources = hashlib.sha256(repr(group).encode() + json.dumps(settings, sort_keys=True).encode())
    tests = hashlib.sha256()
    for digest, paths in ((sources, group.modules),
                          (tests, {*(t.split("::")[0] for t in group.tests), "tests/conftest.py"})):
        for path in sorted(paths):
            digest.update(path.encode() + b"\0" + (ROOT / path).read_bytes())
    return f"{sources.hexdigest()}\n{tests.hexdigest()}"


def results(group: Group) -> dict[str, dict[str, int | None]]:
    """module path -> {mutant name: mutmut exit code}, for the group's patterns."""
    from fnmatch import fnmatch

    found = {}
    for module in group.modules:
        meta = group.work / "mutants" / (module + ".meta")
        if not meta.is_file():
            continue
        codes = json.loads(meta.read_text(encoding="utf-8"))["exit_code_by_key"]
        found[module] = {name: code for name, code in sorted(codes.items())
                         if not group.functions or any(fnmatch(name, p)
                                                       for p in group.functions)}
    return found


def run(group: Group, common: dict[str, Any]) -> int:
    """mutmut over one group, unless its results are complete and up to date."""
    prepare(group, common)
    done, started = group.work / "fingerprint", group.work / "started"
    current = fingerprint(group, common)
    codes = {name: code for found in results(group).values() for name, code in found.items()}
    pending = [name for name, code in codes.items() if code is None]
    last = done.read_text() if done.is_file() else ""
    if last == current and not pending:
        print(f"{group.name}: up to date")
        return 0
    # mutmut runs named mutants again even when it has their result, and only those. So:
    # resuming an unfinished run of unchanged code, name the mutants still to run; after a
    # change of the tests' contents alone, name the ones no test killed yet (a killed mutant
    # stays killed when tests are added); after a change of the modules or of the settings
    # (mutmut itself drops every result when the test selection changes), the group's
    # patterns (or nothing: mutmut keeps the results of unchanged functions) start afresh.
    if started.is_file() and started.read_text() == current and pending:
        names = pending
    elif last and last.split("\n")[0] == current.split("\n")[0]:
        names = [name for name, code in codes.items() if STATUS.get(code) != "killed"]
        # which tests reach which function was recorded with the old tests: a new test
        # that reaches a survivor's function would not be run against it
        (group.work / "mutants" / "mutmut-stats.json").unlink(missing_ok=True)
    else:
        names = []
    started.write_text(current)
    mutmut = Path(sys.executable).parent / "mutmut"
    command = [str(mutmut), "run", "--max-children", str(common["max_children"]),
               *(names or group.functions)]
    print(f"{group.name}: {' '.join(command[1:4])} ({len(names) or 'all'} mutants) "
          f"against {' '.join(group.tests)}", flush=True)
    with (group.work / "run.log").open("w", encoding="utf-8") as log:
        code = subprocess.run(command, cwd=group.work, stdout=log, stderr=subprocess.STDOUT,
                              check=False).returncode
    if code != 0:
        print(f"{group.name}: mutmut failed (exit {code}); see {group.work / 'run.log'}",
              file=sys.stderr)
        return code
    done.write_text(current)
    return 0


def report(groups: list[Group]) -> str:
    """Kill rate per module and every surviving mutant, as a Markdown table."""
    lines = ["| group | module | mutants | killed | survived | no tests | timeout | not run |"
             " kill rate |", "|---|---|---|---|---|---|---|---|---|"]
    survivors = []
    for group in groups:
        for module, codes in results(group).items():
            count = Counter(STATUS.get(code, "suspicious") for code in codes.values())
            tried = count["killed"] + count["survived"] + count["timeout"]
            rate = f"{100 * (count['killed'] + count['timeout']) / tried:.0f} %" if tried else "-"
            lines.append(f"| {group.name} | {module} | {len(codes)} | {count['killed']} | "
                         f"{count['survived']} | {count['no tests']} | {count['timeout']} | "
                         f"{count['not run']} | {rate} |")
            survivors += [name for name, code in codes.items() if code == 0]
    lines += ["", "Surviving mutants (`mutmut show NAME` in build/mutation/GROUP):", ""]
    lines += [f"- `{name}`" for name in survivors] or ["- none"]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m mplang.tools.mutate",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("groups", nargs="*", help="groups to run (default: all)")
    parser.add_argument("--report", action="store_true", help="only report stored results")
    args = parser.parse_args(argv)
    common, groups = load_groups()
    known = {g.name: g for g in groups}
    unknown = [name for name in args.groups if name not in known]
    if unknown:
        parser.error(f"unknown group(s) {', '.join(unknown)}; groups: {', '.join(known)}")
    chosen = [known[name] for name in args.groups] or groups
    failed = 0
    if not args.report:
        for group in chosen:
            failed = run(group, common) or failed
    print(report(chosen))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

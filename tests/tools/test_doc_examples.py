"""Every documented example runs to its documented end (issue 14 item 3): each ```mp block of
docs/*.md is followed by the `mpc run` command that runs it (with the machine file it needs)
and the output it prints, in a ```text block; this test extracts both from the markdown,
runs the command on the example and compares. The samples document their ending in their
header (`# Ends: mpc run ...` and on the next line `#   -> finished, NAME = VALUE, X lp N`),
checked the same way."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import EXIT_OK, main

ROOT = Path(__file__).resolve().parents[2]
FENCE = re.compile(r"^```(\w*)\n(.*?)^```$", re.MULTILINE | re.DOTALL)
ENDS = re.compile(r"^# Ends: (mpc run [^\n]*)\n#\s+-> (finished|FAILED)((?:, [^\n]*)?)$",
                  re.MULTILINE)
AXIS = re.compile(r"([XYZU]) lp (-?\d+)")


def documented_examples() -> list[tuple[str, str, str, str]]:
    """(where, example source, command, documented output) of every ```mp block in docs/."""
    found = []
    for doc in sorted((ROOT / "docs").glob("*.md")):
        text = doc.read_text(encoding="utf-8")
        blocks = list(FENCE.finditer(text))
        for n, block in enumerate(blocks):
            if block.group(1) != "mp":
                continue
            where = f"{doc.relative_to(ROOT)}:{text.count(chr(10), 0, block.start()) + 1}"
            shown = blocks[n + 1] if n + 1 < len(blocks) else None
            if shown is None or shown.group(1) != "text" or \
                    not shown.group(2).startswith("$ mpc run "):
                found.append((where, block.group(2), "", ""))  # fails: no documented end
                continue
            command, _nl, output = shown.group(2).partition("\n")
            found.append((where, block.group(2), command[2:], output))
    return found


EXAMPLES = documented_examples()


def run_in_root(monkeypatch: pytest.MonkeyPatch, args: list[str]) -> tuple[int, str, str]:
    monkeypatch.chdir(ROOT)  # the commands name machine files from the repository's root
    result = CliRunner().invoke(main, args)
    return result.exit_code, result.stdout, result.stderr


def test_the_docs_have_examples() -> None:
    assert len(EXAMPLES) >= 11


@pytest.mark.parametrize(("where", "source", "command", "output"), EXAMPLES,
                         ids=[e[0] for e in EXAMPLES])
def test_a_documented_example_runs_to_its_documented_end(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, where: str, source: str,
        command: str, output: str) -> None:
    assert command, f"{where}: the example is not followed by a ```text block with the " \
        "`$ mpc run ...` command that runs it and what it prints"
    args = shlex.split(command)[2:]
    names = [a for a in args if a.endswith(".mp") and not (ROOT / a).exists()]
    assert len(names) == 1, f"{where}: name the example's file once in {command!r}"
    example = tmp_path / names[0]
    example.write_text(source, encoding="utf-8")
    code, out, err = run_in_root(monkeypatch, ["run", *[str(example) if a == names[0] else a
                                                        for a in args]])
    assert out == output, f"{where}: `{command}` printed\n{out}{err}"
    assert code == (EXIT_OK if "finished after" in output.split("\n", 1)[0] else 5)


def sample_endings() -> list[tuple[str, str, str, str]]:
    """(sample, command, finished or FAILED, ", NAME = VALUE, ...") of every `# Ends:`."""
    found = []
    for sample in sorted((ROOT / "samples").rglob("*")):
        if sample.suffix not in (".mp", ".csim", ".fbs"):
            continue
        for match in ENDS.finditer(sample.read_text(encoding="utf-8")):
            found.append((str(sample.relative_to(ROOT)), match.group(1), match.group(2),
                          match.group(3)))
    return found


SAMPLES = sample_endings()


def test_every_m8194h_sample_program_documents_its_end() -> None:
    documented = {sample for sample, *_rest in SAMPLES}
    programs = [str(p.relative_to(ROOT)) for p in sorted((ROOT / "samples").rglob("*.mp"))
                if re.search(r"^MP\b", p.read_text(encoding="utf-8"), re.MULTILINE)]
    assert programs and [p for p in programs if p not in documented] == []


@pytest.mark.parametrize(("sample", "command", "state", "values"), SAMPLES,
                         ids=[f"{s[0]}:{s[1]}" for s in SAMPLES])
def test_a_sample_runs_to_its_documented_end(monkeypatch: pytest.MonkeyPatch, sample: str,
                                             command: str, state: str, values: str) -> None:
    args = shlex.split(command)[2:]
    assert sample in args, f"{sample}: `# Ends:` runs another file: {command}"
    code, out, err = run_in_root(monkeypatch, ["run", "--json", *args])
    summary = json.loads(out)
    assert (summary["error"] is None) == (state == "finished"), err
    assert code == (EXIT_OK if state == "finished" else 5)
    for pair in filter(None, (p.strip() for p in values.split(","))):
        axis = AXIS.fullmatch(pair)
        if axis is not None:
            assert summary["axes"][axis.group(1)]["lp"] == int(axis.group(2)), \
                f"{sample}: {pair}"
            continue
        name, _eq, value = pair.partition(" = ")
        assert summary["vars"].get(name, 0) == int(value), f"{sample}: {pair}"

"""The Python examples of docs/fatek.md run, and print what the comments after their print
calls say (up to a trailing ' ...' or ' (')."""

from __future__ import annotations

import contextlib
import io
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BLOCKS = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "fatek.md").read_text("utf-8"),
                    re.DOTALL)


def promised(block: str) -> list[str]:
    """The outputs the block's comments promise: after a print call, or on their own line
    right below one (a continuation of its output)."""
    out = []
    previous_printed = False
    for line in block.splitlines():
        code, _, comment = line.partition("# ")
        printing = "print(" in code
        if comment and (printing or (not code.strip() and previous_printed)):
            out.append(re.split(r" \.\.\.| \(", comment)[0].rstrip())
        previous_printed = printing or (previous_printed and not code.strip())
    return out


@pytest.mark.parametrize("block", BLOCKS, ids=[f"example{i}" for i in range(len(BLOCKS))])
def test_the_example_runs_and_prints_what_it_says(block: str) -> None:
    output = io.StringIO()
    here = Path.cwd()
    os.chdir(ROOT)
    try:
        with contextlib.redirect_stdout(output):
            exec(compile(block, "docs/fatek.md", "exec"), {})
    finally:
        os.chdir(here)
    for expected in promised(block):
        assert expected in output.getvalue(), (expected, output.getvalue()[:2000])


def test_the_documentation_has_examples_with_promised_output() -> None:
    assert len(BLOCKS) >= 4
    assert sum(len(promised(b)) for b in BLOCKS) >= 6

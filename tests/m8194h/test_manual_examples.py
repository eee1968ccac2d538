"""The manual's worked macro examples, reproduced register for register.

tests/data/manual_examples.toml holds every "The MODBUS command is listed as follows" table of
chapters 3-9 whose command has a macro form: the equivalent mplang statement(s) and the
registers the manual prints (corrected, with a note, where the print is a known misprint).
Each is compiled as a one-program build and the tested frame compared.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import pytest

from mplang.m8194h.compiler import Options, compile_source

DATA = Path(__file__).resolve().parents[1] / "data" / "manual_examples.toml"
EXAMPLES: list[dict[str, Any]] = tomllib.loads(DATA.read_text())["example"]


def example_id(example: dict[str, Any]) -> str:
    return f"{example['section']}-{example['command']}-RS{example['line']}"


def program_text(example: dict[str, Any]) -> str:
    kind = example.get("program", "mp")
    slot = 151 if kind == "mp" else 19  # roomy slots: the test is about frames, not budgets
    header = f"{kind.upper()} {slot}"
    return f"{header}\n{example['source']}\nEND {kind.upper()}\n"


@pytest.mark.parametrize("example", EXAMPLES, ids=[example_id(e) for e in EXAMPLES])
def test_manual_example(example: dict[str, Any]) -> None:
    # The examples come from the RS manual, so they build for the RS-M8194H (INTP_END).
    result = compile_source(program_text(example), f"{example_id(example)}.mp",
                            Options(target="rs"))
    errors = [d.render() for d in result.diagnostics if d.severity.value == "error"]
    assert not errors, "\n".join(errors)
    (program,) = result.programs
    if example.get("kind") in ("close", "isr_close"):
        frame = program.close
    else:
        frame = program.lines[example.get("frame", 0)].frame
    assert frame == example["registers"], (
        f"RS {example['line']} ({example['section']}): got "
        f"{' '.join(f'{w:04X}' for w in frame)}, manual "
        f"{' '.join(f'{w:04X}' for w in example['registers'])}")


def test_examples_cover_every_macro_command_with_a_printed_frame() -> None:
    commands = {e["command"] for e in EXAMPLES}
    assert len(EXAMPLES) >= 120
    assert {"RSM_MACRO_IF", "RSM_MACRO_FOR", "RSM_MACRO_VAR_CALCULATE",
            "RSM_MACRO_RECTANGLE", "RSM_MACRO_HELIX_3D"} <= commands

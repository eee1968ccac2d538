"""Messages that point the way (issue 26 item 5), through the real `mpc`: an unknown axis gets
an axis hint, an undeclared variable a `VAR name` hint, a misspelt GOTO label or CALL target a
did-you-mean with the caret under the name, E503 for an mpc.toml pin blames the pin's line,
and `mpc status` against a device preloaded by `mpc sim FILE...` (no build manifest) says
`unknown`, not `missing`, for every slot."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from simproc import start_sim

from mplang.cli.commands.status import EXIT_OUT_OF_SYNC
from mplang.cli.common import EXIT_OK, EXIT_SOURCE_ERRORS

SOURCE = """VAR total
MP main
    FIXED_MOVE Q, 1000
    SET_V XW, 2000
    count = 1
    totl = 2
    total = undeclared + 1
    LABEL top
    IF total > 2
        GOTO tpo
    END IF
    CALL mian
END MP
"""


def mpc(cwd: Path, *args: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=120)


def findings(tmp_path: Path) -> dict[int, tuple[str, str, str]]:
    """Line -> (the gcc line, the caret line, the hint) of `mpc lint` on SOURCE."""
    (tmp_path / "hints.mp").write_text(SOURCE)
    done = mpc(tmp_path, "lint", "--isolated", "hints.mp")
    assert done.returncode == EXIT_SOURCE_ERRORS
    found: dict[int, tuple[str, str, str]] = {}
    for block in done.stdout.split("hints.mp:")[1:]:
        lines = block.splitlines()
        number = int(lines[0].split(":")[0])
        hint = next((line.split("hint: ", 1)[1] for line in lines if "hint: " in line), "")
        found[number] = (lines[0], lines[3], hint)
    return found


def caret_under(found: tuple[str, str, str], word: str) -> bool:
    """Whether the carets of an excerpt stand exactly under `word` of its source line."""
    source = SOURCE.splitlines()[int(found[0].split(":")[0]) - 1]
    carets = found[1].split("| ", 1)[1]
    start = source.index(word)
    return carets == " " * start + "^" * len(word)


def test_hints_name_what_to_write(tmp_path: Path) -> None:
    found = findings(tmp_path)
    axis = found[3]
    assert "unknown name 'Q'; FIXED_MOVE axis takes an axis: X, Y, Z, U" in axis[0]
    assert "axis name" in axis[2] and "CONST or ALIAS" not in axis[2].split(", or")[0]
    assert found[4][2] == "did you mean X?"  # XW: the nearest axis name
    assert "`VAR count`" in found[5][2]  # assigning an undeclared name
    assert found[6][2] == "did you mean TOTAL?"  # a declared variable misspelt
    assert "`VAR undeclared`" in found[7][2]  # reading one


def test_goto_and_call_to_a_misspelt_name_suggest_it_under_the_name(tmp_path: Path) -> None:
    found = findings(tmp_path)
    goto, call = found[10], found[12]
    assert "error[E325]: GOTO tpo" in goto[0] and goto[2].startswith("did you mean TOP?")
    assert caret_under(goto, "tpo")
    assert "error[E434]" in call[0] and call[2] == "did you mean MAIN?"
    assert caret_under(call, "mian")


def test_lint_fix_takes_the_label_suggestion(tmp_path: Path) -> None:
    source = tmp_path / "jump.mp"
    source.write_text("MP main\n    LABEL top\n    VAR1 = VAR1 + 1\n    GOTO tpo\nEND MP\n")
    assert mpc(tmp_path, "lint", "--isolated", "--fix", "jump.mp").returncode == EXIT_OK
    assert "    GOTO top\n" in source.read_text()


def test_e503_of_a_pinned_program_blames_the_pin(tmp_path: Path) -> None:
    (tmp_path / "mpc.toml").write_text('[project]\nsources = ["big.mp"]\n\n[slots]\n'
                                       'big = "MP3"\n')
    (tmp_path / "big.mp").write_text("MP big\n" + "    VAR1 = 1\n" * 9 + "END MP\n")
    done = mpc(tmp_path, "lint")
    assert done.returncode == EXIT_SOURCE_ERRORS
    first, *rest = done.stdout.splitlines()
    assert first.startswith("mpc.toml:5:1: error[E503]: MP3 big needs 10 lines")
    assert ' 5 | big = "MP3"' in rest
    assert any(line.startswith("big.mp:1:1: note: the program") for line in rest)
    assert "hint: pin it to a slot in MP41-MP90 (16 lines), remove the pin" in done.stdout
    assert "drop the number" not in done.stdout  # the source has none


def test_status_of_a_preloaded_sim_says_unknown_for_every_slot(tmp_path: Path) -> None:
    (tmp_path / "job.mp").write_text("MP 3 first\n    VAR1 = 1\nEND MP\n\n"
                                     "MP 4 second\n    VAR2 = 2\nEND MP\n")
    proc, port = start_sim(str(tmp_path / "job.mp"), "--duration", "60")
    try:
        text = mpc(tmp_path, "status", "--tcp", f"127.0.0.1:{port}", "job.mp")
        assert text.returncode == EXIT_OUT_OF_SYNC
        assert "unknown: no build manifest to compare with" in text.stdout
        slots = [line.split() for line in text.stdout.splitlines()
                 if line.startswith("  ") and line.split()[0] in ("unknown", "missing")]
        assert slots == [["unknown", "MP3", "first"], ["unknown", "MP4", "second"]]
        data = json.loads(mpc(tmp_path, "status", "--tcp", f"127.0.0.1:{port}", "job.mp",
                              "--json").stdout)
        assert {s["slot"]: s["status"] for s in data["slots"]} == {"MP3": "unknown",
                                                                   "MP4": "unknown"}
    finally:
        proc.terminate()
        proc.wait(10)


def test_plot_past_max_time_exits_as_the_docs_say(tmp_path: Path) -> None:
    """docs/cli.md gives the exit code of `mpc plot` past --max-time; the process agrees."""
    import re

    from mplang.cli.runwatch import EXIT_OUT_OF_TIME

    docs = (Path(__file__).resolve().parents[3] / "docs" / "cli.md").read_text()
    plot = docs.split("## `mpc plot", 1)[1].split("\n## ", 1)[0]
    stated = re.search(r"(\d+) out of\s+`--max-time`", plot)
    assert stated is not None and int(stated.group(1)) == EXIT_OUT_OF_TIME
    (tmp_path / "spin.mp").write_text("MP 1 spin\n    VAR1 = 0\n    LABEL again\n"
                                      "    VAR1 = VAR1 + 1\n    GOTO again\nEND MP\n")
    done = mpc(tmp_path, "plot", "spin.mp", "-o", "spin.png", "--max-time", "0.2",
               "--isolated")
    assert done.returncode == EXIT_OUT_OF_TIME, done.stderr
    assert "error[R202]" in done.stderr and (tmp_path / "spin.png").is_file()

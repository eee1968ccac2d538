"""`mpc fmt` as a user runs it: in place, --check, --diff, standard input, exit codes."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from mplang.cli import (
    EXIT_INTERNAL,
    EXIT_NO_INPUT,
    EXIT_OUTPUT,
    EXIT_SOURCE_ERRORS,
    EXIT_USAGE,
    EXIT_WOULD_REFORMAT,
    main,
)
from mplang.tools import fmt

MESSY = "mp 21 square\nset_v X,2000   # speed\n\n\n  fixed_move X,1000\nend mp\n"
TIDY = "MP 21 square\n    SET_V X, 2000  # speed\n\n    FIXED_MOVE X, 1000\nEND MP\n"
BROKEN = "MP 1\n  SET_V X,, 1\nEND MP\n"


def run(*args: str, stdin: bytes | None = None) -> Result:
    return CliRunner().invoke(main, ["fmt", *args], input=stdin)


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    (tmp_path / "messy.mp").write_text(MESSY)
    (tmp_path / "tidy.mp").write_text(TIDY)
    return tmp_path


def test_fmt_is_listed_in_the_help() -> None:
    result = CliRunner().invoke(main, ["--help"])
    assert result.exit_code == 0 and "fmt" in result.stdout


def test_rewrites_files_in_place_and_leaves_formatted_ones_alone(tree: Path) -> None:
    tidy = tree / "tidy.mp"
    os.utime(tidy, (1_000_000, 1_000_000))
    result = run(str(tree))
    assert result.exit_code == 0, result.stderr
    assert (tree / "messy.mp").read_text() == TIDY
    assert tidy.stat().st_mtime == 1_000_000  # not rewritten
    assert f"reformatted {tree / 'messy.mp'}" in result.stderr
    assert "mpc fmt: 1 file reformatted, 1 unchanged" in result.stderr
    assert result.stdout == ""
    assert sorted(p.name for p in tree.iterdir()) == ["messy.mp", "tidy.mp"]  # no temp files


def test_check_writes_nothing_and_exits_12(tree: Path) -> None:
    result = run("--check", str(tree / "messy.mp"), str(tree / "tidy.mp"))
    assert result.exit_code == EXIT_WOULD_REFORMAT == 12
    assert (tree / "messy.mp").read_text() == MESSY
    assert f"would reformat {tree / 'messy.mp'}" in result.stderr
    assert "tidy.mp" not in result.stderr.replace("1 unchanged", "")
    assert run("--check", str(tree / "tidy.mp")).exit_code == 0


def test_diff_prints_a_unified_diff_and_writes_nothing(tree: Path) -> None:
    messy = tree / "messy.mp"
    result = run("--diff", str(messy))
    assert result.exit_code == 0
    assert messy.read_text() == MESSY
    lines = result.stdout.splitlines()
    assert lines[0] == f"--- {messy}\t(original)"
    assert lines[1] == f"+++ {messy}\t(formatted)"
    assert "-set_v X,2000   # speed" in lines
    assert "+    SET_V X, 2000  # speed" in lines
    assert run("--diff", "--check", str(messy)).exit_code == EXIT_WOULD_REFORMAT


def test_diff_marks_a_missing_final_newline(tmp_path: Path) -> None:
    source = tmp_path / "a.mp"
    source.write_text("CONST A = 1")
    result = run("--diff", str(source))
    assert result.stdout.endswith("-CONST A = 1\n\\ No newline at end of file\n+CONST A = 1\n")


def test_standard_input_to_standard_output_keeps_crlf() -> None:
    result = run("-", stdin=MESSY.replace("\n", "\r\n").encode())
    assert result.exit_code == 0
    assert result.stdout_bytes == TIDY.replace("\n", "\r\n").encode()


def test_standard_input_with_options_check_and_diff() -> None:
    lower = run("-", "--indent", "2", "--keyword-case", "lower", stdin=MESSY.encode())
    assert lower.stdout.splitlines()[:2] == ["mp 21 square", "  set_v X, 2000  # speed"]
    check = run("-", "--check", stdin=MESSY.encode())
    assert (check.exit_code, check.stdout) == (EXIT_WOULD_REFORMAT, "")
    assert "would reformat <stdin>" in check.stderr
    assert run("-", "--check", stdin=TIDY.encode()).exit_code == 0
    diff = run("-", "--diff", stdin=MESSY.encode())
    assert diff.exit_code == 0 and diff.stdout.startswith("--- <stdin>\t(original)\n")


def test_standard_input_with_syntax_errors_prints_nothing_on_stdout() -> None:
    result = run("-", stdin=BROKEN.encode())
    assert result.exit_code == EXIT_SOURCE_ERRORS
    assert result.stdout == ""
    assert "<stdin>:2:11: error[E101]" in result.stderr


def test_standard_input_cannot_be_mixed_with_files(tree: Path) -> None:
    result = run("-", str(tree / "tidy.mp"))
    assert result.exit_code == EXIT_USAGE
    assert "cannot be combined" in result.stderr


def test_syntax_errors_leave_the_file_untouched_and_exit_1(tree: Path) -> None:
    broken = tree / "broken.mp"
    broken.write_text(BROKEN)
    result = run(str(tree))
    assert result.exit_code == EXIT_SOURCE_ERRORS
    assert broken.read_text() == BROKEN
    assert (tree / "messy.mp").read_text() == TIDY  # the others are still formatted
    assert f"{broken}:2:11: error[E101]: unexpected ','" in result.stderr
    assert f"mpc: error: {broken} has syntax errors; left as it is" in result.stderr
    assert "1 with errors left as they are" in result.stderr


def test_syntax_errors_outrank_would_reformat(tree: Path) -> None:
    (tree / "broken.mp").write_text(BROKEN)
    assert run("--check", str(tree)).exit_code == EXIT_SOURCE_ERRORS


def test_text_that_is_not_utf8_is_a_source_error(tmp_path: Path) -> None:
    latin = tmp_path / "latin.mp"
    latin.write_bytes(b"# caf\xe9\nCONST A = 1\n")
    result = run(str(latin))
    assert result.exit_code == EXIT_SOURCE_ERRORS
    assert f"{latin}:1:1: error[E105]: {latin} is not UTF-8 text" in result.stderr
    assert latin.read_bytes() == b"# caf\xe9\nCONST A = 1\n"


def test_missing_input_exits_3(tmp_path: Path) -> None:
    result = run(str(tmp_path / "nothere.mp"))
    assert result.exit_code == EXIT_NO_INPUT
    assert "no such file" in result.stderr


def test_unreadable_file_exits_3_after_the_others(tree: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    unreadable = tree / "tidy.mp"
    real_read = Path.read_bytes

    def read_bytes(self: Path) -> bytes:
        if self == unreadable:
            raise PermissionError(13, "Permission denied")
        return real_read(self)

    monkeypatch.setattr(Path, "read_bytes", read_bytes)
    result = run(str(tree))
    assert result.exit_code == EXIT_NO_INPUT
    assert f"mpc: error: cannot read {unreadable}: Permission denied" in result.stderr
    assert (tree / "messy.mp").read_text() == TIDY


def test_unwritable_file_exits_4_and_keeps_the_original(tree: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(_source: object, _target: object) -> None:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(os, "replace", refuse)
    result = run(str(tree / "messy.mp"))
    assert result.exit_code == EXIT_OUTPUT
    assert f"mpc: error: cannot write {tree / 'messy.mp'}: Permission denied" in result.stderr
    assert (tree / "messy.mp").read_text() == MESSY
    assert sorted(p.name for p in tree.iterdir()) == ["messy.mp", "tidy.mp"]  # temp removed


def test_permissions_and_symlinks_survive_the_rewrite(tree: Path) -> None:
    messy = tree / "messy.mp"
    messy.chmod(0o640)
    link = tree / "link.mp"
    link.symlink_to(messy)
    assert run(str(link)).exit_code == 0
    assert link.is_symlink() and messy.read_text() == TIDY
    assert stat.S_IMODE(messy.stat().st_mode) == 0o640


def test_globs_are_expanded(tree: Path) -> None:
    result = run(str(tree / "m*.mp"))
    assert result.exit_code == 0
    assert (tree / "messy.mp").read_text() == TIDY


@pytest.mark.parametrize(("option", "value"), [("--indent", "0"), ("--indent", "x"),
                                               ("--keyword-case", "title")])
def test_bad_options_exit_2(tree: Path, option: str, value: str) -> None:
    result = run(option, value, str(tree))
    assert result.exit_code == EXIT_USAGE
    assert (tree / "messy.mp").read_text() == MESSY


def test_a_formatter_bug_is_an_internal_error_not_a_changed_file(
        tree: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(*_args: object, **_kwargs: object) -> str:
        raise fmt.FormatterBug("the formatted text does not hold the same tokens")

    monkeypatch.setattr(fmt, "format_source", broken)
    result = run(str(tree / "messy.mp"))
    assert result.exit_code == EXIT_INTERNAL
    assert "internal error: FormatterBug" in result.stderr
    assert "Traceback" not in result.stderr + result.stdout
    assert (tree / "messy.mp").read_text() == MESSY


def test_command_line_settings_override_a_project_table() -> None:
    from mplang.cli.commands.fmt import _options

    base = fmt.FormatOptions.from_mapping({"indent": 2, "keyword-case": "lower"})
    assert _options(None, None, base) == base
    assert _options(8, None, base) == fmt.FormatOptions(indent=8, keyword_case="lower")
    assert _options(None, "upper", base) == fmt.FormatOptions(indent=2, keyword_case="upper")


def test_project_file_gives_sources_and_options(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """Without FILE, mpc fmt formats the sources of mpc.toml with its [fmt] options; options
    on the command line win, and a bad [fmt] key names the file."""
    (tmp_path / "job.mp").write_text("MP 1 job\nVAR1=1\nEND MP\n")
    (tmp_path / "mpc.toml").write_text('[project]\nsources = ["job.mp"]\n[fmt]\nindent = 2\n')
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    assert runner.invoke(main, ["fmt"]).exit_code == 0
    assert (tmp_path / "job.mp").read_text() == "MP 1 job\n  VAR1 = 1\nEND MP\n"
    assert runner.invoke(main, ["fmt", "--indent", "3"]).exit_code == 0
    assert (tmp_path / "job.mp").read_text() == "MP 1 job\n   VAR1 = 1\nEND MP\n"
    (tmp_path / "mpc.toml").write_text('[project]\nsources = ["job.mp"]\n[fmt]\nwidth = 2\n')
    bad = runner.invoke(main, ["fmt"])
    assert bad.exit_code == 3 and "mpc.toml" in bad.output

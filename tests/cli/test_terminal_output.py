"""Terminal output like rustc and ruff (issue 15 item 5): the gcc-style first line kept, the
source line with a caret range under it, colour only on a terminal (NO_COLOR, --color), one
error prefix, a one-line summary, and a closed pipe that ends quietly."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import EXIT_BROKEN_PIPE, EXIT_NO_INPUT, EXIT_OK, EXIT_SOURCE_ERRORS, main, style
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink, Severity, Span
from mplang.lang.parser import parse_text

ESC = "\x1b["
CLEAN = "MP clean\n    VAR1 = 5\nEND MP\n"
UNKNOWN_NAME = "MP bad\n    VAR1 = nosuch + 1\nEND MP\n"


def run(*args: object, env: dict[str, str] | None = None) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, [str(a) for a in args], env=env)
    return result.exit_code, result.stdout, result.stderr


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_lint_text_keeps_the_gcc_line_and_adds_the_source_line_and_carets(
        tmp_path: Path) -> None:
    bad = write(tmp_path, "bad.mp", UNKNOWN_NAME)
    code, out, err = run("lint", bad)
    assert code == EXIT_SOURCE_ERRORS
    lines = out.splitlines()
    assert lines[0].startswith(f"{bad}:2:12: error[")  # the line problem matchers read
    assert lines[1:4] == ["   |",
                          " 2 |     VAR1 = nosuch + 1",
                          "   |            ^^^^^^"]  # the caret range covers the name
    assert ESC not in out + err  # a pipe: no colour
    assert err == "1 error, 0 warnings in 1 file\n"


def test_syntax_error_range_covers_the_offending_token() -> None:
    """docs/language.md, statements: a stray word after a complete statement."""
    sink = DiagnosticSink()
    parse_text("MP x\n    MOVE foo barbaz\nEND MP\n", "t.mp", sink)
    (diagnostic,) = [d for d in sink.items if d.code == "E101"]
    assert (diagnostic.span.col, diagnostic.span.end_col) == (14, 20)  # all of 'barbaz'


def test_excerpt_is_left_out_where_the_source_cannot_be_read() -> None:
    diagnostic = Diagnostic("E101", Severity.ERROR, "syntax error", Span("<nowhere>", 3, 2))
    assert style.render_diagnostic(diagnostic, style.SourceLines(), False) == \
        "<nowhere>:3:2: error[E101]: syntax error"
    known = style.SourceLines({"<stdin>": ["MP1 x", "\tA B"]})
    shown = style.render_diagnostic(
        Diagnostic("E101", Severity.ERROR, "m", Span("<stdin>", 2, 4, 5), hint="h"), known,
        False)
    assert shown.splitlines()[1:] == ["   |", " 2 |  A B", "   |    ^", "    hint: h"]


def test_plain_rendering_is_the_painted_one_without_its_colour_codes() -> None:
    """The plain text (a whole device's warnings) is made on a path of its own: it says
    exactly what the painted text says, for every part a diagnostic can have."""
    import click

    known = style.SourceLines({"a.mp": ["MP 1 x", "\tSET_V X, 1   ", "  " + "A" * 210,
                                        "  VAR1 = 2"]})
    cases = [
        Diagnostic("W103", Severity.WARNING, "read first", Span("a.mp", 2, 2, 7), hint="h"),
        Diagnostic("E101", Severity.ERROR, "m", Span("a.mp", 4, 3, None),
                   related=((Span("a.mp", 2, 9, 30), "there"), (Span("b.mp", 1, 1), "gone"))),
        Diagnostic("W2", Severity.WARNING, "long", Span("a.mp", 3, 0, 2)),
        Diagnostic("W1", Severity.WARNING, "past the end", Span("a.mp", 4, 40, 44)),
    ]
    for diagnostic in cases:
        plain = style.render_diagnostic(diagnostic, known, False)
        painted = style.render_diagnostic(diagnostic, known, True)
        assert plain == click.unstyle(painted) and plain != painted
    assert style.render_diagnostic(cases[0], known, False).splitlines()[2] == " 2 |  SET_V X, 1"


def test_colour_follows_color_option_and_no_color(tmp_path: Path) -> None:
    bad = write(tmp_path, "bad.mp", UNKNOWN_NAME)
    _, out, err = run("--color", "always", "lint", bad)
    assert ESC in out and ESC in err
    assert click_unstyle(out).splitlines()[0].startswith(f"{bad}:2:12: error[")
    _, out, err = run("--color", "never", "lint", bad)
    assert ESC not in out + err
    _, out, err = run("--color", "always", "build", bad, env={"NO_COLOR": "1"})
    assert ESC in err  # an explicit --color always wins over the environment
    _, out, err = run("build", bad, env={"NO_COLOR": "1"})
    assert ESC not in out + err


def test_no_color_is_honoured_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(style, "is_terminal", lambda _stream: True)
    monkeypatch.delenv("NO_COLOR", raising=False)
    assert style.color_enabled()
    monkeypatch.setenv("NO_COLOR", "1")
    assert not style.color_enabled()


def click_unstyle(text: str) -> str:
    import click

    return click.unstyle(text)


def test_summary_counts_errors_warnings_and_files() -> None:
    def at(file: str, severity: Severity) -> Diagnostic:
        return Diagnostic("E101" if severity is Severity.ERROR else "W102", severity, "m",
                          Span(file, 1))

    assert style.summary([at("a.mp", Severity.ERROR), at("b.mp", Severity.ERROR),
                          at("c.mp", Severity.WARNING)]) == "2 errors, 1 warning in 3 files"
    assert style.summary([at("a.mp", Severity.WARNING)]) == "0 errors, 1 warning in 1 file"


def test_clean_lint_says_all_checks_passed_on_a_terminal_only(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    clean = write(tmp_path, "clean.mp", CLEAN)
    assert run("lint", clean) == (EXIT_OK, "", "")  # a pipe: silence, as before
    monkeypatch.setattr(style, "is_terminal", lambda _stream: True)
    code, out, err = run("lint", clean)
    assert (code, out) == (EXIT_OK, "")
    assert click_unstyle(err) == "All checks passed\n"


def test_errors_of_mpc_itself_have_one_prefix(tmp_path: Path) -> None:
    missing = tmp_path / "missing.mp"
    for command in ("build", "lint", "run"):
        code, _, err = run(command, missing)
        assert (code, err) == (EXIT_NO_INPUT, f"mpc: error: {missing}: no such file\n")


def test_build_ends_with_the_summary(tmp_path: Path) -> None:
    bad = write(tmp_path, "bad.mp", UNKNOWN_NAME)
    code, out, err = run("build", bad)
    assert (code, out) == (EXIT_SOURCE_ERRORS, "")
    assert " 2 |     VAR1 = nosuch + 1\n" in err
    assert err.endswith("\n1 error, 0 warnings in 1 file\n")


def test_a_closed_pipe_ends_quietly(tmp_path: Path) -> None:
    """`mpc fmt --diff DIR | head -1`: the reader leaves after one line."""
    for n in range(40):
        write(tmp_path, f"messy{n}.mp",
              "MP1 messy\nVAR1=5\n" + "VAR2   =   VAR1+1\n" * 200 + "END MP\n")
    proc = subprocess.Popen([sys.executable, "-m", "mplang", "fmt", "--diff", str(tmp_path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()
    proc.stdout.close()  # as `head -1` does
    err = proc.stderr.read().decode()
    code = proc.wait(timeout=120)
    assert first.startswith(b"---")
    assert "Traceback" not in err and "internal error" not in err and "Exception" not in err
    assert code == EXIT_BROKEN_PIPE


def test_listing_columns_hold_for_long_paths(tmp_path: Path) -> None:
    """The listing's lines/cost/frame columns start at the same place on every row, however
    long the source's path (issue 15: they fell apart beyond ~25 characters)."""
    folder = tmp_path / ("a_folder_with_a_rather_long_name" * 2)
    folder.mkdir()
    source = write(folder, "square.mp", "MP 21 square\n    FIXED_MOVE X, 1000\n"
                   "    FIXED_MOVE Y, 1000\nEND MP\n")
    code, out, _ = run("build", source, "--format", "listing")
    assert code == EXIT_OK
    rows = [row for row in out.splitlines() if row.startswith("  ")]
    header = next(row for row in rows if row.lstrip().startswith("source"))
    frame_at = header.index("frame")
    assert len(rows) >= 4
    for row in rows[1:]:
        # the frame column begins where the header says, after the right-aligned cost
        assert row[frame_at - 2:frame_at] == "  " and row[frame_at] in "0123456789ABCDEF", row

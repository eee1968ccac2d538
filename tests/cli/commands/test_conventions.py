"""The command-line habits users bring from ruff, git and cargo (issue 26 item 1), each driven
through the real `mpc` process: `mpc lint -` / `mpc fmt -` with `--stdin-filename`,
`mpc lint --fix` and `--diff`, FORCE_COLOR and TERM=dumb, `-q/--quiet`, a werror summary that
says why, `mpc init`, and a did-you-mean for a mistyped command."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mplang.cli import EXIT_OK, EXIT_OUTPUT, EXIT_SOURCE_ERRORS, EXIT_USAGE
from mplang.cli.commands.init import FILES

ESC = "\x1b["
MISSPELT = "VAR total\nMP main\n    total = 0\n    FIXD_MOVE X, 100\n    SET_V X, 2000\nEND MP\n"
FIXED = MISSPELT.replace("FIXD_MOVE", "FIXED_MOVE")
WARNING = "MP main\n    FOR 0\n        VAR1 = 1\n    NEXT\nEND MP\n"  # W102: never runs


def mpc(*args: object, cwd: Path | None = None, stdin: str | None = None,
        env: dict[str, str] | None = None, complete_as: str | None = None
        ) -> subprocess.CompletedProcess[str]:
    """The real process; `complete_as`: run as click's completion of that program name."""
    environment = {k: v for k, v in os.environ.items()
                   if k not in ("NO_COLOR", "FORCE_COLOR", "TERM")}
    environment.update(env or {})
    command = [sys.executable, "-m", "mplang", *map(str, args)]
    if complete_as is not None:
        command = [sys.executable, "-c", "import sys; from mplang.cli import main; "
                   f"sys.exit(main(prog_name={complete_as!r}))"]
    return subprocess.run(command, cwd=cwd,
                          input=stdin if stdin is not None else "", capture_output=True,
                          text=True, env=environment, timeout=120)


@pytest.fixture()
def project(tmp_path: Path) -> Path:
    """A project whose mpc.toml sets what standard input must pick up: [fmt] indent = 2 and
    werror."""
    root = tmp_path / "cell"
    (root / "src").mkdir(parents=True)
    (root / "mpc.toml").write_text('[project]\nsources = ["src"]\nwerror = true\n\n'
                                   "[fmt]\nindent = 2\n")
    (root / "src" / "main.mp").write_text("MP main\n  VAR1 = 1\nEND MP\n")
    return root


# ----------------------------------------------------------------------------- stdin


def test_lint_reads_standard_input_as_the_file_stdin_filename_names(project: Path,
                                                                    tmp_path: Path) -> None:
    name = project / "src" / "main.mp"
    done = mpc("lint", "-", "--stdin-filename", name, stdin=MISSPELT, cwd=tmp_path)
    assert done.returncode == EXIT_SOURCE_ERRORS
    # named as every source is: relative to the working directory
    assert done.stdout.startswith("cell/src/main.mp:4:5: error[E201]: unknown command "
                                  "'FIXD_MOVE'")
    assert "FIXD_MOVE X, 100" in done.stdout  # the excerpt is standard input's line
    # the project's werror applies to standard input: a warning fails it, and says why
    done = mpc("lint", "-", "--stdin-filename", name, stdin=WARNING, cwd=tmp_path)
    assert done.returncode == EXIT_SOURCE_ERRORS
    assert "warning[W102]" in done.stdout
    assert "0 errors, 1 warning in 1 file; failed: warnings are errors" in done.stderr
    # without the project (another folder), the same text passes
    elsewhere = tmp_path / "loose.mp"
    done = mpc("lint", "-", "--stdin-filename", elsewhere, stdin=WARNING, cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr


def test_lint_of_standard_input_without_a_name_calls_it_stdin(tmp_path: Path) -> None:
    done = mpc("lint", "-", stdin=MISSPELT, cwd=tmp_path)
    assert done.returncode == EXIT_SOURCE_ERRORS
    assert done.stdout.startswith("<stdin>:4:5: error[E201]")
    assert mpc("lint", "-", stdin=FIXED, cwd=tmp_path).returncode == EXIT_OK


def test_stdin_filename_needs_standard_input(project: Path) -> None:
    done = mpc("lint", project / "src" / "main.mp", "--stdin-filename", "x.mp")
    assert done.returncode == EXIT_USAGE and "--stdin-filename" in done.stderr
    done = mpc("fmt", "-", project / "src" / "main.mp", stdin="")
    assert done.returncode == EXIT_USAGE


def test_fmt_of_standard_input_takes_the_fmt_table_nearest_stdin_filename(
        project: Path, tmp_path: Path) -> None:
    text = "MP main\nSET_V X,1\nEND MP\n"
    done = mpc("fmt", "-", "--stdin-filename", project / "src" / "new.mp", stdin=text,
               cwd=tmp_path)
    assert (done.returncode, done.stdout) == (EXIT_OK, "MP main\n  SET_V X, 1\nEND MP\n")
    done = mpc("fmt", "-", "--stdin-filename", tmp_path / "new.mp", stdin=text,
               cwd=tmp_path)
    assert done.stdout == "MP main\n    SET_V X, 1\nEND MP\n"
    done = mpc("fmt", "-", "--check", "--stdin-filename", "cell/src/x.mp", stdin=text,
               cwd=tmp_path)
    assert done.returncode != EXIT_OK and "would reformat cell/src/x.mp" in done.stderr


# ----------------------------------------------------------------------------- --fix


def test_lint_fix_applies_the_preferred_fixes_in_place(tmp_path: Path) -> None:
    source = tmp_path / "prog.mp"
    source.write_text(MISSPELT)
    done = mpc("lint", "--fix", "--diff", source)
    assert done.returncode == EXIT_SOURCE_ERRORS  # a fix would be applied
    assert "-    FIXD_MOVE X, 100\n+    FIXED_MOVE X, 100\n" in done.stdout
    assert source.read_text() == MISSPELT  # --diff changes nothing
    done = mpc("lint", "--fix", source)
    assert done.returncode == EXIT_OK, done.stdout + done.stderr
    assert source.read_text() == FIXED
    assert f"fixed {source} (1 fix)" in done.stderr
    done = mpc("lint", "--fix", "--diff", source)
    assert (done.returncode, done.stdout) == (EXIT_OK, "")  # nothing left to fix


def test_lint_fix_keeps_crlf_line_endings(tmp_path: Path) -> None:
    source = tmp_path / "dos.mp"
    source.write_bytes(MISSPELT.replace("\n", "\r\n").encode())
    assert mpc("lint", "--fix", source).returncode == EXIT_OK
    assert source.read_bytes() == FIXED.replace("\n", "\r\n").encode()


def test_lint_fix_leaves_what_has_no_preferred_fix_and_reports_it(tmp_path: Path) -> None:
    source = tmp_path / "prog.mp"
    source.write_text(WARNING)  # a warning's only fix is an ignore comment: never preferred
    done = mpc("lint", "--fix", source)
    assert source.read_text() == WARNING
    assert done.returncode == EXIT_OK and "warning[W102]" in done.stdout


def test_lint_fix_of_standard_input_prints_the_fixed_text(tmp_path: Path) -> None:
    done = mpc("lint", "-", "--fix", stdin=MISSPELT, cwd=tmp_path)
    assert (done.returncode, done.stdout) == (EXIT_OK, FIXED)


# ----------------------------------------------------------------------------- colour


def test_force_color_colours_a_pipe_and_no_color_still_wins(tmp_path: Path) -> None:
    source = tmp_path / "bad.mp"
    source.write_text(MISSPELT)
    assert ESC not in mpc("lint", source).stdout
    assert ESC in mpc("lint", source, env={"FORCE_COLOR": "1"}).stdout
    assert ESC not in mpc("lint", source, env={"FORCE_COLOR": "0"}).stdout
    done = mpc("lint", source, env={"FORCE_COLOR": "1", "NO_COLOR": "1"})
    assert ESC not in done.stdout + done.stderr


def test_term_dumb_gets_no_escape_sequences_on_a_terminal(tmp_path: Path) -> None:
    """A real terminal (a pty pair): colour by default, none with TERM=dumb."""
    import pty

    source = tmp_path / "bad.mp"
    source.write_text(MISSPELT)

    def on_terminal(term: str) -> str:
        main, child = pty.openpty()
        environment = {k: v for k, v in os.environ.items()
                       if k not in ("NO_COLOR", "FORCE_COLOR")}
        environment["TERM"] = term
        try:
            process = subprocess.Popen([sys.executable, "-m", "mplang", "lint", str(source)],
                                       stdin=subprocess.DEVNULL, stdout=child, stderr=child,
                                       env=environment)
            os.close(child)
            chunks = []
            while True:
                try:
                    chunk = os.read(main, 4096)
                except OSError:  # the child closed its end
                    break
                if not chunk:
                    break
                chunks.append(chunk)
            process.wait(timeout=120)
        finally:
            os.close(main)
        return b"".join(chunks).decode("utf-8", "replace")

    assert ESC in on_terminal("xterm-256color")
    text = on_terminal("dumb")
    assert "error[E201]" in text and ESC not in text


# ----------------------------------------------------------------------------- --quiet


def test_quiet_drops_summaries_and_progress_but_not_the_report(tmp_path: Path) -> None:
    source = tmp_path / "bad.mp"
    source.write_text(MISSPELT)
    done = mpc("lint", "-q", source)
    assert done.returncode == EXIT_SOURCE_ERRORS
    assert "error[E201]" in done.stdout and done.stderr == ""
    done = mpc("-q", "build", source)  # before the command too
    assert "error[E201]" in done.stderr and "1 error" not in done.stderr
    ugly = tmp_path / "ugly.mp"
    ugly.write_text("MP main\nVAR1 = 1\nEND MP\n")
    done = mpc("fmt", "--quiet", ugly)
    assert (done.returncode, done.stderr) == (EXIT_OK, "")
    assert ugly.read_text() == "MP main\n    VAR1 = 1\nEND MP\n"
    clean = tmp_path / "clean.mp"
    clean.write_text(FIXED)
    done = mpc("run", "-q", clean)
    assert done.returncode == EXIT_OK and "finished" in done.stdout


def test_quiet_flash_prints_nothing_but_errors(tmp_path: Path) -> None:
    """A flash to a virtual controller: its narration without -q, none with it; an error
    (nothing listening) is still said."""
    from simproc import start_sim

    source = tmp_path / "job.mp"
    source.write_text(FIXED)
    proc, port = start_sim("--duration", "60")
    try:
        loud = mpc("flash", source, "--tcp", f"127.0.0.1:{port}", "--record",
                   tmp_path / "r.json", "--force")
        assert loud.returncode == EXIT_OK and "mpc flash: " in loud.stderr
        quiet = mpc("-q", "flash", source, "--tcp", f"127.0.0.1:{port}", "--record",
                    tmp_path / "r.json", "--force")
        assert (quiet.returncode, quiet.stderr) == (EXIT_OK, "")
    finally:
        proc.terminate()
        proc.wait(10)
    refused = mpc("flash", "-q", source, "--tcp", f"127.0.0.1:{port}", "--record",
                  tmp_path / "r.json", "--force")
    assert refused.returncode != EXIT_OK and "error" in refused.stderr


def test_werror_summary_says_why_the_check_fails(tmp_path: Path) -> None:
    source = tmp_path / "warn.mp"
    source.write_text(WARNING)
    done = mpc("lint", "--werror", source)
    assert done.returncode == EXIT_SOURCE_ERRORS
    assert done.stderr.strip().endswith("0 errors, 1 warning in 1 file; failed: warnings are "
                                        "errors here (--werror, or werror = true in mpc.toml)")
    done = mpc("build", "--werror", source)
    assert done.returncode == EXIT_SOURCE_ERRORS and "failed: warnings are errors" in \
        done.stderr
    done = mpc("lint", source)
    assert done.returncode == EXIT_OK and "failed" not in done.stderr


# ----------------------------------------------------------------------------- init


def test_init_starts_a_project_that_builds_lints_and_formats_with_no_arguments(
        tmp_path: Path) -> None:
    done = mpc("init", "new cell", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    root = tmp_path / "new cell"
    assert sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()) == \
        sorted(FILES)
    assert "# " in (root / "mpc.toml").read_text()  # commented
    assert "mpc-lint" in (root / ".pre-commit-config.yaml").read_text()
    for command in (["build"], ["lint", "--werror"], ["fmt", "--check"], ["run"]):
        done = mpc(*command, cwd=root)
        assert done.returncode == EXIT_OK, (command, done.stdout, done.stderr)
    assert '"format"' in mpc("build", cwd=root).stdout


def test_init_refuses_to_overwrite_and_writes_nothing(tmp_path: Path) -> None:
    (tmp_path / "mpc.toml").write_text("# mine\n")
    done = mpc("init", cwd=tmp_path)
    assert done.returncode == EXIT_OUTPUT
    assert "mpc.toml: already there" in done.stderr and "Traceback" not in done.stderr
    assert (tmp_path / "mpc.toml").read_text() == "# mine\n"
    assert not (tmp_path / "src").exists() and not (tmp_path / ".gitignore").exists()
    (tmp_path / "file").write_text("")
    done = mpc("init", "file", cwd=tmp_path)
    assert done.returncode == EXIT_OUTPUT and "not a directory" in done.stderr


# ----------------------------------------------------------------------------- did you mean


def test_a_mistyped_command_gets_a_suggestion() -> None:
    done = mpc("biuld")
    assert done.returncode == EXIT_USAGE
    assert "No such command 'biuld'; did you mean 'build'?" in done.stderr
    done = mpc("xyzzy")
    assert done.returncode == EXIT_USAGE and "did you mean" not in done.stderr


# ----------------------------------------------------------------------------- paths


def test_every_format_names_an_included_file_by_one_normalised_path(tmp_path: Path) -> None:
    """`cell one/main.mp` INCLUDEs "../lib/common.mp": text, JSON, GitHub and SARIF all say
    `lib/common.mp`, never `cell one/../lib/common.mp`."""
    import json

    (tmp_path / "mpc.toml").write_text("")
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "common.mp").write_text("MP helper\n    FIXD_MOVE X, 1\nEND MP\n")
    cell = tmp_path / "cell one"
    cell.mkdir()
    (cell / "main.mp").write_text('INCLUDE "../lib/common.mp"\nMP main\n    VAR1 = 1\nEND MP\n')
    text = mpc("lint", "cell one/main.mp", cwd=tmp_path).stdout
    assert text.startswith("lib/common.mp:2:5: error[E201]") and "/../" not in text
    (found,) = json.loads(mpc("lint", "--format", "json", "cell one/main.mp",
                              cwd=tmp_path).stdout)
    assert found["file"] == "lib/common.mp"
    assert "file=lib/common.mp,line=2" in mpc("lint", "--format", "github", "cell one/main.mp",
                                              cwd=tmp_path).stdout
    sarif = json.loads(mpc("lint", "--format", "sarif", "cell one/main.mp",
                           cwd=tmp_path).stdout)
    (result,) = sarif["runs"][0]["results"]
    location = result["locations"][0]["physicalLocation"]["artifactLocation"]
    assert location["uri"] == "lib/common.mp"


# ----------------------------------------------------------------------------- completion


def complete(words: str, cwd: Path) -> list[str]:
    """What bash completion offers for the last word of `words`, from the real `mpc` (as
    `mpc completion bash` sets it up: the variable is `_MPC_COMPLETE`)."""
    done = mpc(cwd=cwd, complete_as="mpc",
               env={"_MPC_COMPLETE": "bash_complete", "COMP_WORDS": words,
                    "COMP_CWORD": str(len(words.split(" ")) - 1)})
    assert done.returncode == EXIT_OK, done.stderr
    return [line.split(",", 1)[1] for line in done.stdout.splitlines() if line]


def test_call_completes_program_names_and_to_completes_targets(tmp_path: Path) -> None:
    (tmp_path / "mpc.toml").write_text('[project]\nsources = ["cycle.mp"]\n\n'
                                       '[targets.cell1]\ntcp = "192.168.0.16"\n'
                                       '[targets.glue]\nserial = "/dev/ttyUSB0"\n')
    (tmp_path / "cycle.mp").write_text("MP 96 cycle\n    CALL prep\nEND MP\n\n"
                                       "MP prep\n    VAR1 = 1\nEND MP\n\nISR 2 on_stop\nEND ISR\n")
    (tmp_path / "other.mp").write_text("MP 7 other_main\nEND MP\n")
    assert complete("mpc run --call ", tmp_path) == ["MP96", "cycle", "prep"]
    assert complete("mpc plot --call c", tmp_path) == ["cycle"]
    assert complete("mpc run other.mp --call ", tmp_path) == ["MP7", "other_main"]
    assert complete("mpc flash --to ", tmp_path) == ["cell1", "glue"]
    assert complete("mpc status --to g", tmp_path) == ["glue"]
    assert complete("mpc flash --to ", tmp_path / "..") == []  # no project: nothing offered

"""Packaging (issue 15 item 8): matplotlib is the `plot` extra and `mpc plot` says so when it
is missing, the licence is an SPDX expression with its LICENSE file, and the shell completion
of `mpc completion` completes commands and file names."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import EXIT_MISSING_EXTRA, EXIT_OK, EXIT_USAGE, main

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "samples" / "home_then_square.mp"


def test_mpc_plot_without_matplotlib_names_the_extra(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # `import matplotlib` now fails
    out = tmp_path / "square.png"
    result = CliRunner().invoke(main, ["plot", str(SAMPLE), "-o", str(out)])
    assert result.exit_code == EXIT_MISSING_EXTRA
    # the extra by name, and the form that works in the source folder (on a public index,
    # `mplang[plot]` may be another project's)
    assert "install the plot extra of mplang" in result.stderr and "matplotlib" in result.stderr
    assert "pip install '.[plot]'" in result.stderr and "'mplang[" not in result.stderr
    assert "Traceback" not in result.output and not out.exists()


def test_only_mpc_plot_needs_matplotlib(tmp_path: Path) -> None:
    """Every other command runs with matplotlib unimportable, as in an install without the
    extra."""
    script = ("import sys\nsys.modules['matplotlib'] = None\nfrom mplang.cli import main\n"
              "main(sys.argv[1:], prog_name='mpc')\n")
    for args in (["lint", str(SAMPLE)], ["build", str(SAMPLE), "-o", str(tmp_path / "i.json")],
                 ["run", str(SAMPLE), "--json"], ["--help"]):
        proc = subprocess.run([sys.executable, "-c", script, *args], capture_output=True,
                              text=True, check=False, cwd=ROOT)
        assert proc.returncode == EXIT_OK, (args, proc.stderr)


def test_make_installs_every_extra_and_the_dev_group() -> None:
    """The tests plot, drive the language server and the dashboard: `make` installs all three
    extras beside the dev dependency group, which pyproject keeps unpublished."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "dev" not in project["project"]["optional-dependencies"]
    assert any(d.startswith("pytest") for d in project["dependency-groups"]["dev"])
    extras = set(project["project"]["optional-dependencies"])
    assert extras == {"plot", "lsp", "monitor"}
    makefile = (ROOT / "Makefile").read_text()
    assert "pip install --quiet -e '.[plot,lsp,monitor]' --group dev" in makefile
    assert "'pip>=25.1'" in makefile  # the first pip with --group


def test_pyproject_plot_extra_spdx_licence_and_license_file() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    meta = project["project"]
    assert not any(d.startswith("matplotlib") for d in meta["dependencies"])
    assert [d for d in meta["optional-dependencies"]["plot"] if d.startswith("matplotlib")]
    assert meta["license"] == "MIT" and meta["license-files"] == ["LICENSE"]
    # PEP 639 license expressions: setuptools 77 and later.
    assert "setuptools>=77" in project["build-system"]["requires"]
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License") and "Copyright (c) 2026 mplang contributors" in text


def complete(words: str) -> list[str]:
    """What `mpc` answers a bash completion request (click's protocol: `type,value` lines)."""
    args = words.split()
    cword = len(args) - (0 if words.endswith(" ") else 1)
    result = CliRunner().invoke(main, [], prog_name="mpc", env={
        "_MPC_COMPLETE": "bash_complete", "COMP_WORDS": words, "COMP_CWORD": str(cword)})
    assert result.exit_code == EXIT_OK
    return result.stdout.splitlines()


@pytest.mark.parametrize("words", [
    "mpc lint sam", "mpc build ", "mpc fmt src/a", "mpc run x.mp ", "mpc plot ", "mpc flash ",
    "mpc sim ", "mpc import lega", "mpc disasm ", "mpc build x.mp -o ", "mpc run x --trace ",
    "mpc plot x.mp -o "])
def test_file_arguments_complete_file_names(words: str) -> None:
    incomplete = "" if words.endswith(" ") else words.split()[-1]
    assert complete(words) == [f"file,{incomplete}"]


def test_commands_and_choices_complete() -> None:
    assert "plain,lint" in complete("mpc li")
    assert complete("mpc lint x.mp --format g") == ["plain,github", "plain,gitlab"]
    assert complete("mpc completion ") == ["plain,bash", "plain,zsh", "plain,fish"]


@pytest.mark.parametrize("shell", ["bash", "zsh", "fish"])
def test_completion_prints_clicks_script(shell: str) -> None:
    runner = CliRunner()
    printed = runner.invoke(main, ["completion", shell])
    assert printed.exit_code == EXIT_OK
    sourced = runner.invoke(main, [], prog_name="mpc", env={"_MPC_COMPLETE": f"{shell}_source"})
    assert printed.stdout.strip() == sourced.stdout.strip() and "_MPC_COMPLETE" in printed.stdout


def test_completion_refuses_other_shells() -> None:
    result = CliRunner().invoke(main, ["completion", "tcsh"])
    assert result.exit_code == EXIT_USAGE and "tcsh" in result.stderr


@pytest.mark.needs_tool("bash")
def test_bash_script_completes_through_the_installed_mpc() -> None:
    """The printed script, sourced in bash, asks the `mpc` on PATH and fills COMPREPLY."""
    mpc = Path(sys.executable).parent / "mpc"
    assert mpc.exists()
    script = ('eval "$(mpc completion bash)"\n'
              'COMP_WORDS=(mpc li); COMP_CWORD=1; _mpc_completion mpc\n'
              'printf "%s\\n" "${COMPREPLY[@]}"\n')
    env = {**os.environ, "PATH": f"{mpc.parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    proc = subprocess.run(["bash", "--norc", "-c", script], capture_output=True, text=True,
                          env=env, check=False, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["lint"]

"""One configuration everywhere (issue 15 item 3, docs/project.md "Which project file
applies"): for every FILE the nearest mpc.toml above it applies, in `mpc lint`, `build`,
`run`, `fmt` and the pre-commit hooks (which pass file names), with `[lint] ignore` beside
the per-line `# mpc: ignore[...]`. The commands run as a user or pre-commit runs them: a
real `mpc` process in the project's folder."""

from __future__ import annotations

import os
import shlex
import subprocess
import sys
from pathlib import Path

from mplang.cli import (
    EXIT_NO_INPUT,
    EXIT_OK,
    EXIT_SOURCE_ERRORS,
    EXIT_USAGE,
    EXIT_WOULD_REFORMAT,
)

ROOT = Path(__file__).resolve().parents[3]
WARNS = """MP 1 one
    FOR 0
        FIXED_MOVE X, 100
    NEXT
END MP
"""
"""A program whose only finding is the warning W102 (FOR 0 never runs its body)."""


def mpc(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """`mpc ARGS` in `cwd`, as a shell (or pre-commit) runs it."""
    argv = [sys.executable, "-m", "mplang", *args]
    return subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "NO_COLOR": "1"})


def two_projects(tmp_path: Path) -> tuple[Path, Path]:
    """strict/ (werror = true) and plain/ (no project file), each with the W102 program."""
    strict, plain = tmp_path / "strict", tmp_path / "plain"
    for folder in (strict, plain):
        folder.mkdir()
        (folder / "job.mp").write_text(WARNS)
    (strict / "mpc.toml").write_text("[project]\nwerror = true\n")
    return strict, plain


def hook_entry(hook: str) -> tuple[str, ...]:
    """The `entry:` of a hook in .pre-commit-hooks.yaml (one `key: value` per line)."""
    lines = (ROOT / ".pre-commit-hooks.yaml").read_text().splitlines()
    start = lines.index(f"- id: {hook}")
    for line in lines[start + 1:]:
        if line.strip().startswith("entry:"):
            return tuple(shlex.split(line.split(":", 1)[1]))
    raise AssertionError(f"no entry for {hook}")


def test_lint_file_uses_the_nearest_project_files_werror(tmp_path: Path) -> None:
    strict, _plain = two_projects(tmp_path)
    failed = mpc("lint", "strict/job.mp", cwd=tmp_path)
    assert failed.returncode == EXIT_SOURCE_ERRORS, failed.stderr
    assert "warning[W102]" in failed.stdout
    assert mpc("lint", "plain/job.mp", cwd=tmp_path).returncode == EXIT_OK
    deep = strict / "sub" / "deeper"  # searched upward from the file's folder
    deep.mkdir(parents=True)
    (deep / "more.mp").write_text(WARNS.replace("MP 1 one", "MP 2 two"))
    assert mpc("lint", "job.mp", cwd=deep.parent.parent).returncode == EXIT_SOURCE_ERRORS
    assert mpc("lint", "more.mp", cwd=deep).returncode == EXIT_SOURCE_ERRORS


def test_the_pre_commit_lint_hook_fails_on_werror_of_the_nearest_project(tmp_path: Path
                                                                        ) -> None:
    entry = hook_entry("mpc-lint")
    assert entry[0] == "mpc"
    two_projects(tmp_path)
    # pre-commit runs the entry in the repository's root with the staged files' names
    hooked = mpc(*entry[1:], "plain/job.mp", "strict/job.mp", cwd=tmp_path)
    assert hooked.returncode == EXIT_SOURCE_ERRORS, hooked.stderr
    assert mpc(*entry[1:], "plain/job.mp", cwd=tmp_path).returncode == EXIT_OK


def test_lint_ignore_silences_a_warning_in_every_file_of_the_project(tmp_path: Path) -> None:
    strict, _plain = two_projects(tmp_path)
    (strict / "mpc.toml").write_text('[project]\nwerror = true\n\n[lint]\nignore = ["W102"]\n')
    both = mpc("lint", "strict/job.mp", "plain/job.mp", cwd=tmp_path)
    assert both.returncode == EXIT_OK, both.stderr
    assert "strict/job.mp" not in both.stdout  # ignored there ...
    assert "plain/job.mp:2:9: warning[W102]" in both.stdout  # ... not in another project
    built = mpc("build", "job.mp", "--format", "listing", cwd=strict)  # werror, yet clean
    assert built.returncode == EXIT_OK, built.stderr
    assert "W102" not in built.stderr


def test_lint_ignore_refuses_errors_and_unknown_codes_at_its_line(tmp_path: Path) -> None:
    strict, _ = two_projects(tmp_path)
    (strict / "mpc.toml").write_text('[lint]\n\nignore = ["E201"]\n')
    error = mpc("lint", "strict/job.mp", cwd=tmp_path)
    assert error.returncode == EXIT_NO_INPUT
    assert "strict/mpc.toml:3: [lint] ignore: E201 is an error, and errors cannot be " \
        "ignored" in error.stderr
    (strict / "mpc.toml").write_text('[lint]\nignore = ["W9999"]\n')
    unknown = mpc("lint", "strict/job.mp", cwd=tmp_path)
    assert unknown.returncode == EXIT_NO_INPUT
    assert "'W9999' is no check code; the warnings are" in unknown.stderr
    assert "W102" in unknown.stderr


def test_one_build_of_two_projects_is_refused_naming_both(tmp_path: Path) -> None:
    two_projects(tmp_path)
    for command in ("build", "run"):
        refused = mpc(command, "strict/job.mp", "plain/job.mp", cwd=tmp_path)
        assert refused.returncode == EXIT_USAGE
        assert "belong to projects with different settings: strict/job.mp " \
            "(strict/mpc.toml) and " \
            "plain/job.mp (no mpc.toml)" in refused.stderr
    isolated = mpc("build", "--isolated", "strict/job.mp", "plain/job.mp", cwd=tmp_path)
    assert isolated.returncode == EXIT_SOURCE_ERRORS  # one build, so MP1 is defined twice
    assert "belong to projects" not in isolated.stderr


def test_isolated_and_config_choose_the_project_file(tmp_path: Path) -> None:
    two_projects(tmp_path)
    assert mpc("lint", "--isolated", "strict/job.mp", cwd=tmp_path).returncode == EXIT_OK
    chosen = mpc("lint", "--config", "strict/mpc.toml", "plain/job.mp", cwd=tmp_path)
    assert chosen.returncode == EXIT_SOURCE_ERRORS
    both = mpc("lint", "--config", "strict/mpc.toml", "--isolated", "plain/job.mp",
               cwd=tmp_path)
    assert both.returncode == EXIT_USAGE
    assert "give --project FILE or --isolated, not both" in both.stderr


def test_projects_that_agree_make_one_build(tmp_path: Path) -> None:
    _, plain = two_projects(tmp_path)
    (plain / "mpc.toml").write_text("[project]\nwerror = true\n")  # the same settings
    (plain / "job.mp").write_text(WARNS.replace("MP 1 one", "MP 2 two"))
    built = mpc("build", "strict/job.mp", "plain/job.mp", "--format", "listing", cwd=tmp_path)
    assert built.returncode == EXIT_SOURCE_ERRORS  # one build, werror: the warnings fail it
    assert "belong to projects" not in built.stderr
    assert "strict/job.mp:2:9: warning[W102]" in built.stderr
    assert "plain/job.mp:2:9: warning[W102]" in built.stderr


def test_a_folder_argument_leaves_out_sub_folders_that_are_projects(tmp_path: Path) -> None:
    (tmp_path / "main.mp").write_text(WARNS)
    inner = tmp_path / "cell"
    inner.mkdir()
    (inner / "mpc.toml").write_text("[project]\n")
    (inner / "other.mp").write_text(WARNS)  # MP 1 again: one build with main.mp would clash
    built = mpc("build", ".", "--format", "listing", cwd=tmp_path)
    assert built.returncode == EXIT_OK, built.stderr
    assert "mpc: note: cell: left out (1 .mp file), a project of its own (cell/mpc.toml)" \
        in built.stderr
    linted = mpc("lint", ".", cwd=tmp_path)  # lint checks every project, each on its own
    assert linted.returncode == EXIT_OK, linted.stderr
    assert "cell/other.mp:2:9: warning[W102]" in linted.stdout
    assert "main.mp:2:9: warning[W102]" in linted.stdout


def test_fmt_file_honours_the_nearest_projects_fmt_table(tmp_path: Path) -> None:
    strict, plain = two_projects(tmp_path)
    (strict / "mpc.toml").write_text("[fmt]\nindent = 2\n")
    flat = "MP 1 one\nFOR 0\nFIXED_MOVE X, 100\nNEXT\nEND MP\n"
    for folder in (strict, plain):
        (folder / "job.mp").write_text(flat)
    entry = hook_entry("mpc-fmt")  # the pre-commit hook: `mpc fmt FILE...`
    assert entry[0] == "mpc"
    done = mpc(*entry[1:], "strict/job.mp", "plain/job.mp", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    assert (strict / "job.mp").read_text() == \
        "MP 1 one\n  FOR 0\n    FIXED_MOVE X, 100\n  NEXT\nEND MP\n"
    assert (plain / "job.mp").read_text() == WARNS
    assert mpc("fmt", "--check", "strict/job.mp", cwd=tmp_path).returncode == EXIT_OK
    isolated = mpc("fmt", "--check", "--isolated", "strict/job.mp", cwd=tmp_path)
    assert isolated.returncode == EXIT_WOULD_REFORMAT  # the defaults indent by 4

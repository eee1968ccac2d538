"""docs/ci.md says what a CI step sees (issue 15 item 7): its "Try it locally" lines run here
as a shell runs them, from a folder holding a copy of the repository's samples/, and each
exits with the code its `# exit` comment names. Every `mpc` command of the page's workflows
(GitHub Actions, GitLab CI) is one of those lines, so the workflows are covered too."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "ci.md"
EXIT = re.compile(r"#\s*exit\s+(\d+)")


def local_lines() -> list[str]:
    """The sh block under "### Try it locally"."""
    text = DOC.read_text()
    section = text[text.index("### Try it locally"):]
    block = section[section.index("```sh\n") + len("```sh\n"):]
    return [line for line in block[:block.index("```")].splitlines() if line.strip()]


def workflow_commands() -> list[str]:
    """The `mpc` commands of the YAML blocks (`run: mpc ...`, `- mpc ...`)."""
    found = []
    for block in re.findall(r"```yaml\n(.*?)```", DOC.read_text(), re.DOTALL):
        for line in block.splitlines():
            match = re.match(r"\s*(?:run:|-)\s+(mpc\s.*?)\s*$", line)
            if match:
                found.append(match.group(1))
    return found


def test_ci_doc_commands_exit_as_the_page_says(tmp_path: Path) -> None:
    shutil.copytree(ROOT / "samples", tmp_path / "samples")
    env = {**os.environ, "NO_COLOR": "1",
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    checked = 0
    for line in local_lines():
        command = line.split("#", 1)[0].strip() if line.lstrip().startswith("mpc") else line
        done = subprocess.run(["bash", "-c", command], cwd=tmp_path, env=env, text=True,
                              capture_output=True, timeout=300)
        expected = EXIT.search(line)
        if expected is None:  # a preparing step: it must simply work
            assert done.returncode == 0, (line, done.stderr)
            continue
        assert done.returncode == int(expected.group(1)), (line, done.stdout, done.stderr)
        checked += 1
        if "::error file=" in line:
            assert "::error file=programs/untidy.mp,line=2," in done.stdout
        if "would reformat" in line:
            assert "would reformat programs/untidy.mp" in done.stderr
    assert checked >= 6
    assert (tmp_path / "mpc.sarif").is_file()
    assert (tmp_path / "gl-code-quality-report.json").is_file()


def test_every_workflow_command_is_tried_locally() -> None:
    tried = {line.split("#", 1)[0].strip() for line in local_lines()}
    commands = workflow_commands()
    assert len(commands) >= 5
    for command in commands:
        assert command in tried, command

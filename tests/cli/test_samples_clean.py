"""The project's own material passes its own tools (issue 15 item 7): `mpc build samples/`,
`mpc lint samples/` and `mpc fmt --check samples/` pass from the repository's root (each
family folder is a project of its own, with its own mpc.toml), and what `mpc disasm` writes
for every sample image is already in `mpc fmt`'s layout."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import EXIT_OK, main

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "samples"
PROJECTS = sorted(p.parent for p in SAMPLES.glob("*/mpc.toml"))


@pytest.fixture()
def at_root(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)


@pytest.mark.usefixtures("at_root")
@pytest.mark.parametrize("command", [["build", "samples/", "-o", "-"], ["lint", "samples/"],
                                     ["fmt", "--check", "samples/"]],
                         ids=lambda c: c[0])
def test_samples_pass_their_own_tools(command: list[str]) -> None:
    result = CliRunner().invoke(main, command)
    assert result.exit_code == EXIT_OK, result.output
    if command[0] == "build":  # the family folders are other projects, said so
        for project in PROJECTS:
            assert f"mpc: note: samples/{project.name}: left out" in result.stderr


def test_every_family_folder_is_a_project_that_builds_on_its_own(
        monkeypatch: pytest.MonkeyPatch) -> None:
    assert {p.name for p in PROJECTS} == {"controller", "csim", "families", "fatek", "host"}
    for project in PROJECTS:
        monkeypatch.chdir(project)
        result = CliRunner().invoke(main, ["build", "-o", "-"])
        assert result.exit_code == EXIT_OK, (project, result.output)


def test_disasm_of_every_sample_image_is_fmt_clean(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    builds = [(ROOT, ["build", "samples/"])] + [(p, ["build"]) for p in PROJECTS]
    for number, (folder, command) in enumerate(builds):
        monkeypatch.chdir(folder)
        image, source = tmp_path / f"image{number}.json", tmp_path / f"back{number}.mp"
        built = CliRunner().invoke(main, [*command, "-o", str(image)])
        assert built.exit_code == EXIT_OK, built.output
        back = CliRunner().invoke(main, ["disasm", str(image), "-o", str(source)])
        assert back.exit_code == EXIT_OK, back.output
        checked = CliRunner().invoke(main, ["fmt", "--check", str(source)])
        assert checked.exit_code == EXIT_OK, (folder, checked.output)

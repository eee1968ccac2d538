"""The family registry: one line per family, every command reaches every family through it."""

from __future__ import annotations

from pathlib import Path

import pytest

import mplang.csim
import mplang.fatek
import mplang.m8194h
from mplang.family import registry
from mplang.family.face import Family, NoSuchProgram, RunSetupError
from mplang.ir.unit import Options


def test_registry_lines_repeat_the_packages_own_targets_and_suffixes() -> None:
    for entry in registry.FAMILIES:
        family = entry.load()
        assert entry.targets == family.TARGETS, entry.package
        assert entry.suffixes == family.SUFFIXES, entry.package


def test_targets_and_suffixes_find_their_family() -> None:
    assert registry.known_targets() == ("et", "rs", *mplang.fatek.TARGETS, *mplang.csim.TARGETS)
    assert registry.DEFAULT_TARGET == "et"
    assert registry.family_of_target("et") is mplang.m8194h
    assert registry.family_of_target("rs") is mplang.m8194h
    assert registry.family_of_target("csim") is mplang.csim
    assert registry.family_of_target("fbs-fun140") is mplang.fatek
    assert registry.family_of_target("nothing") is None
    assert registry.family_of_path(Path("a.fbs")) is mplang.fatek
    assert registry.family_of_path(Path("b.CSIM")) is mplang.csim
    assert registry.family_of_path(Path("c.mp")) is None


@pytest.mark.parametrize("family", [mplang.m8194h, mplang.fatek, mplang.csim],
                         ids=lambda f: f.TITLE)
def test_every_family_shares_the_run_errors(family: Family) -> None:
    assert issubclass(family.NoSuchProgram, NoSuchProgram)
    assert family.RunSetupError is RunSetupError


def test_the_m8194h_face_builds_renders_and_runs(tmp_path: Path) -> None:
    source = tmp_path / "one.mp"
    source.write_text("MP 3 one\n  VAR1 = 5\nEND MP\n")
    build = mplang.m8194h.compile_mp([source], Options(), "rs")
    assert build.ok and build.target == "rs"
    assert build.render("json") == build.render(mplang.m8194h.DEFAULT_FORMAT)
    run = mplang.m8194h.run_build(build, None, 1.0, sample_period=0.001)
    assert run.finished and run.called == "MP3" and run.to_json()["vars"]["VAR1"] == 5
    assert run.trace is not None and len(run.trace) >= 1
    assert run.plot_title("M8194H", str(source)).startswith("MP3 one (")

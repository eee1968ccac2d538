"""`mpc disasm` reaches the family an image names: the M8194H disassembles its images, the
families without an image format say so as a usage error."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import main
from mplang.cli.common import EXIT_USAGE

ROOT = Path(__file__).resolve().parents[3]
SAMPLES = ROOT / "samples"


@pytest.mark.parametrize(("listing", "title"), [
    (SAMPLES / "fatek" / "jog_forward.fbs", "FATEK FBs-PLC"),
    (SAMPLES / "csim" / "jog.csim", "CSIM"),
])
def test_family_images_are_refused_by_name(tmp_path: Path, listing: Path, title: str) -> None:
    runner = CliRunner()
    image = tmp_path / "build.json"
    built = runner.invoke(main, ["build", str(listing), "--format", "json", "-o", str(image)])
    assert built.exit_code == 0, built.output
    result = runner.invoke(main, ["disasm", str(image)])
    assert result.exit_code == EXIT_USAGE
    assert f"{title} images cannot be disassembled" in " ".join(result.output.split())


def test_an_m8194h_image_goes_to_the_m8194h(tmp_path: Path) -> None:
    runner = CliRunner()
    image = tmp_path / "tour.json"
    built = runner.invoke(main, ["build", str(SAMPLES / "tour.mp"), "-o", str(image)])
    assert built.exit_code == 0, built.output
    result = runner.invoke(main, ["disasm", str(image)])
    assert result.exit_code == 0, result.output
    assert "MP 100 tour" in result.output

"""`mpc plot` for the FATEK and CSIM families: drawn from the family's samples, in the asked
format and size, with the M8194H's exit codes."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang import csim
from mplang.cli import EXIT_OK, EXIT_OUTPUT, EXIT_RUN_FAILED, EXIT_USAGE, main
from mplang.family.trace import trace_from_samples
from mplang.tools.plot import PlotRequest, render

ROOT = Path(__file__).resolve().parents[3]
SAMPLES = ROOT / "samples"


def run(*args: str | Path) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


def png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = struct.unpack(">II", data[16:24])
    return width, height


def test_a_csim_listing_is_plotted_from_its_samples(tmp_path: Path) -> None:
    image = tmp_path / "helix.png"
    code, out, _ = run("plot", SAMPLES / "csim" / "helix.csim", "-o", image, "--width", "320",
                       "--height", "300")
    assert code == EXIT_OK
    assert out == f"helix: finished after 675.986 ms simulated; 676 samples plotted to {image}\n"
    assert png_size(image.read_bytes()) == (320, 300)


def test_the_image_is_the_drawing_of_the_samples(tmp_path: Path) -> None:
    listing = SAMPLES / "csim" / "two_axis_2ma.csim"
    image = tmp_path / "line.svg"
    assert run("plot", listing, "-o", image, "--width", "400", "--height", "300")[0] == EXIT_OK
    outcome = csim.run_build(csim.check_native([listing]), None, 3600.0)
    title = (f"{outcome.called} ({listing}) on the virtual CSIM\nfinished after "
             f"{outcome.time_s:.3f} s simulated, sampled every 1 ms")
    expected = render(trace_from_samples(outcome.samples, 0.001, "units"),
                      PlotRequest(title, "svg", 400, 300))
    assert image.read_bytes() == expected


@pytest.mark.parametrize("target", ["fbs-fun147", "csim"])
def test_an_mp_job_is_plotted_for_a_family_target(tmp_path: Path, target: str) -> None:
    image = tmp_path / f"gantry-{target}.svg"
    code, out, _ = run("plot", SAMPLES / "fatek" / "gantry.mp", "--target", target, "-o",
                       image, "--trace-period", "0.005", "--width", "300", "--height", "300")
    assert code == EXIT_OK and out.startswith("gantry: finished")
    assert image.read_bytes().startswith(b"<?xml")


def test_a_run_that_does_not_finish_is_plotted_and_exits_5(tmp_path: Path) -> None:
    image = tmp_path / "drvc.png"
    code, out, err = run("plot", SAMPLES / "fatek" / "drvc_three_speeds.fbs", "-o", image,
                         "--width", "300", "--height", "300")
    assert code == EXIT_RUN_FAILED and image.exists()
    assert out.startswith("drvc_three_speeds: FAILED after 5348.322 ms")
    assert err.startswith("samples/fatek/drvc_three_speeds.fbs:13:1: error[R201]: step 3 waits "
                          "for X0")


def test_output_problems_and_bad_calls(tmp_path: Path) -> None:
    listing = SAMPLES / "csim" / "jog.csim"
    assert run("plot", listing, "-o", tmp_path / "a.gif")[0] == EXIT_USAGE
    assert run("plot", listing, "-o", tmp_path / "none" / "a.png")[0] == EXIT_OUTPUT
    code, _, err = run("plot", listing, "-o", tmp_path / "a.png", "--call", "$NOPE")
    assert code == EXIT_USAGE and "--call" in err

"""`mpc plot` and `mplang.tools.plot`: the image has the asked size and format, shows what the run
did, and every kind of bad input gets its own exit code."""

from __future__ import annotations

import struct
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import main
from mplang.family.trace import Trace
from mplang.m8194h.compiler import Options, compile_paths, compile_source
from mplang.m8194h.run import run_build
from mplang.tools.plot import PlotRequest, path_planes, render

SAMPLES = Path(__file__).resolve().parents[2] / "samples"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

# Z plunges while X and Y trace a quarter arc: all three path planes are drawn.
ARC_AND_PLUNGE = """MP 41 arc_and_plunge
    SET_V XYZ, 20000
    FIXED_MOVE Z, -2000
    STOP_WAIT Z
    AXIS_ASSIGN X, Y, 0
    VECTOR_SPEED 0
    SET_VV 20000
    ARC_CCW 0, 8000, 8000, 8000
    STOP_WAIT X
    FIXED_MOVE Z, 2000
    STOP_WAIT Z
END MP
"""


def png_size(data: bytes) -> tuple[int, int]:
    """Width and height from the IHDR chunk (bytes 16-24 of every PNG)."""
    assert data[:8] == PNG_SIGNATURE and data[12:16] == b"IHDR"
    width, height = struct.unpack(">II", data[16:24])
    return width, height


def invoke(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, list(args))
    return result.exit_code, result.stdout, result.stderr


@pytest.fixture
def project(tmp_path: Path) -> Path:
    (tmp_path / ".git").mkdir()
    (tmp_path / "arc.mp").write_text(ARC_AND_PLUNGE)
    return tmp_path


def test_sample_with_arcs_plots_to_a_png_of_the_asked_size(tmp_path: Path) -> None:
    """samples/home_then_square.mp: two laps of a 100 mm square with 10 mm corner arcs whose
    lower left corner is at (30 mm, 30 mm), 1000 pulses per mm."""
    sources = sorted(str(p) for p in SAMPLES.glob("*.mp"))
    out = tmp_path / "square.png"
    code, stdout, _ = invoke("plot", *sources, "--call", "home_then_square", "-o", str(out),
                             "--width", "480", "--height", "360", "--trace-period", "0.01")
    assert code == 0, stdout
    assert png_size(out.read_bytes()) == (480, 360)
    assert "MP131: finished" in stdout and str(out) in stdout
    build = compile_paths([Path(s) for s in sources], Options())
    trace = run_build(build, "home_then_square", trace_period=0.01).trace
    assert trace is not None
    x, y = trace.lp[0], trace.lp[1]
    assert max(x) == 130000 and max(y) == 130000
    on_square = [k for k in range(len(trace)) if y[k] >= 30000 and x[k] >= 30000]
    assert min(x[k] for k in on_square) == 30000 and min(y[k] for k in on_square) == 30000
    assert (x[-1], y[-1]) == (0, 0)


def test_svg_output_has_the_size_at_100_dpi_and_no_date(project: Path) -> None:
    out = project / "arc.svg"
    code, _, _ = invoke("plot", str(project / "arc.mp"), "-o", str(out), "--width", "500",
                        "--height", "400")
    assert code == 0
    root = ElementTree.fromstring(out.read_bytes())
    assert root.tag.endswith("svg")
    assert (root.get("width"), root.get("height")) == ("360pt", "288pt")  # px * 72 / 100
    assert b"<dc:date>" not in out.read_bytes()


def test_z_moves_add_the_xz_and_yz_planes() -> None:
    build = compile_source(ARC_AND_PLUNGE)
    trace = run_build(build, trace_period=0.005).trace
    assert trace is not None
    assert trace.moving_axes() == ("X", "Y", "Z")
    assert path_planes(trace) == [("X", "Y"), ("X", "Z"), ("Y", "Z")]
    assert trace.extent("Z") == (-2000, 0)
    assert trace.extent("X") == (0, 8000) and trace.extent("Y") == (0, 8000)
    flat = run_build(compile_source(ARC_AND_PLUNGE.replace("Z, -2000", "Z, 0")
                                    .replace("Z, 2000", "Z, 0")), trace_period=0.005).trace
    assert flat is not None and path_planes(flat) == [("X", "Y")]


def test_rendering_is_deterministic_and_handles_a_run_without_motion() -> None:
    trace = run_build(compile_source("MP 1\n  VAR1 = 1\nEND MP\n"), trace_period=0.001).trace
    assert trace is not None and trace.moving_axes() == ()
    request = PlotRequest("no motion", "svg", 300, 300)
    first = render(trace, request)
    assert first == render(trace, request)
    assert png_size(render(trace, PlotRequest("no motion", "png", 320, 300))) == (320, 300)


def test_render_refuses_unknown_formats_and_empty_traces() -> None:
    trace = Trace(0.001)
    with pytest.raises(ValueError, match="no samples"):
        render(trace, PlotRequest("empty"))
    with pytest.raises(ValueError, match="format"):
        render(trace, PlotRequest("empty", "gif"))


def test_failing_program_is_plotted_up_to_the_failure_and_exits_5(project: Path) -> None:
    (project / "fail.mp").write_text("MP 1\n  FIXED_MOVE X, 100000\n  TIMER 30\n"
                                     "  VAR1 = VAR2 / VAR3\nEND MP\n")
    out = project / "fail.png"
    code, stdout, err = invoke("plot", str(project / "fail.mp"), "-o", str(out), "--width",
                               "400", "--height", "300")
    assert code == 5
    assert "FAILED" in stdout and "division by zero" in err
    assert png_size(out.read_bytes()) == (400, 300)


def test_usage_errors_exit_2(project: Path) -> None:
    source = str(project / "arc.mp")
    for output in ("out.jpg", "out", "-", "out.png.txt"):
        code, _, err = invoke("plot", source, "-o", str(project / output))
        assert code == 2 and ".png or .svg" in err, (output, err)
    assert invoke("plot", source)[0] == 2  # no -o
    assert invoke("plot", source, "-o", str(project / "a.png"), "--width", "10")[0] == 2
    assert invoke("plot", source, "-o", str(project / "a.png"), "--call", "MP99")[0] == 2
    assert not (project / "a.png").exists()


def test_input_source_and_output_errors(project: Path) -> None:
    source = str(project / "arc.mp")
    code, _, err = invoke("plot", str(project / "missing.mp"), "-o", str(project / "a.png"))
    assert code == 3 and "no such file" in err
    (project / "bad.mp").write_text("MP 1\n  FIXD_MOVE X, 1\nEND MP\n")
    code, _, err = invoke("plot", str(project / "bad.mp"), "-o", str(project / "a.png"))
    assert code == 1 and "bad.mp:2:3: error[E201]" in err
    code, _, err = invoke("plot", source, "-o", str(project / "nowhere" / "a.png"))
    assert code == 4 and "no directory" in err
    (project / "dir.png").mkdir()
    code, _, err = invoke("plot", source, "-o", str(project / "dir.png"))
    assert code == 4 and "is a directory" in err
    assert not (project / "a.png").exists()


def test_a_family_trace_is_drawn_with_its_unit() -> None:
    """Another family's samples (here in CSIM units) label the panels with their unit; the
    M8194H's traces keep pulses."""
    from matplotlib.figure import Figure

    from mplang.family.trace import trace_from_samples
    from mplang.tools import plot

    samples = [(k / 100, {"X": float(k), "Y": k / 2, "Z": 0.0, "U": 0.0}) for k in range(50)]
    labels = {}
    for trace in (trace_from_samples(samples, 0.01, "units"), Trace(0.01)):
        if not len(trace):
            trace.time = [0.0, 1.0]
            trace.lp = trace.ep = [[0, 10], [0, 5], [0, 0], [0, 0]]
            trace.velocity = [[0.0, 10.0], [0.0, 5.0], [0.0, 0.0], [0.0, 0.0]]
        figure = Figure()
        plot._draw(figure, trace)
        labels[trace.unit] = {panel.get_ylabel() for sub in figure.subfigs for panel in sub.axes}
    assert {"Y (units)", "X (units)", "X (units/s)"} <= labels["units"]
    assert {"Y (pulses)", "X (pulses)", "X (pulses/s)"} <= labels["pulses"]
    assert render(trace_from_samples(samples, 0.01, "units"),
                  PlotRequest("family", "png", 300, 300))[:8] == PNG_SIGNATURE

"""The shared run trace: one row per instant, whatever float dust the families' clocks carry."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import main
from mplang.family.trace import Trace, trace_from_samples

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "samples"


def test_near_equal_sample_times_are_one_row_with_the_later_reading() -> None:
    trace = trace_from_samples([(0.213, {"X": 95.0}), (0.214, {"X": 100.0}),
                                (0.21400000000000002, {"X": 100.005})], 0.001, "units")
    assert trace.time == [0.213, 0.21400000000000002]
    assert trace.lp[0] == [95.0, 100.005]
    assert trace.velocity[0][-1] == pytest.approx((100.005 - 95.0) / (0.21400000000000002 - 0.213))


def test_a_recorded_instant_replaces_the_one_before() -> None:
    trace = Trace(0.001)
    trace.add(0.5, [(1, 1, 0.0)] * 4)
    trace.add(0.5 + 1e-12, [(2, 2, 5.0)] * 4)
    assert len(trace) == 1 and trace.lp[0] == [2]


@pytest.mark.parametrize("source", [
    SAMPLES / "csim" / "program_flow.csim", SAMPLES / "csim" / "jog.csim",
    SAMPLES / "fatek" / "jog_forward.fbs", SAMPLES / "tour.mp",
], ids=lambda p: p.name)
def test_traces_of_every_family_have_one_row_per_time(tmp_path: Path, source: Path) -> None:
    out = tmp_path / "trace.csv"
    result = CliRunner().invoke(main, ["run", str(source), "--trace", str(out),
                                       "--max-time", "5"])
    assert result.exit_code in (0, 5, 18), result.output  # 18: out of --max-time
    times = [line.split(",", 1)[0] for line in out.read_text().splitlines()[1:]]
    assert times and len(times) == len(set(times))

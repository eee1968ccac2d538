"""Continuous interpolation that runs for ever (7.4.2-7.4.10, LINE_2D_CONTINUE and
MIX_2D_CONTINUE): the chain forgets the segments it has finished, so a program that loops
segments keeps a bounded path however long it runs, and every sampled position and speed is
the one the unbounded chain gave."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from mplang.ir import catalogue
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.paths import _ChainPath
from mplang.m8194h.sim.preload import preload

CAPACITY = catalogue.load().profile.limit("motion_queue")

# a stadium lap (line, half circle, line back, half circle) for ever, one chain
LAPS = """MP 41
  MIX_2D_INITIAL X, Y, 1, 300, 18000, 500000
  LABEL top
  MIX_2D_CONTINUE 0, LINE_2D, 0, 0, 20000, 0
  MIX_2D_CONTINUE 0, ARC_CCW, 0, 5000, 0, 10000
  MIX_2D_CONTINUE 0, LINE_2D, 0, 0, -20000, 0
  MIX_2D_CONTINUE 0, ARC_CCW, 0, -5000, 0, -10000
  GOTO top
END MP
"""

# a zig-zag of short lines for ever: many segments per second
ZIGZAG = """MP 41
  LINE_2D_INITIAL X, Y, 300, 18000, 500000
  LABEL top
  LINE_2D_CONTINUE 0, 300, 100
  LINE_2D_CONTINUE 0, -300, 100
  GOTO top
END MP
"""


def loaded(source: str) -> VirtualController:
    build = compile_source(source)
    assert build.ok, [d.render() for d in build.diagnostics]
    vc = VirtualController()
    preload(vc, build)
    return vc


def sampled(source: str, until: float, step: float) -> tuple[list[tuple[int, ...]], int]:
    """Positions and speeds of X and Y every `step` seconds up to `until`, and the most
    parts the running chain's path ever held."""
    vc = loaded(source)
    vc.call(41)
    samples = []
    most = 0
    t = 0.0
    while t < until:
        t = round(t + step, 9)
        vc.advance(t)
        assert vc.running and vc.error is None
        m = vc.motion
        samples.append((m.lp(1, t), m.lp(2, t), m.cv(1, t), m.cv(2, t)))
        chain = m._open
        assert chain is not None and chain.started
        most = max(most, len(chain.path.parts))
    return samples, most


@pytest.mark.parametrize("source", [LAPS, ZIGZAG], ids=["mix_2d_laps", "line_2d_zigzag"])
def test_7_4_continuous_interpolation_looping_for_600_s_keeps_a_bounded_path(
        source: str) -> None:
    _samples, most = sampled(source, 600.0, 5.0)
    # the segments not reached yet (at most the motion queue's bound), the one running
    # and the one before it: nothing grows with the time simulated
    assert most <= CAPACITY + 2


def test_7_4_forgetting_finished_segments_changes_no_sampled_value(
        monkeypatch: pytest.MonkeyPatch) -> None:
    bounded, most = sampled(ZIGZAG, 20.0, 0.01)
    monkeypatch.setattr(_ChainPath, "forget", lambda self, s: None)
    unbounded, grown = sampled(ZIGZAG, 20.0, 0.01)
    assert grown > 10 * most  # the reference really kept every segment
    assert bounded == unbounded  # positions and speeds, exactly


def test_7_4_mpc_run_of_a_continuous_loop_ends_at_max_time(tmp_path: Path) -> None:
    (tmp_path / "laps.mp").write_text(LAPS)
    result = subprocess.run([sys.executable, "-m", "mplang", "run", "laps.mp", "--max-time",
                             "600"], capture_output=True, text=True, timeout=300,
                            cwd=tmp_path)
    assert result.returncode == 18, result.stderr  # out of --max-time: 18 since issue 14 item 4
    head = re.search(r"MP41: FAILED after ([\d.]+) ms simulated", result.stdout)
    assert head is not None, result.stdout
    assert float(head.group(1)) == 600_000.0
    assert "without finishing" in result.stderr and "Traceback" not in result.stderr

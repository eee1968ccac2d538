"""FATEK and CSIM runs can be watched and stopped as the M8194H's are (`mplang.family.watch`,
`mpc run` on a terminal and Ctrl-C), and run without a time limit (issue 14 item 4)."""

from __future__ import annotations

import math
from pathlib import Path

from mplang import csim, fatek
from mplang.family.run_error import SourcePlace
from mplang.family.watch import Where

SAMPLES = Path(__file__).resolve().parents[2] / "samples"

LOOP_CSIM = "$TOP\nN1=N1+1  # mpc: ignore[W701]\nJP $TOP\n"


class StopAfter:
    """A watch that stops the run on its n-th call and keeps the places it was shown."""

    def __init__(self, calls: int) -> None:
        self.calls = calls
        self.places: list[tuple[float, SourcePlace]] = []

    def __call__(self, time_s: float, where: Where) -> bool:
        self.places.append((time_s, where()))
        return len(self.places) >= self.calls


def test_a_fatek_jog_stops_on_the_watch_at_its_step() -> None:
    listing = SAMPLES / "fatek" / "example4_jog_forward.fbs"
    watch = StopAfter(2)  # the watch sees the run before every step
    run = fatek.run_build(fatek.check_native([listing]), None, math.inf, watch=watch)
    assert not run.finished and run.error is None and run.failure is None
    time_s, place = watch.places[-1]
    assert place.file is not None and Path(place.file).name == listing.name
    assert place.line is not None
    assert run.time_s == time_s


def test_a_csim_loop_stops_on_the_watch_at_its_line(tmp_path: Path) -> None:
    listing = tmp_path / "loop.csim"
    listing.write_text(LOOP_CSIM)
    build = csim.check_native([listing])
    assert build.ok, [d.message for d in build.diagnostics]
    watch = StopAfter(500)
    run = csim.run_build(build, None, math.inf, watch=watch)
    assert not run.finished and run.error is None and run.failure is None
    _, place = watch.places[-1]
    assert place.file == str(listing) and place.line in (1, 2, 3)
    assert run.to_json()["vars"]


def test_without_a_watch_the_runs_are_unchanged() -> None:
    listing = SAMPLES / "fatek" / "jog_forward.fbs"
    build = fatek.check_native([listing])
    plain = fatek.run_build(build, None, 3600.0)
    watched = fatek.run_build(build, None, 3600.0, watch=lambda time_s, where: False)
    assert plain.to_json() == watched.to_json()
    flow = csim.check_native([SAMPLES / "csim" / "program_flow.csim"])
    assert csim.run_build(flow, None, 600.0).to_json() == \
        csim.run_build(flow, None, 600.0, watch=lambda time_s, where: False).to_json()

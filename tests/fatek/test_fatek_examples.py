"""Every worked example of the FBs-PLC chapter (FB = shared/manuals/002_9f89b86e496499fb.txt)
runs as printed on the virtual PLC and ends where the manual says: all 22 of them, the four
coordinate forms of 11.2 (FB 65-99) included, with `DRV ABS, ,0,Ut` going to 0 mm (FB 66, 75);
and the WR+1 status bits of 11.6 (FB 757-763) change as the table runs."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from mplang.fatek import FamilyRun, check_native, run_build
from mplang.fatek.model import Register
from mplang.fatek.profile import load

SAMPLES = Path(__file__).resolve().parents[2] / "samples" / "fatek"
MM = 200  # coordinates.fbs: 1 mm = 200 Ps


@dataclass(frozen=True)
class Example:
    """One worked example: where the manual prints it, the sample that transcribes it (and
    cites those lines), and the pulse position it must reach: the end of leg `leg` of the
    run (None: where the run ends)."""

    lines: tuple[int, ...]
    sample: str
    position: int
    leg: int | None = None


EXAMPLES = {
    # 11.2: absolute and relative coordinates on a mm axis (FB 58-99)
    "abs-100-to-300": Example((65, 84), "coordinates.fbs", 300 * MM, 1),
    "abs-300-to-0": Example((66, 75), "coordinates.fbs", 0, 2),
    "adr-100-to-300": Example((69, 99), "coordinates.fbs", 300 * MM, 4),
    "adr-300-to-0": Example((70, 90), "coordinates.fbs", 0, 5),
    # the ADR/ABS note after DRVZ (FB 1062-1074), repeated on the FUN147 pages (FB 2305-2317)
    "adr-30000-to-minus-10000": Example((1066, 2309), "adr_abs_pairs.fbs", -10_000, 1),
    "adr-minus-10000-to-10000": Example((1074, 2317), "adr_abs_pairs.fbs", 10_000, 2),
    "abs-30000-to-minus-10000": Example((1066, 2309), "adr_abs_pairs.fbs", -10_000, 4),
    "abs-minus-10000-to-10000": Example((1074, 2317), "adr_abs_pairs.fbs", 10_000, 5),
    # 11.6: the DRVC chain and the FUN140 and FUN147 program formats
    "drvc-three-speeds": Example((988, 997), "drvc_three_speeds.fbs", 85_000),
    "format-example": Example((1161, 1178), "format_example.fbs", 5_000),
    "fun147-format-example": Example((2406, 2417), "fun147_format_example.fbs", 3_500),
    # the jog and home-return ladders (FB 1301-1397, 2901-3149)
    "jog-forward": Example((1301, 1309), "jog_forward.fbs", 1_000_000),
    "jog-backward": Example((1389, 1397), "jog_backward.fbs", -1_000_000),
    "home-method-1": Example((2901, 2909), "home_method_1.fbs", -59_999),
    "home-method-2": Example((3136, 3149), "home_method_2.fbs", 948_999),
    # 11.7 examples 3-6 (FB 3457-3877)
    "example3-drvz-md2": Example((3485,), "example3_drvz_md2.fbs", 100),
    "example4-jog-forward": Example((3710, 3718), "example4_jog_forward.fbs", 100_000_000),
    "example5-jog-backward": Example((3721, 3729), "example5_jog_backward.fbs", -100_000_000),
    "example6-cycle": Example((3858, 3877), "example6_cycle.fbs", 0),
}
"""The chapter's listings, by the notes' ids (shared/manuals/notes/fatek-csim.md 1.4.3, 1.5):
the 8 lines of 11.2, the 4 of the ADR/ABS note, and the 10 program listings make 22."""

PRINTED_LINES = {65, 66, 69, 70, 75, 84, 90, 99, 1066, 1074, 2309, 2317,
                 988, 1161, 1301, 1389, 2901, 3136, 3710, 3721, 3858, 2406}


def run_sample(name: str) -> FamilyRun:
    return run_build(check_native([SAMPLES / name]), None, 6000.0)


def cited(sample: str) -> set[int]:
    """Every FB line number a sample's comments cite (singly or as the ends of a range)."""
    text = (SAMPLES / sample).read_text()
    found: set[int] = set()
    for group in re.findall(r"FB ([0-9 ,\-]+)", text):
        for part in group.split(","):
            ends = [int(p) for p in part.strip().split("-") if p.strip().isdigit()]
            found.update(range(ends[0], ends[-1] + 1) if ends else ())
    return found


def test_the_22_worked_examples_are_all_transcribed() -> None:
    """Each printed listing is cited by the sample that transcribes it, and each sample runs
    it (the parametrized test below)."""
    assert len(PRINTED_LINES) == 22
    assert {line for e in EXAMPLES.values() for line in e.lines} >= PRINTED_LINES
    for name, example in EXAMPLES.items():
        assert set(example.lines) <= cited(example.sample), (name, example.sample)


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_every_worked_example_runs_as_printed_to_its_documented_end(name: str) -> None:
    example = EXAMPLES[name]
    run = run_sample(example.sample)
    assert not (run.error or "").startswith("PLC error"), run.error
    if example.leg is None:
        assert run.positions[0] == example.position, run.error
    else:
        leg = run.legs[example.leg]
        assert round(leg.position(0, leg.t_end)) == example.position


def test_11_2_abs_stroke_0_goes_from_300_mm_to_0_mm() -> None:
    """FB 66 and 75: `DRV ABS, ,0,Ut` is the move from 300 mm to 0 mm, not a run for ever."""
    run = run_sample("coordinates.fbs")
    assert run.finished and run.error is None
    third = run.legs[2]
    assert third.start[0] == 300 * MM and third.targets == {0: 0}
    assert build_lint("coordinates.fbs") == []


def test_11_6_drv_stroke_0_still_runs_on_for_adr() -> None:
    """FB 955-957 is the rule of relative strokes: ADR 0 runs until EXT ends it."""
    text = ("TABLE t FUN140 Ps0 SR=R100 WR=R50\n001 SPD 1000\n    DRV ADR,+,0,Ps\n"
            "    EXT X0\n    GOTO NEXT\n002 SPD 1000\n    DRV ABS,,0,Ps\n    MEND\n"
            "SIM X0 ON AT 2\n")
    path = Path("t.fbs")
    build = check_native([path], texts={path: text})
    assert build.ok, [d.render() for d in build.diagnostics]
    run = run_build(build, None, 60.0)
    assert run.finished and run.positions[0] == 0
    assert run.legs[0].targets is None and round(run.legs[0].position(0, 2.0)) > 0
    assert run.legs[1].targets == {0: 0}


def build_lint(sample: str) -> list[str]:
    return [d.code for d in check_native([SAMPLES / sample]).diagnostics]


WAITING, CONTINUOUS, PULSING, DONE = 1 << 9, 1 << 10, 1 << 12, 1 << 14


def flags_at(run: FamilyRun, when: float) -> int:
    """WR+1 just after `when` (the last change at or before it)."""
    value = run.wr_trace[0][1]
    for time, flags in run.wr_trace:
        if time <= when:
            value = flags
    return value


def test_11_6_wr1_b12_pulsing_and_b9_waiting_for_the_transition() -> None:
    """Example 6 (FB 3858-3877): B12 while step 1 outputs its pulses, then B9 (and DN, B14)
    during its WAIT TIME,100; B9 while step 2 waits for M200 (ON at 25 s)."""
    run = run_sample("example6_cycle.fbs")
    first = run.legs[0]
    assert flags_at(run, first.t0 + 1.0) == PULSING | 4  # B0-B7: 4 steps
    assert flags_at(run, first.t_end + 0.5) == WAITING | DONE | 4
    second = run.legs[1]
    assert flags_at(run, second.t0 + 0.1) & (PULSING | WAITING) == PULSING
    assert flags_at(run, (second.t_end + 25.0) / 2) & (PULSING | WAITING) == WAITING
    assert flags_at(run, run.legs[2].t0 + 0.1) & (PULSING | WAITING) == PULSING
    # it ends waiting for X16: B9 stays on, nothing pulses, DN is on
    final = run.registers[Register("R", 2022)]
    assert final == WAITING | DONE | 4


def test_11_6_wr1_b10_continuous_run_until_ext_cuts_it() -> None:
    """FB 760: B10 while a stroke of 0 runs on; EXT X0 ends it, and B10/B12 go off."""
    text = ("TABLE t FUN140 Ps0 SR=R100 WR=R50\n001 SPD 1000\n    DRV ADR,+,0,Ps\n"
            "    EXT X0\n    GOTO NEXT\n002 SPD 1000\n    DRV ADR,+,100,Ps\n    MEND\n"
            "SIM X0 ON AT 2\n")
    path = Path("t.fbs")
    run = run_build(check_native([path], texts={path: text}), None, 60.0)
    assert run.finished
    assert flags_at(run, 1.0) == CONTINUOUS | PULSING | 2
    assert flags_at(run, 2.0) & (CONTINUOUS | PULSING) == PULSING  # step 2 pulses at once
    assert run.registers[Register("R", 51)] == DONE | 2


def test_11_6_the_literal_reading_of_fb_955_keeps_abs_0_running(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """semantics.abs_zero = 'continuous' (the profile's visible alternative): ABS 0 runs on
    forward, and the checker warns (W603) that nothing in the step ends it."""
    monkeypatch.setitem(load().raw["semantics"], "abs_zero", "continuous")
    build = check_native([SAMPLES / "coordinates.fbs"])
    assert [d.code for d in build.diagnostics] == ["W603"]
    run = run_build(build, None, 30.0)
    assert not run.finished and "runs for ever" in (run.error or "")
    assert run.legs[2].targets is None and run.positions[0] > 300 * MM

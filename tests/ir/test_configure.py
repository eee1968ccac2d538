"""INIT, INTERRUPTS and TRIGGERS blocks: the frames the manual's examples imply, the checks,
and the effect on the virtual controller (chapter 8, 7.3.12, chapter 10)."""

from __future__ import annotations

import json
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.m8194h.compiler import BuildResult, Options, compile_paths, compile_source
from mplang.m8194h.image import render_json, render_listing, render_triggers
from mplang.m8194h.sim.controller import VirtualController
from mplang.tools.fmt import format_source

ROOT = Path(__file__).resolve().parents[2]
CONTROLLER_SAMPLE = ROOT / "samples" / "controller" / "controller.mp"

# Chapter 8.1 "Related example" (RS 9760-9785): the five settings, then LOAD_INITIAL.
CHAPTER8_EXAMPLE = """INIT
    SET_PULSE_MODE INITIAL_XYZU, 0
    SET_MAX_V INITIAL_XY, 200000
    SET_HLMT INITIAL_XYZU, 0, 0
    LIMITSTOP_MODE INITIAL_X, 0
    SET_NHOME INITIAL_XY, 0
END INIT
"""
# Codes from the appendix table (RS 11521-11525, 11617); axis register INITIAL_* (Table 5).
CHAPTER8_FRAMES = [
    [0x0A0C, 0x1F, 0],
    [0x0A0D, 0x13, 0x0003, 0x0D40],  # 200000 = 0x00030D40, MSW first
    [0x0A0E, 0x1F, 0, 0],
    [0x0A0F, 0x11, 0],
    [0x0A10, 0x13, 0],
    [0x0AC8],  # RSM_LOAD_INITIAL (8.1)
]
# The factory defaults of chapter 8 (RS 9701-9722), as the table they describe.
FACTORY_DEFAULTS = """INIT
    SET_PULSE_MODE XYZU, 0
    SET_MAX_V XYZU, 200000
    SET_HLMT XYZU, 0, 0
    LIMITSTOP_MODE XYZU, 0
    SET_NHOME XYZU, 0
    SET_HOME_EDGE XYZU, 0
    CLEAR_SLMT XYZU
    SET_ENCODER XYZU, 0, 0, 0
    SERVO_OFF XYZU
    SET_ALARM XYZU, 0, 0
    SET_INPOS XYZU, 0, 0
    SET_FILTER XYZU, 0, 0
    VRING_DISABLE XYZU
    AVTRI_DISABLE XYZU
    EXD_DISABLE XYZU
END INIT
"""
# 7.3.12 "Example1: Using call the ISR to set multi-group compare" (RS 8030-8080), written
# with an INTERRUPTS block for the first factor and ON lines in the ISRs for the rest.
EXAMPLE_7312 = """INTERRUPTS main
    ON X P>=C+ CALL ISR 1
END INTERRUPTS
MP 41 main
    SET_MAX_V XYZU, 8000
    NORMAL_SPEED XYZU, 0
    SET_V XYZU, 2000
    SET_A XYZU, 100000
    SET_SV XYZU, 100
    SET_COMPARE X, 0, 0, 2000
    FIXED_MOVE X, 16000
END MP
ISR 1
    SET_COMPARE X, 0, 0, 4000
    ON X P>=C+ CALL ISR 2
    FIXED_MOVE Y, 1000
END ISR
ISR 2
    SET_COMPARE X, 0, 0, 6000
    ON X P>=C+ CALL ISR 3
    FIXED_MOVE Z, 1000
END ISR
ISR 3
    FIXED_MOVE U, 1000
END ISR
"""


def built(source: str, name: str = "config.mp") -> BuildResult:
    result = compile_source(source, name)
    assert result.ok, "\n".join(d.render() for d in result.diagnostics)
    return result


def codes(source: str) -> list[tuple[str, int]]:
    return [(d.code, d.span.line) for d in compile_source(source, "config.mp").diagnostics]


def run_mp(build: BuildResult, slot: int) -> VirtualController:
    controller = VirtualController(word_order=build.word_order)
    for image in build.programs:
        assert controller.load_frames(image.program.kind, image.placement.slot,
                                      image.frames) is None
    controller.call(slot)
    outcome = controller.run(max_time=60)
    assert outcome.finished and outcome.error is None
    return controller


# ------------------------------------------------------------------------------- INIT
def test_chapter8_example_compiles_to_the_initial_table_frames() -> None:
    result = built(CHAPTER8_EXAMPLE)
    assert result.init is not None
    assert result.init.frames == CHAPTER8_FRAMES
    assert result.programs == []
    image = json.loads(render_json(result))
    assert image["init"]["frames"] == CHAPTER8_FRAMES
    assert image["init"]["frame_lines"] == [2, 3, 4, 5, 6, 7]


def test_plain_axis_names_mean_the_initial_table_inside_init() -> None:
    plain = CHAPTER8_EXAMPLE.replace("INITIAL_", "")
    assert built(plain).init.frames == CHAPTER8_FRAMES  # type: ignore[union-attr]


def test_every_factory_default_setting_writes_the_table_for_all_axes() -> None:
    result = built(FACTORY_DEFAULTS)
    assert result.init is not None
    frames = result.init.frames
    assert len(frames) == 16 and frames[-1] == [0x0AC8]
    assert all(frame[1] == 0x1F for frame in frames[:-1])


def test_word_order_one_swaps_the_table_values() -> None:
    result = compile_source(CHAPTER8_EXAMPLE, "config.mp", Options(word_order=1))
    assert result.init is not None and result.init.frames[1] == [0x0A0D, 0x13, 0x0D40, 0x0003]


def test_init_checks() -> None:
    assert codes("INIT\n    FIXED_MOVE X, 100\nEND INIT\n") == [("E803", 2)]
    assert codes("INIT\n    SET_MAX_V X, VAR3\nEND INIT\n") == [("E804", 2)]
    assert codes("INIT\n    SET_MAX_V X, 100\nEND INIT\n") == [("E412", 2)]
    assert codes("INIT\n    SERVO_ON XY\n    SERVO_OFF Y\nEND INIT\n") == [("W801", 3)]
    assert codes("INIT\nEND INIT\nINIT\nEND INIT\n") == [("E801", 3)]


def test_macro_spelling_is_taken_as_its_initial_table_twin() -> None:
    result = built("INIT\n    RSM_MACRO_SET_MAX_V X, 200000\nEND INIT\n")
    assert result.init is not None and result.init.frames[0][:2] == [0x0A0D, 0x11]


# ---------------------------------------------------------------------- INTERRUPTS
def test_interrupts_block_puts_the_factor_then_enable_at_the_start_of_the_setup_program(
) -> None:
    result = built(EXAMPLE_7312)
    main = next(p for p in result.programs if p.program.name == "main")
    # the macro forms of RSM_INTFACTOR_ENABLE(AXIS_X, 4, ISR1) and RSM_ENABLE_INT (7.3.10-12)
    assert main.frames[1] == [0x0CAC, 1, 4, 1]
    assert main.frames[2] == [0x0CAA]
    isr1 = next(p for p in result.programs if p.program.kind == "isr" and p.placement.slot == 1)
    assert [0x0CAC, 1, 4, 2] in isr1.frames


def test_example_7312_fires_each_isr_when_its_compare_condition_is_met() -> None:
    controller = run_mp(built(EXAMPLE_7312), 41)
    axes = controller.snapshot()["axes"]
    assert axes == {"X": {"lp": 16000, "ep": 16000}, "Y": {"lp": 1000, "ep": 1000},
                    "Z": {"lp": 1000, "ep": 1000}, "U": {"lp": 1000, "ep": 1000}}
    started = [line for line in controller.log if "started" in line and "ISR" in line]
    assert [line.split(": ")[1] for line in started] == ["ISR1 started", "ISR2 started",
                                                         "ISR3 started"]


def test_without_the_wiring_no_isr_runs() -> None:
    unwired = EXAMPLE_7312.split("MP 41 main", 1)[1]
    controller = run_mp(built("MP 41 main" + unwired), 41)
    axes = controller.snapshot()["axes"]
    assert axes["X"]["lp"] == 16000 and axes["Y"]["lp"] == axes["Z"]["lp"] == 0


def test_multi_axis_on_line_wires_each_axis() -> None:
    result = built("INTERRUPTS go\n    ON XZ D-END CALL done\nEND INTERRUPTS\n"
                   "MP 1 go\n    FIXED_MOVE X, 10\nEND MP\nISR 5 done\n    VAR1 = 1\nEND ISR\n")
    go = result.programs[0]
    assert go.frames[1:4] == [[0x0CAC, 1, 7, 5], [0x0CAC, 4, 7, 5], [0x0CAA]]


def test_interrupt_lines_count_in_the_setup_programs_budget() -> None:
    body = "".join(f"    VAR{n} = {n}\n" for n in range(1, 7))
    source = (f"INTERRUPTS MP 1\n    ON X D-END CALL ISR 1\nEND INTERRUPTS\nMP 1\n{body}END MP\n"
              "ISR 1\n    VAR9 = 1\nEND ISR\n")
    assert [c for c, _ in codes(source)] == ["E503"]


def test_slmt_conflict_is_lifted_by_a_compare_value_in_the_setup_program() -> None:
    source = ("INIT\n    SET_SLMT X, 1000, -1000, 0\nEND INIT\n"
              "INTERRUPTS go\n    ON X P>=C+ CALL ISR 1\nEND INTERRUPTS\n"
              "MP 1 go\n    FIXED_MOVE X, 10\nEND MP\nISR 1\n    VAR1 = 1\nEND ISR\n")
    assert codes(source) == [("E814", 5)]
    assert codes(source.replace("    FIXED_MOVE X, 10", "    SET_COMPARE X, 0, 0, 5\n"
                                "    FIXED_MOVE X, 10")) == []
    assert codes(source.replace("SET_SLMT X, 1000, -1000, 0", "SET_SLMT X, 1000, -1000, 0\n"
                                "    CLEAR_SLMT X")) == [("W801", 3), ("W812", 6)]
    # factors that do not read the comparators do not conflict
    assert codes(source.replace("P>=C+", "D-END")) == []


# ------------------------------------------------------------------------ TRIGGERS
TRIGGERS = """TRIGGERS
    ON DI 8.0 OFF_TO_ON CALL cycle
    ON DI 8.1 ON_TO_OFF CALL MP 18
    ON DI 8.3 CHANGE ABORT COMMAND
    ON DI 8.4 OFF_TO_ON ABORT MACRO
    ON DI 9.6 ON HOLD X
    ON DI 15.15 OFF HOLD XYZU
END TRIGGERS
MP 1 cycle
    FIXED_MOVE X, 100
END MP
MP 18
    FIXED_MOVE Y, 100
END MP
"""


def test_trigger_table_entries_resolve_program_slots() -> None:
    result = built(TRIGGERS)
    assert result.triggers is not None
    assert result.triggers.entries == [
        {"group": 8, "channel": 0, "condition": "off-to-on", "event": "mp", "mp": 1,
         "line": 2},
        {"group": 8, "channel": 1, "condition": "on-to-off", "event": "mp", "mp": 18,
         "line": 3},
        {"group": 8, "channel": 3, "condition": "change", "event": "abort-command", "line": 4},
        {"group": 8, "channel": 4, "condition": "off-to-on", "event": "abort-macro", "line": 5},
        {"group": 9, "channel": 6, "condition": "on", "event": "hold-drive", "axes": 1,
         "line": 6},
        {"group": 15, "channel": 15, "condition": "off", "event": "hold-drive", "axes": 15,
         "line": 7},
    ]
    image = json.loads(render_json(result))
    assert image["triggers"]["enabled"] is True
    assert image["triggers"]["entries"] == result.triggers.entries


def test_trigger_table_renders_as_the_utilitys_window() -> None:
    text = render_triggers(built(TRIGGERS))
    rows = [line.split() for line in text.splitlines()[2:8]]
    assert rows[0] == ["8", "0", "OFF", "to", "ON", "MP1", "2"]
    assert rows[2] == ["8", "3", "Change", "Abort", "Command", "4"]
    assert rows[4] == ["9", "6", "ON", "Hold", "Drive", "X", "6"]
    assert "holding register 9" in text.splitlines()[0]


def test_build_id_changes_with_the_configuration() -> None:
    base = built(TRIGGERS).build_id()
    changed = built(TRIGGERS.replace("ON DI 8.3 CHANGE", "ON DI 8.3 ON")).build_id()
    with_init = built(CHAPTER8_EXAMPLE + TRIGGERS).build_id()
    assert len({base, changed, with_init}) == 3


# ------------------------------------------------------------------- the whole sample
def test_controller_sample_builds_formats_and_runs() -> None:
    result = compile_paths([CONTROLLER_SAMPLE])
    assert result.ok and not result.diagnostics, [d.render() for d in result.diagnostics]
    assert result.init is not None and result.triggers is not None
    text = CONTROLLER_SAMPLE.read_text()
    assert format_source(text) == text
    listing = render_listing(result, result.sources)
    assert "INIT  (" in listing and "TRIGGERS  (" in listing
    stroke = next(p for p in result.programs if p.program.name == "stroke")
    axes = run_mp(result, stroke.placement.slot).snapshot()["axes"]
    assert {name: axis["lp"] for name, axis in axes.items()} == {
        "X": 16000, "Y": 1000, "Z": 1000, "U": 1000}


# ----------------------------------------------------------------- property: ON lines
AXES = st.sampled_from(["X", "Y", "Z", "U", "XY", "XYZU", "AXIS_ZU", "W", "INITIAL_X"])
FACTORS = st.sampled_from(["PULSE", "P>=C-", "P<C-", "P<C+", "P>=C+", "C-END", "C-STA",
                           "D-END", "0", "7", "8", "P>C+", "DEND"])
TARGETS = st.sampled_from(["ISR 1", "ISR1", "handler", "ISR 21", "MP 1", "go", "nothing"])


@settings(max_examples=60, deadline=None)
@given(AXES, FACTORS, TARGETS)
def test_any_on_line_compiles_or_says_why(axis: str, factor: str, target: str) -> None:
    source = (f"INTERRUPTS go\n    ON {axis} {factor} CALL {target}\nEND INTERRUPTS\n"
              "MP 1 go\n    SET_COMPARE X, 0, 0, 5\n    FIXED_MOVE X, 10\nEND MP\n"
              "ISR 1 handler\n    VAR1 = 1\nEND ISR\n")
    result = compile_source(source, "on.mp")
    errors = {d.code for d in result.diagnostics if d.severity.value == "error"}
    good_axis = axis not in ("W", "INITIAL_X")
    good_factor = factor not in ("8", "P>C+", "DEND")
    good_target = target in ("ISR 1", "ISR1", "handler")
    assert result.ok == (good_axis and good_factor and good_target), errors
    if result.ok:
        go = next(p for p in result.programs if p.program.name == "go")
        wired = [f for f in go.frames if f[0] == 0x0CAC]
        assert len(wired) == len(axis.removeprefix("AXIS_")) and all(f[3] == 1 for f in wired)
        assert go.frames[len(wired) + 1] == [0x0CAA]
    else:
        assert errors <= {"E413", "E811", "E812"}


def test_other_families_refuse_configuration_blocks_instead_of_dropping_them() -> None:
    from mplang import csim, fatek

    for family, target, code in ((csim, "csim", "E721"), (fatek, "fbs-fun140", "E640"),
                                 (fatek, "fbs-fun147", "E640")):
        build = family.compile_mp([CONTROLLER_SAMPLE], Options(), target)
        lines = sorted(d.span.line for d in build.diagnostics if d.code == code
                       and "block cannot be expressed" in d.message)
        assert lines == [20, 31, 35], (target, [d.render() for d in build.diagnostics])
        assert not build.ok

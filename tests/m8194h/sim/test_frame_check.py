"""The device's own check of a sub-function's parameters (`mplang.m8194h.sim.frame_check`),
in process: each parameter kind of stdlib/m8194h/FORMAT.md at its edges (the last value it
takes and the first it does not), the catalogue's ranges and the profile's limits, the
refusal's words (`mpc sim -v` shows them) and the download error it makes (9.12, RS 10974:
0x06 a wrong IF operator, 0x10 a wrong VAR_CALCULATE operator, 0x0F otherwise). Expected
values come from the manual lines cited, the catalogue rows (stdlib/m8194h/commands.toml)
and the profile (stdlib/m8194h/device.toml); the Modbus side is in
tests/m8194h/test_device_refusals.py."""

from __future__ import annotations

import pytest
from deviceframes import CAT, CLOSE, CREATE, CREATE_ISR, ISR_CLOSE, macro, rtc

from mplang.ir.catalogue import Catalogue
from mplang.ir.macro import BVarRef, Operand, ProgramRef, VarRef
from mplang.m8194h.sim import frame_check
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.registers import RegisterMap

# the download errors of wErrCode (RS 10974) and the register-102 cause (RS 11368)
WRONG_IF, NOT_WRITTEN, WRONG_CALC, OUT_OF_RANGE = 0x06, 0x0F, 0x10, 0x02
IMMEDIATE = "-2000000000..2000000000"  # device.toml [variables] immediate_min/max


@pytest.fixture(autouse=True)
def _sets_worked_out_afresh() -> None:
    """Each test starts with no closed value set worked out: a set kept from an earlier test
    (or from the run before a mutant's) would answer for the code that works it out."""
    frame_check._ALLOWED.clear()


def refusal(vendor: str, *operands: Operand, catalogue: Catalogue = CAT) -> str | None:
    """`param: reason` of the first refused parameter of a frame, or None (accepted)."""
    bad = frame_check.check(catalogue.by_vendor[vendor], operands, catalogue.profile)
    return None if bad is None else f"{bad.param}: {bad.reason}"


def error(vendor: str, *operands: Operand) -> int | None:
    """The download error a refused frame makes (None: accepted)."""
    bad = frame_check.check(CAT.by_vendor[vendor], operands, CAT.profile)
    return None if bad is None else bad.download_error


def not_taken(value: int) -> str:
    return f"{value:#x} is not one of the values it takes"


# --- axis codes (Table 4, RS 970-979; Table 5 = Table 4 + 0x10, RS 981-988) ---------------

def test_an_axis_is_any_combination_of_table_4() -> None:
    """`axis`: SET_MAX_V takes "Axis or axes" (RS 1157), X=1, Y=2, Z=4, U=8 and their sums
    1..15; 0 names no axis, and a macro line takes no Table 5 code ("IT table can not be
    used inside macro program", RS 990)."""
    for axis in (1, 2, 5, 8, 15):
        assert refusal("RSM_MACRO_SET_MAX_V", axis, 8000) is None
    for axis in (0, 16, 0x11, 0x1F):
        assert refusal("RSM_MACRO_SET_MAX_V", axis, 8000) == f"axis: {not_taken(axis)}"


def test_a_single_axis_is_one_of_x_y_z_u() -> None:
    """`axis1`: INTFACTOR_ENABLE names one axis, "X, Y, Z or U (1 or 2 or 4 or 8)" (RS 8003)."""
    for axis in (1, 2, 4, 8):
        assert refusal("RSM_MACRO_INTFACTOR_ENABLE", axis, 0, 1) is None
    for axis in (0, 3, 15, 16):
        assert refusal("RSM_MACRO_INTFACTOR_ENABLE", axis, 0, 1) == f"axis: {not_taken(axis)}"


def test_the_third_axis_of_an_assignment_may_be_none() -> None:
    """`axis1_or_none`: AXIS_ASSIGN's axis3 takes one axis or 0, "Without 3rd axis the value
    is 0" (RS 5709); its axis1 does not take 0."""
    assert refusal("RSM_MACRO_AXIS_ASSIGN", 1, 2, 0) is None
    assert refusal("RSM_MACRO_AXIS_ASSIGN", 1, 2, 8) is None
    assert refusal("RSM_MACRO_AXIS_ASSIGN", 1, 2, 3) == f"axis3: {not_taken(3)}"
    assert refusal("RSM_MACRO_AXIS_ASSIGN", 1, 2, 16) == f"axis3: {not_taken(16)}"
    assert refusal("RSM_MACRO_AXIS_ASSIGN", 0, 2, 4) == f"axis1: {not_taken(0)}"


def test_a_real_time_setting_takes_table_5_codes_for_the_initial_table() -> None:
    """`axis_it`: SET_PULSE_MODE, "Table 4 or Table 5" (RS 1081), takes 1..15 and
    0x11..0x1F; 0x10 and 0x20 are in neither table."""
    for axis in (1, 15, 0x11, 0x1F):
        assert refusal("RSM_SET_PULSE_MODE", axis, 0) is None
    for axis in (0, 0x10, 0x20, 0x2F):
        assert refusal("RSM_SET_PULSE_MODE", axis, 0) == f"axis: {not_taken(axis)}"


def test_an_axis_the_manual_narrows_takes_only_its_listed_values() -> None:
    """LINE_SCAN works on "X or Y (1, 2)" (RS 8963), LINE_SCAN_START on X, Y or XY
    (its row's values [1, 2, 3]): Z (4) is a single axis of Table 4 but not one of theirs."""
    assert refusal("RSM_LINE_SCAN", 2, 0, 0, 0, 10) is None
    assert refusal("RSM_LINE_SCAN", 4, 0, 0, 0, 10) == f"axis: {not_taken(4)}"
    assert refusal("RSM_LINE_SCAN_START", 3, 0, 10) is None
    assert refusal("RSM_LINE_SCAN_START", 4, 0, 10) == f"axis: {not_taken(4)}"


# --- listed values, programs, labels ------------------------------------------------------

def test_an_enumerated_parameter_takes_only_its_listed_values() -> None:
    """SET_PULSE_MODE nMode, Table 6's modes 0..5 (RS 1082); FRNET_WAIT's two-register
    dwDiInput "1:ON, 0:OFF" (RS 4593)."""
    assert refusal("RSM_SET_PULSE_MODE", 1, 5) is None
    assert refusal("RSM_SET_PULSE_MODE", 1, 6) == f"nMode: {not_taken(6)}"
    assert refusal("RSM_MACRO_FRNET_WAIT", 8, 0, 1, 0) is None
    assert refusal("RSM_MACRO_FRNET_WAIT", 8, 0, 2, 0) == f"dwDiInput: {not_taken(2)}"


@pytest.mark.parametrize("vendor", ["RSM_MP_CREATE", "RSM_MACRO_MP_CALL"])
def test_a_macro_program_is_mp1_to_mp157(vendor: str) -> None:
    """The slot table (RS 332-355, Figure 4 RS 9796-9812) ends at MP157."""
    assert refusal(vendor, 1) is None
    assert refusal(vendor, 157) is None
    assert refusal(vendor, 0) == f"{CAT.by_vendor[vendor].params[0].name}: {not_taken(0)}"
    assert refusal(vendor, 158) == f"{CAT.by_vendor[vendor].params[0].name}: {not_taken(158)}"


def test_an_isr_is_isr1_to_isr20_and_a_sync_action_may_name_none() -> None:
    """ISR slots 1..20 (RS 332-355); a synchronous action's isrNoX is ISR1 ~ ISR20 (RS 7076)
    or 0 when its interrupt is not enabled (RS 7121)."""
    assert refusal("RSM_MP_ISR_CREATE", 1) is None
    assert refusal("RSM_MP_ISR_CREATE", 20) is None
    assert refusal("RSM_MP_ISR_CREATE", 0) == f"isr_No: {not_taken(0)}"
    assert refusal("RSM_MP_ISR_CREATE", 21) == f"isr_No: {not_taken(21)}"
    assert refusal("RSM_MACRO_INTFACTOR_ENABLE", 1, 0, 21) == f"isrNo: {not_taken(21)}"
    sync = (1, 2, 0, 0, 0, 0, 0, 0)  # axes, nSYNC and the enumerated settings
    assert refusal("RSM_MACRO_SYNC_ACTION", *sync, 0, 20, 1, 0) is None
    assert refusal("RSM_MACRO_SYNC_ACTION", *sync, 21, 0, 0, 0) == f"isrNoX: {not_taken(21)}"
    assert refusal("RSM_MACRO_SYNC_ACTION", *sync, 0, 0, 0, 21) == f"isrNoU: {not_taken(21)}"


def test_a_label_is_0_to_3() -> None:
    """"Only four labels are supported ... 0, 1, 2, 3" (RS 10719)."""
    for label in range(4):
        assert refusal("RSM_MACRO_GOTO", label) is None
        assert refusal("RSM_MACRO_LABEL", label) is None
    assert refusal("RSM_MACRO_GOTO", 4) == f"lableNo: {not_taken(4)}"
    assert refusal("RSM_MACRO_LABEL", 255) == f"lableNo: {not_taken(255)}"


def test_a_program_name_is_never_a_device_value() -> None:
    """A name is resolved to a slot by the linker; a frame carrying one is refused."""
    assert refusal("RSM_MACRO_MP_CALL", ProgramRef("main")) == \
        "mpNo: a program name is not a device value"
    assert refusal("RSM_MACRO_MP_CALL", ProgramRef(slot=3)) == \
        "mpNo: a program name is not a device value"
    assert error("RSM_MACRO_MP_CALL", ProgramRef("main")) == NOT_WRITTEN


# --- operators (IF: RS 10535-10562, VAR_CALCULATE: RS 10285-10295) -------------------------

def test_every_var_calculate_operator_of_the_ascii_table_is_taken() -> None:
    for op in (0x2B, 0x2D, 0x2A, 0x2F, 0x26, 0x7C):  # + - * / & | (RS 10289-10295)
        assert refusal("RSM_MACRO_VAR_CALCULATE", 1, op, 2, VarRef(3)) is None


@pytest.mark.parametrize("op", [0x25, 0x5E, 0x00, 0x2B2B])  # % ^ nothing, "++"
def test_another_var_calculate_operator_is_download_error_0x10(op: int) -> None:
    assert refusal("RSM_MACRO_VAR_CALCULATE", 1, op, 2, VarRef(3)) == \
        f"Operator: {not_taken(op)}"
    assert error("RSM_MACRO_VAR_CALCULATE", 1, op, 2, VarRef(3)) == WRONG_CALC


def test_every_if_operator_is_taken_in_either_byte_order() -> None:
    """The constant table's words (RS 10537-10545), and the worked example's order of the two
    characters of a two-character operator ('<=' printed 3C 3D, RS 10577; the profile's
    compare_order choice)."""
    for op in (0x003C, 0x003E, 0x3D3C, 0x3D3E, 0x3D3D, 0x3D21):
        assert refusal("RSM_MACRO_IF", VarRef(1), op, 0) is None
    for op in (0x3C3D, 0x3E3D, 0x213D):
        assert refusal("RSM_MACRO_IF", VarRef(1), op, 0) is None


@pytest.mark.parametrize("op", [
    0x3C00,  # '<' moved to the high byte: a one-character operator has no second character
    0x3D3F,  # '?=' is in no table
    0x0021,  # '!' alone: in the worked example's ASCII table, not an operator (compare_set)
    0x003D,  # '=' alone: the same
    0x3C3C,  # '<<'
])
def test_another_if_operator_is_download_error_0x06(op: int) -> None:
    """Only the six comparisons of the constant table (RS 10536-10542), in either order."""
    assert refusal("RSM_MACRO_IF", VarRef(1), op, 0) == f"Operator: {not_taken(op)}"
    assert error("RSM_MACRO_IF", VarRef(1), op, 0) == WRONG_IF


# --- variables (VAR0..VAR511, RS 2394 and 10144; bVAR0..bVAR127, RS 2350) -----------------

def test_a_variable_parameter_takes_var0_to_var511_and_nothing_else() -> None:
    """WRITE_VAR's and SET_VAR's varNo, VAR_CALCULATE's varNo2 must be a variable."""
    assert refusal("RSM_WRITE_VAR", VarRef(0), 7) is None
    assert refusal("RSM_WRITE_VAR", VarRef(511), 7) is None
    assert refusal("RSM_WRITE_VAR", VarRef(512), 7) == \
        "varNo: VAR512 does not exist (VAR0..VAR511)"
    assert refusal("RSM_WRITE_VAR", VarRef(-1), 7) == \
        "varNo: VAR-1 does not exist (VAR0..VAR511)"
    assert refusal("RSM_MACRO_SET_VAR", 5, 7) == \
        "varNo: 5 is not a variable (VARn is sent as 0x7fff0000 + n)"
    assert refusal("RSM_MACRO_VAR_CALCULATE", 1, 0x2B, 2, 3) == \
        "varNo2: 3 is not a variable (VARn is sent as 0x7fff0000 + n)"
    assert error("RSM_MACRO_SET_VAR", VarRef(512), 7) == NOT_WRITTEN


def test_a_value_parameter_that_takes_a_variable_takes_var0_to_var511() -> None:
    """SET_VAR's data is a value "or MACRO variable (VAR0 ~ VAR511)" (RS 10145);
    FRNET_OUT's data "can also use VARn" (RS 4349), sent as its holding address."""
    assert refusal("RSM_MACRO_SET_VAR", VarRef(1), VarRef(511)) is None
    assert refusal("RSM_MACRO_SET_VAR", VarRef(1), VarRef(512)) == \
        "data: VAR512 does not exist (VAR0..VAR511)"
    assert refusal("RSM_MACRO_FRNET_OUT", 0, VarRef(0)) is None


def test_a_byte_variable_parameter_takes_bvar0_to_bvar127() -> None:
    """WRITE_bVAR's bvarNo "bVAR0 ~ bVAR127" (RS 2319) must be a byte variable; FRNET_OUT's
    bGroup is a byte variable or a group "between 0~7" (RS 4348)."""
    assert refusal("RSM_WRITE_BVAR", BVarRef(0), 255) is None
    assert refusal("RSM_WRITE_BVAR", BVarRef(127), 0) is None
    assert refusal("RSM_WRITE_BVAR", BVarRef(128), 0) == "bvarNo: bVAR128 is not allowed here"
    assert refusal("RSM_WRITE_BVAR", BVarRef(-1), 0) == "bvarNo: bVAR-1 is not allowed here"
    assert refusal("RSM_WRITE_BVAR", 5, 0) == \
        "bvarNo: 5 is not a byte variable (bVARn is sent as 0x80 + n)"
    assert refusal("RSM_MACRO_FRNET_OUT", BVarRef(127), VarRef(2)) is None
    assert refusal("RSM_MACRO_FRNET_OUT", 0, VarRef(2)) is None
    assert refusal("RSM_MACRO_FRNET_OUT", 7, VarRef(2)) is None
    assert refusal("RSM_MACRO_FRNET_OUT", 8, VarRef(2)) == "bGroup: 8 is outside 0..7"
    assert refusal("RSM_MACRO_FRNET_OUT", -1, VarRef(2)) == "bGroup: -1 is outside 0..7"


def test_a_byte_variable_is_refused_where_the_parameter_is_not_one() -> None:
    assert refusal("RSM_MACRO_FRNET_WAIT", BVarRef(0), 0, 0, 0) == \
        "bDiGroup: bVAR0 is not allowed here"
    assert refusal("RSM_MACRO_FIXED_MOVE", 1, BVarRef(3)) == "data: bVAR3 is not allowed here"


# --- ranges -----------------------------------------------------------------------------

@pytest.mark.parametrize(("vendor", "before", "after", "low", "high", "name"), [
    # SET_MAX_V "8,000~4,000,000 PPS" (RS 1158)
    ("RSM_MACRO_SET_MAX_V", (1,), (), 8000, 4000000, "data"),
    # SET_FILTER FEn "(0~31)", one register (RS 1802)
    ("RSM_MACRO_SET_FILTER", (1,), (0,), 0, 31, "FEn"),
    # SET_AO "-32,768 ~ +32,767" (RS 5363)
    ("RSM_MACRO_SET_AO", (1,), (), -32768, 32767, "data"),
    # FRNET_WAIT bDiGroup "8~15" (RS 4591)
    ("RSM_MACRO_FRNET_WAIT", (), (0, 0, 0), 8, 15, "bDiGroup"),
    # WRITE_MD mdNo MD0 ~ MD2047 (RS 2602) and its long data, the whole 32-bit range (RS 2603)
    ("RSM_WRITE_MD", (), (0, 0.0), 0, 2047, "mdNo"),
    ("RSM_WRITE_MD", (0,), (0.0,), -2147483648, 2147483647, "ldata"),
    # a move's data "-2,000,000,000 ~ +2,000,000,000" (RS 5418)
    ("RSM_MACRO_FIXED_MOVE", (1,), (), -2000000000, 2000000000, "data"),
    # TIMER's wait "Value (0 ~ +2,000,000,000) ms" (RS 10793)
    ("RSM_MACRO_TIMER", (), (), 0, 2000000000, "varNo"),
])
def test_a_range_takes_its_edges_and_refuses_one_beyond(
        vendor: str, before: tuple[int, ...], after: tuple[float, ...], low: int, high: int,
        name: str) -> None:
    assert refusal(vendor, *before, low, *after) is None
    assert refusal(vendor, *before, high, *after) is None
    assert refusal(vendor, *before, low - 1, *after) == \
        f"{name}: {low - 1} is outside {low}..{high}"
    assert refusal(vendor, *before, high + 1, *after) == \
        f"{name}: {high + 1} is outside {low}..{high}"
    assert error(vendor, *before, high + 1, *after) == NOT_WRITTEN


def test_a_32_bit_value_with_no_documented_range_is_held_to_the_immediate_range() -> None:
    """SET_V's data has no range in its row: a 32-bit value is +-2,000,000,000 (device.toml
    immediate_min/max, RS 2451)."""
    assert refusal("RSM_MACRO_SET_V", 1, 2000000000) is None
    assert refusal("RSM_MACRO_SET_V", 1, -2000000000) is None
    assert refusal("RSM_MACRO_SET_V", 1, 2000000001) == f"data: 2000000001 is outside {IMMEDIATE}"
    assert refusal("RSM_MACRO_SET_V", 1, -2000000001) == \
        f"data: -2000000001 is outside {IMMEDIATE}"


def test_a_range_with_one_documented_end_takes_the_immediate_bound_at_the_other() -> None:
    """SET_K documents only its maximum, FRNET_WAIT's dwTimeout only its minimum
    ("0: ... infinite", RS 4594)."""
    assert refusal("RSM_MACRO_SET_K", 1, 2000000000) is None
    assert refusal("RSM_MACRO_SET_K", 1, -2000000000) is None
    assert refusal("RSM_MACRO_SET_K", 1, 2000000001) == f"data: 2000000001 is outside {IMMEDIATE}"
    assert refusal("RSM_MACRO_SET_K", 1, -2000000001) == \
        f"data: -2000000001 is outside {IMMEDIATE}"
    assert refusal("RSM_MACRO_FRNET_WAIT", 8, 0, 0, 0) is None
    assert refusal("RSM_MACRO_FRNET_WAIT", 8, 0, 0, 2000000000) is None
    assert refusal("RSM_MACRO_FRNET_WAIT", 8, 0, 0, -1) == \
        "dwTimeout: -1 is outside 0..2000000000"
    assert refusal("RSM_MACRO_FRNET_WAIT", 8, 0, 0, 2000000001) == \
        "dwTimeout: 2000000001 is outside 0..2000000000"


def test_a_float_is_any_finite_number() -> None:
    """WRITE_MD's float data (RS 2586) has no documented range; a NaN or an infinity is
    not a number the machine data can hold."""
    for value in (0.0, -1.5, 3.4e38, -3.4e38):
        assert refusal("RSM_WRITE_MD", 1024, 0, value) is None
    for value in (float("nan"), float("inf"), float("-inf")):
        assert refusal("RSM_WRITE_MD", 1024, 0, value) == f"fdata: {value} is not a number"
    assert error("RSM_WRITE_MD", 1024, 0, float("nan")) == NOT_WRITTEN


# --- the first refusal, the words, the profile ---------------------------------------------

def test_the_first_refused_parameter_is_the_one_reported() -> None:
    """The parameters are read in the frame's order: with a wrong operator and a wrong
    varNo2 the operator is reported, and its download error (0x10) is the line's."""
    command = CAT.by_vendor["RSM_MACRO_VAR_CALCULATE"]
    bad = frame_check.check(command, (1, 0x25, 2, 3), CAT.profile)
    assert bad == frame_check.BadParameter("Operator", not_taken(0x25), WRONG_CALC)
    assert bad.describe(command) == "VAR_CALCULATE Operator: 0x25 is not one of the values it takes"
    bad = frame_check.check(command, (VarRef(512), 0x25, 2, 3), CAT.profile)
    assert bad == frame_check.BadParameter(
        "varNo", "VAR512 does not exist (VAR0..VAR511)", NOT_WRITTEN)


def test_an_operand_count_that_is_not_the_commands_is_an_error_not_a_pass() -> None:
    """The decoder gives every parameter its operand; a short tuple is a caller's mistake
    and must not pass unchecked."""
    with pytest.raises(ValueError, match="shorter"):
        frame_check.check(CAT.by_vendor["RSM_MACRO_FIXED_MOVE"], (1,), CAT.profile)


def _with(section: str, **values: object) -> Catalogue:
    profile = CAT.profile
    raw = {**profile.raw, section: {**profile.raw[section], **values}}
    return CAT.replace(profile=profile.replace(raw=raw))


def test_the_limits_are_the_profiles() -> None:
    """Another firmware's profile with eight labels, 1024 variables and a narrower immediate
    range is read as it stands, beside the standard profile, whichever is asked first."""
    other = _with("limits", label_max=7)
    for _ in range(2):
        assert refusal("RSM_MACRO_GOTO", 7) == f"lableNo: {not_taken(7)}"
        assert refusal("RSM_MACRO_GOTO", 7, catalogue=other) is None
        assert refusal("RSM_MACRO_GOTO", 8, catalogue=other) == f"lableNo: {not_taken(8)}"
    more = _with("variables", count=1024, byte_count=256, immediate_min=-5, immediate_max=5)
    assert refusal("RSM_WRITE_VAR", VarRef(1023), 7, catalogue=more) is None
    assert refusal("RSM_WRITE_VAR", VarRef(1024), 7, catalogue=more) == \
        "varNo: VAR1024 does not exist (VAR0..VAR1023)"
    assert refusal("RSM_WRITE_BVAR", BVarRef(255), 0, catalogue=more) is None
    assert refusal("RSM_MACRO_SET_V", 1, 6, catalogue=more) == "data: 6 is outside -5..5"
    assert refusal("RSM_MACRO_SET_V", 1, -6, catalogue=more) == "data: -6 is outside -5..5"


def test_an_operator_the_profile_does_not_list_is_refused() -> None:
    """The operators are the profile's: a firmware whose table has no '|' (0x7C) for
    VAR_CALCULATE or no '!=' (0x3D21) for IF refuses them, though the catalogue's rows
    list them."""
    profile = CAT.profile
    calc = {op: code for op, code in profile.calc_ops.items() if op != "|"}
    cmp = {op: code for op, code in profile.cmp_ops.items() if op != "!="}
    other = CAT.replace(profile=profile.replace(calc_ops=calc, cmp_ops=cmp))
    assert refusal("RSM_MACRO_VAR_CALCULATE", 1, 0x7C, 2, VarRef(3), catalogue=other) == \
        f"Operator: {not_taken(0x7C)}"
    assert refusal("RSM_MACRO_VAR_CALCULATE", 1, 0x26, 2, VarRef(3), catalogue=other) is None
    assert refusal("RSM_MACRO_IF", VarRef(1), 0x3D21, 0, catalogue=other) == \
        f"Operator: {not_taken(0x3D21)}"
    assert refusal("RSM_MACRO_IF", VarRef(1), 0x3D3D, 0, catalogue=other) is None


def test_each_closed_set_is_worked_out_once_per_parameter_and_profile() -> None:
    """Every downloaded line asks for its parameters' sets: the one worked out for a
    parameter and a profile is kept, whatever was asked in between, and another profile
    gets its own."""
    goto = CAT.by_vendor["RSM_MACRO_GOTO"].params[0]
    operator = CAT.by_vendor["RSM_MACRO_VAR_CALCULATE"].params[1]
    other = _with("limits", label_max=7).profile
    first = frame_check._allowed(goto, CAT.profile)
    assert first == frozenset({0, 1, 2, 3})
    assert frame_check._allowed(operator, CAT.profile) == frozenset(
        {0x2B, 0x2D, 0x2A, 0x2F, 0x26, 0x7C})
    assert frame_check._allowed(goto, other) == frozenset(range(8))
    assert frame_check._allowed(goto, CAT.profile) is first
    assert frame_check._allowed(goto, other) == frozenset(range(8))


# --- the controller's answer to a refused frame --------------------------------------------

def inputs(vc: VirtualController, address: int, count: int) -> list[int]:
    return RegisterMap(vc).read_input(address, count)


MP_DOWNLOAD = ([CREATE, 1], CLOSE, [1, 0])  # 110 and 111 after it: MP1, no ISR (RS 10972)
ISR_DOWNLOAD = ([CREATE_ISR, 1], ISR_CLOSE, [0, 1])


@pytest.mark.parametrize(("line", "expected", "downloads"), [
    (macro("IF", VarRef(1), 0x3D3F, 0), WRONG_IF, [MP_DOWNLOAD, ISR_DOWNLOAD]),
    (macro("VAR_CALCULATE", VarRef(1), 0x25, VarRef(2), VarRef(3)), WRONG_CALC,
     [MP_DOWNLOAD, ISR_DOWNLOAD]),
    (macro("SET_VAR", VarRef(1), 2000000001), NOT_WRITTEN, [MP_DOWNLOAD, ISR_DOWNLOAD]),
    (macro("GOTO", 4), NOT_WRITTEN, [MP_DOWNLOAD]),  # GOTO is an MP command (Table 1)
])
def test_a_refused_download_line_names_its_download_error(
        line: list[int], expected: int,
        downloads: list[tuple[list[int], int, list[int]]]) -> None:
    """Cause 2 for the line (RS 11368); the close reports the line's code, its 0-based line
    number and the download error in 110-114 (RS 10961-10974)."""
    for create, close, numbers in downloads:
        vc = VirtualController()
        assert vc.write_subfunction(create) == 0
        assert vc.write_subfunction(macro("SET_VAR", VarRef(0), 1)) == 0
        assert vc.write_subfunction(line) == OUT_OF_RANGE
        assert inputs(vc, 102, 1) == [OUT_OF_RANGE]
        assert vc.write_subfunction([close]) == 0
        assert inputs(vc, 110, 5) == [*numbers, line[0], 1, expected]


def test_a_refused_real_time_frame_is_cause_2_and_its_reason_is_logged() -> None:
    vc = VirtualController()
    assert vc.write_subfunction(rtc("FIXED_MOVE", 1, 2000000001)) == OUT_OF_RANGE
    assert inputs(vc, 102, 1) == [OUT_OF_RANGE]
    assert vc.log[-1].endswith(f"refused: FIXED_MOVE data: 2000000001 is outside {IMMEDIATE}")
    assert vc.write_subfunction(rtc("FIXED_MOVE", 1, 2000000000)) == 0

"""Prove stdlib/m8194h/commands.toml against the RS-M8194H API manual (v3.1).

The manual's tables (table 1, appendix table 21, the 9.3.2 list, the C prototypes and the
worked examples' lines) are parsed by `rs_manual.py`, each row with its line in the manual,
and stored in tests/data/rs-manual-tables.json: every clone runs these checks, with or
without the manual beside it, so that a wrong code, count, scope, cost or parameter in the
catalogue fails. Where the manual is beside the repository (../shared/manuals), the stored
tables are extracted again from it and must be identical. Deviations from the manual are
allowed only for rows that carry a ``choice`` and are listed below with the value the
catalogue must hold.
"""

from __future__ import annotations

import tomllib
from functools import cache
from typing import Any

import pytest
import rs_manual
from rs_manual import CATALOGUE

# --- deviations from appendix table 21 that a `choice` explains --------------------------
CODE_DEVIATIONS = {
    # 12.3 swaps these pairs; section remarks and example frames give the values below
    "RSM_MACRO_LINE_3D_CONTINUE": 0x0C81,
    "RSM_ABS_MACRO_LINE_3D_CONTINUE": 0x0CFC,
    "RSM_MIX_2D_CONTINUE": 0x0A84,
    "RSM_MACRO_MIX_2D_CONTINUE": 0x0C84,
    "RSM_ABS_MIX_2D_CONTINUE": 0x0AFD,
    "RSM_ABS_MACRO_MIX_2D_CONTINUE": 0x0CFD,
}
REGISTER_DEVIATIONS = {
    "RSM_MACRO_FRNET_WAIT": 8,  # 12.3 says 7, prototype and example give 8
    "RSM_MACRO_ABS_GET_POSITION": 2,  # 12.3 prints "X" next to a real code
}
WIRE_DEVIATIONS = {
    ("RSM_MACRO_FRNET_READ", "bGroup"): 2,  # BYTE sent as 32 bits
    ("RSM_MACRO_FRNET_WRITE", "bDoGroup"): 2,
}
# Table 1 marks IT on these macro rows; RS 990 forbids the IT table inside macros
IT_SECTIONS = {
    "3.3",
    "3.4",
    "3.5",
    "3.6",
    "3.7",
    "3.8",
    "3.9.1",
    "3.9.2",
    "3.10",
    "3.11.1",
    "3.11.2",
    "3.12",
    "3.13",
    "3.14",
    "3.15.1",
    "3.15.2",
    "3.16.1",
    "3.16.2",
}
RS_ONLY = {"RSM_INTP_END", "RSM_MACRO_INTP_END"}
INPUT_POINTERS = {("RSM_FRNET_WRITE_MULTI_GROUP_DO", "pwOutBuffer")}

WIRE = {"BYTE": 1, "WORD": 1, "short": 1, "DWORD": 2, "long": 2, "float": 2}
KINDS = {
    "axis",
    "axis1",
    "axis1_or_none",
    "axis_it",
    "int",
    "float",
    "var",
    "mp",
    "isr",
    "isr_or_none",
    "label",
    "calc_op",
    "cmp_op",
    "bvar",
    "enum",
}
COMMAND_KEYS = {
    "name",
    "section",
    "code",
    "registers",
    "scope",
    "line_cost",
    "returns",
    "targets",
    "summary",
    "lines",
    "choice",
    "param",
}
PARAM_KEYS = {
    "name",
    "type",
    "wire",
    "kind",
    "var",
    "min",
    "max",
    "values",
    "symbols",
    "encoding",
    "doc",
}


# --- loading ------------------------------------------------------------------------------
@cache
def catalogue() -> list[dict]:
    with CATALOGUE.open("rb") as fh:
        return tomllib.load(fh)["command"]


def by_name() -> dict[str, dict]:
    return {c["name"]: c for c in catalogue()}


def table1() -> dict[str, dict[str, Any]]:
    """Table 1: name -> section, scope, cost, line (RS ~366-666)."""
    return rs_manual.stored()["table1"]  # type: ignore[no-any-return]


def appendix() -> list[dict[str, Any]]:
    """Appendix table 21: section, name, code, registers, line (RS ~11502-11820)."""
    return rs_manual.stored()["appendix"]  # type: ignore[no-any-return]


def rvar_list() -> list[str]:
    """Commands whose result SET_RVAR reads (9.3.2, RS ~10183-10195)."""
    return rs_manual.stored()["rvar"]["names"]  # type: ignore[no-any-return]


def prototypes() -> dict[str, list[tuple[str, str, bool]]]:
    """name -> [(type, param, is_pointer)] from the C prototypes in the function sections."""
    return {name: [(t, n, ptr) for t, n, ptr in proto["args"]]
            for name, proto in rs_manual.stored()["prototypes"].items()}


# --- tests --------------------------------------------------------------------------------
def test_schema():
    rows = catalogue()
    assert len(rows) == 285
    for c in rows:
        assert set(c) <= COMMAND_KEYS, (c["name"], set(c) - COMMAND_KEYS)
        assert ("code" in c) == ("registers" in c), c["name"]
        assert set(c["scope"]) <= {"rtc", "mp", "isr", "it"}
        assert c["line_cost"] in (1, 2, 3, 4)
        assert c["targets"] in (["rs"], ["rs", "et"])
        assert c["summary"] and "\n" not in c["summary"]
        assert set(c["lines"]) <= {"table1", "appendix", "signature", "example"}
        for p in c.get("param", []):
            assert set(p) <= PARAM_KEYS, (c["name"], p["name"], set(p) - PARAM_KEYS)
            assert p["kind"] in KINDS, (c["name"], p["name"])
            assert p["type"] in WIRE, (c["name"], p["name"])
            assert isinstance(p["var"], bool) and p["doc"]
            if "values" in p and "min" in p:
                assert all(p["min"] <= v <= p["max"] for v in p["values"])
            for v in p.get("symbols", {}).values():
                assert v in p.get("values", [v])
            if p["kind"] == "axis_it":
                assert "it" in c["scope"] and "rtc" in c["scope"], c["name"]
            if p.get("encoding") is not None:
                assert p["encoding"] == "holding_address" and "choice" in c


def test_no_duplicates():
    names = [c["name"] for c in catalogue()]
    assert len(names) == len(set(names))
    codes = [c["code"] for c in catalogue() if "code" in c]
    dup = {hex(x) for x in codes if codes.count(x) > 1}
    assert not dup, dup


def test_code_families():
    for c in catalogue():
        if "code" not in c:
            continue
        family = c["code"] >> 8
        if "MACRO" in c["name"]:
            assert family == 0x0C, (c["name"], hex(c["code"]))
        else:
            assert family == 0x0A, (c["name"], hex(c["code"]))


def test_registers_equal_wire_sum():
    for c in catalogue():
        if "code" in c:
            assert c["registers"] == 1 + sum(p["wire"] for p in c.get("param", [])), c["name"]


def test_wire_follows_type_unless_chosen():
    rows = by_name()
    for c in catalogue():
        for p in c.get("param", []):
            key = (c["name"], p["name"])
            if key in WIRE_DEVIATIONS:
                assert p["wire"] == WIRE_DEVIATIONS[key] and "choice" in c, key
            else:
                assert p["wire"] == WIRE[p["type"]], key
    for name, _ in WIRE_DEVIATIONS:
        assert name in rows


def test_targets():
    for c in catalogue():
        if c["name"] in RS_ONLY:
            assert c["targets"] == ["rs"]
        elif c["section"].startswith("2."):
            assert "rs" in c["targets"]
        else:
            assert c["targets"] == ["rs", "et"], c["name"]


def test_returns_match_9_3_2():
    manual = rvar_list()
    assert len(manual) == 12, manual
    assert sorted(c["name"] for c in catalogue() if c["returns"]) == sorted(manual)


def test_appendix_rows_present_with_same_code_and_count():
    rows = by_name()
    app = appendix()
    assert len(app) == 285
    order = [c["name"] for c in catalogue()]
    assert [r["name"] for r in app] == order, "catalogue not in appendix order"
    deviating = set()
    for r in app:
        c = rows[r["name"]]
        assert c["section"] == r["section"], r["name"]
        assert c["lines"]["appendix"] == r["line"], r["name"]
        if r["code"] is None:
            assert "code" not in c, r["name"]
            continue
        if c.get("code") != r["code"] or c.get("registers") != r["registers"]:
            deviating.add(r["name"])
    for name, code in CODE_DEVIATIONS.items():
        assert rows[name]["code"] == code and "choice" in rows[name], name
    for name, regs in REGISTER_DEVIATIONS.items():
        assert rows[name]["registers"] == regs and "choice" in rows[name], name
    assert rows["RSM_MACRO_FRNET_WAIT"]["registers"] == 8
    assert deviating == set(CODE_DEVIATIONS) | set(REGISTER_DEVIATIONS)


def test_swapped_codes_stay_unique_pairs():
    # the six corrected codes are exactly the appendix's codes permuted
    rows = by_name()
    app = {r["name"]: r["code"] for r in appendix()}
    printed = sorted(app[n] for n in CODE_DEVIATIONS)
    assert printed == sorted(rows[n]["code"] for n in CODE_DEVIATIONS)


IT_ADDED = {"RSM_EXD_DISABLE"}


def test_scope_and_cost_equal_table1():
    t1 = table1()
    assert len(t1) == 276
    it_dropped = set()
    for c in catalogue():
        r = t1.get(c["name"])
        if r is None:
            assert c["section"].startswith("2.1."), c["name"]
            assert c["scope"] == [] and "table1" not in c["lines"]
            continue
        assert c["section"] == r["section"], c["name"]
        assert c["lines"]["table1"] == r["line"], c["name"]
        assert c["line_cost"] == r["cost"], c["name"]
        if c["scope"] != r["scope"] and c["name"] in IT_ADDED:
            # chapter 8's default list names it among the initial-table settings (RS 9721)
            assert "choice" in c and "RS 9721" in c["choice"], c["name"]
            assert c["scope"] == [*r["scope"], "it"], c["name"]
        elif c["scope"] != r["scope"]:
            assert "choice" in c, c["name"]
            assert c["scope"] == [s for s in r["scope"] if s != "it"], c["name"]
            it_dropped.add(c["name"])
    expected = {
        n
        for n, r in t1.items()
        if "MACRO" in n and r["section"] in IT_SECTIONS and "it" in r["scope"]
    }
    assert len(expected) == 18
    assert it_dropped == expected


def test_it_rows_take_table5_axes():
    for c in catalogue():
        if "rtc" in c["scope"] and "it" in c["scope"]:
            axes = [p for p in c.get("param", []) if p["name"] == "axis"]
            assert axes and axes[0]["kind"] == "axis_it", c["name"]


def test_parameters_match_prototypes():
    protos = prototypes()
    for c in catalogue():
        proto = protos.get(c["name"])
        assert proto is not None, c["name"]
        assert c["lines"]["signature"] > 0
        expected = [
            (t, n)
            for t, n, ptr in proto
            if n not in ("hRsm", "SlaveAddr") and (not ptr or (c["name"], n) in INPUT_POINTERS)
        ]
        got = [(p["type"], p["name"]) for p in c.get("param", [])]
        assert got == expected, c["name"]


def test_prototype_counts_explain_register_deviations():
    # 12.2.5 rule on the prototype reproduces every count except the FRnet group rows
    protos = prototypes()
    for c in catalogue():
        if "code" not in c:
            continue
        skip = ("hRsm", "SlaveAddr")
        args = [t for t, name, ptr in protos[c["name"]] if name not in skip and not ptr]
        n = 1 + sum(WIRE[t] for t in args)
        if c["name"] in {k for k, _ in WIRE_DEVIATIONS}:
            assert c["registers"] == n + 1, c["name"]
        else:
            assert c["registers"] == n, c["name"]


def test_var_operands_are_documented():
    protos = rs_manual.stored()["prototypes"]
    for c in catalogue():
        for p in c.get("param", []):
            if p["var"] or p["kind"] == "var":
                # the 60 lines after the prototype give VAR0 ~ VAR511 (or "use VARn")
                assert protos[c["name"]]["var_documented"], (c["name"], p["name"])


def test_line_references_point_at_the_row():
    protos = rs_manual.stored()["prototypes"]
    examples = rs_manual.stored()["examples"]
    for c in catalogue():
        assert c["lines"]["signature"] == protos[c["name"]]["line"], c["name"]
        ex = c["lines"].get("example")
        if ex:
            assert str(ex) in examples, (
                f"{c['name']}: example line RS {ex} is not in {rs_manual.TABLES.name}; "
                "run python tests/stdlib/rs_manual.py with the manual beside the repository")
            text = examples[str(ex)]
            code_bytes = f"{c['code'] >> 8:02X} {c['code'] & 0xFF:02X}" if "code" in c else None
            assert c["name"] in text or (code_bytes and code_bytes in text), c["name"]


def test_the_stored_tables_are_the_manual_s():
    """The table in tests/data is what the manual says, row for row, line for line. Without
    the manual this one test skips, saying the checks above ran from the stored table;
    with MPLANG_MANUALS naming a directory without it, it fails."""
    why = rs_manual.absent()
    if why is not None and rs_manual.required():
        pytest.fail(f"MPLANG_MANUALS is set: {why}; the stored tables cannot be checked "
                    "against it",
                    pytrace=False)
    if why is not None:
        pytest.skip(f"{why}; the checks above ran from {rs_manual.TABLES.name}")
    fresh = rs_manual.extract()
    stored = rs_manual.stored()
    for key in sorted(set(fresh) | set(stored)):
        assert fresh.get(key) == stored.get(key), (
            f"{rs_manual.TABLES.name}: {key!r} differs from the manual; regenerate it with "
            "python tests/stdlib/rs_manual.py")
    assert rs_manual.render(fresh) == rs_manual.TABLES.read_text(encoding="utf-8")


def test_a_changed_cost_fails_without_the_manual():
    """RSM_HELIX_3D costs three lines (table 1, RS 607): the stored row says so."""
    row = table1()["RSM_HELIX_3D"]
    assert (row["cost"], row["line"]) == (3, 607)
    assert by_name()["RSM_HELIX_3D"]["line_cost"] == row["cost"]

"""The formatter: pinned layouts, idempotence, and that formatting never changes a build."""

from __future__ import annotations

import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lark import Lark

from mplang.ir import catalogue
from mplang.ir.scope import KEYWORDS
from mplang.m8194h.compiler import BuildResult, compile_paths, compile_source
from mplang.tools.fmt import (
    FormatOptions,
    FormatOptionsError,
    FormatterBug,
    SourceNotFormattable,
    _Renderer,
    format_source,
)

ROOT = Path(__file__).resolve().parents[2]
CASES = ROOT / "tests" / "data" / "fmt"
SAMPLES = sorted((ROOT / "samples").glob("*.mp"))
CASE_NAMES = sorted(p.name.removesuffix(".mp") for p in CASES.glob("*.mp")
                    if not p.name.endswith(".expected.mp"))
# Pinned cases that must build without errors, so their images are compared frame by frame.
BUILDING_CASES = {"blank_lines", "commands", "comments", "expressions", "for_next", "headers",
                  "if_else", "labels_calls"}


def case_options(name: str) -> FormatOptions:
    settings_file = CASES / f"{name}.toml"
    if not settings_file.exists():
        return FormatOptions()
    return FormatOptions.from_mapping(tomllib.loads(settings_file.read_text()))


def frames(result: BuildResult) -> list[tuple[str, int, list[list[int]]]]:
    """What must not change: every program's slot and download frames (not source lines)."""
    return [(p.program.kind, p.placement.slot, p.frames) for p in result.programs]


def codes(result: BuildResult) -> list[str]:
    return sorted(d.code for d in result.diagnostics)


# ------------------------------------------------------------------- pinned cases


def test_every_case_has_its_expected_layout() -> None:
    inputs = {p.name.removesuffix(".mp") for p in CASES.glob("*.mp")
              if not p.name.endswith(".expected.mp")}
    expected = {p.name.removesuffix(".expected.mp") for p in CASES.glob("*.expected.mp")}
    options = {p.stem for p in CASES.glob("*.toml")}
    assert inputs == expected and options <= inputs
    assert inputs >= BUILDING_CASES and len(inputs) >= 11


@pytest.mark.parametrize("name", CASE_NAMES)
def test_pinned_layout(name: str) -> None:
    source = (CASES / f"{name}.mp").read_text()
    expected = (CASES / f"{name}.expected.mp").read_text()
    options = case_options(name)
    assert format_source(source, options) == expected
    assert format_source(expected, options) == expected


@pytest.mark.parametrize("name", CASE_NAMES)
def test_pinned_case_builds_the_same(name: str) -> None:
    display = str(CASES / f"{name}.mp")
    source = (CASES / f"{name}.mp").read_text()
    before = compile_source(source, display)
    after = compile_source(format_source(source, case_options(name)), display)
    assert codes(after) == codes(before)
    assert frames(after) == frames(before)
    assert before.ok == (name in BUILDING_CASES)


# ------------------------------------------------------------------------ samples


@cache
def formatted_sample(path: Path) -> str:
    return format_source(path.read_text(), name=str(path))


@cache
def sample_frames(path: Path) -> list[tuple[str, int, list[list[int]]]]:
    """The sample built on its own (with what it includes), as it is on disk."""
    result = compile_paths([path])
    assert result.ok, [d.render() for d in result.diagnostics]
    return frames(result)


def build_instead(path: Path, text: str) -> BuildResult:
    """The sample built on its own with `text` in place of the file's contents."""
    return compile_paths([path], texts={path: text, path.resolve(): text})


@pytest.mark.parametrize("path", SAMPLES, ids=lambda p: p.name)
def test_sample_formats_idempotently_and_builds_the_same(path: Path) -> None:
    formatted = formatted_sample(path)
    assert format_source(formatted) == formatted
    after = build_instead(path, formatted)
    assert after.ok and frames(after) == sample_frames(path)


def test_all_samples_still_build_together_once_formatted() -> None:
    texts = {key: formatted_sample(path) for path in SAMPLES for key in (path, path.resolve())}
    before, after = compile_paths(SAMPLES), compile_paths(SAMPLES, texts=texts)
    assert before.ok and after.ok and frames(after) == frames(before)
    assert after.build_id() == before.build_id()


def test_layout_choices_on_a_sample() -> None:
    text = (ROOT / "samples" / "nested_loops_labels.mp").read_text()
    lines = format_source(text).splitlines()
    assert "LABEL rs_retry" in lines  # labels stand at their program's edge
    assert "    FOR RS_ROWS  # outer loop: rows (Y)" in lines  # two spaces before a comment
    assert "CONST RS_SETTLE_MS = 40  # probe settling time per pin" in lines
    assert "                EXIT FOR  # leave the column loop" in lines


# --------------------------------------------------------------- text-level rules


def test_syntax_errors_are_reported_not_formatted() -> None:
    source = "MP 1\n  SET_V X,, 1\n  FIXED_MOVE X 1\nEND MP\n"
    with pytest.raises(SourceNotFormattable) as caught:
        format_source(source, name="bad.mp")
    rendered = [d.render().splitlines()[0] for d in caught.value.diagnostics]
    assert rendered[0].startswith("bad.mp:2:11: error[E101]: unexpected ','")
    assert rendered[1].startswith("bad.mp:3:16: error[E101]: unexpected number '1'")
    assert len(rendered) == 2


def test_a_malformed_argument_list_is_a_syntax_error_too() -> None:
    with pytest.raises(SourceNotFormattable) as caught:
        format_source("MP 1\nFIXED_MOVE((1, 2), 3)\nEND MP\n")
    assert [d.code for d in caught.value.diagnostics] == ["E101"]


def test_crlf_sources_stay_crlf() -> None:
    source = "mp 1\r\n  set_v x,1   # c\r\n\r\n\r\nend mp"
    assert format_source(source) == "MP 1\r\n    SET_V x, 1  # c\r\n\r\nEND MP\r\n"


def test_the_first_line_break_decides_the_newline() -> None:
    assert format_source("MP 1\nSTOP_WAIT X\r\nEND MP\r\n") == "MP 1\n    STOP_WAIT X\nEND MP\n"


def test_stray_carriage_returns_at_line_ends_go_like_other_trailing_space() -> None:
    assert format_source("MP 1\r\r\nEND MP\r\n") == "MP 1\r\nEND MP\r\n"


@pytest.mark.parametrize("source", ["", "\n", "  \n\t\n\n", "\r\n"])
def test_empty_sources_format_to_nothing(source: str) -> None:
    assert format_source(source) == ""


def test_final_newline_is_added_and_trailing_blank_lines_go() -> None:
    assert format_source("CONST A = 1") == "CONST A = 1\n"
    assert format_source("CONST A = 1\n\n\n") == "CONST A = 1\n"


def test_comment_text_is_kept_but_not_its_trailing_space() -> None:
    source = "#   odd   spacing\t inside  \t\n"
    assert format_source(source) == "#   odd   spacing\t inside\n"


@pytest.mark.parametrize("indent", [1, 2, 8])
def test_indent_option(indent: int) -> None:
    source = "MP 1\nFOR 2\nIF VAR1 == 0\nLABEL a\nEND IF\nNEXT\nEND MP\n"
    pad = " " * indent
    assert format_source(source, FormatOptions(indent=indent)) == (
        f"MP 1\n{pad}FOR 2\n{pad * 2}IF VAR1 == 0\n{pad * 2}LABEL a\n{pad * 2}END IF\n"
        f"{pad}NEXT\nEND MP\n")


def test_keyword_case_covers_keywords_commands_and_reads_only() -> None:
    source = "Mp 5 Main\n  For VAR1\n    Var2 = Get_Lp(X) + Speed\n  Next\n  Call Other\nEnd Mp\n"
    assert format_source(source, FormatOptions(keyword_case="lower")) == (
        "mp 5 Main\n    for VAR1\n        Var2 = get_lp(X) + Speed\n    next\n"
        "    call Other\nend mp\n")


def test_a_program_named_like_a_keyword_keeps_its_spelling() -> None:
    """The parser reads `next` after `MP 5` as a name; the image carries it as written."""
    assert format_source("mp 5 next\nend mp\n") == "MP 5 next\nEND MP\n"


def test_a_renderer_that_loses_a_token_is_caught(monkeypatch: pytest.MonkeyPatch) -> None:
    original: Callable[[_Renderer, Any], str] = _Renderer.expr

    def dropping_unary_minus(self: _Renderer, tree: Any) -> str:
        text = original(self, tree)
        return text.lstrip("-") if tree.data == "expr" else text  # the flat expression

    monkeypatch.setattr(_Renderer, "expr", dropping_unary_minus)
    with pytest.raises(FormatterBug):
        format_source("MP 1\nFIXED_MOVE X, -5\nEND MP\n")


def test_a_comment_moved_off_its_line_is_caught(monkeypatch: pytest.MonkeyPatch) -> None:
    """`# mpc: ignore[...]` silences its own line: a comment must stay with its code."""
    monkeypatch.setattr("mplang.tools.fmt.COMMENT_GAP", "\n")
    with pytest.raises(FormatterBug):
        format_source("MP 1\nVAR7 = VAR7 + 1  # mpc: ignore[W103]\nEND MP\n")


# ------------------------------------------------------------------------ options


def test_options_from_a_project_table() -> None:
    options = FormatOptions.from_mapping({"indent": 2, "keyword-case": "lower"})
    assert options == FormatOptions(indent=2, keyword_case="lower")
    assert FormatOptions.from_mapping({}) == FormatOptions(indent=4, keyword_case="upper")


@pytest.mark.parametrize(("table", "message"), [
    ({"indnet": 2}, "mpc.toml [fmt]: unknown key 'indnet' (known keys: indent, keyword-case)"),
    ({"indent": 0}, "mpc.toml [fmt]: indent must be a whole number of spaces from 1 to 16, "
                    "not 0"),
    ({"indent": 17}, "not 17"),
    ({"indent": "4"}, "not '4'"),
    ({"indent": True}, "not True"),
    ({"indent": 2.0}, "not 2.0"),
    ({"keyword-case": "title"}, "mpc.toml [fmt]: keyword-case must be one of upper, lower, "
                                "not 'title'"),
    ({"keyword_case": "lower"}, "unknown key 'keyword_case'"),
])
def test_bad_options_are_refused_with_a_clear_message(table: dict[str, object],
                                                       message: str) -> None:
    with pytest.raises(FormatOptionsError) as caught:
        FormatOptions.from_mapping(table, where="mpc.toml [fmt]")
    assert message in str(caught.value)


def test_options_are_checked_when_made_directly() -> None:
    with pytest.raises(FormatOptionsError):
        FormatOptions(indent=-1)


# -------------------------------------------------------------- property tests
#
# Programs are generated as token lines, then written out twice: plainly (single spaces) and
# perturbed (random whitespace, indentation, keyword case, repeated blank lines). Both must
# format to the same text, formatting must be idempotent, and the build must not change.

WORD = "word"  # a name or number: needs whitespace next to another word
KEY = "key"  # keyword or command name: its case is the formatter's to choose
PUNCT = "punct"


@dataclass(frozen=True)
class Tok:
    text: str
    kind: str


Line = tuple[tuple[Tok, ...], str | None] | None  # tokens and trailing comment; None: blank

AXES = ["X", "Y", "Z", "U"]


def key(text: str) -> Tok:
    return Tok(text, KEY)


def word(text: str) -> Tok:
    return Tok(text, WORD)


def punct(text: str) -> Tok:
    return Tok(text, PUNCT)


@st.composite
def expressions(draw: st.DrawFn, depth: int = 0, *, constant: bool = False,
                reads: bool = False) -> list[Tok]:
    """Small integer expressions (folded values stay far inside the device range); with
    variables unless `constant`, with value-returning reads if `reads`."""
    options = [st.integers(0, 99).map(lambda n: [word(str(n))]),
               st.integers(1, 63).map(lambda n: [word(hex(n))]),
               st.just([word("SPEED")])]
    if not constant:
        options.append(st.integers(1, 40).map(lambda n: [word(f"VAR{n}")]))
    if reads:
        options.append(st.sampled_from(AXES).map(
            lambda a: [key("GET_LP"), punct("("), word(a), punct(")")]))
    atoms = st.one_of(*options)
    if depth >= 2:
        return draw(atoms)
    inner = expressions(depth + 1, constant=constant, reads=reads)
    choice = draw(st.integers(0, 4))
    if choice == 0:
        return draw(atoms)
    if choice == 1:
        return [punct("-"), *draw(inner)]
    if choice == 2:
        return [punct("("), *draw(inner), punct(")")]
    op = draw(st.sampled_from(["+", "-", "*", "/", "&", "|"]))
    left = draw(inner)
    right = [word(str(draw(st.integers(1, 9))))] if op == "/" else draw(inner)  # never / 0
    return [*left, punct(op), *right]


@st.composite
def simple_statements(draw: st.DrawFn, labels: tuple[str, ...]) -> list[Tok]:
    axis = draw(st.sampled_from(AXES))
    choice = draw(st.integers(0, 6 if labels else 5))
    if choice == 0:
        return [key("SET_V"), word(axis), punct(","), word(str(draw(st.integers(1, 20000))))]
    if choice == 1:
        return [key("FIXED_MOVE"), word(axis), punct(","),
                *draw(expressions(1, constant=True))]
    if choice == 2:
        return [key("STOP_WAIT"), word(axis)]
    if choice == 3:
        target = word(f"VAR{draw(st.integers(1, 40))}")
        return [target, punct("="), *draw(expressions(reads=True))]
    if choice == 4:
        return [key("TIMER"), word(str(draw(st.integers(0, 500))))]
    if choice == 5:
        return [key("CALL"), word("helper")]
    return [key("GOTO"), word(draw(st.sampled_from(labels)))]


@st.composite
def blocks(draw: st.DrawFn, depth: int, labels: tuple[str, ...]) -> list[Line]:
    lines: list[Line] = []
    for _ in range(draw(st.integers(1, 3))):
        comment = draw(st.none() | st.sampled_from(["# note", "// why", "#x#y"]))
        kind = draw(st.integers(0, 5)) if depth < 2 else draw(st.sampled_from([0, 5]))
        if draw(st.booleans()) and draw(st.booleans()):
            lines.append(None)
        if kind in (0, 1, 2):
            lines.append((tuple(draw(simple_statements(labels))), comment))
        elif kind == 3:
            count = draw(st.integers(1, 5).map(str) | st.just("VAR7"))
            lines.append(((key("FOR"), word(count)), comment))
            lines += draw(blocks(depth + 1, labels))
            if draw(st.booleans()):
                lines.append(((key("EXIT"), key("FOR")), None))
            lines.append(((key("NEXT"),), None))
        elif kind == 4:
            cmp = draw(st.sampled_from(["<", ">", "<=", ">=", "==", "!="]))
            then = (key("THEN"),) if draw(st.booleans()) else ()
            head = (key("IF"), *draw(expressions(1)), punct(cmp), *draw(expressions(1)), *then)
            lines.append((head, comment))
            lines += draw(blocks(depth + 1, labels))
            if draw(st.booleans()):
                lines.append(((key("ELSE"),), None))
                lines += draw(blocks(depth + 1, labels))
            lines.append(((key("END"), key("IF")), None))
        else:
            lines.append(((), draw(st.sampled_from(["# own line", "// own line"]))))
    return lines


@st.composite
def programs(draw: st.DrawFn) -> list[Line]:
    labels = ("again",) if draw(st.booleans()) else ()
    lines: list[Line] = [((key("CONST"), word("SPEED"), punct("="), word("20"), punct("*"),
                           word("2")), "# speed"),
                         None,
                         ((key("MP"), word("156"), word("main")), None)]
    if labels:
        lines.append(((key("LABEL"), word("again")), None))
    lines += draw(blocks(0, labels))
    lines += [((key("END"), key("MP")), None), None,
              ((key("MP"), word("helper")), None),
              ((key("SET_V"), word("X"), punct(","), word("100")), None),
              ((key("END"), key("MP")), None)]
    return lines


def plain(lines: list[Line]) -> str:
    out = []
    for line in lines:
        if line is None:
            out.append("")
            continue
        tokens, comment = line
        text = " ".join(t.text for t in tokens)
        out.append(f"{text} {comment}".strip() if comment else text)
    return "\n".join(out) + "\n"


@st.composite
def perturbed(draw: st.DrawFn, lines: list[Line]) -> str:
    """The same program with whitespace, keyword case and blank-line runs changed."""
    space = st.text(alphabet=" \t", min_size=1, max_size=4)
    maybe_space = st.text(alphabet=" \t", max_size=3)
    out: list[str] = [""] * draw(st.integers(0, 2))
    for line in lines:
        if line is None:
            out += [draw(maybe_space) for _ in range(draw(st.integers(1, 3)))]
            continue
        tokens, comment = line
        text = draw(maybe_space)
        previous: Tok | None = None
        for tok in tokens:
            if previous is not None:
                both_words = previous.kind != PUNCT and tok.kind != PUNCT
                text += draw(space if both_words else maybe_space)
            spelling = tok.text
            if tok.kind == KEY:
                flips = draw(st.lists(st.booleans(), min_size=len(spelling),
                                      max_size=len(spelling)))
                spelling = "".join(c.lower() if flip else c for c, flip in zip(spelling, flips,
                                                                               strict=True))
            text += spelling
            previous = tok
        if comment:
            text += draw(maybe_space) + comment
        out.append(text + draw(maybe_space))
    out += [""] * draw(st.integers(0, 2))
    return "\n".join(out)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), options=st.builds(FormatOptions, indent=st.integers(1, 8),
                                         keyword_case=st.sampled_from(["upper", "lower"])))
def test_generated_programs_format_stably_and_build_the_same(data: st.DataObject,
                                                             options: FormatOptions) -> None:
    lines = data.draw(programs())
    source = plain(lines)
    messy = data.draw(perturbed(lines))
    formatted = format_source(messy, options)
    assert formatted == format_source(source, options)
    assert format_source(formatted, options) == formatted
    before, after = compile_source(messy), compile_source(formatted)
    assert before.ok, [d.render() for d in before.diagnostics]
    assert frames(after) == frames(before)
    assert codes(after) == codes(before)


@cache
def basic_lexer() -> Lark:
    grammar = resources.files("mplang.grammar").joinpath("mplang.lark").read_text("utf-8")
    return Lark(grammar, parser="lalr", lexer="basic", start="start")


@st.composite
def messed_up_sample(draw: st.DrawFn, path: Path) -> str:
    """A sample with every run of whitespace, the case of its keywords and commands, blank
    runs and indentation changed, and spaces put next to its punctuation. (One random
    generator per example: drawing each of thousands of tokens from hypothesis is slow.)"""
    rnd = draw(st.randoms(use_true_random=False))
    known = catalogue.load()

    def whitespace(least: int) -> str:
        return "".join(rnd.choice(" \t") for _ in range(rnd.randint(least, 3)))

    out: list[str] = [whitespace(0)]
    line_has_content = False
    for token in basic_lexer().lex(path.read_text(), dont_ignore=True):
        text = str(token)
        if token.type.startswith("__IGNORE"):
            out.append(whitespace(1))
            continue
        if token.type == "_NL":
            if not line_has_content:  # a blank line: make the run longer, maybe
                out.append((text + whitespace(0)) * rnd.randint(0, 2))
            out += [text, whitespace(0)]
            line_has_content = False
            continue
        line_has_content = True
        if token.type in KEYWORDS or (token.type == "NAME" and known.lookup(text)):
            text = rnd.choice([text.lower(), text.upper(), text.title()])
        elif token.type not in ("NAME", "INT", "STRING", "COMMENT"):
            text = whitespace(0) + text + whitespace(0)
        out.append(text)
    return "".join(out)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), path=st.sampled_from(SAMPLES))
def test_messed_up_samples_format_back_and_build_the_same(data: st.DataObject,
                                                          path: Path) -> None:
    messy = data.draw(messed_up_sample(path))
    formatted = format_source(messy)
    assert formatted == formatted_sample(path)
    for text in (messy, formatted):
        result = build_instead(path, text)
        assert result.ok and frames(result) == sample_frames(path)


VOCABULARY = ["MP", "ISR", "END", "FOR", "NEXT", "IF", "ELSE", "THEN", "EXIT", "LABEL", "GOTO",
              "CALL", "CONST", "ALIAS", "INCLUDE", "TERMINATE", "SET_V", "get_lp", "END_IF",
              "X", "xy", "VAR1", "var2", "A", "7", "0x1F", "-", "+", "*", "/", "&", "|", "(",
              ")", ",", "=", "==", "<=", "!=", "'+'", '"s"', "# c", "// c", "\v", "\r", "@"]


@settings(max_examples=150, deadline=None)
@given(st.lists(st.lists(st.tuples(st.sampled_from(VOCABULARY),
                                   st.text(alphabet=" \t", max_size=2)), max_size=6),
                max_size=12))
def test_any_token_soup_is_formatted_safely_or_refused(soup: list[list[tuple[str, str]]]
                                                       ) -> None:
    """Whatever the text, the formatter either refuses it with diagnostics or returns a
    fixed point that builds exactly as the source does."""
    source = "\n".join("".join(token + space for token, space in line) for line in soup)
    try:
        formatted = format_source(source)
    except SourceNotFormattable as refused:
        assert refused.diagnostics and all(d.code == "E101" for d in refused.diagnostics)
        return
    assert format_source(formatted) == formatted
    before, after = compile_source(source), compile_source(formatted)
    assert codes(after) == codes(before)
    assert frames(after) == frames(before)

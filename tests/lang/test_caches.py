"""mpc's caches (docs/cli.md, "Caches"): per-file front-end results, the catalogue and lark's
tables, each rebuilt on any change and ignored when damaged. Parses are counted through the
parser's hook, never timed."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner

from mplang.cli import main
from mplang.ir import catalogue
from mplang.lang import caches, frontcache, parser
from mplang.lang.diagnostics import DiagnosticSink
from mplang.m8194h.compiler import compile_paths

MAIN = 'INCLUDE "a.mp"\nINCLUDE "b.mp"\nMP 1\n  X_SPEED = A + B\nEND MP\n'


@pytest.fixture
def cache_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    directory = tmp_path / "cache"
    monkeypatch.setenv("MPLANG_CACHE", str(directory))
    return directory


@pytest.fixture
def parsed() -> Iterator[list[str]]:
    """The files parsed (not taken from the cache) while the test runs."""
    names: list[str] = []
    parser.PARSE_HOOKS.append(names.append)
    yield names
    parser.PARSE_HOOKS.remove(names.append)


def _project(root: Path) -> Path:
    (root / "mpc.toml").write_text("")
    (root / "a.mp").write_text("CONST A = 1\nALIAS X_SPEED = VAR7\n")
    (root / "b.mp").write_text("CONST B = 2\n")
    main_file = root / "main.mp"
    main_file.write_text(MAIN)
    return main_file


def _image(main_file: Path) -> tuple[object, ...]:
    result = compile_paths([main_file])
    return (result.ok, [d.render() for d in result.diagnostics],
            [[line.frame for line in p.lines] for p in result.programs])


def test_a_second_build_parses_only_the_changed_file(tmp_path: Path, cache_dir: Path,
                                                     parsed: list[str]) -> None:
    main_file = _project(tmp_path)
    first = _image(main_file)
    assert sorted(Path(name).name for name in parsed) == ["a.mp", "b.mp", "main.mp"]
    parsed.clear()
    assert _image(main_file) == first
    assert parsed == []
    (tmp_path / "b.mp").write_text("CONST B = 2 * 2\n")
    changed = _image(main_file)
    assert [Path(name).name for name in parsed] == ["b.mp"]
    assert changed != first  # the new constant reached the image


def test_a_number_edit_is_built_without_a_parse(tmp_path: Path, cache_dir: Path,
                                                parsed: list[str]) -> None:
    """A line that differs from a cached one in its numbers only is built from the recipe
    kept with it (`mplang.lang.recipes`): no parse, and the image and diagnostics of a
    build without any cache; a number too long is parsed, and reported as then."""
    main_file = _project(tmp_path)
    _image(main_file)
    # an entry keeps the recipes of the file's lines as it was last built: a hex number
    # is another template; after the line failed there is none
    for text, parses in (("CONST B = 7\n", []), ("CONST B = 12345\n", []),
                         ("CONST B = 0x7F\n", ["b.mp"]), ("CONST B = 0x10\n", []),
                         ("CONST B = " + "9" * 30 + "\n", ["b.mp"]),
                         ("CONST B = 5\n", ["b.mp"]), ("CONST B = 6\n", [])):
        parsed.clear()
        (tmp_path / "b.mp").write_text(text)
        changed = _image(main_file)
        assert [Path(name).name for name in parsed] == parses, text
        caches.turn_off(True)
        try:
            assert _image(main_file) == changed, text
        finally:
            caches.turn_off(False)


def test_syntax_errors_come_back_from_the_cache(tmp_path: Path, cache_dir: Path,
                                                parsed: list[str]) -> None:
    main_file = tmp_path / "bad.mp"
    main_file.write_text("MP 1\n  X = = 1\n  FOO 999999999999999999999\nEND MP\n")
    first = _image(main_file)
    assert parsed and not first[0]
    parsed.clear()
    assert _image(main_file) == first
    assert parsed == []


def test_a_damaged_cache_is_ignored(tmp_path: Path, cache_dir: Path,
                                    parsed: list[str]) -> None:
    main_file = _project(tmp_path)
    first = _image(main_file)
    entries = list((cache_dir / "front").iterdir())
    assert len(entries) == 3
    for number, entry in enumerate(entries):
        # garbage, a cut-off pickle, and a well-formed pickle of something else
        entry.write_bytes([b"\x80\x05garbage", entry.read_bytes()[:20],
                           b"\x80\x04\x95\x05\x00\x00\x00\x00\x00\x00\x00K\x01K\x02\x86."]
                          [number % 3])
    parsed.clear()
    assert _image(main_file) == first
    assert len(parsed) == 3


def test_another_front_end_is_a_miss(tmp_path: Path, cache_dir: Path, parsed: list[str],
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """A changed grammar or parser (here, its key) never reuses an entry."""
    main_file = _project(tmp_path)
    _image(main_file)
    parsed.clear()
    monkeypatch.setattr(frontcache, "front_end_key", lambda: "another front end")
    _image(main_file)
    assert len(parsed) == 3


def test_an_unwritable_cache_dir_only_costs_time(tmp_path: Path, parsed: list[str],
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    blocker = tmp_path / "not-a-dir"
    blocker.write_text("")
    monkeypatch.setenv("MPLANG_CACHE", str(blocker / "cache"))
    main_file = _project(tmp_path)
    assert _image(main_file)[0]
    assert _image(main_file)[0]
    assert len(parsed) == 6


def test_no_cache_parses_every_file(tmp_path: Path, cache_dir: Path, parsed: list[str],
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    main_file = _project(tmp_path)
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    assert runner.invoke(main, ["lint", str(main_file)]).exit_code == 0
    parsed.clear()
    assert runner.invoke(main, ["lint", "--no-cache", str(main_file)]).exit_code == 0
    assert len(parsed) == 3
    parsed.clear()
    assert runner.invoke(main, ["lint", str(main_file)]).exit_code == 0  # on again
    assert parsed == []


def test_cache_off_in_the_environment(tmp_path: Path, parsed: list[str],
                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MPLANG_CACHE", "off")
    assert caches.user_cache_dir() is None
    main_file = _project(tmp_path)
    _image(main_file)
    _image(main_file)
    assert len(parsed) == 6


def test_the_catalogue_is_rebuilt_when_its_toml_changes(cache_dir: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """stdlib/m8194h/*.toml stay the one source: a changed text is a miss."""
    catalogue.load.cache_clear()
    monkeypatch.setattr(catalogue, "BUILDS", [])
    try:
        first = catalogue.load()
        catalogue.load.cache_clear()
        assert catalogue.load() == first
        assert catalogue.BUILDS == ["m8194h"]  # the second load came from the cache
        original = catalogue._read_text

        def changed(family: str, filename: str) -> str:
            text = original(family, filename)
            return text.replace('summary = "', 'summary = "changed: ', 1) \
                if filename == "commands.toml" else text

        monkeypatch.setattr(catalogue, "_read_text", changed)
        catalogue.load.cache_clear()
        rebuilt = catalogue.load()
        assert catalogue.BUILDS == ["m8194h", "m8194h"]
        assert any(c.summary.startswith("changed: ") for c in rebuilt.commands)
        for entry in cache_dir.glob("catalogue-*"):
            entry.write_bytes(b"damaged")
        catalogue.load.cache_clear()
        assert catalogue.load() == rebuilt
        assert len(catalogue.BUILDS) == 3
    finally:
        catalogue.load.cache_clear()


def test_lark_tables_from_the_cache_parse_the_same(cache_dir: Path) -> None:
    grammar = parser._grammar()
    built = parser.cached_lark(grammar, "test", start="start")
    assert list(cache_dir.glob("lark-test-*.pickle"))
    loaded = parser.cached_lark(grammar, "test", start="start")
    text = "MP 1\n  X = -(1 + 2) * 3\nEND MP\n"
    assert loaded.parse(text) == built.parse(text)


def test_a_damaged_lark_table_cache_is_rebuilt(cache_dir: Path) -> None:
    grammar = parser._grammar()
    parser.cached_lark(grammar, "damaged", start="start")
    (entry,) = cache_dir.glob("lark-damaged-*.pickle")
    entry.write_bytes(entry.read_bytes()[:100])
    rebuilt = parser.cached_lark(grammar, "damaged", start="start")
    assert rebuilt.parse("MP 1\nEND MP\n").data == "start"


def test_an_unwritable_lark_table_cache_only_costs_time(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("MPLANG_CACHE", str(blocker / "cache"))
    built = parser.cached_lark(parser._grammar(), "nowhere", start="start")
    assert built.parse("MP 1\nEND MP\n").data == "start"


def test_the_kept_parser_parses_as_lark_builds_it(cache_dir: Path) -> None:
    """The fast parser kept pickled (`parser._freeze`) and read back by a later run gives
    the statements, spans and all, that a parser lark builds with every cache off."""
    text = "\n".join((Path(__file__).parents[2] / "samples" / name).read_text("utf-8")
                     for name in ("pick_and_place.mp", "machine.mp", "expressions.mp"))
    parser._fast_parser.cache_clear()
    try:
        parser._fast_parser()  # builds the tables, keeps them and the parser
        (state,) = cache_dir.glob("lark-fast-*.state")
        parser._fast_parser.cache_clear()
        thawed, _ = parser._fast_parser()
        assert type(thawed.parser.lexer) is parser.FastLexer
        # read back from the kept parser: lark's own cache would have made it anew
        assert thawed.source_path != "<deserialized>"
        assert thawed._callbacks is thawed.parser.parser.parser.callbacks
        kept = parser.parse_text(text, "s.mp", DiagnosticSink())
        caches.turn_off(True)
        parser._fast_parser.cache_clear()
        assert parser.parse_text(text, "s.mp", DiagnosticSink()) == kept
        assert parser._fast_parser()[0] is not thawed
    finally:
        caches.turn_off(False)
        parser._fast_parser.cache_clear()
    assert state.is_file()


@pytest.mark.parametrize("damage", [b"", b"damaged", None])
def test_a_damaged_kept_parser_is_made_again(cache_dir: Path, damage: bytes | None) -> None:
    grammar = parser._grammar()
    parser.cached_lark(grammar, "kept", start="start")
    (state,) = cache_dir.glob("lark-kept-*.state")
    good = state.read_bytes()
    damaged = good[:len(good) // 2] if damage is None else damage
    state.write_bytes(damaged)
    again = parser.cached_lark(grammar, "kept", start="start")
    assert again.parse("MP 1\nEND MP\n").data == "start"
    assert state.read_bytes() not in (damaged, b"")  # kept again, whole

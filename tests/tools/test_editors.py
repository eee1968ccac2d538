"""The VS Code extension (editors/vscode/) and the pre-commit hooks (.pre-commit-hooks.yaml).

The grammar and language configuration are generated from the language's own sources
(`python -m mplang.tools.editors`); these tests keep them current, check what they match against the
catalogue and the parser, and run the extension's own JavaScript test suites with node.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import click
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from mplang.cli import main
from mplang.ir import catalogue
from mplang.lang import ast
from mplang.lang.diagnostics import DiagnosticSink
from mplang.lang.parser import parse_text
from mplang.lang.sources import SourceFile, SourceSet
from mplang.lang.structure import build_unit
from mplang.tools.editors import CONFIGURATION_FILE, GRAMMAR_FILE, SCOPE, VSCODE, generated

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = sorted((ROOT / "samples").glob("*.mp"))
HOOKS_FILE = ROOT / ".pre-commit-hooks.yaml"
NODE_SETUP = "run `make tools` (it runs `npm ci --prefix editors/vscode`)"

# Every way of opening and closing a block, in mixed case and without indentation.
BLOCKS = """\
MP 21 square
    FOR 4
        IF VAR1 <= 5 THEN
            EXIT FOR
        ELSE
            VAR2 = 1
        END IF
    NEXT
    for var3
    end for
END MP
isr 3 on_compare
if var1 == 0
var2 = 1
end if
END ISR
MP helper
    RSM_MACRO_FOR 3
        rsm_macro_if VAR1, "<", 5
            VAR2 = 2
        ETM_MACRO_ELSE
            VAR2 = 3
        END_IF
    ETM_MACRO_NEXT
    Rsm_Macro_For 2
        IF VAR1 > 0
        RSM_MACRO_END_IF
    next
    # FOR in a comment opens nothing
    MP_CALL MP21
    EXIT_FOR_X = 1
    WHILE VAR1 < 10
        repeat 3
            VAR1 = VAR1 + 1
        End Repeat
    END WHILE
END   MP
"""


def _load(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


# ------------------------------------------------------------------ generated files


def test_generated_editor_files_are_committed_and_current() -> None:
    stale = [str(path.relative_to(ROOT)) for path, text in generated().items()
             if not path.exists() or path.read_text(encoding="utf-8") != text]
    assert stale == [], "run `python -m mplang.tools.editors` and commit the result"


def test_json_files_are_valid_and_agree() -> None:
    manifest = _load(VSCODE / "package.json")
    lock = _load(VSCODE / "package-lock.json")
    grammar = _load(GRAMMAR_FILE)
    configuration = _load(CONFIGURATION_FILE)
    (language,) = manifest["contributes"]["languages"]
    (contributed,) = manifest["contributes"]["grammars"]
    assert language["extensions"] == [".mp"]
    assert contributed["language"] == language["id"] == "mplang"
    assert contributed["scopeName"] == grammar["scopeName"] == SCOPE
    assert (VSCODE / contributed["path"]).resolve() == GRAMMAR_FILE
    assert (VSCODE / language["configuration"]).resolve() == CONFIGURATION_FILE
    assert manifest["main"] == "./dist/extension.js"  # the bundle `npm run bundle` makes
    assert (VSCODE / "extension.js").is_file() and (VSCODE / manifest["icon"]).is_file()
    assert f"onLanguage:{language['id']}" in manifest["activationEvents"]
    assert "mplang.server.path" in manifest["contributes"]["configuration"]["properties"]
    # bundled: the language client is built into dist/extension.js, nothing is installed
    assert "dependencies" not in manifest
    assert {"vscode-languageclient", "vscode-tmgrammar-test", "@vscode/vsce", "esbuild"} <= \
        set(manifest["devDependencies"])
    root_package = lock["packages"][""]
    assert (lock["name"], lock["version"]) == (manifest["name"], manifest["version"])
    assert root_package["devDependencies"] == manifest["devDependencies"]
    assert configuration["comments"]["lineComment"] == "#"
    assert ["(", ")"] in configuration["brackets"]
    ignored = (VSCODE / ".gitignore").read_text().split()
    assert {"node_modules/", "dist/", "*.vsix"} <= set(ignored)
    assert (VSCODE / "LICENSE").read_text() == (ROOT / "LICENSE").read_text()


MATCHER_PROBE = """MP 1 probe
    FIXED_MOVE X, 10
    GOTO away
    SET_V X, 5
    FOO X
END MP
"""


def _problem_matcher() -> dict[str, Any]:
    (matcher,) = _load(VSCODE / "package.json")["contributes"]["problemMatchers"]
    assert matcher["name"] == "mpc"
    return dict(matcher)


@pytest.mark.parametrize("command", ["lint", "build"])
def test_the_mpc_problem_matcher_reads_every_diagnostic_of_mpc_text_output(
        tmp_path: Path, command: str) -> None:
    """`$mpc` against real `mpc lint` / `mpc build` output: every diagnostic the JSON report
    lists is one matched line with its file, line, column, severity, code and message (the
    pattern is plain enough to mean the same in JavaScript and Python)."""
    matcher = _problem_matcher()
    pattern = matcher["pattern"]
    regexp = re.compile(pattern["regexp"])
    (tmp_path / "probe.mp").write_text(MATCHER_PROBE)
    args = ["-o", "probe.json"] if command == "build" else []
    text = subprocess.run([sys.executable, "-m", "mplang", command, "probe.mp", *args],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    report = subprocess.run([sys.executable, "-m", "mplang", "lint", "probe.mp",
                             "--format", "json"], cwd=tmp_path, capture_output=True, text=True,
                            timeout=120)
    expected = [(d["file"], str(d["line"]), str(d["column"]), d["severity"], d["code"],
                 d["message"]) for d in json.loads(report.stdout)]
    assert {e[3] for e in expected} == {"error", "warning"} and len(expected) >= 3
    found = []
    for line in (text.stdout + text.stderr).splitlines():
        match = regexp.match(line)
        if match:
            found.append(tuple(match.group(pattern[key]) for key in
                               ("file", "line", "column", "severity", "code", "message")))
    assert found == expected
    assert matcher["fileLocation"][0] == "autoDetect"  # relative to the folder, or absolute
    windows = regexp.match(r"C:\cell\job.mp:3:5: warning[W101]: unreachable: x")
    assert windows is not None and windows.group(pattern["file"]) == r"C:\cell\job.mp"


def test_the_task_type_runs_lint_and_build() -> None:
    (task,) = _load(VSCODE / "package.json")["contributes"]["taskDefinitions"]
    assert task["type"] == "mpc" and task["required"] == ["command"]
    assert task["properties"]["command"]["enum"] == ["lint", "build"]
    assert "\"problemMatcher\": \"$mpc\"" in (ROOT / "docs" / "editors.md").read_text()


def test_vsce_packages_the_bundle_alone_without_a_warning(tmp_path: Path) -> None:
    """`vsce package` (its prepublish step bundles extension.js with esbuild) warns about
    nothing, and the .vsix holds only what runs."""
    vsix = tmp_path / "mplang.vsix"
    result = _npx("vsce", "package", "--allow-missing-repository", "-o", str(vsix))
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    assert "WARNING" not in output, output
    names = set(zipfile.ZipFile(vsix).namelist())
    assert {n for n in names if n.startswith("extension/")} == {
        "extension/package.json", "extension/dist/extension.js", "extension/LICENSE.txt",
        "extension/readme.md", "extension/images/icon.png",
        "extension/language-configuration.json", "extension/syntaxes/mplang.tmLanguage.json"}


def _grammar_rules() -> list[dict[str, Any]]:
    """Every rule of the grammar's repository, nested pattern lists flattened."""
    rules: list[dict[str, Any]] = []

    def collect(rule: dict[str, Any]) -> None:
        rules.append(rule)
        for inner in rule.get("patterns", []):
            collect(inner)

    for rule in _load(GRAMMAR_FILE)["repository"].values():
        collect(rule)
    return rules


def _scopes_matching(word: str) -> set[str]:
    """Scopes of the single-token rules that match `word` whole (Python's re reads these
    Oniguruma patterns the same way: `(?i)`, `\\b`, classes and alternations only)."""
    found = set()
    for rule in _grammar_rules():
        if "name" in rule and "match" in rule and re.fullmatch(rule["match"], word):
            found.add(rule["name"])
    return found


def test_every_macro_command_is_highlighted_in_every_spelling() -> None:
    cat = catalogue.load()
    expected = {"support.function.command.mplang", "support.function.query.mplang",
                "keyword.control.mplang"}
    missing = []
    for command in cat.commands:
        if not command.is_macro:
            continue
        tail = command.name.upper().removeprefix("RSM_")
        for spelling in (command.short_name, command.short_name.lower(), "RSM_" + tail,
                         "ETM_" + tail.lower()):
            scopes = _scopes_matching(spelling) & expected
            wanted = "support.function.query.mplang" if command.returns else None
            if not scopes or (wanted and wanted not in scopes):
                missing.append(spelling)
    assert missing == []


def test_real_time_only_commands_are_not_highlighted_as_commands() -> None:
    cat = catalogue.load()
    rtc_only = [c.short_name for c in cat.commands
                if not c.is_macro and c.short_name not in cat.macro_by_short]
    assert rtc_only
    highlighted = [name for name in rtc_only
                   if _scopes_matching(name) & {"support.function.command.mplang",
                                                "support.function.query.mplang"}]
    assert highlighted == []


def test_symbols_and_axis_names_follow_the_catalogue() -> None:
    cat = catalogue.load()
    symbols = set(cat.profile.cmp_symbols)
    for command in cat.commands:
        if command.is_macro:
            for param in command.params:
                symbols |= set(param.symbols)
    assert symbols
    assert [s for s in symbols if "support.constant.symbol.mplang" not in _scopes_matching(s)] \
        == []
    axis = "constant.language.axis.mplang"
    for code in range(1, 16):
        name = cat.profile.axis_name(code)
        for spelling in (name, name.lower(), f"AXIS_{name}", f"INITIAL_{name}"):
            assert cat.profile.axis_code(spelling) is not None
            assert axis in _scopes_matching(spelling), spelling
    for not_an_axis in ("YX", "XX", "UZ", "AXIS_", "XYZ_SPEED", "XA"):
        assert cat.profile.axis_code(not_an_axis) is None
        assert axis not in _scopes_matching(not_an_axis), not_an_axis


# ------------------------------------------------------------ language configuration


def _marker_ranges(text: str, start: str, end: str) -> set[tuple[int, int]]:
    """Folding ranges (1-based first and last line) that VS Code makes from the markers.

    The marker part of VS Code's indentation range provider: lines are read bottom-up, the
    two regexes are joined as `(start)|(?:end)` without flags, an end marker is pushed, a
    start marker folds up to the nearest unconsumed end marker below it.
    """
    pattern = re.compile(f"({start})|(?:{end})")
    ends: list[int] = []
    ranges = set()
    lines = text.splitlines()
    for number in range(len(lines), 0, -1):
        line = lines[number - 1]
        if not line.strip():
            continue
        match = pattern.match(line)
        if match is None:
            continue
        if match.group(1) is None:
            ends.append(number)
        elif ends:
            ranges.add((number, ends.pop()))
    return ranges


def _block_ranges(text: str) -> set[tuple[int, int]]:
    """(first, last) line of every MP/ISR, FOR and IF block, as the compiler's front end
    matches them."""
    sink = DiagnosticSink()
    statements = parse_text(text, "blocks.mp", sink)
    unit = build_unit(SourceSet([SourceFile(Path("blocks.mp"), "blocks.mp", text,
                                            statements)]), sink)
    assert sink.errors == []
    ranges = set()

    def walk(nodes: list[ast.Node]) -> None:
        for node in nodes:
            if isinstance(node, ast.ForBlock | ast.RepeatBlock | ast.WhileBlock):
                ranges.add((node.span.line, node.end_span.line))
                walk(node.body)
            elif isinstance(node, ast.IfBlock):
                ranges.add((node.span.line, node.end_span.line))
                walk(node.then)
                walk(node.otherwise or [])

    for program in unit.programs:
        ranges.add((program.span.line, program.end_span.line))
        walk(program.body)
    return ranges


def _folding(text: str) -> set[tuple[int, int]]:
    markers = _load(CONFIGURATION_FILE)["folding"]["markers"]
    return _marker_ranges(text, markers["start"], markers["end"])


def test_folding_markers_fold_every_block_spelling() -> None:
    expected = _block_ranges(BLOCKS)
    assert len(expected) == 13
    assert _folding(BLOCKS) == expected


@pytest.mark.parametrize("sample", SAMPLES, ids=lambda p: p.name)
def test_folding_markers_fold_the_blocks_of_the_samples(sample: Path) -> None:
    text = sample.read_text(encoding="utf-8")
    assert _folding(text) == _block_ranges(text)


def _program_text(draw: st.DrawFn) -> str:
    """A random MP or ISR: nested FOR, REPEAT, WHILE and IF/ELSE blocks, random case and
    indentation (the structure pass accepts them anywhere; the lowering would reject some)."""
    lines: list[str] = []

    def word(text: str) -> str:
        return "".join(ch.lower() if draw(st.booleans()) else ch for ch in text)

    def indent() -> str:
        return " " * draw(st.sampled_from([0, 1, 4]))

    def body(depth: int) -> None:
        for _ in range(draw(st.integers(0, 3))):
            kind = draw(st.sampled_from(["stmt", "for", "if", "loop"] if depth < 4
                                        else ["stmt"]))
            if kind == "stmt":
                lines.append(indent() + draw(st.sampled_from(
                    ["VAR1 = VAR1 + 1", "FIXED_MOVE X, 10", "# FOR 2", "EXIT FOR",
                     "STOP_WAIT X"])))
            elif kind == "loop":
                head, end = draw(st.sampled_from([("WHILE VAR2 > 0", "END WHILE"),
                                                  ("REPEAT 3", "END REPEAT")]))
                lines.append(indent() + word(head))
                body(depth + 1)
                lines.append(indent() + word(end))
            elif kind == "for":
                lines.append(indent() + word(draw(st.sampled_from(["FOR", "RSM_MACRO_FOR"])))
                             + " 2")
                body(depth + 1)
                lines.append(indent() + word(draw(st.sampled_from(
                    ["NEXT", "END FOR", "ETM_MACRO_NEXT"]))))
            else:
                lines.append(indent() + word("IF") + " VAR1 < 3")
                body(depth + 1)
                if draw(st.booleans()):
                    lines.append(indent() + word("ELSE"))
                    body(depth + 1)
                lines.append(indent() + word(draw(st.sampled_from(
                    ["END IF", "END_IF", "RSM_MACRO_END_IF"]))))

    kind = draw(st.sampled_from(["MP", "ISR"]))
    lines.append(word(kind) + " 10 generated")
    body(0)
    lines.append(indent() + word(f"END {kind}"))
    return "\n".join(lines) + "\n"


@settings(max_examples=60, deadline=None)
@given(st.composite(_program_text)())
def test_folding_markers_agree_with_the_parser_on_any_nesting(text: str) -> None:
    assert _folding(text) == _block_ranges(text)


def _opens_or_closes(statement: ast.Statement) -> tuple[bool, bool]:
    """Whether a line should indent the next line, and whether it should dedent itself."""
    if isinstance(statement, ast.Command):
        name = statement.name.upper()
        for prefix in ("RSM_MACRO_", "ETM_MACRO_"):
            name = name.removeprefix(prefix)
        return name in ("FOR", "IF", "ELSE"), name in ("NEXT", "END_IF", "ELSE")
    opens = isinstance(statement, ast.ProgramHeader | ast.ForStmt | ast.IfStmt | ast.Else
                       | ast.WhileStmt | ast.RepeatStmt)
    closes = isinstance(statement, ast.End | ast.Next | ast.Else)
    return opens, closes


@pytest.mark.parametrize("name", ["blocks", *(p.name for p in SAMPLES)])
def test_indentation_rules_follow_the_blocks(name: str) -> None:
    text = BLOCKS if name == "blocks" else (ROOT / "samples" / name).read_text("utf-8")
    rules = _load(CONFIGURATION_FILE)["indentationRules"]
    increase = re.compile(rules["increaseIndentPattern"])
    decrease = re.compile(rules["decreaseIndentPattern"])
    lines = text.splitlines()
    statements = parse_text(text, name, DiagnosticSink())
    assert statements
    for statement in statements:
        line = lines[statement.span.line - 1]
        opens, closes = _opens_or_closes(statement)
        assert bool(increase.match(line)) == opens, line
        assert bool(decrease.match(line)) == closes, line


# ---------------------------------------------------------- the JavaScript test suites


def _npx(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """Run a tool of editors/vscode/node_modules; fail (never skip) when it is missing."""
    npx = shutil.which("npx")
    if npx is None:
        pytest.fail(f"npx (Node.js) is not installed: {NODE_SETUP}")
    if not (VSCODE / "node_modules" / ".bin" / args[0]).exists():
        pytest.fail(f"editors/vscode/node_modules has no {args[0]}: {NODE_SETUP}")
    return subprocess.run([npx, "--no", "--", *args], cwd=VSCODE, capture_output=True,
                          text=True, timeout=300, env=env)


def test_grammar_unit_tests_pass() -> None:
    result = _npx("vscode-tmgrammar-test", "--compact", "tests/unit/*.mptest")
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.count("run successful") == len(list((VSCODE / "tests" / "unit")
                                                             .glob("*.mptest")))


def test_grammar_snapshot_is_unchanged() -> None:
    result = _npx("vscode-tmgrammar-snap", "--scope", SCOPE, "tests/snap/*.mptest")
    assert result.returncode == 0, (result.stdout + result.stderr
                                    + "\nif the change is intended: cd editors/vscode && "
                                      "npm run snap:update")
    assert "run successfully" in result.stdout


def test_extension_tests_pass_against_the_real_mpc_lsp() -> None:
    """extension.js with a fake VS Code, and `mpc lsp` started the way it starts it."""
    node = shutil.which("node")
    if node is None:
        pytest.fail(f"node is not installed: {NODE_SETUP}")
    if not (VSCODE / "node_modules" / "vscode-languageclient").is_dir():
        pytest.fail(f"editors/vscode/node_modules is missing: {NODE_SETUP}")
    mpc = Path(sys.executable).parent / "mpc"
    assert mpc.exists(), "the mpc script of this Python environment is missing"
    env = {**os.environ, "MPLANG_SERVER_PATH": str(mpc)}
    result = subprocess.run([node, "--test", "tests/"], cwd=VSCODE, capture_output=True,
                            text=True, timeout=300, env=env)
    assert result.returncode == 0, result.stdout + result.stderr
    assert re.search(r"^# fail 0$", result.stdout, re.MULTILINE), result.stdout
    passed = re.search(r"^# pass (\d+)$", result.stdout, re.MULTILINE)
    assert passed is not None and int(passed.group(1)) >= 6, result.stdout


# ------------------------------------------------------------------ pre-commit hooks


def read_hooks(text: str) -> list[dict[str, str]]:
    """The hooks of .pre-commit-hooks.yaml: a YAML list of flat `key: value` mappings.

    Only that subset is read (no PyYAML dependency for one small file); anything else fails.
    """
    hooks: list[dict[str, str]] = []
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.rstrip()
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        if line.startswith("- "):
            hooks.append({})
            line = "  " + line[2:]
        match = re.fullmatch(r"  ([a-z_]+): (\S.*)", line)
        if match is None or not hooks:
            raise ValueError(f".pre-commit-hooks.yaml:{number}: not a `key: value` line of a "
                             f"hook: {raw!r}")
        key, value = match.groups()
        if value[0] in "'\"" and value[-1] == value[0]:
            value = value[1:-1]
        elif value[0] in "[{&*!|>'\"" or " #" in value:
            raise ValueError(f".pre-commit-hooks.yaml:{number}: write {key} as a plain value")
        if key in hooks[-1]:
            raise ValueError(f".pre-commit-hooks.yaml:{number}: {key} given twice")
        hooks[-1][key] = value
    return hooks


def test_hook_reader_refuses_what_it_cannot_read() -> None:
    assert read_hooks("- id: a\n  entry: 'mpc lint'\n") == [{"id": "a", "entry": "mpc lint"}]
    for bad in ("- id: a\n  args: [--werror]\n", "id: a\n", "- id: a\n    entry: x\n",
                "- id: a\n  id: b\n", "- id: a  # comment\n"):
        with pytest.raises(ValueError):
            read_hooks(bad)


def _command(name: str) -> click.Command:
    with click.Context(main) as ctx:
        command = main.get_command(ctx, name)
    assert command is not None, f"`mpc {name}` is not a command of mpc"
    assert isinstance(command, click.Command)
    return command


def _unknown_options(name: str, words: list[str]) -> list[str]:
    """Options among `words` that `mpc NAME` does not have (after checking it exists)."""
    result = CliRunner().invoke(main, [name, "--help"])
    assert result.exit_code == 0, result.output
    known = {opt for param in _command(name).params
             for opt in (*param.opts, *param.secondary_opts)}
    return [w for w in words if w.startswith("-") and w != "-" and w.split("=")[0] not in known]


@pytest.mark.parametrize("page", ["ci.md", "editors.md"])
def test_docs_name_real_mpc_commands_and_options(page: str) -> None:
    text = (ROOT / "docs" / page).read_text(encoding="utf-8")
    blocks = re.findall(r"^```(?:sh|yaml)\n(.*?)^```", text, re.MULTILINE | re.DOTALL)
    lines = re.findall(r"^\s*(?:- )?(?:run: |entry: )?(mpc [^#\n]*)", "\n".join(blocks),
                       re.MULTILINE)
    assert len(lines) >= 2
    for line in lines:
        _, name, *words = shlex.split(line)
        assert _unknown_options(name, words) == [], line


def test_hooks_name_real_mpc_commands_and_options() -> None:
    hooks = {hook["id"]: hook for hook in read_hooks(HOOKS_FILE.read_text(encoding="utf-8"))}
    assert set(hooks) == {"mpc-lint", "mpc-fmt"}
    for hook_id, hook in hooks.items():
        assert hook["language"] == "python"
        assert hook["name"] and hook["description"]
        files = re.compile(hook["files"])
        assert files.search("samples/tour.mp") and not files.search("notes.mpx")
        program, name, *options = shlex.split(hook["entry"]) + shlex.split(hook.get("args", ""))
        assert (program, hook_id) == ("mpc", f"mpc-{name}")
        assert _unknown_options(name, options) == []
    assert hooks["mpc-lint"]["require_serial"] == "true"


def _hook(hook_id: str, *files: Path) -> tuple[int, str]:
    """Run a hook's entry on files, the way pre-commit does (entry, args, then filenames)."""
    hook = {h["id"]: h for h in read_hooks(HOOKS_FILE.read_text(encoding="utf-8"))}[hook_id]
    _, *words = shlex.split(hook["entry"]) + shlex.split(hook.get("args", ""))
    result = CliRunner().invoke(main, [*words, *map(str, files)])
    return result.exit_code, result.output


def test_lint_hook_passes_clean_files_and_stops_on_errors(tmp_path: Path) -> None:
    (tmp_path / ".git").mkdir()
    good = tmp_path / "good.mp"
    good.write_text("MP 21 square\n    FIXED_MOVE X, 1000\nEND MP\n")
    bad = tmp_path / "bad.mp"
    bad.write_text("MP 22 broken\n    FIXED_MOVE X\nEND MP\n")
    assert _hook("mpc-lint", good)[0] == 0
    code, output = _hook("mpc-lint", good, bad)
    assert code == 1
    assert "bad.mp:2:5: error[E411]" in output


def test_fmt_hook_leaves_files_formatted(tmp_path: Path) -> None:
    (tmp_path / ".git").mkdir()
    messy = tmp_path / "messy.mp"
    messy.write_text("mp 21 square\nfixed_move   x,1000\n  end mp\n")
    code, output = _hook("mpc-fmt", messy)
    assert code == 0, output
    assert messy.read_text() != "mp 21 square\nfixed_move   x,1000\n  end mp\n"
    check = CliRunner().invoke(main, ["fmt", "--check", str(messy)])
    assert check.exit_code == 0, check.output

"""`mpc lint` reports for CI: SARIF 2.1.0 that the official schema and GitHub's documented
ingestion rules accept, GitHub workflow commands with the toolkit's escaping, and GitLab Code
Quality JSON with its documented required keys."""

from __future__ import annotations

import json
import re
from importlib.metadata import version
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlsplit

import pytest
from click.testing import CliRunner
from sarifcheck import SCHEMA, validated

from mplang.cli import EXIT_SOURCE_ERRORS, main
from mplang.lang.diagnostics import Diagnostic, Span
from mplang.lang.rules import RULES
from mplang.tools import report
from mplang.tools.report import render_github, render_gitlab, render_sarif

ODD_NAME = "cell one/bad #1 ü.mp"


def every_rule(file: str) -> list[Diagnostic]:
    """One diagnostic per rule, so every rule's metadata goes through the checks."""
    return [Diagnostic(code, rule.severity, f"message of {code}", Span(file, n + 1, 3, 9),
                       hint="did you mean X?" if n % 2 else "")
            for n, (code, rule) in enumerate(RULES.items())]


def test_sarif_of_every_rule_validates_with_encoded_relative_uris(tmp_path: Path) -> None:
    sarif = validated(render_sarif(every_rule(str(tmp_path / ODD_NAME)), root=tmp_path))
    (run,) = sarif["runs"]
    assert run["columnKind"] == "unicodeCodePoints"
    assert run["originalUriBaseIds"] == {"%SRCROOT%": {"uri": tmp_path.resolve().as_uri() + "/"}}
    artifact = run["results"][0]["locations"][0]["physicalLocation"]["artifactLocation"]
    assert artifact == {"uri": "cell%20one/bad%20%231%20%C3%BC.mp", "uriBaseId": "%SRCROOT%"}
    rules = run["tool"]["driver"]["rules"]
    assert [r["id"] for r in rules] == sorted(RULES)
    for rule in rules:
        source = RULES[rule["id"]]
        assert rule["defaultConfiguration"] == {"level": source.severity.value}
        for part in (source.summary, source.why, source.fix):
            assert part in rule["help"]["text"] and part in rule["help"]["markdown"]


def test_sarif_relative_input_paths_and_files_outside_the_root(tmp_path: Path) -> None:
    inside = Diagnostic("E201", RULES["E201"].severity, "m", Span("a b.mp", 2))
    outside = Diagnostic("E202", RULES["E202"].severity, "m", Span("/elsewhere/x y.mp", 1))
    sarif = validated(render_sarif([inside, outside], root=tmp_path))
    first, second = (r["locations"][0]["physicalLocation"]["artifactLocation"]
                     for r in sarif["runs"][0]["results"])
    assert first == {"uri": "a%20b.mp", "uriBaseId": "%SRCROOT%"}
    assert second == {"uri": "file:///elsewhere/x%20y.mp"}


def from_uri(uri: str) -> Path:
    parts = urlsplit(uri)
    assert parts.scheme == "file"
    return Path(unquote(parts.path))


def test_sarif_links_the_docs_only_where_they_are_published(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """No link by default (no guessed address, never a file: URI of the machine that ran
    mpc), the help embedded; with MPC_DOCS_URL, helpUri and informationUri under it, naming
    pages that exist in docs/checks."""
    monkeypatch.delenv("MPC_DOCS_URL", raising=False)
    diagnostics = every_rule("x.mp")[:1]
    code = diagnostics[0].code
    driver = validated(render_sarif(diagnostics, root=tmp_path))["runs"][0]["tool"]["driver"]
    assert "helpUri" not in driver["rules"][0] and "informationUri" not in driver
    assert code in driver["rules"][0]["help"]["markdown"]
    root = Path(report.__file__).resolve().parents[2]  # the pages the links name exist
    assert (root / "docs" / "checks" / f"{code}.md").is_file()
    assert (root / "docs" / "checks" / "README.md").is_file()
    monkeypatch.setenv("MPC_DOCS_URL", "https://docs.example.org/mplang/")
    driver = validated(render_sarif(diagnostics, root=tmp_path))["runs"][0]["tool"]["driver"]
    assert driver["rules"][0]["helpUri"] == f"https://docs.example.org/mplang/checks/{code}.md"
    assert driver["informationUri"] == "https://docs.example.org/mplang/checks/README.md"


def test_the_forms_issue_15_reported_are_rejected(tmp_path: Path) -> None:
    """The checks have teeth: a relative helpUri, an unencoded file name and a relative
    file URI without a base fail them."""
    sarif = json.loads(render_sarif(every_rule("x.mp")[:1], root=tmp_path))
    sarif["runs"][0]["tool"]["driver"]["rules"][0]["helpUri"] = "docs/checks/E101.md"
    with pytest.raises(AssertionError, match="is not a 'uri'"):
        validated(json.dumps(sarif))
    sarif = json.loads(render_sarif(every_rule("x.mp")[:1], root=tmp_path))
    artifact = sarif["runs"][0]["results"][0]["locations"][0]["physicalLocation"][
        "artifactLocation"]
    artifact["uri"] = "cell one/bad.mp"
    with pytest.raises(AssertionError, match="is not a 'uri-reference'"):
        validated(json.dumps(sarif))
    artifact["uri"] = "bad.mp"
    del artifact["uriBaseId"]
    with pytest.raises(AssertionError, match="relative uri without uriBaseId"):
        validated(json.dumps(sarif))


def _unescape(text: str) -> str:
    return re.sub(r"%(25|0D|0A|3A|2C)", lambda m: bytes.fromhex(m[1]).decode(), text)


COMMAND = re.compile(r"^::(error|warning|notice) ([^:]*)::(.*)$")


def parse_commands(text: str) -> list[tuple[str, dict[str, str], str]]:
    """Workflow commands read back as the runner reads them."""
    parsed = []
    for line in text.splitlines():
        match = COMMAND.match(line)
        assert match, line
        props = dict(pair.split("=", 1) for pair in match[2].split(","))
        parsed.append((match[1], {k: _unescape(v) for k, v in props.items()},
                       _unescape(match[3])))
    return parsed


def test_github_workflow_commands_escape_data_and_properties(tmp_path: Path) -> None:
    file = tmp_path / "a,b:c" / "100%.mp"
    message = "50% of\r\nthe line: a, b"
    diagnostics = [Diagnostic("E201", RULES["E201"].severity, message, Span(str(file), 4, 3, 12),
                              hint="use X"),
                   Diagnostic("W102", RULES["W102"].severity, "w", Span(str(file), 5, 1))]
    text = render_github(diagnostics, root=tmp_path)
    assert text.startswith("::error file=a%2Cb%3Ac/100%25.mp,line=4,col=3,endLine=4,"
                           "endColumn=12,title=E201 unknown-command::50%25 of%0D%0Athe line: "
                           "a, b (use X)\n")
    assert parse_commands(text) == [
        ("error", {"file": "a,b:c/100%.mp", "line": "4", "col": "3", "endLine": "4",
                   "endColumn": "12", "title": "E201 unknown-command"},
         message + " (use X)"),
        ("warning", {"file": "a,b:c/100%.mp", "line": "5", "col": "1", "endLine": "5",
                     "title": f"W102 {RULES['W102'].name}"}, "w")]


GITLAB_SEVERITIES = {"info", "minor", "major", "critical", "blocker"}
# the Code Climate issue categories, of which GitLab's format is a subset
CODE_CLIMATE_CATEGORIES = {"Bug Risk", "Clarity", "Compatibility", "Complexity", "Duplication",
                           "Performance", "Security", "Style"}


def check_code_quality(issues: Any) -> None:
    """GitLab's Code Quality report format: the keys its documentation marks required, and
    the Code Climate spec's `type` (always "issue") and `categories` (one or more of its
    list)."""
    assert isinstance(issues, list)
    for issue in issues:
        assert issue["type"] == "issue"
        assert issue["categories"] and set(issue["categories"]) <= CODE_CLIMATE_CATEGORIES
        for key in ("description", "check_name", "fingerprint", "severity"):
            assert isinstance(issue[key], str) and issue[key], key
        assert issue["severity"] in GITLAB_SEVERITIES
        assert isinstance(issue["location"]["path"], str)
        assert not Path(issue["location"]["path"]).is_absolute()
        assert isinstance(issue["location"]["lines"]["begin"], int)
    fingerprints = [issue["fingerprint"] for issue in issues]
    assert len(set(fingerprints)) == len(fingerprints)


def test_gitlab_code_quality_keys_and_stable_fingerprints(tmp_path: Path) -> None:
    diagnostics = every_rule(str(tmp_path / ODD_NAME))
    diagnostics.append(diagnostics[0])  # the same finding twice in one file
    issues = json.loads(render_gitlab(diagnostics, root=tmp_path))
    check_code_quality(issues)
    assert issues[0]["location"] == {"path": ODD_NAME, "lines": {"begin": 1, "end": 1}}
    assert {i["severity"] for i in issues} == {"major", "minor"}
    moved = [Diagnostic(d.code, d.severity, d.message, Span(d.span.file, d.span.line + 7),
                        d.hint) for d in diagnostics]
    assert ([i["fingerprint"] for i in json.loads(render_gitlab(moved, root=tmp_path))]
            == [i["fingerprint"] for i in issues])


def test_lint_github_and_gitlab_formats_from_the_command_line(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / ".git").mkdir()
    (tmp_path / "cell one").mkdir()
    (tmp_path / "cell one" / "bad.mp").write_text("MP 1\n  FIXD_MOVE X, 1\nEND MP\n")
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    result = runner.invoke(main, ["lint", "cell one/bad.mp", "--format", "github"])
    assert result.exit_code == EXIT_SOURCE_ERRORS
    ((level, props, message),) = parse_commands(result.stdout)
    assert (level, props["file"], props["line"], props["title"]) == (
        "error", "cell one/bad.mp", "2", "E201 unknown-command")
    assert "FIXED_MOVE" in message
    result = runner.invoke(main, ["lint", "cell one/bad.mp", "--format", "gitlab",
                                  "-o", "gl-code-quality-report.json"])
    assert result.exit_code == EXIT_SOURCE_ERRORS
    issues = json.loads((tmp_path / "gl-code-quality-report.json").read_text())
    check_code_quality(issues)
    assert [(i["check_name"], i["location"]["path"]) for i in issues] == [
        ("E201", "cell one/bad.mp")]
    result = runner.invoke(main, ["lint", "cell one/bad.mp", "--format", "sarif"])
    artifact = validated(result.stdout)["runs"][0]["results"][0]["locations"][0][
        "physicalLocation"]["artifactLocation"]
    assert artifact == {"uri": "cell%20one/bad.mp", "uriBaseId": "%SRCROOT%"}


def test_sarif_regions_tool_and_schema_address(tmp_path: Path) -> None:
    """A region ends at its endColumn, the column after the last character (SARIF 3.30.5),
    and has none when a finding has no width (an endColumn equal to startColumn would be an
    empty region, SARIF 3.30.2, that code scanning highlights nothing of). The driver names
    the tool and its installed version; `$schema` is a published address of the 2.1.0 schema
    (the OASIS schema's own id, or schemastore's, which GitHub's documentation uses)."""
    wide = Diagnostic("E201", RULES["E201"].severity, "m", Span("a.mp", 2, 3, 9))
    point = Diagnostic("E201", RULES["E201"].severity, "m", Span("a.mp", 4, 5, 5))
    sarif = validated(render_sarif([wide, point], root=tmp_path))
    regions = [r["locations"][0]["physicalLocation"]["region"] for r in sarif["runs"][0]["results"]]
    assert regions == [{"startLine": 2, "startColumn": 3, "endColumn": 9},
                       {"startLine": 4, "startColumn": 5}]
    driver = sarif["runs"][0]["tool"]["driver"]
    assert (driver["name"], driver["version"]) == ("mplang", version("mplang"))
    schema_id = json.loads(SCHEMA.read_text(encoding="utf-8"))["id"]
    assert sarif["$schema"] in {schema_id, "https://json.schemastore.org/sarif-2.1.0.json"}


def test_ci_reports_name_a_file_outside_the_root_by_its_own_path(tmp_path: Path) -> None:
    """A file outside the working directory has no repository-relative path: GitHub's and
    GitLab's reports name it as given, never as 'None'."""
    outside = Diagnostic("E201", RULES["E201"].severity, "m", Span("/elsewhere/x y.mp", 3))
    ((_, props, _),) = parse_commands(render_github([outside], root=tmp_path))
    assert props["file"] == "/elsewhere/x y.mp"
    (issue,) = json.loads(render_gitlab([outside], root=tmp_path))
    assert issue["location"]["path"] == "/elsewhere/x y.mp"

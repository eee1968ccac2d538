"""Diagnostics as reports: gcc-style text, a JSON list, SARIF 2.1.0, GitHub workflow commands
and GitLab Code Quality JSON. Family-free: every family's checks produce the same
`Diagnostic` objects."""

from __future__ import annotations

import hashlib
import json
import os
from collections import Counter
from pathlib import Path, PurePosixPath
from typing import Any
from urllib.parse import quote

from mplang import __version__
from mplang.lang.diagnostics import Diagnostic
from mplang.lang.rules import RULES, Rule
from mplang.lang.severity import Severity

SRCROOT = "%SRCROOT%"
DOCS_URL_VARIABLE = "MPC_DOCS_URL"
"""The environment variable that names where mplang's docs/ folder is published. SARIF's
`helpUri` is then its `checks/CODE.md` and `informationUri` its `checks/README.md`. Unset, no
link is written: the project has no public address yet, and a guessed one would be a dead
link in code scanning, as a path into the runner's site-packages was. Each rule's help is
always embedded (`help.text`, `help.markdown`), which code scanning shows without a link."""
# docs/checks/<CODE>.md: shipped inside the package (mplang/docs/checks) or, in a source
# checkout, at the top of the repository.
_PACKAGE = Path(__file__).resolve().parents[1]
CHECK_PAGE_DIRS = (_PACKAGE / "docs" / "checks", _PACKAGE.parent / "docs" / "checks")


def render_text(diagnostics: list[Diagnostic]) -> str:
    return "".join(d.render() + "\n" for d in diagnostics)


def render_diagnostics_json(diagnostics: list[Diagnostic]) -> str:
    return json.dumps([{
        "code": d.code, "name": RULES[d.code].name, "severity": d.severity.value,
        "message": d.message, "hint": d.hint, "file": d.span.file, "line": d.span.line,
        "column": d.span.col, "end_column": d.span.end_col,
    } for d in diagnostics], indent=1) + "\n"


def _message(d: Diagnostic) -> str:
    return d.message + (f" ({d.hint})" if d.hint else "")


def relative_path(file: str, root: Path) -> PurePosixPath | None:
    """`file` relative to `root` in '/' form, or None when it lies outside `root`: CI
    systems name files by their path from the repository root, where mpc is run."""
    path = Path(file)
    if not path.is_absolute():
        path = root / path
    try:
        return PurePosixPath(path.resolve().relative_to(root.resolve()).as_posix())
    except ValueError:
        return None


def check_page(code: str) -> Path | None:
    """The installed documentation page of a check, if this installation has it."""
    return next((d / f"{code}.md" for d in CHECK_PAGE_DIRS if (d / f"{code}.md").is_file()),
                None)


def docs_url(page: str) -> str | None:
    """The public address of a page of docs/ under `MPC_DOCS_URL`, None when it is unset."""
    base = os.environ.get(DOCS_URL_VARIABLE, "").strip()
    return base.rstrip("/") + "/" + page if base else None


def rule_markdown(rule: Rule) -> str:
    """The rule's full help as its docs/checks page says it (without the example)."""
    parts = [f"**{rule.code} `{rule.name}`** ({rule.severity.value}): {rule.summary}",
             f"**Why.** {rule.why}"]
    if rule.device:
        parts.append("**What the device would do.** Downloading such a program would fail on "
                     f"the controller: {rule.device}.")
    parts.append(f"**How to fix it.** {rule.fix}")
    return "\n\n".join(parts)


def rule_text(rule: Rule) -> str:
    parts = [f"{rule.code} {rule.name} ({rule.severity.value}): {rule.summary}",
             f"Why: {rule.why}"]
    if rule.device:
        parts.append(f"What the device would do: downloading such a program would fail on the "
                     f"controller: {rule.device}.")
    parts.append(f"How to fix it: {rule.fix}")
    return "\n\n".join(parts)


def _sarif_rule(code: str) -> dict[str, Any]:
    rule = RULES[code]
    descriptor: dict[str, Any] = {
        "id": code, "name": rule.name,
        "shortDescription": {"text": rule.summary},
        "fullDescription": {"text": rule.why},
        "help": {"text": rule_text(rule), "markdown": rule_markdown(rule)},
        "defaultConfiguration": {"level": rule.severity.value},
        "properties": {"tags": ["mplang", "device" if rule.device else "correctness"]},
    }
    help_uri = docs_url(f"checks/{code}.md")
    if help_uri is not None:
        descriptor["helpUri"] = help_uri
    return descriptor


def _artifact(file: str, root: Path) -> dict[str, str]:
    """A relative, percent-encoded URI against %SRCROOT% (the working directory), or an
    absolute file: URI for a file outside it."""
    relative = relative_path(file, root)
    if relative is None:
        return {"uri": Path(file).resolve().as_uri()}
    return {"uri": quote(str(relative), safe="/"), "uriBaseId": SRCROOT}


def render_sarif(diagnostics: list[Diagnostic], root: Path | None = None) -> str:
    """SARIF 2.1.0 as the OASIS schema defines it and GitHub code scanning ingests it
    (docs/ci.md says what was checked); file URIs are relative to `root` (the working
    directory), which CI runs at the repository root."""
    root = Path.cwd() if root is None else root
    used = sorted({d.code for d in diagnostics})
    results = []
    for d in diagnostics:
        region: dict[str, int] = {"startLine": d.span.line, "startColumn": d.span.col}
        if d.span.end_col and d.span.end_col > d.span.col:
            region["endColumn"] = d.span.end_col
        results.append({
            "ruleId": d.code, "ruleIndex": used.index(d.code), "level": d.severity.value,
            "message": {"text": _message(d)},
            "locations": [{"physicalLocation": {
                "artifactLocation": _artifact(d.span.file, root), "region": region}}],
        })
    driver: dict[str, Any] = {"name": "mplang", "version": __version__}
    information_uri = docs_url("checks/README.md")
    if information_uri is not None:
        driver["informationUri"] = information_uri
    driver["rules"] = [_sarif_rule(code) for code in used]
    sarif = {
        "$schema": "https://json.schemastore.org/sarif-2.1.0.json",
        "version": "2.1.0",
        "runs": [{"tool": {"driver": driver},
                  "originalUriBaseIds": {SRCROOT: {"uri": root.resolve().as_uri() + "/"}},
                  "columnKind": "unicodeCodePoints",
                  "results": results}],
    }
    return json.dumps(sarif, indent=1) + "\n"


def _escape_data(text: str) -> str:
    """Workflow-command message escaping, as GitHub's actions toolkit does it."""
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def _escape_property(text: str) -> str:
    return _escape_data(text).replace(":", "%3A").replace(",", "%2C")


_GITHUB_LEVEL = {Severity.ERROR: "error", Severity.WARNING: "warning"}


def _ci_path(file: str, root: Path) -> str:
    relative = relative_path(file, root)
    return str(relative) if relative is not None else Path(file).as_posix()


def render_github(diagnostics: list[Diagnostic], root: Path | None = None) -> str:
    """GitHub Actions workflow commands (`::error file=...::message`): each becomes an
    annotation on its line in the run and the pull request, with no upload step."""
    root = Path.cwd() if root is None else root
    lines = []
    for d in diagnostics:
        props = [("file", _ci_path(d.span.file, root)), ("line", str(d.span.line)),
                 ("col", str(d.span.col)), ("endLine", str(d.span.line))]
        if d.span.end_col and d.span.end_col > d.span.col:
            props.append(("endColumn", str(d.span.end_col)))
        props.append(("title", f"{d.code} {RULES[d.code].name}"))
        level = _GITHUB_LEVEL.get(d.severity, "notice")
        rendered = ",".join(f"{key}={_escape_property(value)}" for key, value in props)
        lines.append(f"::{level} {rendered}::{_escape_data(_message(d))}\n")
    return "".join(lines)


_GITLAB_SEVERITY = {Severity.ERROR: "major", Severity.WARNING: "minor"}


def render_gitlab(diagnostics: list[Diagnostic], root: Path | None = None) -> str:
    """GitLab Code Quality JSON (the `codequality` report artifact). The fingerprint hashes
    the file, code, message and how many times that triple came before, not the line, so a
    finding keeps its identity when lines above it move."""
    root = Path.cwd() if root is None else root
    seen: Counter[tuple[str, str, str]] = Counter()
    issues = []
    for d in diagnostics:
        path = _ci_path(d.span.file, root)
        key = (path, d.code, _message(d))
        seen[key] += 1
        digest = hashlib.sha256(
            json.dumps([*key, seen[key]], ensure_ascii=False).encode("utf-8")).hexdigest()
        issues.append({
            "type": "issue", "check_name": d.code,
            "description": f"{d.code} {RULES[d.code].name}: {_message(d)}",
            "categories": ["Bug Risk"], "fingerprint": digest,
            "severity": _GITLAB_SEVERITY.get(d.severity, "info"),
            "location": {"path": path, "lines": {"begin": d.span.line, "end": d.span.line}},
        })
    return json.dumps(issues, indent=1) + "\n"

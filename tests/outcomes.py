"""What a "never crashes" test asserts about the result: diagnostics, or a documented refusal
with its message (never only "it returned")."""

from __future__ import annotations

import re
from typing import Any

from mplang.lang.diagnostics import Diagnostic
from mplang.lang.severity import Severity

CODE = re.compile(r"[EW]\d{3}")


def assert_diagnostics(build: Any) -> None:
    """A build's answer to any text: diagnostics that each carry a check code, a severity
    that agrees with it, a message and a line, sorted out so that the build is `ok` exactly
    when none of them is an error."""
    assert isinstance(build.diagnostics, list)
    for d in build.diagnostics:
        assert isinstance(d, Diagnostic), d
        assert CODE.fullmatch(d.code), d.render()
        assert d.severity in (Severity.ERROR, Severity.WARNING), d.render()
        assert d.message and d.span.line >= 1, d.render()
    errors = [d for d in build.diagnostics if d.severity is Severity.ERROR]
    assert build.ok == (not errors), [d.render() for d in build.diagnostics]


def assert_refusal(exc: BaseException, place: str) -> None:
    """A documented error of a file: its message starts with the file's place."""
    assert str(exc).startswith(place), str(exc)
    assert len(str(exc)) > len(place) + 2, str(exc)

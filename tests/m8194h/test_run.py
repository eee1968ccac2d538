"""`mpc run --call` names what can be called when the program asked for is not there."""

from __future__ import annotations

import pytest

from mplang.family.face import NoSuchProgram
from mplang.m8194h.compiler import compile_source
from mplang.m8194h.run import run_build

SOURCE = "MP 4 first\n  VAR1 = 1\nEND MP\nMP 9\n  VAR2 = 2\nEND MP\n"


@pytest.mark.parametrize("call", ["nosuch", "MP5", "7"])
def test_an_unknown_call_lists_the_callable_programs(call: str) -> None:
    build = compile_source(SOURCE)
    with pytest.raises(NoSuchProgram) as caught:
        run_build(build, call)
    assert str(caught.value).endswith("; callable: MP4 first, MP9")


def test_a_known_call_runs() -> None:
    report = run_build(compile_source(SOURCE), "first")
    assert report.finished and report.called == "MP4"

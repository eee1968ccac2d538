"""Declared variables (`VAR name`, `VAR name @ VARn`): placement, the variable maps (JSON, C
header, Python module), and a host that uses the generated module over Modbus."""

from __future__ import annotations

import asyncio
import importlib.util
import json
import subprocess
from pathlib import Path
from types import ModuleType

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mplang.m8194h.compiler import BuildResult, Options, compile_source
from mplang.m8194h.image import render_variables_c, render_variables_json, render_variables_python
from mplang.m8194h.modbus import DeviceLink, Endpoint
from mplang.m8194h.modbus_server import DeviceFace, SimClock, serve_tcp, stop
from mplang.m8194h.sim.controller import VirtualController
from mplang.m8194h.sim.service import preload

JOB = """VAR speed
VAR result
VAR limit @ VAR20
ALIAS scratch = VAR400

MP 7 scale
    scratch = speed * 2
    result = scratch + limit
    VAR401 = 1
END MP
"""


def build(source: str, options: Options | None = None) -> BuildResult:
    result = compile_source(source, "job.mp", options or Options())
    assert result.ok, [d.render() for d in result.diagnostics]
    return result


def test_placement_skips_every_variable_the_build_names() -> None:
    result = build(JOB)
    placed = {v.name: (v.index, v.pinned) for v in result.variables}
    # VAR400 (the alias) and VAR401 (written literally) are taken: speed and result go after
    assert placed == {"speed": (402, False), "result": (403, False), "limit": (20, True)}
    # declared variables are the host's: reading them first is no W103
    assert not result.diagnostics


def test_the_pool_comes_from_the_options() -> None:
    result = build(JOB, Options(var_pool=range(100, 110)))
    assert {v.name: v.index for v in result.variables} == {"limit": 20, "speed": 100,
                                                           "result": 101}


def test_declarations_stay_at_the_top_level() -> None:
    result = compile_source("MP 1 x\n    VAR inner\nEND MP\n")
    assert [d.code for d in result.diagnostics] == ["E301"]


def test_the_json_map() -> None:
    data = json.loads(render_variables_json(build(JOB)))
    assert data["format"] == "mplang-variables/1" and data["holding_base"] == 300
    assert data["variables"] == [
        {"name": "limit", "var": 20, "register": 340, "pinned": True, "source": "job.mp:3"},
        {"name": "speed", "var": 402, "register": 1104, "pinned": False, "source": "job.mp:1"},
        {"name": "result", "var": 403, "register": 1106, "pinned": False,
         "source": "job.mp:2"}]


@pytest.mark.needs_tool("gcc")
def test_the_c_header_compiles(tmp_path: Path) -> None:
    (tmp_path / "mpc_vars.h").write_text(render_variables_c(build(JOB)))
    (tmp_path / "use.c").write_text(
        '#include "mpc_vars.h"\n'
        "_Static_assert(MPC_VAR_SPEED == 402, \"index\");\n"
        "_Static_assert(MPC_REG_SPEED == MPC_HOLDING_BASE + 2 * MPC_VAR_SPEED, \"reg\");\n"
        "_Static_assert(MPC_REG_LIMIT == 340 && MPC_WORD_ORDER == 0, \"pinned\");\n"
        "int main(void) { return 0; }\n")
    done = subprocess.run(["gcc", "-fsyntax-only", "-Wall", "-Werror", "use.c"],
                          cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def load_module(tmp_path: Path, text: str, name: str = "mpc_vars") -> ModuleType:
    path = tmp_path / f"{name}.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def modules(tmp_path_factory: pytest.TempPathFactory) -> list[ModuleType]:
    folder = tmp_path_factory.mktemp("vars")
    return [load_module(folder, render_variables_python(build(JOB, Options(word_order=order))),
                        f"mpc_vars_{order}") for order in (0, 1)]


@given(st.integers(-2**31, 2**31 - 1), st.sampled_from([0, 1]))
def test_python_module_splits_and_joins_32_bit_values(modules: list[ModuleType], value: int,
                                                       order: int) -> None:
    module = modules[order]
    words = module.to_registers(value)
    assert all(0 <= w <= 0xFFFF for w in words) and module.from_registers(words) == value


def test_python_module_names_every_variable(modules: list[ModuleType]) -> None:
    module = modules[0]
    assert module.VARIABLES == {"limit": 20, "speed": 402, "result": 403}
    assert module.SPEED == 402 and module.register("result") == 1106
    with pytest.raises(ValueError):
        module.to_registers(2**31)


@pytest.mark.parametrize("order", [0, 1])
def test_a_host_sets_and_reads_variables_by_name_over_modbus(tmp_path: Path,
                                                            order: int) -> None:
    """What the generated module is for: write named inputs, call the MP, read the result."""
    result = build(JOB, Options(word_order=order))
    host = load_module(tmp_path, render_variables_python(result), f"host_vars_{order}")
    controller = VirtualController(word_order=order)
    preload(controller, result)

    async def session() -> int:
        server, port = await serve_tcp(DeviceFace(controller, SimClock(100.0)), "127.0.0.1", 0)
        try:
            async with DeviceLink(Endpoint(host="127.0.0.1", port=port)) as link:
                await link.write_holding(host.register("speed"), host.to_registers(-1500))
                await link.write_holding(host.register("limit"), host.to_registers(70000))
                # holding register 8 calls an MP (not idempotent in general; fine for a test)
                await link.write_holding(8, [7])
                for _ in range(200):
                    (running,) = await link.read_holding(8, 1)
                    if running == 0:
                        break
                    await asyncio.sleep(0.005)
                value = host.from_registers(await link.read_holding(host.register("result"), 2))
                return int(value)
        finally:
            await stop(server)

    assert asyncio.run(session()) == -1500 * 2 + 70000


def test_placement_skips_variables_named_deep_in_expressions_and_blocks() -> None:
    """VARn read inside an expression, a call's arguments or a nested block is taken too."""
    result = compile_source("VAR speed\nMP 156\n  FOR 2\n    IF 1 + VAR400 > 0\n      speed = 5\n"
                            "    END IF\n  NEXT\n  speed = (VAR401 * 2) + 1\n"
                            "  speed = -VAR402\nEND MP\n", "job.mp")
    assert result.ok, [d.render() for d in result.diagnostics]
    assert {v.name: v.index for v in result.variables} == {"speed": 403}

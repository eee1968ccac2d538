"""`mpc export`: the host's view of a build in every format, each carrying the build id; the
C header compiled by gcc with -Wall -Werror into a program that prints what it defines, the
Python module imported, the CSV read as an HMI tag import reads it."""

from __future__ import annotations

import csv
import importlib.util
import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from mplang.cli.common import EXIT_OK, EXIT_SOURCE_ERRORS
from mplang.family.hostexport import CSV_HEADER

JOB = """CONST STEP = 250
CONST LIMIT = STEP * 4 + 1
VAR speed
VAR parts @ VAR20
ALIAS total = VAR10

MP 100 tour
    SET_V X, speed  # mpc: ignore[W107]
    FIXED_MOVE X, STEP
    parts = parts + 1
    CALL tally
END MP

MP tally
    total = total + parts  # mpc: ignore[W103]
END MP

ISR 2 edge
    parts = 0
END ISR
"""


def mpc(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mplang", *args], capture_output=True,
                          text=True, timeout=60, cwd=cwd)


def export(tmp_path: Path, fmt: str, source: str = JOB) -> str:
    (tmp_path / "job.mp").write_text(source)
    done = mpc(tmp_path, "export", "job.mp", "--format", fmt)
    assert done.returncode == EXIT_OK, done.stderr
    return done.stdout


def build_id(tmp_path: Path) -> str:
    done = mpc(tmp_path, "build", "job.mp")
    assert done.returncode == EXIT_OK, done.stderr
    return str(json.loads(done.stdout)["build_id"])


def test_json_is_the_whole_view(tmp_path: Path) -> None:
    data = json.loads(export(tmp_path, "json"))
    assert data["format"] == "mplang-host/1" and data["build_id"] == build_id(tmp_path)
    programs = {p["name"]: p for p in data["programs"]}
    assert programs["tour"]["slot"] == 100 and programs["tour"]["register"] == 8
    assert programs["tour"]["writes"] == ["parts", "total"]  # tally's write, through CALL
    assert programs["edge"]["kind"] == "isr" and programs["edge"]["register"] is None
    variables = {v["name"]: v for v in data["variables"]}
    assert (variables["parts"]["device_name"], variables["parts"]["register"]) == ("VAR20", 340)
    assert variables["total"]["kind"] == "alias" and variables["total"]["register"] == 320
    assert variables["speed"]["source"] == "job.mp:3"
    assert {c["name"]: c["value"] for c in data["consts"]} == {"STEP": 250, "LIMIT": 1001}


def test_csv_has_the_tag_header_and_one_row_per_tag(tmp_path: Path) -> None:
    text = export(tmp_path, "csv")
    assert text.splitlines()[0] == ",".join(CSV_HEADER) == \
        "name,kind,device_name,register,function,words,type,word_order,access,source"
    rows = list(csv.DictReader(io.StringIO(text)))
    assert rows[0]["kind"] == "build" and rows[0]["device_name"] == build_id(tmp_path)
    tags = {row["name"]: row for row in rows[1:]}
    assert set(tags) == {"tour", "tally", "speed", "parts", "total"}  # no ISR: not callable
    assert tags["tour"]["register"] == "8" and tags["tour"]["device_name"] == "MP100"
    assert tags["speed"]["register"] == str(300 + 2 * 400)  # the first free VAR of the pool
    assert [tags["parts"][k] for k in ("words", "type", "word_order", "access")] == \
        ["2", "int32", "msw-first", "read-write"]


def test_word_order_1_is_named_in_every_tag(tmp_path: Path) -> None:
    (tmp_path / "job.mp").write_text(JOB)
    done = mpc(tmp_path, "export", "job.mp", "--format", "csv", "--word-order", "1")
    assert done.returncode == EXIT_OK, done.stderr
    rows = [r for r in csv.DictReader(io.StringIO(done.stdout)) if r["kind"] == "var"]
    assert {r["word_order"] for r in rows} == {"lsw-first"}


def test_c_header_compiles_warning_free_and_defines_the_view(tmp_path: Path) -> None:
    gcc = shutil.which("gcc")
    if gcc is None:
        if os.environ.get("CI") == "true":
            pytest.fail("gcc is not installed: run make tools")
        pytest.skip("gcc is not installed (make tools installs it)")
    (tmp_path / "mpc_host.h").write_text(export(tmp_path, "c"))
    (tmp_path / "host.c").write_text(
        '#include <stdio.h>\n#include "mpc_host.h"\n#include "mpc_host.h"\n'
        "int main(void) {\n"
        '    printf("%s %d %d %d %d %ld\\n", MPC_BUILD_ID, MPC_CALL_REGISTER, MPC_MP_TOUR,\n'
        "           MPC_REG_PARTS, MPC_WORDS_PARTS, MPC_CONST_LIMIT);\n"
        "    return 0;\n}\n")
    compiled = subprocess.run([gcc, "-Wall", "-Wextra", "-Werror", "-std=c99", "-pedantic",
                               "-o", str(tmp_path / "host"), str(tmp_path / "host.c")],
                              capture_output=True, text=True, timeout=60)
    assert compiled.returncode == 0, compiled.stderr
    ran = subprocess.run([str(tmp_path / "host")], capture_output=True, text=True, timeout=10)
    assert ran.stdout == f"{build_id(tmp_path)} 8 100 340 2 1001\n"


def test_python_module_is_importable_with_the_same_values(tmp_path: Path) -> None:
    path = tmp_path / "mpc_host.py"
    path.write_text(export(tmp_path, "python"))
    spec = importlib.util.spec_from_file_location("mpc_host", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert build_id(tmp_path) == module.BUILD_ID
    assert (module.MP_TOUR, module.REG_PARTS, module.CONST_LIMIT) == (100, 340, 1001)
    assert {"tour": 100, "tally": module.PROGRAMS["tally"]} == module.PROGRAMS
    assert module.VARIABLES["total"]["device_name"] == "VAR10"


def test_csharp_class_carries_the_same_constants(tmp_path: Path) -> None:
    text = export(tmp_path, "csharp")
    assert f'public const string Id = "{build_id(tmp_path)}";' in text
    for line in ("public const int MP_TOUR = 100;", "public const int REG_PARTS = 340;",
                 "public const int CONST_LIMIT = 1001;", "public const int CallRegister = 8;"):
        assert line in text
    assert text.count("{") == text.count("}")


def test_output_file_and_a_build_with_errors(tmp_path: Path) -> None:
    (tmp_path / "job.mp").write_text(JOB)
    done = mpc(tmp_path, "export", "job.mp", "--format", "csv", "-o", "tags.csv")
    assert done.returncode == EXIT_OK and done.stdout == ""
    assert (tmp_path / "tags.csv").read_text().startswith("name,kind,")
    (tmp_path / "bad.mp").write_text("MP 1\n    VAR1 = nosuch\nEND MP\n")
    bad = mpc(tmp_path, "export", "bad.mp")
    assert bad.returncode == EXIT_SOURCE_ERRORS and bad.stdout == ""
    assert "bad.mp:2:12: error[E202]" in bad.stderr


def test_shell_completion_offers_the_host_commands_and_their_formats() -> None:
    from click.testing import CliRunner

    from mplang.cli import main

    def complete(words: str) -> list[str]:
        """click's bash completion protocol: `type,value` lines."""
        cword = len(words.split()) - (0 if words.endswith(" ") else 1)
        return CliRunner().invoke(main, [], prog_name="mpc", env={
            "_MPC_COMPLETE": "bash_complete", "COMP_WORDS": words,
            "COMP_CWORD": str(cword)}).stdout.splitlines()

    assert {"plain,call", "plain,var", "plain,export"} <= set(complete("mpc "))
    assert complete("mpc exp") == ["plain,export"]
    assert complete("mpc export --format ") == [
        f"plain,{fmt}" for fmt in ("json", "csv", "c", "python", "csharp")]

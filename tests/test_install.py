"""A plain (non-editable) install finds the grammar and the device data.

The wheel is built from this checkout and imported straight from the .whl file (zip import),
with the working directory elsewhere, so nothing can come from the source tree.
"""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from sourcebuild import checkout_build

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    with checkout_build(tmp_path_factory.getbasetemp()):
        subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                        "--no-build-isolation", "-q", "-w", str(out), str(ROOT)], check=True,
                       capture_output=True)
    (found,) = out.glob("mplang-*.whl")
    return found


def test_wheel_contains_grammar_and_stdlib(wheel: Path) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "mplang/grammar/mplang.lark" in names
    assert "mplang/stdlib/m8194h/commands.toml" in names
    assert "mplang/stdlib/m8194h/device.toml" in names
    for asset in ("index.html", "monitor.js", "monitor.css", "favicon.svg"):  # served
        assert f"mplang/tools/monitor/assets/{asset}" in names


def test_wheel_carries_every_module(wheel: Path) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    modules = {p.relative_to(ROOT).as_posix() for p in (ROOT / "mplang").rglob("*.py")}
    assert modules - names == set()


def test_installed_package_compiles(wheel: Path, tmp_path: Path) -> None:
    script = (
        "import mplang, sys\n"
        "assert mplang.__file__.startswith(sys.argv[1]), mplang.__file__\n"
        "from mplang.m8194h.compiler import compile_source\n"
        "r = compile_source('MP 21\\n  FIXED_MOVE X, 1000\\nEND MP\\n')\n"
        "print(r.programs[0].frames)\n"
    )
    proc = subprocess.run([sys.executable, "-c", script, str(wheel)], cwd=tmp_path,
                          env={"PYTHONPATH": str(wheel), "PATH": "/usr/bin:/bin"},
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[[2761, 21], [3150, 1, 0, 1000], [3274]]"


def test_wheel_metadata_licence_and_plot_extra(wheel: Path) -> None:
    """PEP 639 licence metadata with the LICENSE file, and matplotlib only in `plot`."""
    archive = zipfile.ZipFile(wheel)
    names = archive.namelist()
    (metadata,) = [n for n in names if n.endswith(".dist-info/METADATA")]
    text = archive.read(metadata).decode()
    assert "License-Expression: MIT" in text.splitlines()
    assert "Provides-Extra: plot" in text.splitlines()
    matplotlib = [line for line in text.splitlines()
                  if line.startswith("Requires-Dist: matplotlib")]
    assert matplotlib and all('extra == "plot"' in line for line in matplotlib)
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)


def test_wheel_ships_the_check_and_runtime_pages(wheel: Path, tmp_path: Path) -> None:
    """docs/checks and docs/runtime are package data: installed from the wheel (with pip,
    away from the source tree), the SARIF help links and the language server's
    documentation links find the pages (issue 15 items 4 and 8)."""
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {"mplang/docs/checks/E201.md", "mplang/docs/checks/README.md",
            "mplang/docs/runtime/README.md"} <= names
    assert {f"mplang/docs/checks/{p.name}" for p in (ROOT / "docs" / "checks").glob("*.md")} \
        <= names
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "-q",
                    "--target", str(target), str(wheel)], check=True, capture_output=True)
    script = (
        "import json, sys\n"
        "from mplang.tools.report import check_page, render_sarif\n"
        "from mplang.lang.diagnostics import Diagnostic, Severity, Span\n"
        "page = check_page('E201')\n"
        "assert page is not None and str(page).startswith(sys.argv[1]), page\n"
        "d = Diagnostic('E201', Severity.ERROR, 'unknown command', Span('a.mp', 1, 1, 3))\n"
        "rule = json.loads(render_sarif([d]))['runs'][0]['tool']['driver']['rules'][0]\n"
        "print(rule['helpUri'])\n"
    )
    env = {"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin",
           "MPC_DOCS_URL": "https://docs.example.org/mplang"}
    proc = subprocess.run([sys.executable, "-c", script, str(target)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    # the published address, never a path into site-packages
    assert proc.stdout.strip() == "https://docs.example.org/mplang/checks/E201.md"


def test_wheel_metadata_lsp_extra(wheel: Path) -> None:
    """pygls only in the `lsp` extra: the base install (CI, pre-commit) goes without it."""
    archive = zipfile.ZipFile(wheel)
    (metadata,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
    lines = archive.read(metadata).decode().splitlines()
    assert "Provides-Extra: lsp" in lines
    pygls = [line for line in lines if line.startswith("Requires-Dist: pygls")]
    assert pygls and all('extra == "lsp"' in line for line in pygls)

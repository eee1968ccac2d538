"""The package as an index would take it: `python -m build` makes the sdist and, from the
sdist alone, the wheel; `twine check --strict` passes both; the sdist carries the tests and
what they read, and its tests run against the wheel built from it."""

from __future__ import annotations

import os
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest
from sourcebuild import checkout_build

ROOT = Path(__file__).resolve().parent.parent
CARRIED = ("tests", "samples", "docs", "grammar", "stdlib", "mplang", "bench")
"""The folders whose every file the sdist carries (compiled Python files aside)."""


@pytest.fixture(scope="module")
def dist(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sdist and the wheel built from it, in one folder. No isolation: the build uses
    this environment's setuptools (the dev group has it) instead of fetching one."""
    out = tmp_path_factory.mktemp("dist")
    with checkout_build(tmp_path_factory.getbasetemp()):
        done = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "-o",
                               str(out), str(ROOT)], capture_output=True, text=True,
                              timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "Successfully built mplang-" in done.stdout
    return out


def test_twine_check_strict_passes_the_sdist_and_the_wheel(dist: Path) -> None:
    files = sorted(str(p) for p in dist.iterdir())
    assert sorted(Path(f).suffix for f in files) == [".gz", ".whl"]
    done = subprocess.run([sys.executable, "-m", "twine", "check", "--strict", *files],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.count("PASSED") == 2


def test_the_metadata_names_platforms_pythons_keywords_and_authors(dist: Path) -> None:
    (wheel,) = dist.glob("*.whl")
    archive = zipfile.ZipFile(wheel)
    (metadata,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
    lines = archive.read(metadata).decode().splitlines()
    for classifier in ("Operating System :: Microsoft :: Windows",
                       "Operating System :: POSIX :: Linux", "Operating System :: MacOS",
                       "Programming Language :: Python :: 3.11",
                       "Topic :: Software Development :: Compilers"):
        assert f"Classifier: {classifier}" in lines
    assert "License-Expression: MIT" in lines and "Requires-Python: >=3.11" in lines
    assert any(line.startswith("Keywords: ") and "M8194H" in line for line in lines)
    assert "Author: mplang contributors" in lines
    # development tools are a dependency group, never a published extra
    assert "Provides-Extra: dev" not in lines
    assert not any(line.startswith(("Requires-Dist: pytest", "Requires-Dist: mypy"))
                   for line in lines)


def test_the_sdist_carries_the_tests_and_what_they_read(dist: Path) -> None:
    (sdist,) = dist.glob("*.tar.gz")
    with tarfile.open(sdist) as archive:
        names = {n.split("/", 1)[1] for n in archive.getnames() if "/" in n}
    wanted = {p.relative_to(ROOT).as_posix() for folder in CARRIED
              for p in (ROOT / folder).rglob("*")
              if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"}
    assert wanted - names == set()
    assert {"Makefile", "LICENSE", "README.md", "pyproject.toml",
            "editors/vscode/package.json"} <= names
    assert not any("node_modules" in n or n.endswith(".vsix") for n in names)


def test_tests_run_from_the_sdist_against_the_wheel_built_from_it(dist: Path,
                                                                 tmp_path: Path) -> None:
    """Unpacked elsewhere, the sdist's own tests import the package installed from the wheel
    (`-P`: the unpacked source folder is not on the path)."""
    (sdist,) = dist.glob("*.tar.gz")
    (wheel,) = dist.glob("*.whl")
    with tarfile.open(sdist) as archive:
        archive.extractall(tmp_path / "src", filter="data")
    (source,) = (tmp_path / "src").iterdir()
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "-q",
                    "--target", str(site), str(wheel)], check=True, capture_output=True)
    env = {**os.environ, "PYTHONPATH": str(site)}
    # Every sample compiled through the grammar, catalogue and profile the wheel ships to
    # the image JSON, and its package data read (a property test would only add time).
    done = subprocess.run([sys.executable, "-P", "-m", "pytest", "-p", "no:cacheprovider",
                           "tests/m8194h/test_image_json.py", "tests/lang/test_packagedata.py"],
                          cwd=source, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert " passed" in done.stdout
    where = subprocess.run([sys.executable, "-P", "-c", "import mplang; print(mplang.__file__)"],
                           cwd=source, env=env, capture_output=True, text=True, timeout=60)
    assert where.stdout.strip() == str(site / "mplang" / "__init__.py")

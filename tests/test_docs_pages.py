"""Every page of docs/ (and the README) renders and points only at what a clone has: code
fences are balanced (an unclosed fence turns the rest of a page into code), and every file a
page cites, by a relative link or as a backticked repository path, is in the repository;
nothing cites the device manuals or the contract kept outside it (`shared/...`)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [*sorted((ROOT / "docs").rglob("*.md")), ROOT / "README.md"]
TOP_FOLDERS = ("docs/", "mplang/", "stdlib/", "samples/", "tests/", "editors/", "grammar/",
               "bench/")
FENCE = re.compile(r"^ {0,3}(`{3,}|~{3,})")
PLACEHOLDER = re.compile(r"[*?<>{}$]|\b(?:CODE|NAME|N)\b")


def tracked() -> set[str]:
    """The repository's files (as git lists them, new ones included)."""
    listed = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"],
                            cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return set(listed.splitlines())


FILES = tracked()


def exists(path: str) -> bool:
    """A file or folder of the repository; a path given from inside a folder of it (the
    VS Code extension's `tests/...`) counts when a tracked file ends with it."""
    path = path.rstrip("/")
    return (path in FILES or any(f.startswith(path + "/") for f in FILES)
            or any(f.endswith("/" + path) for f in FILES))


def unbalanced_fence(text: str) -> int | None:
    """The line of a fence that is never closed, or None (a fence closes with the same
    character, at least as long, as CommonMark has it)."""
    opened: tuple[str, int] | None = None
    for number, line in enumerate(text.splitlines(), 1):
        match = FENCE.match(line)
        if match is None:
            continue
        marker = match.group(1)
        if opened is None:
            opened = (marker, number)
        elif marker[0] == opened[0][0] and len(marker) >= len(opened[0]) and \
                not line.strip()[len(marker):].strip():
            opened = None
    return opened[1] if opened else None


def citations(page: Path) -> list[str]:
    """The repository files a page names: relative link targets and backticked paths that
    start at a top folder of the repository (placeholders like CODE.md left out)."""
    text = page.read_text(encoding="utf-8")
    found: list[str] = []
    for match in re.finditer(r"\]\(([^)\s]+)\)", text):
        target = match.group(1).split("#")[0]
        if target and not re.match(r"[a-z][a-z0-9+.-]*:", target):
            found.append(str((page.parent / target).resolve().relative_to(ROOT)))
    for match in re.finditer(r"`([^`\s]+)`", text):
        cited = match.group(1).rstrip(".,:;").split(":")[0]
        if cited.startswith(TOP_FOLDERS) and not PLACEHOLDER.search(cited):
            found.append(cited)
    return found


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_page_fences_are_balanced(page: Path) -> None:
    assert unbalanced_fence(page.read_text(encoding="utf-8")) is None, \
        f"{page.relative_to(ROOT)}: the fence opened here is never closed"


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_page_cites_only_files_of_the_repository(page: Path) -> None:
    missing = [cited for cited in citations(page) if not exists(cited)]
    assert not missing, f"{page.relative_to(ROOT)} cites files a clone lacks: {missing}"
    assert "shared/" not in page.read_text(encoding="utf-8"), \
        f"{page.relative_to(ROOT)} names shared/..., which is not part of the repository"


def test_the_checks_have_teeth() -> None:
    assert unbalanced_fence("text\n```toml\na = 1\n```\nmore\n```\nopen\n") == 6
    assert unbalanced_fence("````\n```\nstill code\n````\n") is None
    assert not exists("docs/no-such-page.md") and exists("docs/image.md")


MP_BLOCK = re.compile(r"^```mp\n(.*?)^```$", re.DOTALL | re.MULTILINE)


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_mp_examples_are_laid_out_as_mpc_fmt_lays_them_out(page: Path) -> None:
    """The docs show what `mpc fmt` writes (no hand-aligned `=` or comment columns that the
    formatter would undo); a block with syntax errors on purpose is left out."""
    from mplang.tools.fmt import SourceNotFormattable, format_source

    for match in MP_BLOCK.finditer(page.read_text(encoding="utf-8")):
        block = match.group(1)
        try:
            formatted = format_source(block)
        except SourceNotFormattable:
            continue
        assert formatted == block, f"{page.relative_to(ROOT)}: an example mpc fmt would change"

"""The files one check of the language server reads: the editor's texts, and the disk's read
bounded; and the diagnostics that say which files it would not read."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from mplang.lang import ast
from mplang.lang.diagnostics import Diagnostic, Severity, Span
from mplang.lang.sources import SourceFile
from mplang.tools.lsp.workspace import LIMIT_TEXT, RefusedFile, read_text


class OpenTexts(dict[Path, str]):
    """In-editor texts keyed by resolved path, found under any spelling of the path; the
    files of the build on disk are read here too, bounded, instead of by the loader.

    The loader looks INCLUDEd files up as `including_dir / "name.mp"`, unresolved; resolving
    on lookup lets `../common.mp` find the open buffer of the same file. A file on disk is
    read with `workspace.read_text`, so an INCLUDE (or a project source) naming a device, a
    FIFO or a huge file never blocks or floods the server: that file counts as empty and
    `refused` says why (the analysis reports it as E102). A file that is missing or not UTF-8
    is left to the loader, which reports it as `mpc build` does.
    """

    def __init__(self, texts: Mapping[Path, str] | None = None) -> None:
        self.resolved: dict[Path, Path] = {}  # a path as spelt -> resolved, for one check
        super().__init__({self.resolve(p): t for p, t in (texts or {}).items()})
        self.disk: dict[Path, str] = {}
        self.refused: dict[Path, str] = {}  # resolved path -> why it was not read

    def resolve(self, path: Path) -> Path:
        """`path.resolve()`, once per spelling in a check: the loader, the index and the
        placement ask for the same few files' again and again (each a system call per
        part of the path)."""
        found = self.resolved.get(path)
        if found is None:
            found = self.resolved[path] = path.resolve()
        return found

    def __contains__(self, key: object) -> bool:
        if not isinstance(key, Path):
            return False
        resolved = self.resolve(key)
        if super().__contains__(resolved) or resolved in self.disk or resolved in self.refused:
            return True
        try:
            self.disk[resolved] = read_text(resolved)
        except RefusedFile as exc:
            self.refused[resolved] = exc.reason
        except (OSError, UnicodeDecodeError):
            return False
        return True

    def __getitem__(self, key: Path) -> str:
        resolved = self.resolve(key)
        if super().__contains__(resolved):
            return super().__getitem__(resolved)
        if resolved in self.disk:
            return self.disk[resolved]
        if resolved in self.refused:
            return ""
        raise KeyError(key)


def refusals(files: list[SourceFile], roots: list[Path], refused: Mapping[Path, str]
              ) -> list[Diagnostic]:
    """E102 for each INCLUDE (and project source) naming a file the server would not read:
    the loader saw it as empty, so the build would otherwise pass in silence."""
    if not refused:
        return []
    found: list[Diagnostic] = []
    for root in roots:
        reason = refused.get(root.resolve())
        if reason is not None:
            found.append(Diagnostic("E102", Severity.ERROR, f"cannot read {root}: {reason}",
                                    Span(str(root), 1), hint=_REFUSED_HINT))
    for source in files:
        for statement in source.statements:
            if not isinstance(statement, ast.Include) or "\0" in statement.path:
                continue
            target = (source.path.parent / statement.path).resolve()
            reason = refused.get(target)
            if reason is not None:
                found.append(Diagnostic("E102", Severity.ERROR,
                                        f"cannot include {statement.path}: {reason}",
                                        statement.span, hint=_REFUSED_HINT))
    return found


_REFUSED_HINT = f"the language server reads only regular files of at most {LIMIT_TEXT}"

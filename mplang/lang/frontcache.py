"""Front-end results kept across runs, as ruff and mypy keep theirs: the statements and
syntax diagnostics of each source text, so re-building a project where one file changed
parses that one file.

An entry is found by the file's path and its name as diagnostics show it, and kept under a
key of that name, its text and the front end itself (the grammar and the source of the
modules that read it, with mpc's and Python's version): any change to one of them is a
miss, and the file is parsed again. Entries live in the user cache dir
(`mplang.lang.caches`, `front/`), one file per source file, replaced atomically, so runs
side by side never read half of one; a damaged entry is a miss too. `--no-cache` (or
`MPLANG_CACHE=off`) parses everything.
"""

from __future__ import annotations

import hashlib
from functools import cache
from importlib import resources

from mplang.lang import ast, caches
from mplang.lang.diagnostics import Diagnostic, DiagnosticSink

KEYED_MODULES = ("ast", "diagnostics", "limits", "parser", "tokenizer")
"""The modules of `mplang.lang` whose source is part of the key, named, not imported: the
parser and tokenizer bring lark, which a run where every file hits needs never load."""

FORMAT = "front 1"
"""Part of the key: change it when what an entry holds changes shape."""


@cache
def front_end_key() -> str:
    """What the parse of a text depends on besides the text: the grammar and the code of
    the modules that turn it into statements and diagnostics."""
    parts: list[bytes] = [FORMAT.encode(), resources.files("mplang.grammar")
                          .joinpath("mplang.lark").read_bytes()]
    package = resources.files("mplang.lang")  # read so, they are found in a wheel too
    for name in KEYED_MODULES:
        try:
            parts.append(package.joinpath(name + ".py").read_bytes())
        except OSError:  # an install without sources: its version stands for them (STAMP)
            parts.append(name.encode())
    return caches.digest(*parts)


def parse(text: str, display: str, sink: DiagnosticSink, *, store: bool = True,
          where: str = "") -> list[ast.Statement]:
    """`parser.parse_text(text, display, sink)`, from the cache when it holds this text;
    a text parsed here is kept for the next run unless `store` is false (the language
    server: what it parses is mostly text being typed, never to be seen again). `where`
    (the file's resolved path) keeps apart files shown under the same name from two
    projects."""
    directory = caches.user_cache_dir()
    if directory is None:
        return _parse_text(text, display, sink)
    key = caches.digest(front_end_key(), display, text)
    name = hashlib.sha256(f"{where}\0{display}".encode("utf-8", "surrogatepass")
                          ).hexdigest()[:32]
    path = directory / "front" / f"{name}.pickle"
    found = caches.load(path, key)
    if isinstance(found, tuple) and len(found) == 2:
        statements, reported = found
        for item in reported:
            sink.add(item.code, item.span, item.message, item.hint, item.related)
        return statements  # type: ignore[no-any-return]
    scratch = DiagnosticSink()
    statements = _parse_text(text, display, scratch)
    reported_now: list[Diagnostic] = scratch.items
    for item in reported_now:
        sink.add(item.code, item.span, item.message, item.hint, item.related)
    if store:
        caches.store(path, key, (statements, reported_now))
    return statements


def _parse_text(text: str, display: str, sink: DiagnosticSink) -> list[ast.Statement]:
    """`parser.parse_text`, its module (and lark with it) imported on the first miss only."""
    from mplang.lang import parser

    return parser.parse_text(text, display, sink)

"""Front-end results kept across runs, as ruff and mypy keep theirs: the statements and
syntax diagnostics of each distinct source line (the first line of each text, its number
with it: every other line of the same text is a copy, its spans moved), so re-building a
project where one file changed parses that file's changed lines only
(`mplang.lang.linecache`); a line repeated all over a file is kept, and read back, once.
Beside the lines an entry keeps how lark built those with numbers (`mplang.lang.recipes`),
pickled apart and unpickled only when a line misses: a line whose numbers alone changed is
then built without importing the parser.

An entry is found by the file's path and its name as diagnostics show it, and kept under a
key of that name, its text and the front end itself (the grammar and the source of the
modules that read it, with mpc's and Python's version), and under a second key without the
text: the first is a hit for the whole file; the second gives the lines of an earlier text,
and only lines not among them are parsed. A change of the front end misses both, and the
file is parsed again. The keys head the entry and are compared before it is unpickled.
Entries live in the user cache dir (`mplang.lang.caches`, `front/`), one file per source
file, replaced atomically, so runs side by side never read half of one; a damaged entry is
a miss too. `--no-cache` (or `MPLANG_CACHE=off`) keeps nothing across runs: every line is
parsed, a text's repeated lines once (a `linecache.StatementCache` for the run).
"""

from __future__ import annotations

from functools import cache

from mplang.lang import ast, caches, packagedata
from mplang.lang.diagnostics import DiagnosticSink
from mplang.lang.digest import sha256
from mplang.lang.linecache import Numbered, StatementCache

KEYED_MODULES = ("ast", "builder", "diagnostics", "limits", "linecache", "parser", "recipes",
                 "tokenizer")
"""The modules of `mplang.lang` whose source is part of the key, named, not imported: the
parser and tokenizer bring lark, which a run where every file hits needs never load."""

FORMAT = "front 4"
"""Part of the key: change it when what an entry holds changes shape."""


@cache
def front_end_key() -> str:
    """What the parse of a text depends on besides the text: the grammar and the code of
    the modules that turn it into statements and diagnostics."""
    parts: list[bytes] = [FORMAT.encode(), packagedata.read_bytes("mplang.grammar",
                                                                   "mplang.lark")]
    for name in KEYED_MODULES:  # read so, they are found in a wheel too
        try:
            parts.append(packagedata.read_bytes("mplang.lang", name + ".py"))
        except OSError:  # an install without sources: its version stands for them (STAMP)
            parts.append(name.encode())
    return caches.digest(*parts)


def parse(text: str, display: str, sink: DiagnosticSink, *, store: bool = True,
          where: str = "", lines: StatementCache | None = None) -> list[ast.Statement]:
    """`parser.parse_text(text, display, sink)`, from the cache when it holds this text;
    a text parsed here is kept for the next run unless `store` is false (the language
    server: what it parses is mostly text being typed, never to be seen again). `where`
    (the file's resolved path) keeps apart files shown under the same name from two
    projects. `lines`, a process's own `StatementCache` (the language server's), parses the
    lines it has not seen; without it, an entry of an earlier text of the file gives the
    lines that did not change, so an edit parses the edited lines."""
    directory = caches.user_cache_dir()
    if directory is None:  # still a line repeated in the text is parsed once
        return (lines or StatementCache()).parse(text, display, sink)
    table = lines or StatementCache(record=store)
    seeded = bool(table.lines_of(display))
    if seeded and not store:  # the language server's buffers: its own table has the lines
        return table.parse(text, display, sink)
    front = front_end_key()
    key = caches.digest(front, display, text)
    file_key = caches.digest(front, display, where)
    name = sha256(f"{where}\0{display}".encode("utf-8", "surrogatepass")
                          ).hexdigest()[:32]
    path = directory / "front" / f"{name}.pickle"
    same = False
    if not seeded:
        found = caches.load_keyed(path, (key, file_key))
        if found is not None and _well_formed(found[1]):
            entry: tuple[list[Numbered], bytes] = found[1]  # type: ignore[assignment]
            table.seed(display, *entry)
            same = found[0] == 0  # kept from this very text: nothing new to keep
    statements = table.parse(text, display, sink)
    if store and not same:
        kept = table.distinct_of(display)
        if kept is not None:
            caches.store(path, key, (kept, table.recipes_for(kept)), file_key)
    return statements


def _well_formed(entry: object) -> bool:
    """An entry is its lines, of the shape of `linecache.Numbered`, and their recipes
    pickled (a damaged one may not be so)."""
    if type(entry) is not tuple or len(entry) != 2 or type(entry[1]) is not bytes:
        return False
    kept = entry[0]
    return isinstance(kept, list) and all(
        type(entry) is tuple and len(entry) == 2 and type(entry[0]) is int
        and type(line := entry[1]) is tuple and len(line) == 3 and type(line[0]) is str
        and type(line[1]) is list and type(line[2]) is list for entry in kept)

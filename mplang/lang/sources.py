"""Reading the files of a build, following INCLUDEs.

Each file joins a build once, however often it is included (so two programs may both
include a shared constants file). Include paths are relative to the including file and
must stay inside the project root (the nearest directory with `mpc.toml` or `.git` above
the file named on the command line, else that file's directory) unless allowed.

`INCLUDE "std:NAME.mp"` names a file of the routine library shipped inside the package
(`mplang.stdlib`, read through importlib.resources so it works from a wheel too). Library
files are outside every project by nature, so the project check does not apply to them,
and an INCLUDE inside a library file names another library file.
"""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Callable, Iterator
from itertools import compress
from pathlib import Path
from typing import TYPE_CHECKING

from mplang.lang import ast, frontcache
from mplang.lang.diagnostics import DiagnosticSink, Span
from mplang.lang.linecache import StatementCache
from mplang.lang.record import Record

if TYPE_CHECKING:
    from importlib.resources.abc import Traversable


class SourceFile(Record):
    path: Path
    display: str  # how the file is named in diagnostics and the image
    text: str
    statements: list[ast.Statement]
    _fields = __match_args__ = ("path", "display", "text", "statements")

    def __init__(self, path: Path, display: str, text: str,
                 statements: list[ast.Statement] | None = None) -> None:
        self.path = path
        self.display = display
        self.text = text
        self.statements = [] if statements is None else statements


def of_types(statements: list[ast.Statement], kinds: frozenset[type]
             ) -> Iterator[ast.Statement]:
    """The statements of exactly these classes (no syntax-tree class has subclasses), picked
    in C: a whole device has thousands of statements and a pass wants a few of them."""
    return compress(statements, map(kinds.__contains__, map(type, statements)))


_NESTING = frozenset({ast.ProgramHeader, ast.End, ast.Include})
"""What an INCLUDE's place in or outside a block depends on."""
LIBRARY_PREFIX = "std:"
LIBRARY_PACKAGE = "mplang.stdlib"


def library_files() -> dict[str, Traversable]:
    """The `.mp` files of the routine library, by file name (importlib.resources is
    imported here: a build that INCLUDEs no library file never needs it)."""
    from importlib import resources

    root = resources.files(LIBRARY_PACKAGE)
    return {entry.name: entry for entry in root.iterdir()
            if entry.name.endswith(".mp") and entry.is_file()}


def project_root(path: Path) -> Path:
    for parent in [path.parent, *path.parent.parents]:
        if (parent / "mpc.toml").exists() or (parent / ".git").exists():
            return parent
    return path.parent


FILE_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
              (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
              (stat.S_ISSOCK, "a socket"))


def not_regular(path: Path) -> str | None:
    """What `path` is if not a regular file ("a FIFO (named pipe)", ...), else None. Uses
    os.stat (following links), so nothing is opened: opening a FIFO for reading blocks until
    a writer comes, and a device can be endless. OSError if it does not exist."""
    mode = os.stat(path).st_mode
    if stat.S_ISREG(mode):
        return None
    return next((kind for test, kind in FILE_KINDS if test(mode)), "a special file")


def read_regular(path: Path) -> str:
    """The text of a file checked by `not_regular`: opened without blocking (if a FIFO took
    its place since, the open returns at once) and checked again on the open descriptor."""
    descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    with open(descriptor, encoding="utf-8") as stream:  # as Path.read_text reads
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):
            raise OSError(errno.EINVAL, "it is no longer a regular file")
        return stream.read()


def read_regular_bytes(path: Path) -> bytes:
    """The bytes of a file a user names (a project, a machine file, C source), never
    blocking on what is not a regular file: OSError (EINVAL, "it is a FIFO (named pipe), not
    a regular file") for a FIFO, a device or a socket, as for any file that cannot be read."""
    special = not_regular(path)
    if special is not None:
        raise OSError(errno.EINVAL, f"it is {special}, not a regular file")
    descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    with open(descriptor, "rb") as stream:
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):
            raise OSError(errno.EINVAL, "it is no longer a regular file")
        return stream.read()


def _display(path: Path) -> str:
    """How diagnostics, listings and images name a file: relative to the working directory
    when it is below it, and without `dir/..` steps (an INCLUDE "../lib/common.mp" of
    `cell one/main.mp` is `lib/common.mp`, as SARIF names it), in every output format."""
    path = Path(os.path.normpath(path))
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


class SourceSet(Record):
    """All files of one build in the order their declarations join it."""

    files: list[SourceFile]
    _fields = __match_args__ = ("files",)

    def __init__(self, files: list[SourceFile] | None = None) -> None:
        self.files = [] if files is None else files


def load_sources(paths: list[Path], sink: DiagnosticSink, *,
                 allow_outside: bool = False,
                 texts: dict[Path, str] | None = None,
                 store: bool | Callable[[Path], bool] = True,
                 lines: StatementCache | None = None) -> SourceSet:
    """Read and parse `paths` and everything they include.

    `texts` supplies in-memory contents for some paths (editors, tests); other files are read
    from disk. Parses come from the front-end cache (`frontcache`) when it holds them, and
    are kept there unless `store` is false (or, a function, false for that path). `lines`,
    a caller's own `StatementCache` kept between calls (the language server's), parses only
    the lines it has not seen before.
    """
    result = SourceSet()
    seen: set[Path] = set()
    library: dict[Path, Traversable] = {}  # resolved path -> library entry, once included

    def read(path: Path, display: str, at: Span | None) -> str | None:
        if texts is not None and path in texts:
            return texts[path]
        try:
            entry = library.get(path.resolve())
            if entry is not None:
                return entry.read_text(encoding="utf-8")
            special = not_regular(path)  # a regular file, or nothing is opened
            if special is not None:
                if at is None:
                    sink.add("E102", Span(display, 1), f"cannot read {display}: it is "
                             f"{special}, not a regular file")
                else:
                    sink.add("E102", at, f"cannot include {display}: it is {special}, not a "
                             "regular file", hint="INCLUDE names a .mp source file")
                return None
            return read_regular(path)
        except UnicodeDecodeError as exc:
            sink.add("E105", at or Span(display, 1), f"{display} is not UTF-8 text ({exc.reason})")
        except OSError as exc:
            reason = exc.strerror or str(exc)
            if at is None:
                sink.add("E102", Span(display, 1), f"cannot read {display}: {reason}")
            else:
                sink.add("E102", at, f"cannot include {display}: {reason}",
                         hint="include paths are relative to the including file")
        return None

    # visit calls itself through this table, which is cleared when done: a closure naming
    # itself is a reference cycle, which would hold every statement until a collection
    recurse: dict[str, Callable[[Path, Path, Span | None, list[Path]], None]] = {}

    def visit(path: Path, root: Path, at: Span | None, stack: list[Path]) -> None:
        resolved = path.resolve()
        if resolved in stack:
            chain = " -> ".join(LIBRARY_PREFIX + library[p].name if p in library else _display(p)
                                for p in [*stack[stack.index(resolved):], resolved])
            assert at is not None
            sink.add("E103", at, f"include cycle: {chain}",
                     hint="remove one INCLUDE of the cycle")
            return
        if resolved in seen:
            return
        entry = library.get(resolved)
        display = LIBRARY_PREFIX + entry.name if entry is not None else _display(path)
        text = read(path, display, at)
        if text is None:
            return
        seen.add(resolved)
        source = SourceFile(path, display, text, frontcache.parse(
            text, display, sink, store=store if isinstance(store, bool) else store(path),
            where=str(resolved), lines=lines))
        result.files.append(source)
        statements = source.statements
        # only what comes before the last INCLUDE matters (a block opened or closed): a
        # whole device has thousands of statements and no INCLUDE among them
        kinds = list(map(type, statements))  # one pass in C, not a loop of isinstance
        kinds.reverse()
        last = len(kinds) - kinds.index(ast.Include) if ast.Include in kinds else 0
        depth = 0
        for statement in of_types(statements[:last], _NESTING):
            if isinstance(statement, ast.ProgramHeader):
                depth += 1
            elif isinstance(statement, ast.End) and statement.what in ("mp", "isr"):
                depth = max(0, depth - 1)
            elif isinstance(statement, ast.Include):
                if depth:
                    sink.add("E106", statement.span, "INCLUDE must stand at the top level, "
                             "outside MP/ISR blocks")
                    continue
                if statement.path.startswith(LIBRARY_PREFIX) or entry is not None:
                    target_entry = library_entry(statement)
                    if target_entry is not None:
                        target = Path(str(target_entry))
                        library[target.resolve()] = target_entry
                        recurse["visit"](target, root, statement.span, [*stack, resolved])
                    continue
                target = (path.parent / statement.path)
                if "\0" in statement.path:  # no file can have it; Path.resolve would raise
                    sink.add("E102", statement.span, f"cannot include {statement.path!r}: a "
                             "path cannot contain a NUL character")
                    continue
                if not allow_outside and not target.resolve().is_relative_to(root.resolve()):
                    sink.add("E104", statement.span,
                             f"{statement.path!r} is outside the project ({_display(root)})",
                             hint="pass --allow-outside-includes to permit it")
                    continue
                recurse["visit"](target, root, statement.span, [*stack, resolved])

    def library_entry(statement: ast.Include) -> Traversable | None:
        name = statement.path.removeprefix(LIBRARY_PREFIX)
        available = library_files()
        found = available.get(name)
        if found is None:
            sink.add("E102", statement.span,
                     f"cannot include {statement.path}: the library has no file {name!r}",
                     hint="library files: " + ", ".join(LIBRARY_PREFIX + n
                                                         for n in sorted(available)))
        return found

    recurse["visit"] = visit
    for path in paths:
        visit(path, project_root(path.resolve()), None, [])
    recurse.clear()  # visit reached itself through it: no cycle keeps the statements
    return result

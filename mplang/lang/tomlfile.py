"""TOML files a user hands over (an mpc.toml, a machine file): one reader, so every such file
is read the same way and every problem is one message at its line.

`read_toml` never blocks on what is not a regular file, and says in one line why a file is
no TOML it can use (unreadable, not UTF-8, bad syntax at its line, a number longer than any
setting takes). `TomlLines` finds the line of a `[table]`, a `key =` or a string inside a
table, for the messages the file's own checks write.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from mplang.lang.sources import read_regular_bytes

TABLE_LINE = r"^\s*\[+\s*([^\]]+?)\s*\]+"
KEY_LINE = r"^\s*(\"[^\"]*\"|'[^']*'|[A-Za-z0-9_-]+)\s*="
"""The patterns of a `[table]` line and a `key =` line, compiled (by `re`'s own cache) when
a message first needs a line: a run without a bad TOML file never compiles them."""


class TomlFileError(Exception):
    """Why a file is no TOML mpc can read: `FILE[:LINE]: message`."""


def read_toml(path: Path) -> tuple[dict[str, Any], str]:
    """The table and the text of a TOML file; TomlFileError, with the line where there is
    one, for anything else. tomllib is imported here: a run without such a file never
    loads it."""
    import tomllib

    try:
        text = read_regular_bytes(path).decode("utf-8")
    except OSError as exc:
        raise TomlFileError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise TomlFileError(f"{path}: not UTF-8 text") from None
    except ValueError as exc:  # a name the system cannot take (a NUL)
        raise TomlFileError(f"{str(path)!r}: cannot read: {exc}") from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        match = re.search(r"line (\d+)", str(exc))
        line = match.group(1) if match else str(max(1, len(text.splitlines())))
        raise TomlFileError(f"{path}:{line}: not valid TOML: {exc}") from None
    except ValueError:  # tomllib converts numbers with int(): at most 4,300 digits
        longest = max(re.finditer(r"[0-9_]+", text), key=lambda m: len(m.group()))
        number = text.count("\n", 0, longest.start()) + 1
        raise TomlFileError(f"{path}:{number}: a number of {len(longest.group())} digits: "
                            "no setting takes one") from None


class TomlLines:
    """The lines of a TOML text, to point a message at a `[table]`, a `key =` in it, or a
    string (`needle`) on the key's line or after it."""

    def __init__(self, text: str) -> None:
        self.lines = text.splitlines()

    def line(self, table: str, key: str | None = None, needle: str | None = None) -> int:
        """The line of `needle` (from `key` on), else of `key`, else of `[table]`, else 1."""
        current, found, key_line = "", 1, 0
        for number, raw in enumerate(self.lines, start=1):
            text = raw.split("#", 1)[0] if not raw.lstrip().startswith(("\"", "'")) else raw
            header = re.match(TABLE_LINE, text)
            if header:
                current = ".".join(part.strip().strip("\"'") for part in
                                   header.group(1).split("."))
                if current == table:
                    found = number
                    if key is None and needle is None:
                        return number
                continue
            if current != table:
                continue
            match = re.match(KEY_LINE, text)
            if match and key is not None and match.group(1).strip("\"'") == key:
                found = key_line = number
                if needle is None:
                    return number
            if needle is not None and (key_line or key is None) and needle in raw:
                return number
        return found

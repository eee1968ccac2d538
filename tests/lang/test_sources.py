"""Loading sources and includes: paths no file system accepts are diagnostics, not crashes."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest

from mplang.lang.sources import not_regular, read_regular
from mplang.m8194h.compiler import Options, compile_paths, compile_source


def test_an_include_path_with_a_nul_character_is_an_e102() -> None:
    result = compile_source('INCLUDE "a\0b.mp"\nMP 1 a\n    VAR1 = 1\nEND MP\n')
    assert [(d.code, d.span.line) for d in result.diagnostics] == [("E102", 1)]
    assert "NUL" in result.diagnostics[0].message


def test_an_include_of_anything_but_a_regular_file_is_an_e102(tmp_path: Path) -> None:
    """A FIFO, a device (here behind a symlink) and a directory are named, never opened: a
    FIFO opened for reading would wait for a writer forever (issue 19 item 7)."""
    (tmp_path / "mpc.toml").write_text("")
    os.mkfifo(tmp_path / "pipe.mp")
    (tmp_path / "null.mp").symlink_to("/dev/null")
    (tmp_path / "folder.mp").mkdir()
    (tmp_path / "ok.mp").write_text("CONST A = 1\r\n")
    main = tmp_path / "main.mp"
    main.write_text('INCLUDE "pipe.mp"\nINCLUDE "null.mp"\nINCLUDE "folder.mp"\n'
                    'INCLUDE "ok.mp"\nMP 1 a\n    VAR1 = A\nEND MP\n')
    found: list[list[tuple[str, int, str]]] = []

    def build() -> None:
        result = compile_paths([main], Options(allow_outside_includes=True))
        found.append([(d.code, d.span.line, d.message) for d in result.diagnostics])

    worker = threading.Thread(target=build, daemon=True)
    worker.start()
    worker.join(60)
    if worker.is_alive():  # the FIFO was opened: let the reader go, then fail
        with open(tmp_path / "pipe.mp", "w"):
            pass
        pytest.fail("the build opened the FIFO and waited for a writer")
    (diagnostics,) = found
    assert [(code, line) for code, line, _ in diagnostics] == [("E102", 1), ("E102", 2),
                                                                ("E102", 3)]
    messages = [message for _, _, message in diagnostics]
    assert "pipe.mp: it is a FIFO (named pipe), not a regular file" in messages[0]
    assert "null.mp: it is a character device" in messages[1]
    assert "folder.mp: it is a directory" in messages[2]


def test_an_included_regular_file_reads_as_before(tmp_path: Path) -> None:
    """Read without blocking and checked on its descriptor, the text is still read as
    Path.read_text reads it: UTF-8, universal newlines; bad UTF-8 is E105."""
    (tmp_path / "mpc.toml").write_text("")
    (tmp_path / "crlf.mp").write_bytes(b"CONST A = 1\r\nCONST B = 2\r")
    (tmp_path / "latin.mp").write_bytes(b"# caf\xe9\n")
    main = tmp_path / "main.mp"
    main.write_text('INCLUDE "crlf.mp"\nINCLUDE "latin.mp"\nMP 1 a\n    VAR1 = A + B\n'
                    'END MP\n')
    result = compile_paths([main], Options())
    assert [(d.code, d.span.line) for d in result.diagnostics] == [("E105", 2)]
    assert not_regular(tmp_path / "crlf.mp") is None
    assert read_regular(tmp_path / "crlf.mp") == "CONST A = 1\nCONST B = 2\n"

"""The language server: pygls 2.x glue over `analysis` and `features` (this package).

Each open document is compiled on open and on every change (incremental sync: pygls applies
the client's range edits, counted in the negotiated position encoding, to its copy of the
text). Its diagnostics are published; hover, completion, definition, code lenses and inlay
hints are answered from the latest analysis. Positions cross the boundary here, converted
between code points and the client's negotiated encoding. A handler that fails logs the
error and answers nothing: one bad input never takes the server down.

Speed: each open document keeps a build memo (`mplang.ir.reuse`), so an edit re-checks only
the programs it changed, and its diagnostics, placed and converted to JSON, are taken from
the last check where they are the same objects on unchanged lines (or were shifted with a
program that only moved: their ranges moved as much); a check's diagnostics
are converted to the client's positions once (ASCII lines without counting), semantic
tokens are kept per analysis (`handlers`), and a document whose last check took longer
than `DEBOUNCE_ABOVE_S` is checked `DEBOUNCE_S` after the last change of a burst instead
of after every keystroke (the pause lets the server read the changes that arrived while
it was checking, so a burst costs one check, while an edit on its own is checked at
once); requests on it check it first, and diagnostics are published only
for the document's current version, so none shown is ever stale. After start-up the heap
built so far (catalogue, grammar, the code) is frozen out of the cycle collector, which
would otherwise walk it on every collection, the collector waits while a check runs, and
what a check kept is frozen after it (with a full collection every few hundred checks).

Hostile input: messages are read by `transport` (bounded, resynchronising after a framing
error) instead of pygls' own loop, and a request on a document the client did not open reads
it only if it is a regular file of at most `workspace.MAX_FILE_BYTES` inside the workspace:
never a device, FIFO or socket, which could block the server or feed it without end.
"""

from __future__ import annotations

import asyncio
import functools
import gc
import inspect
import json
import logging
import os
import re
import sys
import threading
import time
from collections.abc import Callable, Hashable, Iterator
from pathlib import Path
from typing import Any, BinaryIO, NamedTuple, TypeVar
from urllib.parse import unquote

from lsprotocol import types as lsp
from pygls import uris
from pygls.exceptions import JsonRpcException, JsonRpcInternalError
from pygls.io_ import StdoutWriter
from pygls.lsp.server import LanguageServer
from pygls.protocol import LanguageServerProtocol, lsp_method

from mplang import __version__
from mplang.ir.reuse import BuildMemo
from mplang.lang.linecache import StatementCache
from mplang.tools.lsp import features
from mplang.tools.lsp.analysis import Analysis, EditorDiagnostic, analyse
from mplang.tools.lsp.ends import same_ends
from mplang.tools.lsp.handlers import register_editing
from mplang.tools.lsp.navigation import register_navigation
from mplang.tools.lsp.positions import (
    ENCODINGS,
    Location,
    Pos,
    Range,
    apply_change,
    from_client_character,
    split_lines,
    to_client_character,
)
from mplang.tools.lsp.transport import Framer, serve, stream_reader
from mplang.tools.lsp.workspace import (
    Overrides,
    RefusedFile,
    context_for,
    read_text,
    refusal,
)

logger = logging.getLogger("mplang.tools.lsp")
R = TypeVar("R")

COMPLETION_KINDS = {
    "command": lsp.CompletionItemKind.Function, "keyword": lsp.CompletionItemKind.Keyword,
    "variable": lsp.CompletionItemKind.Variable, "constant": lsp.CompletionItemKind.Constant,
    "axis": lsp.CompletionItemKind.EnumMember, "value": lsp.CompletionItemKind.EnumMember,
    "label": lsp.CompletionItemKind.Reference, "program": lsp.CompletionItemKind.Module,
    "file": lsp.CompletionItemKind.File, "snippet": lsp.CompletionItemKind.Snippet,
}
# Completion pops up by itself after these: a space (GOTO ., CALL ., FIXED_MOVE .), an
# argument separator, an opening bracket and the quote of an INCLUDE.
TRIGGER_CHARACTERS = [" ", ",", "(", '"']
DEBOUNCE_ABOVE_S = 0.05
"""A document whose last check took longer than this (the budget of one keystroke) is
checked after a pause in its changes rather than after each of them."""
DEBOUNCE_S = 0.005
"""The pause: long enough for the server to read what the client has sent already (changes
typed while the last check ran, waiting in the pipe), so that they are checked once, for
the last of them; short enough that a single edit waits no longer than a few milliseconds
for its check."""
FULL_COLLECTION_EVERY = 256
"""Checks between two full collections of the frozen heap (`MpLanguageServer.settle_heap`):
what cyclic garbage the checks in between left is freed then."""
WARM_UP_TEXT = "MP 1\n    SET_V X, 100\nEND MP\n"
"""Checked once at start-up, so that the catalogue and the grammar are loaded (and frozen
out of the cycle collector's walks) before the first keystroke."""


_SENDING: set[asyncio.Future[Any]] = set()
"""Writes of `EncodedMessage`s still under way on an asynchronous transport."""


class EncodedMessage:
    """A message already written as JSON (ASCII: `json.dumps` escapes the rest), sent as it
    is by `_Protocol._send_data`: a whole device's publish is thousands of diagnostics whose
    JSON text is kept from the publish before, not encoded again. Held as the parts of its
    body, joined by `separator`: the megabyte of text is copied once, with its header, into
    the bytes written, not once per step of putting the message together (nor encoded)."""

    __slots__ = ("parts", "separator")

    def __init__(self, parts: list[bytes], separator: bytes = b"") -> None:
        self.parts = parts
        self.separator = separator

    def framed(self, header: Callable[[int], bytes]) -> bytes:
        """The header (`header` of the body's length) and the body, joined once."""
        parts = self.parts
        length = sum(map(len, parts)) + len(self.separator) * max(len(parts) - 1, 0)
        if not parts:
            return header(length)
        return self.separator.join([header(length) + parts[0], *parts[1:]])


class _Protocol(LanguageServerProtocol):
    """pygls' protocol, with the server's own incremental sync instead of pygls': pygls
    applies a change on lines split by `str.splitlines` (form feeds, U+2028 ... end a line
    there, not in the protocol), clamps the change's positions in place to those lines, and
    rebuilds the whole text line by line for every change. Its document gets the server's
    text whole instead (and the version); only a document the server holds no text of is
    left to pygls."""

    @lsp_method(lsp.TEXT_DOCUMENT_DID_CHANGE)
    def lsp_text_document__did_change(self, params: lsp.DidChangeTextDocumentParams
                                      ) -> Iterator[Any]:
        server = self._server
        text = None
        if isinstance(server, MpLanguageServer):
            try:
                text = server.changed(params)
            except Exception:  # the guard of every handler: logged, never fatal
                logger.exception("applying a change failed")
        if text is None:
            yield from super().lsp_text_document__did_change(params)
            return
        self.workspace.update_text_document(
            params.text_document, lsp.TextDocumentContentChangeWholeDocument(text=text))
        if (handler := self.fm.features.get(lsp.TEXT_DOCUMENT_DID_CHANGE)) is not None:
            yield handler, (params,), None

    def _send_data(self, data: Any) -> None:
        """pygls' sending, and an `EncodedMessage` sent without encoding it again (framed
        and guarded as pygls frames and guards every message)."""
        if not isinstance(data, EncodedMessage):
            super()._send_data(data)
            return
        if self.writer is None:
            logger.error("Unable to send data, no available transport!")
            return
        try:
            written = self.writer.write(data.framed(lambda length: (
                f"Content-Length: {length}\r\nContent-Type: {self.CONTENT_TYPE}; "
                f"charset={self.CHARSET}\r\n\r\n").encode(self.CHARSET)))
            if inspect.isawaitable(written):  # kept until done: a task only weakly held
                sending = asyncio.ensure_future(written)  # may be collected while it runs
                _SENDING.add(sending)
                sending.add_done_callback(_SENDING.discard)
        except BrokenPipeError:
            logger.exception("Error sending data. BrokenPipeError", exc_info=True)
            raise
        except Exception as error:
            logger.exception("Error sending data", exc_info=True)
            self._server._report_server_error(error, JsonRpcInternalError)


class MpLanguageServer(LanguageServer):
    """Holds the command line's options and the latest analysis of every open document."""

    def __init__(self, overrides: Overrides, debounce_above_s: float = DEBOUNCE_ABOVE_S,
                 debounce_s: float = DEBOUNCE_S) -> None:
        super().__init__("mpc-lsp", __version__, protocol_cls=_Protocol,
                         text_document_sync_kind=lsp.TextDocumentSyncKind.Incremental)
        self.overrides = overrides
        self.debounce_above_s = debounce_above_s
        self.debounce_s = debounce_s
        self.analyses: dict[str, Analysis] = {}  # by document URI
        # parsed statements by line text, so that an edit parses the edited lines only
        self.statements = StatementCache()
        # by URI: what each open document's builds keep for the next (`mplang.ir.reuse`),
        # so that an edit re-checks only the programs it changed
        self.memos: dict[str, BuildMemo] = {}
        # By URI: the document version each kept analysis checked, how long its check took,
        # the check waiting for a pause in the changes, and the diagnostics as last
        # converted for the client (with the analysis and encoding they were converted for).
        self.versions: dict[str, int | None] = {}
        self.check_seconds: dict[str, float] = {}
        self.pending: dict[str, asyncio.TimerHandle] = {}
        self.converted: dict[str, tuple[Analysis, str, list[lsp.Diagnostic]]] = {}
        # By URI: the diagnostics last published and their JSON text, for the next publish
        # to take again.
        self.published: dict[str, _Published] = {}
        # The text of each open document (by unquoted URI), kept here with the protocol's
        # line breaks (`positions.apply_change`) rather than by pygls' incremental sync.
        self.texts: dict[str, str] = {}
        self.checks_done = 0  # for the full collection every FULL_COLLECTION_EVERY checks

    # ------------------------------------------------------------------ documents
    @property
    def encoding(self) -> str:
        """The negotiated position encoding: how the client counts `character`."""
        kind = self.workspace.position_encoding
        name = kind.value if isinstance(kind, lsp.PositionEncodingKind) else str(kind or "")
        return name if name in ENCODINGS else "utf-16"

    @staticmethod
    def document_path(uri: str) -> Path:
        """The file behind a URI; an unsaved buffer counts as a file in the current directory
        (its INCLUDEs are then relative to it)."""
        path = uris.to_fs_path(uri) if uris.uri_scheme(uri) == "file" else None
        if path:
            return Path(path)
        name = uri.rstrip("/").rsplit("/", 1)[-1].rsplit(":", 1)[-1] or "untitled.mp"
        return Path.cwd() / name

    def is_open(self, uri: str) -> bool:
        # pygls keys its documents by the unquoted URI; `self.analyses` keeps the client's own
        # spelling, which is what the client matches diagnostics and locations against.
        return unquote(uri) in self.workspace.text_documents

    def workspace_roots(self) -> list[Path]:
        """The folders the client named (root and workspace folders), resolved."""
        workspace = self.workspace
        named = [workspace.root_uri, *(folder.uri for folder in workspace.folders.values())]
        roots = []
        for uri in named:
            path = uris.to_fs_path(uri) if uri and uris.uri_scheme(uri) == "file" else None
            if path:
                roots.append(Path(path).resolve())
        return roots

    def document_text(self, uri: str) -> str:
        """The text of a document: the editor's when it is open, else the file's, read only if
        it is a regular file of at most MAX_FILE_BYTES inside the workspace (when the client
        named one). pygls would read any path, /dev/zero included, to its end."""
        if self.is_open(uri):
            return self.open_text(uri)
        if uris.uri_scheme(uri) != "file":
            return ""  # an unsaved buffer the client did not open: no text (as pygls)
        path = self.document_path(uri)
        reason = refusal(os.stat(path))  # a missing file fails here, as it always did
        if reason is not None:
            raise RefusedFile(path, reason)
        roots = self.workspace_roots()
        if roots and not any(path.resolve().is_relative_to(root) for root in roots):
            raise RefusedFile(path, "not open in the editor and outside the workspace")
        return read_text(path)

    def open_text(self, uri: str) -> str:
        """The editor's text of an open document."""
        kept = self.texts.get(unquote(uri))
        return kept if kept is not None else self.workspace.get_text_document(uri).source

    def opened(self, params: lsp.DidOpenTextDocumentParams) -> None:
        self.texts[unquote(params.text_document.uri)] = params.text_document.text

    def changed(self, params: lsp.DidChangeTextDocumentParams) -> str | None:
        """Apply the client's changes, in order, to the kept text; the new text, or None for
        a document the server holds no text of."""
        key = unquote(params.text_document.uri)
        text = self.open_text(params.text_document.uri) if key in self.texts else None
        if text is None:
            return None  # not opened through didOpen: pygls' copy is all there is
        for change in params.content_changes:
            if isinstance(change, lsp.TextDocumentContentChangePartial):
                start, end = change.range.start, change.range.end
                text = apply_change(text, (start.line, start.character),
                                    (end.line, end.character), change.text, self.encoding)
            else:
                text = change.text
        self.texts[key] = text
        return text

    def analyse_uri(self, uri: str) -> Analysis:
        """Check a document; an open one's analysis is kept for the requests that follow,
        with the version it checked and how long that took."""
        started = time.perf_counter()
        text = self.document_text(uri)
        others = {self.document_path(u).resolve(): self.open_text(u)
                  for u in self.analyses if u != uri and self.is_open(u)}
        path = self.document_path(uri)
        opened = self.is_open(uri)
        memo = self.memos.setdefault(uri, BuildMemo()) if opened else None
        analysis = analyse(path, text, context_for(path, self.overrides), others,
                           self.statements, memo, self.analyses.get(uri) if opened else None)
        if opened:
            self.analyses[uri] = analysis
            self.versions[uri] = self.version_of(uri)
            self.check_seconds[uri] = time.perf_counter() - started
        return analysis

    def analysis(self, uri: str) -> Analysis:
        """The latest analysis of a document: a check waiting for a pause in the changes is
        run (and published) first, so that a request never answers from an older text."""
        if uri in self.pending:
            self.refresh(uri)
        return self.analyses.get(uri) or self.analyse_uri(uri)

    def version_of(self, uri: str) -> int | None:
        return self.workspace.get_text_document(uri).version

    def after_change(self, uri: str) -> None:
        """Check a changed document now, or, when its last check took longer than
        `debounce_above_s`, once its changes pause for `debounce_s`."""
        self.cancel_pending(uri)
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # driven without an event loop: nothing could wait
            loop = None
        if loop is None or self.check_seconds.get(uri, 0.0) <= self.debounce_above_s:
            self.refresh(uri)
            return
        self.pending[uri] = loop.call_later(self.debounce_s, self._paused, uri)

    def _paused(self, uri: str) -> None:
        """The changes of a document paused: check it (a loop callback, so guarded as
        every handler is)."""
        self.pending.pop(uri, None)
        try:
            if self.is_open(uri):
                self.refresh(uri)
        except Exception:
            logger.exception("checking %s failed", uri)

    def cancel_pending(self, uri: str) -> None:
        waiting = self.pending.pop(uri, None)
        if waiting is not None:
            waiting.cancel()

    def refresh(self, uri: str) -> None:
        """Re-check a document, then every open document whose build reads it (it INCLUDEs
        it, or both are sources of one project)."""
        changed = self.check(uri)
        for other, previous in list(self.analyses.items()):
            if other != uri and changed.path in previous.files:
                self.check(other)

    def check(self, uri: str) -> Analysis:
        """Check a document now and publish its diagnostics (a check waiting for a pause in
        its changes is then no longer needed).

        The cycle collector waits until the diagnostics are out: a check allocates hundreds
        of thousands of objects, and collecting while it runs walks them (and the analysis
        kept from before) again and again, a quarter of a whole device's check. What the
        check kept is then frozen out of the collector's walks too (`settle_heap`)."""
        self.cancel_pending(uri)
        collecting = gc.isenabled()
        gc.disable()
        try:
            analysis = self.analyse_uri(uri)
            self.publish(uri, analysis)
        finally:
            if collecting:
                self.settle_heap()
                gc.enable()
        return analysis

    def settle_heap(self) -> None:
        """After a check: freeze what is alive now (the analysis, its build memo, the parsed
        lines), so that the collections that the next check's allocations set off do not
        walk it (a whole device's analysis is hundreds of thousands of objects: a tenth of
        an edit's time went on those walks). Reference counting still frees what a later
        check drops; only cyclic garbage would stay, so every `FULL_COLLECTION_EVERY`
        checks everything is unfrozen, collected once and frozen again."""
        self.checks_done += 1
        if self.checks_done % FULL_COLLECTION_EVERY == 0:
            gc.unfreeze()
            gc.collect()
        gc.freeze()

    def publish(self, uri: str, analysis: Analysis) -> None:
        """Publish a document's diagnostics, only if its analysis checked the version the
        editor holds now: diagnostics of an older text are never shown."""
        version = self.version_of(uri)
        if self.versions.get(uri, version) != version:
            return
        head = {"uri": uri, "version": version} if version is not None else {"uri": uri}
        # the diagnostics' JSON text is kept between publishes, as bytes: the message is put
        # together around it in one join with its header (`EncodedMessage.framed`), never
        # encoded whole again
        opening = (f'{{"jsonrpc":"2.0","params":{_compact(head)[:-1]},"diagnostics":['
                   ).encode()
        closing = f']}},"method":{_compact(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)}}}'.encode()
        parts = self.json_diagnostics(uri, analysis)
        if parts:
            parts = [opening + parts[0], *parts[1:]]
            parts[-1] += closing
        else:
            parts = [opening + closing]
        self.protocol._send_data(EncodedMessage(parts, b","))

    def json_diagnostics(self, uri: str, analysis: Analysis) -> list[bytes]:
        """The diagnostics to publish, as compact JSON text (bytes: ASCII). One that was
        published last time (the same diagnostic on the same line text, in the same
        encoding) is taken from then: after an edit, only the diagnostics it changed are
        converted; the thousands of a whole device's warnings are not.

        The placements the last publish shared with this one, at its start and its end,
        are the very objects of then in the same encoding: their text is taken as a slice
        (`ends.same_ends`, pointers compared in C). Only the ones in between are looked up,
        by identity among the last publish's in between (a placement moved with its
        program, `_moved_json`) or by what their JSON depends on, one by one."""
        encoding = self.encoding
        diagnostics = analysis.diagnostics
        last = self.published.get(uri)
        if last is None or last.encoding != encoding:
            last = _Published([], [], encoding, {})
        head, tail = same_ends(last.diagnostics, diagnostics)
        old_end = len(last.diagnostics) - tail
        same_before = {id(d): (d, encoding, text) for d, text in
                       zip(last.diagnostics[head:old_end], last.texts[head:old_end],
                           strict=True)}
        now: dict[Hashable, bytes] = {}
        found = last.texts[:head]
        for diagnostic in diagnostics[head:len(diagnostics) - tail]:
            kept = same_before.get(id(diagnostic))
            if kept is not None and kept[0] is diagnostic:
                found.append(kept[2])
                continue
            shifted = _moved_json(analysis, diagnostic, same_before, encoding)
            if shifted is not None:
                found.append(shifted)
                continue
            key = _published_key(diagnostic, analysis.lines, encoding)
            value = now.get(key) if key is not None else None
            if value is None and key is not None:
                value = last.by_key.get(key)
            if value is None:
                value = _compact(self.protocol._converter.unstructure(
                    self.diagnostic(uri, analysis, diagnostic))).encode()
            if key is not None:
                now[key] = value
            found.append(value)
        found += last.texts[old_end:]
        if self.is_open(uri):
            self.published[uri] = _Published(diagnostics, found, encoding, now)
        return found

    def client_diagnostics(self, uri: str, analysis: Analysis) -> list[lsp.Diagnostic]:
        """An analysis's diagnostics in the client's positions, converted once per analysis
        (and encoding) of an open document, however often they are asked for."""
        kept = self.converted.get(uri)
        if kept is not None and kept[0] is analysis and kept[1] == self.encoding:
            return kept[2]
        converted = [self.diagnostic(uri, analysis, d) for d in analysis.diagnostics]
        if self.is_open(uri):
            self.converted[uri] = (analysis, self.encoding, converted)
        return converted

    def forget(self, uri: str) -> None:
        self.texts.pop(unquote(uri), None)
        self.cancel_pending(uri)
        for kept in (self.versions, self.check_seconds, self.converted, self.published,
                     self.memos):
            kept.pop(uri, None)
        closed = self.analyses.pop(uri, None)
        self.text_document_publish_diagnostics(lsp.PublishDiagnosticsParams(uri=uri,
                                                                            diagnostics=[]))
        if closed is None:
            return
        entry = closed.files.get(closed.path)
        if entry is not None:
            self.statements.forget(entry.display)
        for other, previous in list(self.analyses.items()):
            if closed.path in previous.files:
                self.check(other)

    # ------------------------------------------------------------------ conversion
    def uri_for(self, uri: str, analysis: Analysis, path: Path) -> str:
        """The root document keeps the client's own URI; open files theirs; others file:."""
        if path == analysis.path:
            return uri
        for other, analysis_of_other in self.analyses.items():
            if analysis_of_other.path == path:
                return other
        return uris.from_fs_path(str(path)) or path.as_uri()

    def lines_of(self, analysis: Analysis, path: Path) -> list[str]:
        entry = analysis.files.get(path)
        if entry is not None:
            return entry.lines
        try:
            return split_lines(read_text(path))
        except (OSError, UnicodeDecodeError):
            return []

    def to_client(self, lines: list[str], range_: Range) -> lsp.Range:
        def convert(pos: Pos) -> lsp.Position:
            text = lines[pos.line] if 0 <= pos.line < len(lines) else ""
            return lsp.Position(line=pos.line, character=to_client_character(
                text, pos.character, self.encoding))

        return lsp.Range(start=convert(range_.start), end=convert(range_.end))

    def from_client(self, analysis: Analysis, position: lsp.Position) -> Pos:
        lines = analysis.lines
        text = lines[position.line] if 0 <= position.line < len(lines) else ""
        return Pos(position.line, from_client_character(text, position.character,
                                                        self.encoding))

    def location(self, uri: str, analysis: Analysis, location: Location) -> lsp.Location:
        return lsp.Location(uri=self.uri_for(uri, analysis, location.path),
                            range=self.to_client(self.lines_of(analysis, location.path),
                                                 location.range))

    def diagnostic(self, uri: str, analysis: Analysis, found: EditorDiagnostic
                   ) -> lsp.Diagnostic:
        message = found.message + (f"\nhint: {found.hint}" if found.hint else "")
        severity = lsp.DiagnosticSeverity.Error if found.severity == "error" else \
            lsp.DiagnosticSeverity.Warning
        related = [lsp.DiagnosticRelatedInformation(
            location=self.location(uri, analysis, where), message=note)
                   for where, note in found.related]
        docs = lsp.CodeDescription(href=_page_uri(found.docs)) if found.docs else None
        return lsp.Diagnostic(range=self.to_client(analysis.lines, found.range),
                              message=message, severity=severity, code=found.code or None,
                              code_description=docs, source="mpc",
                              related_information=related or None)

    # ------------------------------------------------------------------ transport
    def warm_up(self) -> None:
        """Load what every check needs (catalogue, grammar) with one check of a small text,
        then freeze the heap built so far out of the cycle collector: the long-lived objects
        of the server are then never walked again when a check allocates."""
        analyse(Path.cwd() / "warm-up.mp", WARM_UP_TEXT)
        gc.collect()
        gc.freeze()

    def start_io(self, stdin: BinaryIO | None = None, stdout: BinaryIO | None = None) -> None:
        """Serve over stdio as pygls does, but read with the bounded `transport`."""
        self.warm_up()
        self._stop_event = stop = threading.Event()
        self.protocol.set_writer(StdoutWriter(stdout or sys.stdout.buffer))
        framer = Framer(stream_reader(stdin or sys.stdin.buffer))
        try:
            asyncio.run(serve(framer, self.protocol, stop, self.report_dropped,
                              self.report_server_error))
        except BrokenPipeError:
            logger.error("the connection to the client is lost; shutting down")
        except (KeyboardInterrupt, SystemExit):
            pass
        finally:
            self.shutdown()  # type: ignore[no-untyped-call]  # pygls: unannotated

    def start_tcp(self, host: str, port: int) -> None:
        """Serve one client over TCP as pygls does, but read with the bounded `transport`."""
        self.warm_up()
        self._stop_event = stop = threading.Event()

        async def connection(reader: asyncio.StreamReader, writer: asyncio.StreamWriter
                             ) -> None:
            self.protocol.set_writer(writer)
            await serve(Framer(reader.read), self.protocol, stop, self.report_dropped,
                        self.report_server_error)
            self.shutdown()  # type: ignore[no-untyped-call]  # pygls: unannotated

        async def listen() -> None:
            server = await asyncio.start_server(connection, host, port)
            self._server = server
            async with server:
                await server.serve_forever()

        try:
            asyncio.run(listen())
        except asyncio.CancelledError:
            logger.debug("the server was cancelled")

    def report_dropped(self, reason: str) -> None:
        """Input that was no message: to stderr and to the editor's log, not as a popup."""
        logger.warning("%s", reason)
        try:
            self.window_log_message(lsp.LogMessageParams(type=lsp.MessageType.Warning,
                                                         message=f"mpc lsp: {reason}"))
        except Exception:
            logger.exception("cannot report the dropped input to the client")

    def snippets_supported(self) -> bool:
        capabilities = self.client_capabilities.text_document
        completion = capabilities.completion if capabilities else None
        item = completion.completion_item if completion else None
        return bool(item and item.snippet_support)


def _published_key(diagnostic: EditorDiagnostic, lines: list[str], encoding: str
                   ) -> Hashable | None:
    """What a published diagnostic's JSON depends on: its place, kind and words, the text
    of the lines its range is on (positions in the client's units) and the encoding; its
    documentation page follows from its code. A flat tuple of numbers and strings, hashed
    in C (hundreds of diagnostics are looked up per publish). None for one that points into
    other files (related information), which is converted each time."""
    if diagnostic.related:
        return None
    start, end = diagnostic.range.start, diagnostic.range.end
    return (start.line, start.character, end.line, end.character, diagnostic.severity,
            diagnostic.code, diagnostic.message, diagnostic.hint, diagnostic.elsewhere,
            encoding, lines[start.line] if 0 <= start.line < len(lines) else "",
            lines[end.line] if 0 <= end.line < len(lines) and end.line != start.line else "")


class _Published(NamedTuple):
    """A document's last publish: its placements, in order, and their JSON text, the
    encoding they were converted for, and the text of the ones converted or looked up then
    by what their JSON depends on (`_published_key`)."""

    diagnostics: list[EditorDiagnostic]
    texts: list[bytes]
    encoding: str
    by_key: dict[Hashable, bytes]


_compact = json.JSONEncoder(separators=(",", ":")).encode
"""JSON without the blanks after separators: a whole device's publish is a megabyte, which
the client reads and parses on every edit."""

_RANGE_JSON = re.compile(rb'\{"range":\{"start":\{"line":(\d+),"character":(\d+)\},'
                         rb'"end":\{"line":(\d+),"character":(\d+)\}\}')
"""How a published diagnostic's JSON text begins: its range, in the client's units."""


def _moved_json(analysis: Analysis, diagnostic: EditorDiagnostic,
                published: dict[int, tuple[EditorDiagnostic, str, bytes]], encoding: str
                ) -> bytes | None:
    """The JSON text of a diagnostic the analysis moved from the last one's (a program that
    only moved, `analysis.moved`): the one published for it then, its range's lines moved
    (the line's text is unchanged, so are its characters). None when there is none, or
    its text does not begin with the range on the kept lines."""
    moved = analysis.moved.get(id(diagnostic))
    if moved is None or moved[0] is not diagnostic:
        return None
    _, kept, offset = moved
    same = published.get(id(kept))
    if same is None or same[0] is not kept or same[1] != encoding:
        return None
    text = same[2]
    found = _RANGE_JSON.match(text)
    if found is None or int(found[1]) != kept.range.start.line or \
            int(found[3]) != kept.range.end.line:
        return None
    return (b'{"range":{"start":{"line":%d,"character":%s},"end":{"line":%d,"character":%s}}'
            % (int(found[1]) + offset, found[2], int(found[3]) + offset, found[4])
            + text[found.end():])


@functools.lru_cache(maxsize=256)
def _page_uri(page: Path) -> str:
    """A check page's address (a few pages, linked by hundreds of diagnostics)."""
    return page.as_uri()


def _guarded(server: MpLanguageServer
             ) -> Callable[[Callable[[Any], R]], Callable[[Any], R | None]]:
    """Log a failing handler (also to the client's log) and answer nothing instead."""

    def decorate(handler: Callable[[Any], R]) -> Callable[[Any], R | None]:
        @functools.wraps(handler)
        def run(params: Any) -> R | None:
            try:
                return handler(params)
            except JsonRpcException:  # an error meant for the client (a refused rename)
                raise
            except RefusedFile as exc:  # expected of hostile input: no traceback
                logger.warning("%s: %s", handler.__name__, exc)
                try:
                    server.window_log_message(lsp.LogMessageParams(
                        type=lsp.MessageType.Warning,
                        message=f"mpc lsp: {handler.__name__}: {exc}"))
                except Exception:
                    logger.exception("cannot report the error to the client")
                return None
            except Exception as exc:
                logger.exception("%s failed", handler.__name__)
                try:
                    server.window_log_message(lsp.LogMessageParams(
                        type=lsp.MessageType.Error, message=f"mpc lsp: {handler.__name__} "
                        f"failed: {type(exc).__name__}: {exc}"))
                except Exception:
                    logger.exception("cannot report the error to the client")
                return None

        return run

    return decorate


def create_server(overrides: Overrides | None = None, debounce_above_s: float = DEBOUNCE_ABOVE_S,
                  debounce_s: float = DEBOUNCE_S) -> MpLanguageServer:
    """A server with every feature registered (started by `mpc lsp`)."""
    server = MpLanguageServer(overrides or Overrides(), debounce_above_s, debounce_s)

    @server.feature(lsp.TEXT_DOCUMENT_DID_OPEN)
    @_guarded(server)
    def did_open(params: lsp.DidOpenTextDocumentParams) -> None:
        server.opened(params)
        server.refresh(params.text_document.uri)  # also cancels a check still waiting

    @server.feature(lsp.TEXT_DOCUMENT_DID_CHANGE)
    @_guarded(server)
    def did_change(params: lsp.DidChangeTextDocumentParams) -> None:
        server.after_change(params.text_document.uri)  # the text: `_Protocol` kept it

    @server.feature(lsp.TEXT_DOCUMENT_DID_SAVE)
    @_guarded(server)
    def did_save(params: lsp.DidSaveTextDocumentParams) -> None:
        server.refresh(params.text_document.uri)

    @server.feature(lsp.TEXT_DOCUMENT_DID_CLOSE)
    @_guarded(server)
    def did_close(params: lsp.DidCloseTextDocumentParams) -> None:
        server.forget(params.text_document.uri)

    @server.feature(lsp.TEXT_DOCUMENT_HOVER)
    @_guarded(server)
    def hover(params: lsp.HoverParams) -> lsp.Hover | None:
        uri = params.text_document.uri
        analysis = server.analysis(uri)
        found = features.hover(analysis, server.from_client(analysis, params.position))
        if found is None:
            return None
        return lsp.Hover(contents=lsp.MarkupContent(kind=lsp.MarkupKind.Markdown,
                                                    value=found.markdown),
                         range=server.to_client(analysis.lines, found.range))

    @server.feature(lsp.TEXT_DOCUMENT_COMPLETION,
                    lsp.CompletionOptions(trigger_characters=TRIGGER_CHARACTERS))
    @_guarded(server)
    def completion(params: lsp.CompletionParams) -> lsp.CompletionList | None:
        analysis = server.analysis(params.text_document.uri)
        entries = features.completion(analysis, server.from_client(analysis, params.position))
        snippets = server.snippets_supported()
        items = []
        for entry in entries:
            snippet = entry.snippet and snippets
            items.append(lsp.CompletionItem(
                label=entry.label, kind=COMPLETION_KINDS.get(entry.kind),
                detail=entry.detail or None,
                documentation=lsp.MarkupContent(kind=lsp.MarkupKind.Markdown,
                                                value=entry.documentation)
                if entry.documentation else None,
                sort_text=f"{entry.sort_group}{entry.label.lower()}",
                insert_text=entry.insert_text if snippet else None,
                insert_text_format=lsp.InsertTextFormat.Snippet if snippet else None))
        return lsp.CompletionList(is_incomplete=False, items=items)

    @server.feature(lsp.TEXT_DOCUMENT_DEFINITION)
    @_guarded(server)
    def definition(params: lsp.DefinitionParams) -> list[lsp.Location] | None:
        uri = params.text_document.uri
        analysis = server.analysis(uri)
        found = features.definition(analysis, server.from_client(analysis, params.position))
        return [server.location(uri, analysis, where) for where in found] or None

    @server.feature(lsp.TEXT_DOCUMENT_CODE_LENS)
    @_guarded(server)
    def code_lens(params: lsp.CodeLensParams) -> list[lsp.CodeLens] | None:
        analysis = server.analysis(params.text_document.uri)
        # An empty command id: the lens is a label to read, not a button.
        return [lsp.CodeLens(range=server.to_client(analysis.lines, budget.range),
                             command=lsp.Command(title=budget.title, command=""))
                for budget in features.program_budgets(analysis)]

    @server.feature(lsp.TEXT_DOCUMENT_INLAY_HINT)
    @_guarded(server)
    def inlay_hint(params: lsp.InlayHintParams) -> list[lsp.InlayHint] | None:
        analysis = server.analysis(params.text_document.uri)
        first, last = params.range.start.line, params.range.end.line
        hints = []
        for budget in features.program_budgets(analysis):
            if first <= budget.range.end.line <= last:
                end = server.to_client(analysis.lines, budget.range).end
                hints.append(lsp.InlayHint(position=end, label=budget.title, padding_left=True))
        return hints

    register_editing(server, _guarded(server))
    register_navigation(server, _guarded(server))
    return server

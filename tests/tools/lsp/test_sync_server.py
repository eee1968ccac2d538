"""`mpc lsp` kept in step with a fast typist: batches of incremental changes, checks that wait
for a pause in the changes of a slow document, and never a stale diagnostic.

A real client drives a real server process over stdio. The server of this module is started
with a debounce that applies to every document (`debounce_above_s=0`) and a long pause, so
that bursts of changes are coalesced however fast the machine is; no assertion is timed.
"""

from __future__ import annotations

import asyncio
import gc
import random
import sys
import weakref
from collections.abc import AsyncIterator
from pathlib import Path

import pytest
import pytest_lsp
from lspedits import position, random_edit
from lsprotocol import types as lsp
from pytest_lsp import ClientServerConfig, LanguageClient
from sourceedits import SAMPLES, changed

from mplang.tools.lsp.server import FULL_COLLECTION_EVERY, create_server

ASYNC = pytest.mark.asyncio(loop_scope="module")
SERVER = [sys.executable, "-c", "from mplang.tools.lsp.server import create_server; "
          "create_server(debounce_above_s=0.0, debounce_s=0.3).start_io()"]
PUBLISHED: list[lsp.PublishDiagnosticsParams] = []


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("sync")
    (root / ".git").mkdir()
    return root


@pytest_lsp.fixture(scope="module", config=ClientServerConfig(server_command=SERVER))
async def client(lsp_client: LanguageClient, project: Path) -> AsyncIterator[None]:
    features = lsp_client.protocol.fm.features
    shown = features[lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS]

    def record(params: lsp.PublishDiagnosticsParams) -> None:  # every publish, in order
        PUBLISHED.append(params)
        shown(params)

    features[lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS] = record
    await lsp_client.initialize_session(lsp.InitializeParams(
        capabilities=pytest_lsp.client_capabilities("visual-studio-code"),
        root_uri=project.as_uri()))
    yield
    await lsp_client.shutdown_session()


async def published(uri: str, version: int) -> lsp.PublishDiagnosticsParams:
    """The diagnostics published for `version` of a document (fails after 60 s)."""
    for _ in range(1200):
        found = [p for p in PUBLISHED if p.uri == uri and p.version == version]
        if found:
            return found[-1]
        await asyncio.sleep(0.05)
    raise AssertionError(f"no diagnostics of version {version} of {uri}")


def change(uri: str, version: int, *changes: tuple[tuple[int, int], tuple[int, int], str]
           ) -> lsp.DidChangeTextDocumentParams:
    return lsp.DidChangeTextDocumentParams(
        text_document=lsp.VersionedTextDocumentIdentifier(uri=uri, version=version),
        content_changes=[lsp.TextDocumentContentChangePartial(
            range=lsp.Range(start=lsp.Position(line=start[0], character=start[1]),
                            end=lsp.Position(line=end[0], character=end[1])), text=text)
            for start, end, text in changes])


async def open_document(client: LanguageClient, uri: str, text: str) -> None:
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(
        uri=uri, language_id="mplang", version=1, text=text)))
    await published(uri, 1)


def shown(params: lsp.PublishDiagnosticsParams) -> list[tuple[str, int, int, str]]:
    return [(str(d.code), d.range.start.line, d.range.start.character,
             d.message.split("\n")[0]) for d in params.diagnostics]


@ASYNC
async def test_rapid_edits_publish_only_the_diagnostics_of_their_own_text(
        client: LanguageClient, project: Path) -> None:
    """Twenty edits in a burst, each naming a different unknown command: every publish is
    of a version the client sent and names that version's command (never an older text's),
    and the last publish is of the last version."""
    uri = (project / "burst.mp").as_uri()
    await open_document(client, uri, "MP 30 burst\n    NOPE1 X, 1\nEND MP\n")
    line = "    NOPE1 X, 1"
    for version in range(2, 22):
        new = f"    NOPE{version} X, 1"
        client.text_document_did_change(change(uri, version, ((1, 0), (1, len(line)), new)))
        line = new
    last = await published(uri, 21)
    assert shown(last) == [("E201", 1, 4, "unknown command 'NOPE21'")]
    ours = [p for p in PUBLISHED if p.uri == uri]
    assert ours[-1] is last
    versions = [p.version for p in ours]
    assert versions == sorted(versions)  # never an older version after a newer one
    for params in ours:
        assert shown(params) == [("E201", 1, 4, f"unknown command 'NOPE{params.version}'")]


@ASYNC
async def test_a_request_during_the_pause_answers_and_publishes_the_newest_text(
        client: LanguageClient, project: Path) -> None:
    """A request that arrives while the check waits for the pause runs the check first: the
    answer is of the edited text, and its diagnostics are published before the answer."""
    uri = (project / "asked.mp").as_uri()
    await open_document(client, uri, "MP 31 asked\n    SET_V X, 1\nEND MP\n")
    client.text_document_did_change(change(uri, 2, ((0, 0), (0, 0), "CONST FAST = 9\n"),
                                           ((2, 4), (2, 9), "SETV")))
    symbols = await client.text_document_document_symbol_async(lsp.DocumentSymbolParams(
        text_document=lsp.TextDocumentIdentifier(uri=uri)))
    assert symbols is not None
    assert "FAST" in {s.name for s in symbols if isinstance(s, lsp.DocumentSymbol)}
    current = [p for p in PUBLISHED if p.uri == uri and p.version == 2]
    assert current, "the request's check published the new version's diagnostics"
    assert [(c, line) for c, line, _, _ in shown(current[0])] == [("E201", 2)]


@ASYNC
async def test_a_batch_of_changes_applies_each_to_the_text_the_one_before_left(
        client: LanguageClient, project: Path) -> None:
    """Incremental sync: didChange messages of several range changes each (UTF-16 units, an
    emoji of two, CRLF, CR and LF line breaks, form feeds), every change's positions in the
    text the change before it left, as the protocol says. The diagnostics of the edited
    document equal those of one opened whole with the text the client holds."""
    base = "MP 32 batch\r\n    SET_V X, 100 # 😀 é\r\n    VAR1 = 1\nEND MP\n"
    rng = random.Random(28)
    uri = (project / "batch.mp").as_uri()
    await open_document(client, uri, base)
    text = base
    for version in range(2, 8):
        changes = []
        for _ in range(rng.randint(2, 5)):
            start, end, inserted, text = random_edit(text, rng)
            changes.append((start, end, inserted))
        client.text_document_did_change(change(uri, version, *changes))
    edited = await published(uri, 7)
    whole_uri = (project / "whole.mp").as_uri()
    await open_document(client, whole_uri, text)
    whole = await published(whole_uri, 1)
    assert [(c, line, character, m.replace("whole", "batch")) for c, line, character, m
            in shown(whole)] == shown(edited)


@ASYNC
async def test_an_emoji_before_an_error_counts_two_utf16_units(client: LanguageClient,
                                                                project: Path) -> None:
    """A change that puts a syntax error after an emoji (the slow path of the position
    conversion) and an unknown command on an ASCII line (the fast path): both placed as
    UTF-16 counts."""
    uri = (project / "emoji.mp").as_uri()
    text = "MP 33 emoji\n    SET_V X, 1\nEND MP\n"
    await open_document(client, uri, text)
    inserted = "    VAR2 = 1 # 😀\n    SET_V X, '😀' + (\n    NOPE2 Y, 2\n"
    client.text_document_did_change(change(uri, 2, ((2, 0), (2, 0), inserted)))
    text = text.replace("END MP", inserted + "END MP")
    edited = await published(uri, 2)
    assert [(c, line, character) for c, line, character, _ in shown(edited)
            if c.startswith("E")] == [
        ("E101", 3, position(text, text.index("(\n    NOPE2") + 1)[1]),
        ("E201", 4, position(text, text.index("NOPE2"))[1])]


@ASYNC
async def test_semantic_tokens_are_kept_per_analysis(client: LanguageClient,
                                                      project: Path) -> None:
    """Tokens asked twice of one analysis are the same; a delta against them after an edit
    gives the tokens a full request gives."""
    uri = (project / "tokens.mp").as_uri()
    await open_document(client, uri, "MP 34 tokens\n    SET_V X, 1 # 😀\nEND MP\n")
    ident = lsp.TextDocumentIdentifier(uri=uri)
    first = await client.text_document_semantic_tokens_full_async(
        lsp.SemanticTokensParams(text_document=ident))
    again = await client.text_document_semantic_tokens_full_async(
        lsp.SemanticTokensParams(text_document=ident))
    assert first is not None and again is not None and list(first.data) == list(again.data)
    client.text_document_did_change(change(uri, 2, ((1, 4), (1, 4), "CONST A = 1\n    ")))
    delta = await client.text_document_semantic_tokens_full_delta_async(
        lsp.SemanticTokensDeltaParams(text_document=ident,
                                      previous_result_id=again.result_id or ""))
    assert isinstance(delta, lsp.SemanticTokensDelta)
    data = list(again.data)
    for edit in delta.edits:
        data[edit.start:edit.start + edit.delete_count] = edit.data or []
    full = await client.text_document_semantic_tokens_full_async(
        lsp.SemanticTokensParams(text_document=ident))
    assert full is not None and data == list(full.data) != list(again.data)


def test_warm_up_freezes_the_start_up_heap() -> None:
    """After the server's warm-up check, what start-up built is out of the cycle
    collector's walks."""
    frozen = gc.get_freeze_count()
    try:
        create_server().warm_up()
        assert gc.get_freeze_count() > frozen
    finally:
        gc.unfreeze()


@ASYNC
async def test_a_diagnostic_kept_from_the_last_publish_follows_its_lines_text(
        client: LanguageClient, project: Path) -> None:
    """A character before a syntax error becomes an emoji: the same error at the same code
    point, but one UTF-16 unit further right, and published so."""
    uri = (project / "swap.mp").as_uri()
    line = "    SET_V X, 'a' + ("
    await open_document(client, uri, f"MP 35 swap\n{line}\nEND MP\n")
    before = [(c, n, character) for c, n, character, _ in shown(await published(uri, 1))
              if c == "E101"]
    assert before == [("E101", 1, len(line))]
    quote = line.index("a")
    client.text_document_did_change(change(uri, 2, ((1, quote), (1, quote + 1), "😀")))
    after = [(c, n, character) for c, n, character, _ in shown(await published(uri, 2))
             if c == "E101"]
    assert after == [("E101", 1, len(line) + 1)]


@ASYNC
async def test_edits_publish_what_the_same_text_opened_afresh_publishes(
        client: LanguageClient, project: Path) -> None:
    """The server keeps each document's programs between checks (`mplang.ir.reuse`): after
    edits of one program, of another, of a CONST every program reads, and a syntax error,
    the diagnostics equal those of a new document opened with the same text."""
    uri = (project / "kept.mp").as_uri()
    lines = ["CONST FAST = 300000", "MP 36 first", "    SET_V X, FAST", "    VAR7 = VAR8",
             "END MP", "MP 37 second", "    SET_ACC X, 123457", "END MP", ""]
    await open_document(client, uri, "\n".join(lines))
    edits = [(3, "    VAR7 = VAR9"), (6, "    SET_ACC X, 123458"), (0, "CONST FAST = 300001"),
             (3, "    VAR7 = (1 +")]
    for version, (row, new) in enumerate(edits, start=2):
        client.text_document_did_change(change(uri, version, ((row, 0), (row, len(lines[row])),
                                                              new)))
        lines[row] = new
        kept = await published(uri, version)
        fresh = (project / f"fresh{version}.mp").as_uri()
        await open_document(client, fresh, "\n".join(lines))
        assert kept.diagnostics and \
            kept.diagnostics == (await published(fresh, 1)).diagnostics


def test_the_cycle_collector_waits_while_a_check_runs(tmp_path: Path) -> None:
    """A check of a 300-line program allocates far more than a collection's threshold; no
    collection runs until it is done, and the collector is on again after it."""
    path = tmp_path / "long.mp"
    path.write_text("MP 1 long\n" + "    VAR1 = VAR1 + 1\n" * 300 + "END MP\n")
    server = create_server()
    initialize = server.protocol.lsp_initialize(lsp.InitializeParams(
        capabilities=lsp.ClientCapabilities(), root_uri=tmp_path.as_uri()))
    list(initialize)  # the protocol's own initialize, as a client's request runs it
    phases: list[str] = []

    def seen(phase: str, info: dict[str, int]) -> None:
        phases.append(phase)

    gc.callbacks.append(seen)
    try:
        server.check(path.as_uri())
    finally:
        gc.callbacks.remove(seen)
    assert phases == [] and gc.isenabled()


class _Cyclic:
    """An object in a reference cycle with itself: only the cycle collector frees it."""

    def __init__(self) -> None:
        self.me = self


def test_a_check_freezes_what_it_kept_and_a_full_collection_frees_cycles_later(
        tmp_path: Path) -> None:
    """After a check, what is alive is out of the collector's walks; cyclic garbage frozen
    with it is freed by the full collection every FULL_COLLECTION_EVERY checks."""
    path = tmp_path / "short.mp"
    path.write_text("MP 1 short\n    VAR1 = VAR1 + 1\nEND MP\n")
    server = create_server()
    list(server.protocol.lsp_initialize(lsp.InitializeParams(
        capabilities=lsp.ClientCapabilities(), root_uri=tmp_path.as_uri())))
    try:
        garbage = weakref.ref(_Cyclic())  # unreachable at once: only a collection frees it
        frozen = gc.get_freeze_count()
        server.check(path.as_uri())
        assert gc.get_freeze_count() > frozen and gc.isenabled()
        server.checks_done = FULL_COLLECTION_EVERY - 1
        server.check(path.as_uri())
        assert garbage() is None and gc.get_freeze_count() > 0 and gc.isenabled()
    finally:
        gc.unfreeze()


@ASYNC
async def test_programs_moved_by_inserted_and_deleted_lines_publish_as_a_fresh_open(
        client: LanguageClient, project: Path) -> None:
    """Lines inserted and deleted above programs move them: their diagnostics are moved
    from the last publish (placement and JSON text), and equal, in full, those of the same
    text opened whole."""
    text = "".join(f"MP {n} moved{n}\n    SET_V X, 70001 # é\n    NOPE{n} X\nEND MP\n"
                   for n in (41, 42, 43))
    uri = (project / "moving.mp").as_uri()
    await open_document(client, uri, text)
    edits = (((0, 0), (0, 0), "# two lines\n# more\n"), ((0, 0), (1, 0), ""),
             ((3, 0), (3, 0), "    VAR1 = 1\n"), ((0, 0), (1, 0), ""))
    for version, (start, end, inserted) in enumerate(edits, start=2):
        client.text_document_did_change(change(uri, version, (start, end, inserted)))
        lines = text.split("\n")
        lines[start[0]:end[0]] = inserted.split("\n")[:-1]
        text = "\n".join(lines)
        edited = await published(uri, version)
        whole_uri = (project / f"moving-whole-{version}.mp").as_uri()
        await open_document(client, whole_uri, text)
        whole = await published(whole_uri, 1)
        assert edited.diagnostics == whole.diagnostics
        assert [d.code for d in edited.diagnostics].count("W111") == 3


def _line_change(before: list[str], after: list[str]
                 ) -> tuple[tuple[int, int], tuple[int, int], str]:
    """The range edit an editor sends for a change of lines: what lies between the text the
    two versions share at the start and at the end, replaced."""
    old, new = "\n".join(before), "\n".join(after)
    head = 0
    while head < min(len(old), len(new)) and old[head] == new[head]:
        head += 1
    tail = 0
    while tail < min(len(old), len(new)) - head and old[-1 - tail] == new[-1 - tail]:
        tail += 1
    return position(old, head), position(old, len(old) - tail), new[head:len(new) - tail]


@ASYNC
@pytest.mark.parametrize("seed", range(4))
async def test_random_bursts_of_edits_publish_what_a_fresh_open_publishes(
        client: LanguageClient, project: Path, seed: int) -> None:
    """Bursts of random edits of a sample (digits, lines from other files, lines dropped,
    inserted and swapped), sent faster than the server's pause: the last version's
    diagnostics, published once its burst is checked, equal those of its text opened
    afresh, and no publish is of a version older than one already published."""
    rng = random.Random(seed)
    sample = rng.choice(SAMPLES)
    lines = sample.read_text(encoding="utf-8").split("\n")
    uri = (project / f"random{seed}.mp").as_uri()
    await open_document(client, uri, "\n".join(lines))
    version = 1
    for burst in range(3):
        for _ in range(rng.randint(1, 5)):
            after = changed(lines, (rng.randint(0, 5), rng.randint(0, 5_000),
                                    rng.randint(0, 5_000)))
            version += 1
            client.text_document_did_change(change(uri, version, _line_change(lines, after)))
            lines = after
        kept = await published(uri, version)
        fresh = (project / f"random{seed}-fresh{burst}.mp").as_uri()
        await open_document(client, fresh, "\n".join(lines))
        assert kept.diagnostics == (await published(fresh, 1)).diagnostics
    versions = [p.version for p in PUBLISHED if p.uri == uri]
    assert versions == sorted(versions) and versions[-1] == version


@ASYNC
async def test_edits_of_a_middle_program_publish_as_a_fresh_open(client: LanguageClient,
                                                                project: Path) -> None:
    """The publish takes the JSON text of the diagnostics before and after the ones an edit
    changed from the last publish: edits of the middle of three programs that add, drop and
    change its diagnostics (their count changing too) publish, in full and in order, what
    the same text opened afresh publishes."""
    lines = [line for n in (51, 52, 53) for line in (
        f"MP {n} middle{n}", "    SET_V X, 70001", f"    NOPE{n} X", "END MP")]
    uri = (project / "middle.mp").as_uri()
    await open_document(client, uri, "\n".join(lines))
    edits = [(6, "    NOPE52 X\n    NOPE99 Y"), (5, "    SET_V X, 1000"),
             (6, "    VAR1 = 1"), (5, "    SET_V X, 70003 + (")]
    for version, (row, new) in enumerate(edits, start=2):
        client.text_document_did_change(change(uri, version, ((row, 0), (row, len(lines[row])),
                                                              new)))
        lines[row:row + 1] = new.split("\n")
        kept = await published(uri, version)
        fresh = (project / f"middle-fresh{version}.mp").as_uri()
        await open_document(client, fresh, "\n".join(lines))
        fresh_diagnostics = (await published(fresh, 1)).diagnostics
        assert kept.diagnostics == fresh_diagnostics
        assert {d.range.start.line for d in kept.diagnostics} >= {2, len(lines) - 2}

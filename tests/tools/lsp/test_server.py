"""`mpc lsp` end to end: a client starts `python -m mplang lsp`, speaks JSON-RPC over its
stdio, opens a document with errors and asks what an editor asks.

One server serves the whole module; the tests run in file order on the same open document.
"""

from __future__ import annotations

import asyncio
import sys
from collections.abc import AsyncIterator
from pathlib import Path

import pytest
import pytest_asyncio
import pytest_lsp
from lsprotocol import types as lsp
from pytest_lsp import ClientServerConfig, LanguageClient

from mplang.tools.lsp.server import MpLanguageServer, create_server

ASYNC = pytest.mark.asyncio(loop_scope="module")

COMMON = "CONST SPEED = 2000\n"
# Line 5 misspells a command, line 9 is a syntax error; the emoji on line 8 takes two UTF-16
# units, so the error after it tests the position encoding.
MAIN = """INCLUDE "common.mp"
ALIAS count = VAR1

MP 21 main
    FIXD_MOVE X, 1000
    LABEL top
    count = count + 1
    VAR_CALCULATE VAR2, '😀', VAR3, VAR4
    FOR 3 (
    NEXT
    GOTO top
    CALL helper
END MP

MP helper
    SET_V XY, SPEED
END MP
"""
LINES = MAIN.split("\n")


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("lsp")
    (root / ".git").mkdir()
    (root / "common.mp").write_text(COMMON)
    return root


@pytest_lsp.fixture(scope="module", config=ClientServerConfig(
    server_command=[sys.executable, "-m", "mplang", "lsp"]))
async def client(lsp_client: LanguageClient, project: Path) -> AsyncIterator[None]:
    await lsp_client.initialize_session(lsp.InitializeParams(
        capabilities=pytest_lsp.client_capabilities("visual-studio-code"),
        root_uri=project.as_uri()))
    yield
    await lsp_client.shutdown_session()


@pytest_asyncio.fixture(scope="module", loop_scope="module")
async def opened(client: LanguageClient, project: Path) -> str:
    """The document with errors, opened in the editor (not saved to disk)."""
    uri = (project / "main.mp").as_uri()
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(
        uri=uri, language_id="mplang", version=1, text=MAIN)))
    await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    return uri


def at(line: int, word: str, offset: int = 1) -> lsp.Position:
    return lsp.Position(line=line, character=LINES[line].index(word) + offset)


def ident(uri: str) -> lsp.TextDocumentIdentifier:
    return lsp.TextDocumentIdentifier(uri=uri)


@ASYNC
async def test_diagnostics_carry_codes_ranges_and_hints(client: LanguageClient,
                                                         opened: str) -> None:
    diagnostics = {d.code: d for d in client.diagnostics[opened]}
    assert {"E201", "E101", "E424", "W103"} <= set(diagnostics)
    unknown = diagnostics["E201"]
    # mpc reports main.mp:5:5 (1-based); LSP counts from 0.
    assert unknown.range == lsp.Range(start=lsp.Position(line=4, character=4),
                                      end=lsp.Position(line=4, character=13))
    assert unknown.severity == lsp.DiagnosticSeverity.Error
    assert unknown.source == "mpc"
    assert unknown.message == "unknown command 'FIXD_MOVE'\nhint: did you mean FIXED_MOVE?"
    assert unknown.code_description is not None
    assert unknown.code_description.href.endswith("/docs/checks/E201.md")
    assert diagnostics["W103"].severity == lsp.DiagnosticSeverity.Warning
    assert diagnostics["E101"].range.start.line == 8


@ASYNC
async def test_positions_count_utf16_code_units(client: LanguageClient, opened: str) -> None:
    (operator,) = [d for d in client.diagnostics[opened] if d.code == "E424"]
    start = LINES[7].index("'")
    # '😀' is three code points and four UTF-16 units.
    assert operator.range.start == lsp.Position(line=7, character=start)
    assert operator.range.end == lsp.Position(line=7, character=start + 4)


@ASYNC
async def test_hover_on_a_command_shows_the_catalogue(client: LanguageClient,
                                                      opened: str) -> None:
    result = await client.text_document_hover_async(lsp.HoverParams(
        text_document=ident(opened), position=at(15, "SET_V")))
    assert result is not None and isinstance(result.contents, lsp.MarkupContent)
    text = result.contents.value
    assert text.startswith("**SET_V** (RSM_MACRO_SET_V / ETM_MACRO_SET_V)")
    assert "- Scope: MP, ISR" in text and "- Line cost: 1 macro line" in text
    assert "- Manual: section 7.1.3" in text
    assert result.range == lsp.Range(start=lsp.Position(line=15, character=4),
                                     end=lsp.Position(line=15, character=9))


@ASYNC
async def test_hover_on_a_constant_from_an_include(client: LanguageClient, opened: str) -> None:
    result = await client.text_document_hover_async(lsp.HoverParams(
        text_document=ident(opened), position=at(15, "SPEED")))
    assert result is not None and isinstance(result.contents, lsp.MarkupContent)
    assert result.contents.value.startswith("**CONST SPEED** = 2,000")


@ASYNC
async def test_completion_after_goto_call_and_at_a_statement(client: LanguageClient,
                                                             opened: str) -> None:
    async def labels_at(position: lsp.Position) -> dict[str, lsp.CompletionItem]:
        result = await client.text_document_completion_async(lsp.CompletionParams(
            text_document=ident(opened), position=position))
        assert isinstance(result, lsp.CompletionList)
        return {item.label: item for item in result.items}

    assert set(await labels_at(at(10, "top", 0))) == {"top"}
    assert {"helper", "main", "MP21"} <= set(await labels_at(at(11, "helper", 0)))
    statements = await labels_at(lsp.Position(line=15, character=4))
    fixed = statements["FIXED_MOVE"]
    assert fixed.insert_text == "FIXED_MOVE ${1:axis}, ${2:data}"
    assert fixed.insert_text_format == lsp.InsertTextFormat.Snippet
    assert fixed.kind == lsp.CompletionItemKind.Function
    assert {"FOR", "END MP", "count"} <= set(statements)
    axes = await labels_at(at(15, "XY", 0))
    assert {"X", "XY", "XYZU"} <= set(axes)


@ASYNC
async def test_definition_across_files_labels_and_calls(client: LanguageClient, opened: str,
                                                        project: Path) -> None:
    async def where(position: lsp.Position) -> lsp.Location:
        result = await client.text_document_definition_async(lsp.DefinitionParams(
            text_document=ident(opened), position=position))
        assert isinstance(result, list) and len(result) == 1
        (location,) = result
        assert isinstance(location, lsp.Location)
        return location

    speed = await where(at(15, "SPEED"))
    assert speed.uri == (project / "common.mp").as_uri()
    assert speed.range.start == lsp.Position(line=0, character=6)
    label = await where(at(10, "top"))
    assert label.uri == opened and label.range.start == lsp.Position(line=5, character=10)
    called = await where(at(11, "helper"))
    assert called.range.start == lsp.Position(line=14, character=3)
    alias = await where(at(6, "count + 1"))
    assert alias.range.start == lsp.Position(line=1, character=6)


@ASYNC
async def test_program_headers_show_lines_used_against_the_budget(client: LanguageClient,
                                                                  opened: str) -> None:
    lenses = await client.text_document_code_lens_async(lsp.CodeLensParams(
        text_document=ident(opened)))
    assert lenses is not None
    titles = [(lens.range.start.line, lens.command.title if lens.command else "")
              for lens in lenses]
    assert titles == [(3, "MP21: 7/8 lines"), (14, "MP1: 2/8 lines (auto-placed)")]
    hints = await client.text_document_inlay_hint_async(lsp.InlayHintParams(
        text_document=ident(opened), range=lsp.Range(start=lsp.Position(line=0, character=0),
                                                      end=lsp.Position(line=20, character=0))))
    assert hints is not None
    assert [(h.position, h.label) for h in hints] == [
        (lsp.Position(line=3, character=10), "MP21: 7/8 lines"),
        (lsp.Position(line=14, character=9), "MP1: 2/8 lines (auto-placed)")]


@ASYNC
async def test_requests_that_fit_no_document_answer_nothing(client: LanguageClient,
                                                            opened: str) -> None:
    nowhere = await client.text_document_hover_async(lsp.HoverParams(
        text_document=ident(opened), position=lsp.Position(line=500, character=3)))
    assert nowhere is None
    comment = await client.text_document_completion_async(lsp.CompletionParams(
        text_document=ident(opened), position=lsp.Position(line=2, character=0)))
    assert isinstance(comment, lsp.CompletionList)


@ASYNC
async def test_editing_the_document_updates_the_diagnostics(client: LanguageClient,
                                                            opened: str) -> None:
    fixed = MAIN.replace("FIXD_MOVE", "FIXED_MOVE").replace("    FOR 3 (\n    NEXT\n", "")
    fixed = fixed.replace("'😀'", "'+'")
    client.text_document_did_change(lsp.DidChangeTextDocumentParams(
        text_document=lsp.VersionedTextDocumentIdentifier(uri=opened, version=2),
        content_changes=[lsp.TextDocumentContentChangeWholeDocument(text=fixed)]))
    await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    # The errors are gone; the warnings (unreachable CALL after GOTO, VAR1 read before it is
    # written) stay.
    assert {d.code for d in client.diagnostics[opened]} == {"W101", "W103"}


@ASYNC
async def test_editing_an_included_file_rechecks_the_files_that_include_it(
        client: LanguageClient, opened: str, project: Path) -> None:
    common = (project / "common.mp").as_uri()
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(
        uri=common, language_id="mplang", version=1,
        text="CONST SPEED = 2000\nCONST SPEED = 1\n")))
    for _ in range(200):
        if any(d.code == "E203" for d in client.diagnostics.get(opened, [])):
            break
        await asyncio.sleep(0.05)
    (duplicate,) = [d for d in client.diagnostics[opened] if d.code == "E203"]
    assert duplicate.range.start.line == 0  # on the INCLUDE line
    assert "common.mp:2:7: 'SPEED' is already defined" in duplicate.message
    assert [d.code for d in client.diagnostics[common]] == ["E203"]

@ASYNC
async def test_an_unsaved_buffer_is_checked_too(client: LanguageClient) -> None:
    uri = "untitled:Untitled-1"
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(
        uri=uri, language_id="mplang", version=1, text="MP 1\n    SET_V Q, 1\nEND MP\n")))
    await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    assert [d.code for d in client.diagnostics[uri]] == ["E202"]  # unknown name Q


@ASYNC
async def test_uris_keep_the_clients_spelling(client: LanguageClient, project: Path) -> None:
    folder = project / "with space"
    folder.mkdir()
    included, main = (folder / "inc.mp").as_uri(), (folder / "main.mp").as_uri()
    assert "%20" in main
    for uri, text in ((included, "CONST Q = 1000\n"),
                      (main, 'INCLUDE "inc.mp"\nMP 2\n    SET_V X, Q\nEND MP\n')):
        client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(
            uri=uri, language_id="mplang", version=1, text=text)))
        await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    assert list(client.diagnostics[main]) == []
    result = await client.text_document_definition_async(lsp.DefinitionParams(
        text_document=ident(main), position=lsp.Position(line=2, character=14)))
    assert isinstance(result, list) and [loc.uri for loc in result] == [included]  # type: ignore[union-attr]

@ASYNC
async def test_a_failing_request_is_logged_and_answered_with_nothing(
        client: LanguageClient, opened: str) -> None:
    missing = lsp.TextDocumentIdentifier(uri="file:///no/such/dir/x.mp")
    result = await client.text_document_hover_async(lsp.HoverParams(
        text_document=missing, position=lsp.Position(line=0, character=0)))
    assert result is None
    assert any("hover failed: FileNotFoundError" in m.message for m in client.log_messages)
    still = await client.text_document_hover_async(lsp.HoverParams(
        text_document=ident(opened), position=at(1, "count")))
    assert still is not None


def test_document_paths_of_files_and_unsaved_buffers(tmp_path: Path) -> None:
    assert MpLanguageServer.document_path((tmp_path / "a b.mp").as_uri()) == tmp_path / "a b.mp"
    assert MpLanguageServer.document_path("untitled:Untitled-1") == Path.cwd() / "Untitled-1"


def test_every_feature_is_registered() -> None:
    registered = set(create_server().protocol.fm.features)
    assert {lsp.TEXT_DOCUMENT_DID_OPEN, lsp.TEXT_DOCUMENT_DID_CHANGE, lsp.TEXT_DOCUMENT_HOVER,
            lsp.TEXT_DOCUMENT_COMPLETION, lsp.TEXT_DOCUMENT_DEFINITION,
            lsp.TEXT_DOCUMENT_CODE_LENS, lsp.TEXT_DOCUMENT_INLAY_HINT} <= registered

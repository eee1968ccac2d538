"""`mpc lsp --stdio` end to end for the third round's editor features (issue 26 item 3), with
Neovim's client capabilities: document links on INCLUDE (std: files too), the call hierarchy
over CALL and MP_CALL, document highlights, pull diagnostics beside push, incremental sync,
and the `source.fixAll.mpc` code action.

One server serves the module; the tests that change a document come last.
"""

from __future__ import annotations

import random
import sys
from collections.abc import AsyncIterator
from pathlib import Path

import pytest
import pytest_asyncio
import pytest_lsp
from lspedits import random_edit
from lsprotocol import types as lsp
from pytest_lsp import ClientServerConfig, LanguageClient

from mplang.lang.sources import library_files

ASYNC = pytest.mark.asyncio(loop_scope="module")

COMMON = """CONST SPEED = 2000
CONST STD_ESTOP_DO_GROUP = 0
CONST STD_ESTOP_DO_SAFE = 0

MP shared_home
    SET_V X, SPEED
END MP
"""
MAIN = """INCLUDE "lib/common.mp"
INCLUDE "std:estop.mp"
VAR total

MP 60 cycle
    total = 0
    CALL prepare
    CALL shared_home
    LABEL again
    total = total + 1
    CALL prepare
    IF total < 3
        GOTO again
    END IF
    MP_CALL MP21
END MP

MP prepare
    SET_V X, SPEED
    CALL MP21
END MP

MP 21 outputs_off
    FIXD_MOVE X, 0
END MP
"""
LINES = MAIN.split("\n")
INITIALIZED: list[lsp.InitializeResult] = []


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("lsp-navigation")
    (root / "lib").mkdir()
    (root / "lib" / "common.mp").write_text(COMMON)
    (root / "main.mp").write_text(MAIN)
    (root / "mpc.toml").write_text('[project]\nsources = ["main.mp"]\n')
    return root


@pytest_lsp.fixture(scope="module", config=ClientServerConfig(
    server_command=[sys.executable, "-m", "mplang", "lsp", "--stdio"]))
async def client(lsp_client: LanguageClient, project: Path) -> AsyncIterator[None]:
    INITIALIZED.append(await lsp_client.initialize_session(lsp.InitializeParams(
        capabilities=pytest_lsp.client_capabilities("neovim"), root_uri=project.as_uri())))
    yield
    await lsp_client.shutdown_session()


async def open_document(client: LanguageClient, uri: str, text: str) -> None:
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(
        uri=uri, language_id="mplang", version=1, text=text)))
    await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)


@pytest_asyncio.fixture(scope="module", loop_scope="module")
async def opened(client: LanguageClient, project: Path) -> str:
    uri = (project / "main.mp").as_uri()
    await open_document(client, uri, MAIN)
    return uri


def ident(uri: str) -> lsp.TextDocumentIdentifier:
    return lsp.TextDocumentIdentifier(uri=uri)


def at(line: int, word: str, offset: int = 1) -> lsp.Position:
    return lsp.Position(line=line, character=LINES[line].index(word) + offset)


def word_range(line: int, word: str) -> lsp.Range:
    start = LINES[line].index(word)
    return lsp.Range(start=lsp.Position(line=line, character=start),
                     end=lsp.Position(line=line, character=start + len(word)))


@ASYNC
async def test_capabilities_advertise_the_new_features(client: LanguageClient,
                                                       opened: str) -> None:
    capabilities = INITIALIZED[-1].capabilities
    assert capabilities.document_link_provider is not None
    assert capabilities.call_hierarchy_provider
    assert capabilities.document_highlight_provider
    assert isinstance(capabilities.diagnostic_provider, lsp.DiagnosticOptions)
    assert capabilities.diagnostic_provider.inter_file_dependencies
    sync = capabilities.text_document_sync
    assert isinstance(sync, lsp.TextDocumentSyncOptions)
    assert sync.change == lsp.TextDocumentSyncKind.Incremental


@ASYNC
async def test_document_links_open_the_included_files(client: LanguageClient, opened: str,
                                                      project: Path) -> None:
    links = await client.text_document_document_link_async(
        lsp.DocumentLinkParams(text_document=ident(opened)))
    assert links is not None and len(links) == 2
    local, library = links
    assert local.range == word_range(0, '"lib/common.mp"')
    assert local.target == (project / "lib" / "common.mp").resolve().as_uri()
    assert library.range == word_range(1, '"std:estop.mp"')
    shipped = Path(str(library_files()["estop.mp"])).resolve()
    assert library.target == shipped.as_uri() and shipped.is_file()


@ASYNC
async def test_call_hierarchy_follows_call_and_mp_call(client: LanguageClient, opened: str,
                                                       project: Path) -> None:
    items = await client.text_document_prepare_call_hierarchy_async(
        lsp.CallHierarchyPrepareParams(text_document=ident(opened), position=at(4, "cycle")))
    assert items is not None
    (cycle,) = items
    assert cycle.name == "cycle" and cycle.selection_range == word_range(4, "cycle")
    assert cycle.detail == "MP60: 11/16 lines"  # the code lens's budget
    outgoing = await client.call_hierarchy_outgoing_calls_async(
        lsp.CallHierarchyOutgoingCallsParams(item=cycle))
    assert outgoing is not None
    called = {call.to.name: list(call.from_ranges) for call in outgoing}
    assert called == {
        "prepare": [word_range(6, "prepare"), word_range(10, "prepare")],
        "shared_home": [word_range(7, "shared_home")],
        "outputs_off": [word_range(14, "MP21")],  # MP_CALL by slot number
    }
    home = next(call.to for call in outgoing if call.to.name == "shared_home")
    assert home.uri == (project / "lib" / "common.mp").resolve().as_uri()
    # from a CALL's target: the program it names, and who calls it
    items = await client.text_document_prepare_call_hierarchy_async(
        lsp.CallHierarchyPrepareParams(text_document=ident(opened), position=at(19, "MP21")))
    assert items is not None and [i.name for i in items] == ["outputs_off"]
    incoming = await client.call_hierarchy_incoming_calls_async(
        lsp.CallHierarchyIncomingCallsParams(item=items[0]))
    assert incoming is not None
    assert {call.from_.name: list(call.from_ranges) for call in incoming} == {
        "cycle": [word_range(14, "MP21")], "prepare": [word_range(19, "MP21")]}
    # a program nothing calls has no incoming calls; one in another file is found too
    assert not await client.call_hierarchy_incoming_calls_async(
        lsp.CallHierarchyIncomingCallsParams(item=cycle))
    incoming = await client.call_hierarchy_incoming_calls_async(
        lsp.CallHierarchyIncomingCallsParams(item=home))
    assert incoming is not None and [c.from_.name for c in incoming] == ["cycle"]


@ASYNC
async def test_document_highlight_marks_the_definition_and_the_uses(
        client: LanguageClient, opened: str) -> None:
    found = await client.text_document_document_highlight_async(
        lsp.DocumentHighlightParams(text_document=ident(opened), position=at(9, "total")))
    assert found is not None
    marks = sorted((h.range.start.line, h.range.start.character, h.kind) for h in found)
    written = lsp.DocumentHighlightKind.Write
    read = lsp.DocumentHighlightKind.Read
    assert marks == [(2, 4, written), (5, 4, read), (9, 4, read), (9, 12, read),
                     (11, 7, read)]
    labels = await client.text_document_document_highlight_async(
        lsp.DocumentHighlightParams(text_document=ident(opened), position=at(12, "again")))
    assert labels is not None
    assert sorted(h.range.start.line for h in labels) == [8, 12]
    nothing = await client.text_document_document_highlight_async(
        lsp.DocumentHighlightParams(text_document=ident(opened),
                                    position=lsp.Position(line=3, character=0)))
    assert not nothing


@ASYNC
async def test_pull_diagnostics_answer_what_push_publishes(client: LanguageClient,
                                                           opened: str) -> None:
    report = await client.text_document_diagnostic_async(
        lsp.DocumentDiagnosticParams(text_document=ident(opened)))
    assert isinstance(report, lsp.RelatedFullDocumentDiagnosticReport)
    (typo,) = [d for d in report.items if d.code == "E201"]
    assert typo.range == word_range(23, "FIXD_MOVE") and typo.source == "mpc"
    pushed = client.diagnostics[opened]
    assert [(d.code, d.range) for d in pushed] == [(d.code, d.range) for d in report.items]


@ASYNC
async def test_fix_all_applies_every_preferred_fix(client: LanguageClient,
                                                   opened: str) -> None:
    actions = await client.text_document_code_action_async(lsp.CodeActionParams(
        text_document=ident(opened), range=word_range(0, "INCLUDE"),
        context=lsp.CodeActionContext(diagnostics=[], only=[lsp.CodeActionKind.SourceFixAll])))
    assert actions is not None
    (fix_all,) = actions
    assert isinstance(fix_all, lsp.CodeAction) and fix_all.kind == "source.fixAll.mpc"
    assert fix_all.edit is not None and fix_all.edit.changes is not None
    (edit,) = fix_all.edit.changes[opened]
    assert edit.new_text == MAIN.replace("FIXD_MOVE", "FIXED_MOVE")
    quick_only = await client.text_document_code_action_async(lsp.CodeActionParams(
        text_document=ident(opened), range=word_range(0, "INCLUDE"),
        context=lsp.CodeActionContext(diagnostics=[], only=[lsp.CodeActionKind.QuickFix])))
    assert not [a for a in quick_only or [] if isinstance(a, lsp.CodeAction)
                and a.kind == "source.fixAll.mpc"]


@ASYNC
async def test_incremental_edits_leave_the_server_with_the_editors_text(
        client: LanguageClient, project: Path) -> None:
    """Random range edits (in the negotiated encoding, CRLF/LF/CR, form feeds, U+2028) sent one
    change at a time; the server's diagnostics of the result equal those of a document
    opened with the same text in one piece."""
    base = "MP 30 edited\n    SET_V X, 100\n    VAR1 = 1\nEND MP\n"
    encoding = str(INITIALIZED[-1].capabilities.position_encoding or "utf-16")
    rng = random.Random(26)
    for round_number in range(6):
        uri = (project / f"edited{round_number}.mp").as_uri()
        await open_document(client, uri, base)
        text = base
        for version in range(2, 14):
            start, end, inserted, text = random_edit(text, rng, encoding)
            client.text_document_did_change(lsp.DidChangeTextDocumentParams(
                text_document=lsp.VersionedTextDocumentIdentifier(uri=uri, version=version),
                content_changes=[lsp.TextDocumentContentChangePartial(
                    range=lsp.Range(start=lsp.Position(line=start[0], character=start[1]),
                                    end=lsp.Position(line=end[0], character=end[1])),
                    text=inserted)]))
        whole_uri = (project / f"whole{round_number}.mp").as_uri()
        await open_document(client, whole_uri, text)
        edited, whole = [await client.text_document_diagnostic_async(
            lsp.DocumentDiagnosticParams(text_document=ident(u))) for u in (uri, whole_uri)]
        assert isinstance(edited, lsp.RelatedFullDocumentDiagnosticReport)
        assert isinstance(whole, lsp.RelatedFullDocumentDiagnosticReport)
        assert [(d.code, d.range, d.message.replace("whole", "edited")) for d in edited.items] \
            == [(d.code, d.range, d.message.replace("whole", "edited")) for d in whole.items]
        formatted = await client.text_document_formatting_async(lsp.DocumentFormattingParams(
            text_document=ident(uri), options=lsp.FormattingOptions(tab_size=4,
                                                                   insert_spaces=True)))
        again = await client.text_document_formatting_async(lsp.DocumentFormattingParams(
            text_document=ident(whole_uri), options=lsp.FormattingOptions(
                tab_size=4, insert_spaces=True)))
        assert formatted == again

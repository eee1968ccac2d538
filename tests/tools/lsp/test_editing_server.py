"""`mpc lsp --stdio` end to end for the editing and navigation features (issue 15 item 4):
a client with Neovim's capabilities starts the server the way Neovim and Helix do, opens a
project document and asks for formatting, code actions, symbols, folding, semantic tokens,
references, rename and signature help.

One server serves the module; the tests that change the document come last.
"""

from __future__ import annotations

import sys
from collections.abc import AsyncIterator
from pathlib import Path

import pytest
import pytest_asyncio
import pytest_lsp
from lsprotocol import types as lsp
from pygls.exceptions import JsonRpcException
from pytest_lsp import ClientServerConfig, LanguageClient

ASYNC = pytest.mark.asyncio(loop_scope="module")

COMMON = "CONST SPEED = 2000\n"
MAIN = """INCLUDE "common.mp"
ALIAS count = VAR1
VAR total
# the main program
# counts and moves

MP 50 main
    FIXD_MOVE X, SPEED
    LABEL top
    count = count + 1
    FOR 3
        IF count > 2
            total = total + SPEDD
        END IF
    NEXT
    GOTO top
    CALL helper
END MP

MP helper
  SET_V XY,   SPEED
END MP

INIT
    SET_MAX_V X, 200000
END INIT
"""
LINES = MAIN.split("\n")
INITIALIZED: list[lsp.InitializeResult] = []  # the server's answer to initialize


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("lsp-editing")
    (root / "common.mp").write_text(COMMON)
    (root / "main.mp").write_text(MAIN)  # the project lists it; the editor's text is checked
    (root / "mpc.toml").write_text('[project]\nsources = ["main.mp"]\n\n[fmt]\nindent = 2\n')
    return root


@pytest_lsp.fixture(scope="module", config=ClientServerConfig(
    server_command=[sys.executable, "-m", "mplang", "lsp", "--stdio"]))
async def client(lsp_client: LanguageClient, project: Path) -> AsyncIterator[None]:
    INITIALIZED.append(await lsp_client.initialize_session(lsp.InitializeParams(
        capabilities=pytest_lsp.client_capabilities("neovim"), root_uri=project.as_uri())))
    yield
    await lsp_client.shutdown_session()


@pytest_asyncio.fixture(scope="module", loop_scope="module")
async def opened(client: LanguageClient, project: Path) -> str:
    uri = (project / "main.mp").as_uri()
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(
        uri=uri, language_id="mplang", version=1, text=MAIN)))
    await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    return uri


def ident(uri: str) -> lsp.TextDocumentIdentifier:
    return lsp.TextDocumentIdentifier(uri=uri)


def at(line: int, word: str, offset: int = 1) -> lsp.Position:
    return lsp.Position(line=line, character=LINES[line].index(word) + offset)


def whole(line: int) -> lsp.Range:
    return lsp.Range(start=lsp.Position(line=line, character=0),
                     end=lsp.Position(line=line, character=len(LINES[line])))


def apply(text: str, edits: list[lsp.TextEdit]) -> str:
    """Apply edits as an editor does (ASCII text: characters are UTF-16 units)."""
    lines = text.splitlines(keepends=True)
    starts = [0]
    for line in lines:
        starts.append(starts[-1] + len(line))

    def offset(position: lsp.Position) -> int:
        return starts[position.line] + position.character if position.line < len(lines) \
            else len(text)

    for edit in sorted(edits, key=lambda e: (e.range.start.line, e.range.start.character),
                       reverse=True):
        text = text[:offset(edit.range.start)] + edit.new_text + text[offset(edit.range.end):]
    return text


@ASYNC
async def test_capabilities_advertise_what_the_server_answers(
        client: LanguageClient, opened: str) -> None:
    capabilities = INITIALIZED[-1].capabilities
    assert capabilities.document_formatting_provider
    assert capabilities.document_range_formatting_provider
    assert capabilities.document_symbol_provider and capabilities.workspace_symbol_provider
    assert capabilities.folding_range_provider and capabilities.references_provider
    assert isinstance(capabilities.rename_provider, lsp.RenameOptions)
    assert capabilities.rename_provider.prepare_provider
    assert isinstance(capabilities.code_action_provider, lsp.CodeActionOptions)
    assert list(capabilities.code_action_provider.code_action_kinds or []) == [
        lsp.CodeActionKind.QuickFix, "source.fixAll.mpc"]
    semantic = capabilities.semantic_tokens_provider
    assert isinstance(semantic, lsp.SemanticTokensOptions)
    assert semantic.full == lsp.SemanticTokensFullDelta(delta=True) and not semantic.range
    assert capabilities.signature_help_provider is not None
    assert list(capabilities.signature_help_provider.trigger_characters or []) == [" ", ",", "("]
    assert capabilities.document_highlight_provider  # tests/tools/lsp/test_navigation_server.py
    # Not implemented, so not advertised.
    assert capabilities.declaration_provider is None


@ASYNC
async def test_formatting_uses_the_fmt_engine_and_the_projects_fmt_table(
        client: LanguageClient, opened: str) -> None:
    from mplang.tools.fmt import FormatOptions, format_source

    edits = await client.text_document_formatting_async(lsp.DocumentFormattingParams(
        text_document=ident(opened), options=lsp.FormattingOptions(tab_size=8,
                                                                    insert_spaces=True)))
    assert edits
    # [fmt] indent = 2 of the project's mpc.toml wins over the editor's tab size.
    assert apply(MAIN, edits) == format_source(MAIN, FormatOptions(indent=2))
    assert "\n  FIXD_MOVE X, SPEED\n" in apply(MAIN, edits)
    # Only the lines that change are touched.
    assert all(e.range.start.line != 0 for e in edits)


@ASYNC
async def test_range_formatting_touches_only_the_lines_asked_for(
        client: LanguageClient, opened: str) -> None:
    edits = await client.text_document_range_formatting_async(
        lsp.DocumentRangeFormattingParams(text_document=ident(opened), range=whole(20),
                                          options=lsp.FormattingOptions(
                                              tab_size=4, insert_spaces=True)))
    assert edits is not None
    assert [(e.range.start.line, e.new_text) for e in edits] == [(20, "  SET_V XY, SPEED\n")]


@ASYNC
async def test_quick_fixes_from_did_you_mean_hints(client: LanguageClient, opened: str) -> None:
    actions = await client.text_document_code_action_async(lsp.CodeActionParams(
        text_document=ident(opened), range=whole(7),
        context=lsp.CodeActionContext(diagnostics=[])))
    assert actions is not None
    (fix,) = [a for a in actions if isinstance(a, lsp.CodeAction)
              and a.kind == lsp.CodeActionKind.QuickFix]
    assert fix.title == "Replace 'FIXD_MOVE' with 'FIXED_MOVE'"
    assert fix.kind == lsp.CodeActionKind.QuickFix and fix.is_preferred
    assert fix.diagnostics and fix.diagnostics[0].code == "E201"
    assert fix.edit is not None and fix.edit.changes is not None
    (edit,) = fix.edit.changes[opened]
    assert edit.new_text == "FIXED_MOVE"
    assert edit.range == lsp.Range(start=lsp.Position(line=7, character=4),
                                   end=lsp.Position(line=7, character=13))
    name = await client.text_document_code_action_async(lsp.CodeActionParams(
        text_document=ident(opened), range=whole(12),
        context=lsp.CodeActionContext(diagnostics=[])))
    assert name is not None
    (edit,) = name[0].edit.changes[opened]  # type: ignore[union-attr,index]
    assert edit.new_text == "SPEED"
    assert LINES[12][edit.range.start.character:edit.range.end.character] == "SPEDD"


@ASYNC
async def test_ignore_this_warning_on_this_line(client: LanguageClient, opened: str) -> None:
    actions = await client.text_document_code_action_async(lsp.CodeActionParams(
        text_document=ident(opened), range=whole(9),
        context=lsp.CodeActionContext(diagnostics=[])))
    assert actions is not None
    (ignore,) = [a for a in actions if isinstance(a, lsp.CodeAction)
                 and a.kind == lsp.CodeActionKind.QuickFix]
    assert ignore.title == "Ignore W103 on this line" and not ignore.is_preferred
    (edit,) = ignore.edit.changes[opened]  # type: ignore[union-attr,index]
    assert apply(LINES[9], [edit]) == "    count = count + 1  # mpc: ignore[W103]"
    only_refactor = await client.text_document_code_action_async(lsp.CodeActionParams(
        text_document=ident(opened), range=whole(9),
        context=lsp.CodeActionContext(diagnostics=[], only=[lsp.CodeActionKind.Refactor])))
    assert only_refactor is not None and list(only_refactor) == []


@ASYNC
async def test_document_symbols_outline_the_file(client: LanguageClient, opened: str) -> None:
    symbols = await client.text_document_document_symbol_async(lsp.DocumentSymbolParams(
        text_document=ident(opened)))
    assert symbols is not None
    outline = [(s.name, s.kind, s.range.start.line, s.range.end.line) for s in symbols
               if isinstance(s, lsp.DocumentSymbol)]
    assert outline == [("count", lsp.SymbolKind.Variable, 1, 1),
                       ("total", lsp.SymbolKind.Variable, 2, 2),
                       ("main", lsp.SymbolKind.Function, 6, 17),
                       ("helper", lsp.SymbolKind.Function, 19, 21),
                       ("INIT", lsp.SymbolKind.Namespace, 23, 25)]
    main = symbols[2]
    assert isinstance(main, lsp.DocumentSymbol) and main.children
    assert [(c.name, c.kind) for c in main.children] == [("top", lsp.SymbolKind.Key)]


@ASYNC
async def test_workspace_symbols_cover_included_files(client: LanguageClient, opened: str,
                                                      project: Path) -> None:
    found = await client.workspace_symbol_async(lsp.WorkspaceSymbolParams(query="spe"))
    assert found is not None
    (speed,) = found
    assert speed.name == "SPEED" and speed.kind == lsp.SymbolKind.Constant
    assert isinstance(speed.location, lsp.Location)
    assert speed.location.uri == (project / "common.mp").as_uri()
    assert speed.container_name == "common.mp"
    everything = await client.workspace_symbol_async(lsp.WorkspaceSymbolParams(query=""))
    assert {s.name for s in everything or []} == {"SPEED", "count", "total", "main", "helper",
                                                  "top"}


@ASYNC
async def test_folding_ranges_for_blocks_and_comment_runs(client: LanguageClient,
                                                          opened: str) -> None:
    folds = await client.text_document_folding_range_async(lsp.FoldingRangeParams(
        text_document=ident(opened)))
    assert folds is not None
    assert [(f.start_line, f.end_line, f.kind) for f in folds] == [
        (3, 4, lsp.FoldingRangeKind.Comment), (6, 17, lsp.FoldingRangeKind.Region),
        (10, 14, lsp.FoldingRangeKind.Region), (11, 13, lsp.FoldingRangeKind.Region),
        (19, 21, lsp.FoldingRangeKind.Region), (23, 25, lsp.FoldingRangeKind.Region)]


def decode(data: list[int], legend: list[str]) -> dict[tuple[int, int], tuple[int, str]]:
    tokens: dict[tuple[int, int], tuple[int, str]] = {}
    line = start = 0
    for index in range(0, len(data), 5):
        line += data[index]
        start = data[index + 1] + (start if data[index] == 0 else 0)
        tokens[(line, start)] = (data[index + 2], legend[data[index + 3]])
    return tokens


@ASYNC
async def test_semantic_tokens_full_and_delta(client: LanguageClient, opened: str) -> None:
    legend = ["keyword", "function", "variable", "enumMember", "namespace", "label",
              "number", "string", "comment", "operator"]
    full = await client.text_document_semantic_tokens_full_async(lsp.SemanticTokensParams(
        text_document=ident(opened)))
    assert full is not None and full.result_id
    tokens = decode(full.data, legend)
    assert tokens[(0, 0)] == (7, "keyword")  # INCLUDE
    assert tokens[(0, 8)] == (11, "string")
    assert tokens[(3, 0)] == (18, "comment")
    assert tokens[(20, 2)] == (5, "function")  # SET_V
    assert tokens[(20, 8)] == (2, "enumMember")  # XY
    assert tokens[(20, 14)] == (5, "variable")  # SPEED
    assert tokens[(16, 9)] == (6, "namespace")  # CALL helper
    assert tokens[(15, 9)] == (3, "label")  # GOTO top
    delta = await client.text_document_semantic_tokens_full_delta_async(
        lsp.SemanticTokensDeltaParams(text_document=ident(opened),
                                      previous_result_id=full.result_id))
    assert isinstance(delta, lsp.SemanticTokensDelta) and not delta.edits
    stale = await client.text_document_semantic_tokens_full_delta_async(
        lsp.SemanticTokensDeltaParams(text_document=ident(opened), previous_result_id="x"))
    assert isinstance(stale, lsp.SemanticTokens) and stale.data == full.data


@ASYNC
async def test_references_reach_the_included_file(client: LanguageClient, opened: str,
                                                  project: Path) -> None:
    found = await client.text_document_references_async(lsp.ReferenceParams(
        text_document=ident(opened), position=at(7, "SPEED"),
        context=lsp.ReferenceContext(include_declaration=True)))
    assert found is not None
    common = (project / "common.mp").as_uri()
    assert [(f.uri, f.range.start.line, f.range.start.character) for f in found] == [
        (common, 0, 6), (opened, 7, 17), (opened, 20, 14)]
    labels = await client.text_document_references_async(lsp.ReferenceParams(
        text_document=ident(opened), position=at(15, "top"),
        context=lsp.ReferenceContext(include_declaration=False)))
    assert [(f.range.start.line, f.range.start.character) for f in labels or []] == [(15, 9)]


@ASYNC
async def test_rename_a_program_and_a_constant_across_includes(
        client: LanguageClient, opened: str, project: Path) -> None:
    prepared = await client.text_document_prepare_rename_async(lsp.PrepareRenameParams(
        text_document=ident(opened), position=at(16, "helper")))
    assert prepared == lsp.Range(start=lsp.Position(line=16, character=9),
                                 end=lsp.Position(line=16, character=15))
    program = await client.text_document_rename_async(lsp.RenameParams(
        text_document=ident(opened), position=at(16, "helper"), new_name="homing"))
    assert program is not None and program.changes is not None
    assert sorted((e.range.start.line, e.new_text) for e in program.changes[opened]) == [
        (16, "homing"), (19, "homing")]
    constant = await client.text_document_rename_async(lsp.RenameParams(
        text_document=ident(opened), position=at(20, "SPEED"), new_name="FEED"))
    assert constant is not None and constant.changes is not None
    common = (project / "common.mp").as_uri()
    assert [e.range.start for e in constant.changes[common]] == [
        lsp.Position(line=0, character=6)]
    assert len(constant.changes[opened]) == 2
    assert await client.text_document_prepare_rename_async(lsp.PrepareRenameParams(
        text_document=ident(opened), position=at(20, "SET_V"))) is None
    with pytest.raises(JsonRpcException, match="FOR is a keyword or a command"):
        await client.text_document_rename_async(lsp.RenameParams(
            text_document=ident(opened), position=at(20, "SPEED"), new_name="FOR"))


@ASYNC
async def test_signature_help_names_the_parameter_being_typed(client: LanguageClient,
                                                              opened: str) -> None:
    help_ = await client.text_document_signature_help_async(lsp.SignatureHelpParams(
        text_document=ident(opened), position=at(24, "200000", 0)))
    assert help_ is not None
    (signature,) = help_.signatures
    assert signature.label == "SET_MAX_V axis, data"
    assert help_.active_parameter == 1
    assert signature.parameters is not None
    second = signature.parameters[1]
    assert second.label == (16, 20)
    assert isinstance(second.documentation, lsp.MarkupContent)
    assert second.documentation.value.startswith("`")
    nothing = await client.text_document_signature_help_async(lsp.SignatureHelpParams(
        text_document=ident(opened), position=lsp.Position(line=3, character=5)))
    assert nothing is None


@ASYNC
async def test_a_source_with_syntax_errors_gets_no_formatting_edit(client: LanguageClient,
                                                                   opened: str) -> None:
    broken = MAIN.replace("    FOR 3\n", "    FOR 3 (\n")
    client.text_document_did_change(lsp.DidChangeTextDocumentParams(
        text_document=lsp.VersionedTextDocumentIdentifier(uri=opened, version=2),
        content_changes=[lsp.TextDocumentContentChangeWholeDocument(text=broken)]))
    await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    edits = await client.text_document_formatting_async(lsp.DocumentFormattingParams(
        text_document=ident(opened), options=lsp.FormattingOptions(tab_size=4,
                                                                    insert_spaces=True)))
    assert edits is not None and list(edits) == []


@ASYNC
async def test_semantic_tokens_count_the_negotiated_code_units(client: LanguageClient,
                                                               project: Path) -> None:
    # Neovim offers UTF-8 first: the server takes it, and counts bytes.
    assert INITIALIZED[-1].capabilities.position_encoding == lsp.PositionEncodingKind.Utf8
    uri = (project / "emoji.mp").as_uri()
    text = "MP 1\n    VAR_CALCULATE VAR2, '😀', VAR3, VAR4\nEND MP\n"
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(
        uri=uri, language_id="mplang", version=1, text=text)))
    await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    full = await client.text_document_semantic_tokens_full_async(lsp.SemanticTokensParams(
        text_document=ident(uri)))
    assert full is not None
    line = text.split("\n")[1]
    quote = line.index("'")
    tokens = decode(full.data, ["keyword", "function", "variable", "enumMember", "namespace",
                                "label", "number", "string", "comment", "operator"])
    # '😀' is three code points and six UTF-8 bytes: what follows moves by three.
    assert tokens[(1, quote)] == (6, "string")
    assert tokens[(1, quote + 6)] == (1, "operator")
    assert tokens[(1, line.index("VAR3") + 3)] == (4, "variable")
    # An edit below: the emoji line's tokens are taken from the last pass, which the
    # conversion to bytes left in code points (converted again, they would move by three more)
    client.text_document_did_change(lsp.DidChangeTextDocumentParams(
        lsp.VersionedTextDocumentIdentifier(uri=uri, version=2),
        [lsp.TextDocumentContentChangePartial(range=lsp.Range(
            start=lsp.Position(line=2, character=6), end=lsp.Position(line=2, character=6)),
            text="  # done")]))
    await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    again = await client.text_document_semantic_tokens_full_async(lsp.SemanticTokensParams(
        text_document=ident(uri)))
    assert again is not None
    edited = decode(again.data, ["keyword", "function", "variable", "enumMember", "namespace",
                                 "label", "number", "string", "comment", "operator"])
    assert {k: v for k, v in edited.items() if k[0] < 2} == \
        {k: v for k, v in tokens.items() if k[0] < 2}
    assert edited[(2, 8)] == (6, "comment")
    client.text_document_did_close(lsp.DidCloseTextDocumentParams(ident(uri)))

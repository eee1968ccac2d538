"""The server's navigation requests of the third round: document links (INCLUDE), the call
hierarchy (CALL, MP_CALL), document highlights and pull diagnostics (pygls glue over
`calls` and `analysis`).

Registered by `server.create_server` behind the same guard as every feature. Pull
diagnostics (`textDocument/diagnostic`) answer what push diagnostics publish, from a fresh
check of the document, for clients that ask rather than listen (Neovim 0.10+, Helix).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lsprotocol import types as lsp
from pygls import uris

from mplang.tools.lsp import calls
from mplang.tools.lsp.analysis import Analysis, ProgramBlock

if TYPE_CHECKING:
    from mplang.tools.lsp.server import MpLanguageServer


def register_navigation(server: MpLanguageServer, guarded: Callable[[Any], Any]) -> None:
    """Register document links, call hierarchy, highlights and pull diagnostics."""

    @server.feature(lsp.TEXT_DOCUMENT_DOCUMENT_LINK,
                    lsp.DocumentLinkOptions(resolve_provider=False))
    @guarded
    def document_link(params: lsp.DocumentLinkParams) -> list[lsp.DocumentLink] | None:
        analysis = server.analysis(params.text_document.uri)
        capabilities = server.client_capabilities.text_document
        asked = capabilities.document_link if capabilities else None
        tooltips = bool(asked and asked.tooltip_support)
        links = []
        for include in analysis.includes:
            if not include.target.is_file():
                continue  # a missing file: the diagnostic says so, a link would be dead
            target = uris.from_fs_path(str(include.target)) or include.target.as_uri()
            links.append(lsp.DocumentLink(range=server.to_client(analysis.lines,
                                                                 include.range),
                                          target=target,
                                          tooltip=str(include.target) if tooltips else None))
        return links

    def item(uri: str, analysis: Analysis, program: ProgramBlock) -> lsp.CallHierarchyItem:
        lines = server.lines_of(analysis, program.path)
        use = analysis.slot_use(program)
        detail = use.summary if use is not None else program.title
        body = server.to_client(lines, program.header_range)
        end_line = min(program.last_line, max(len(lines) - 1, 0))
        whole = lsp.Range(start=body.start, end=lsp.Position(
            line=end_line, character=len(lines[end_line]) if lines else 0))
        return lsp.CallHierarchyItem(
            name=program.name or program.title, kind=lsp.SymbolKind.Function,
            uri=server.uri_for(uri, analysis, program.path), range=whole,
            selection_range=server.to_client(lines, program.name_range), detail=detail,
            data={"path": str(program.path), "line": program.first_line})

    def program_of(params_item: lsp.CallHierarchyItem
                   ) -> tuple[str, Analysis, ProgramBlock] | None:
        """The program an item stands for, looked up in the analysis of an open document
        whose build holds it (an INCLUDEd file's callers are in the builds that include
        it), else in its own file's."""
        data = params_item.data if isinstance(params_item.data, dict) else {}
        path = Path(str(data.get("path", ""))) if data.get("path") else \
            server.document_path(params_item.uri).resolve()
        line = data.get("line", params_item.selection_range.start.line)
        for uri in [*server.analyses, params_item.uri]:
            analysis = server.analyses.get(uri) or server.analysis(uri)
            if path in analysis.files:
                found = calls.find_program(analysis, path, int(line))
                if found is not None:
                    return uri, analysis, found
        return None

    @server.feature(lsp.TEXT_DOCUMENT_PREPARE_CALL_HIERARCHY)
    @guarded
    def prepare_call_hierarchy(params: lsp.CallHierarchyPrepareParams
                               ) -> list[lsp.CallHierarchyItem] | None:
        uri = params.text_document.uri
        analysis = server.analysis(uri)
        program = calls.program_at(analysis, server.from_client(analysis, params.position))
        return [item(uri, analysis, program)] if program is not None else None

    def related(params_item: lsp.CallHierarchyItem, incoming: bool
                ) -> list[tuple[lsp.CallHierarchyItem, list[lsp.Range]]] | None:
        """The callers (or callees) of an item, each with the call sites' ranges (in the
        caller, which is the other program for incoming calls and this one for outgoing)."""
        found = program_of(params_item)
        if found is None:
            return None
        uri, analysis, program = found
        answer = []
        for other, ranges in calls.related(analysis, program, incoming):
            lines = server.lines_of(analysis, (other if incoming else program).path)
            answer.append((item(uri, analysis, other),
                           [server.to_client(lines, r) for r in ranges]))
        return answer

    @server.feature(lsp.CALL_HIERARCHY_INCOMING_CALLS)
    @guarded
    def incoming_calls(params: lsp.CallHierarchyIncomingCallsParams
                       ) -> list[lsp.CallHierarchyIncomingCall] | None:
        found = related(params.item, True)
        return None if found is None else [
            lsp.CallHierarchyIncomingCall(from_=other, from_ranges=ranges)
            for other, ranges in found]

    @server.feature(lsp.CALL_HIERARCHY_OUTGOING_CALLS)
    @guarded
    def outgoing_calls(params: lsp.CallHierarchyOutgoingCallsParams
                       ) -> list[lsp.CallHierarchyOutgoingCall] | None:
        found = related(params.item, False)
        return None if found is None else [
            lsp.CallHierarchyOutgoingCall(to=other, from_ranges=ranges)
            for other, ranges in found]

    @server.feature(lsp.TEXT_DOCUMENT_DOCUMENT_HIGHLIGHT)
    @guarded
    def document_highlight(params: lsp.DocumentHighlightParams
                           ) -> list[lsp.DocumentHighlight] | None:
        analysis = server.analysis(params.text_document.uri)
        found = calls.highlights(analysis, server.from_client(analysis, params.position))
        return [lsp.DocumentHighlight(
            range=server.to_client(analysis.lines, where),
            kind=lsp.DocumentHighlightKind.Write if written else lsp.DocumentHighlightKind.Read)
            for where, written in found]

    @server.feature(lsp.TEXT_DOCUMENT_DIAGNOSTIC, lsp.DiagnosticOptions(
        identifier="mpc", inter_file_dependencies=True, workspace_diagnostics=False))
    @guarded
    def pull_diagnostics(params: lsp.DocumentDiagnosticParams
                         ) -> lsp.RelatedFullDocumentDiagnosticReport | None:
        uri = params.text_document.uri
        analysis = server.analyse_uri(uri)
        return lsp.RelatedFullDocumentDiagnosticReport(
            items=server.client_diagnostics(uri, analysis))

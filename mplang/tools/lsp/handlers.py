"""The server's editing and navigation requests: formatting, code actions, symbols, folding,
semantic tokens, references, rename and signature help (pygls glue over `editing` and
`outline`).

Kept apart from `server` so that each stays small; `server.create_server` registers these on
the server it builds, each behind the same guard (a failure is logged and answered with
nothing). Positions are converted between code points and the client's encoding here.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from lsprotocol import types as lsp
from pygls.exceptions import JsonRpcInvalidParams

from mplang.tools.lsp import editing, outline
from mplang.tools.lsp.analysis import Analysis
from mplang.tools.lsp.positions import (
    Location,
    Pos,
    Range,
    split_lines,
    to_client_character,
)
from mplang.tools.lsp.workspace import context_for, format_options_for

if TYPE_CHECKING:
    from mplang.tools.lsp.server import MpLanguageServer

logger = logging.getLogger("mplang.tools.lsp")

SYMBOL_KINDS = {"program": lsp.SymbolKind.Function, "const": lsp.SymbolKind.Constant,
                "alias": lsp.SymbolKind.Variable, "var": lsp.SymbolKind.Variable,
                "label": lsp.SymbolKind.Key, "block": lsp.SymbolKind.Namespace}
SIGNATURE_TRIGGERS = [" ", ",", "("]
FIX_ALL = "source.fixAll.mpc"
"""The code action kind of "apply every preferred fix" (ruff's is `source.fixAll.ruff`)."""
SEMANTIC_LEGEND = lsp.SemanticTokensLegend(token_types=outline.TOKEN_TYPES,
                                           token_modifiers=outline.TOKEN_MODIFIERS)


def register_editing(server: MpLanguageServer, guarded: Callable[[Any], Any]) -> None:
    """Register the editing and navigation features on `server`."""
    tokens_sent: dict[str, tuple[str, list[int]]] = {}  # uri -> (result id, data)
    # uri -> the analysis and encoding the tokens were computed for, and the tokens
    tokens_kept: dict[str, tuple[Analysis, str, list[int]]] = {}
    counter = iter(range(1, 1 << 62))

    def client_range(analysis: Analysis, range_: lsp.Range) -> Range:
        return Range(server.from_client(analysis, range_.start),
                     server.from_client(analysis, range_.end))

    def text_edits(lines: list[str], edits: list[editing.TextEdit]) -> list[lsp.TextEdit]:
        return [lsp.TextEdit(range=server.to_client(lines, e.range), new_text=e.text)
                for e in edits]

    def formatted(uri: str, lines: tuple[int, int] | None) -> list[lsp.TextEdit]:
        text = server.document_text(uri)
        options = format_options_for(server.document_path(uri))
        return text_edits(split_lines(text), editing.format_edits(text, options, lines))

    @server.feature(lsp.TEXT_DOCUMENT_FORMATTING)
    @guarded
    def formatting(params: lsp.DocumentFormattingParams) -> list[lsp.TextEdit] | None:
        return formatted(params.text_document.uri, None)

    @server.feature(lsp.TEXT_DOCUMENT_RANGE_FORMATTING)
    @guarded
    def range_formatting(params: lsp.DocumentRangeFormattingParams
                         ) -> list[lsp.TextEdit] | None:
        start, end = params.range.start, params.range.end
        last = end.line - 1 if end.character == 0 and end.line > start.line else end.line
        return formatted(params.text_document.uri, (start.line, last))

    def fix_all(uri: str, analysis: Analysis) -> lsp.CodeAction | None:
        """`source.fixAll.mpc`: every preferred fix of the document in one edit (what
        `mpc lint --fix` writes), or None when there is nothing to fix."""
        from mplang.tools.fix import fix_text

        text = server.document_text(uri)  # as the editor holds it, CRLF kept
        path = server.document_path(uri)
        others = {server.document_path(u).resolve(): server.document_text(u)
                  for u in server.analyses if u != uri and server.is_open(u)}
        fixed = fix_text(path, text, context_for(path, server.overrides), others)
        if fixed.text == text:
            return None
        lines = split_lines(text)
        whole = Range(Pos(0, 0), Pos(len(lines) - 1, len(lines[-1])))
        edit = lsp.WorkspaceEdit(changes={uri: text_edits(lines, [
            editing.TextEdit(whole, fixed.text)])})
        return lsp.CodeAction(title=f"Fix all auto-fixable problems ({fixed.applied})",
                              kind=FIX_ALL, edit=edit)

    def asked(kind: str, wanted: list[str] | None) -> bool:
        """Whether `kind` is among the kinds the client asked for (a kind covers its
        sub-kinds: `source` asks for `source.fixAll.mpc`)."""
        return not wanted or any(kind == k or kind.startswith(f"{k}.") for k in wanted)

    @server.feature(lsp.TEXT_DOCUMENT_CODE_ACTION, lsp.CodeActionOptions(
        code_action_kinds=[lsp.CodeActionKind.QuickFix, FIX_ALL]))
    @guarded
    def code_action(params: lsp.CodeActionParams) -> list[lsp.CodeAction] | None:
        uri = params.text_document.uri
        analysis = server.analysis(uri)
        wanted = [str(getattr(k, "value", k)) for k in params.context.only or []] or None
        actions = []
        quick = asked(lsp.CodeActionKind.QuickFix.value, wanted)
        for fix in editing.quick_fixes(analysis, client_range(analysis, params.range)) \
                if quick else []:
            edit = lsp.WorkspaceEdit(changes={uri: text_edits(analysis.lines, [fix.edit])})
            actions.append(lsp.CodeAction(
                title=fix.title, kind=lsp.CodeActionKind.QuickFix, edit=edit,
                diagnostics=[server.diagnostic(uri, analysis, fix.diagnostic)],
                is_preferred=fix.preferred or None))
        everything = fix_all(uri, analysis) if asked(FIX_ALL, wanted) else None
        return actions + ([everything] if everything is not None else [])

    def symbol(analysis: Analysis, found: outline.Symbol) -> lsp.DocumentSymbol:
        return lsp.DocumentSymbol(
            name=found.name, kind=SYMBOL_KINDS[found.kind], detail=found.detail or None,
            range=server.to_client(analysis.lines, found.range),
            selection_range=server.to_client(analysis.lines, found.selection),
            children=[symbol(analysis, child) for child in found.children] or None)

    @server.feature(lsp.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    @guarded
    def document_symbol(params: lsp.DocumentSymbolParams) -> list[lsp.DocumentSymbol] | None:
        analysis = server.analysis(params.text_document.uri)
        return [symbol(analysis, found) for found in outline.document_symbols(analysis)]

    @server.feature(lsp.WORKSPACE_SYMBOL)
    @guarded
    def workspace_symbol(params: lsp.WorkspaceSymbolParams
                         ) -> list[lsp.WorkspaceSymbol] | None:
        analyses = list(server.analyses.items())
        found = []
        for entry, path in outline.workspace_symbols([a for _, a in analyses], params.query):
            uri, analysis = next(((u, a) for u, a in analyses if path in a.files),
                                 analyses[0])
            location = server.location(uri, analysis, Location(path, entry.selection))
            found.append(lsp.WorkspaceSymbol(name=entry.name, kind=SYMBOL_KINDS[entry.kind],
                                             location=location,
                                             container_name=path.name))
        return found

    @server.feature(lsp.TEXT_DOCUMENT_FOLDING_RANGE)
    @guarded
    def folding_range(params: lsp.FoldingRangeParams) -> list[lsp.FoldingRange] | None:
        analysis = server.analysis(params.text_document.uri)
        return [lsp.FoldingRange(start_line=f.first, end_line=f.last,
                                 kind=lsp.FoldingRangeKind.Comment if f.kind == "comment"
                                 else lsp.FoldingRangeKind.Region)
                for f in outline.folding_ranges(analysis)]

    def encoded(uri: str, analysis: Analysis) -> list[int]:
        """Semantic tokens with starts and lengths in the client's position encoding,
        computed once per analysis of an open document: a delta request after a full one
        (or a second client's) costs no second pass over the document."""
        encoding = server.encoding
        kept = tokens_kept.get(uri)
        if kept is not None and kept[0] is analysis and kept[1] == encoding:
            return kept[2]
        data = outline.semantic_tokens(analysis)
        if encoding != "utf-32":
            data = in_client_units(data, analysis.lines, encoding, analysis.text)
        for other in [u for u in tokens_kept if not server.is_open(u)]:
            del tokens_kept[other]
        if server.is_open(uri):
            tokens_kept[uri] = (analysis, encoding, data)
        return data

    def remember(uri: str, data: list[int]) -> str:
        """Keep the tokens sent for a later delta: only of open documents, so that requests
        on unopened files cannot make the server hold ever more."""
        result_id = str(next(counter))
        for other in [u for u in tokens_sent if not server.is_open(u)]:
            del tokens_sent[other]
        if server.is_open(uri):
            tokens_sent[uri] = (result_id, data)
        return result_id

    @server.feature(lsp.TEXT_DOCUMENT_SEMANTIC_TOKENS_FULL, SEMANTIC_LEGEND)
    @guarded
    def semantic_tokens_full(params: lsp.SemanticTokensParams) -> lsp.SemanticTokens | None:
        uri = params.text_document.uri
        data = encoded(uri, server.analysis(uri))
        return lsp.SemanticTokens(data=data, result_id=remember(uri, data))

    @server.feature(lsp.TEXT_DOCUMENT_SEMANTIC_TOKENS_FULL_DELTA, SEMANTIC_LEGEND)
    @guarded
    def semantic_tokens_delta(params: lsp.SemanticTokensDeltaParams
                              ) -> lsp.SemanticTokens | lsp.SemanticTokensDelta | None:
        uri = params.text_document.uri
        data = encoded(uri, server.analysis(uri))
        sent = tokens_sent.get(uri)
        if sent is None or sent[0] != params.previous_result_id:
            return lsp.SemanticTokens(data=data, result_id=remember(uri, data))
        start, deleted, inserted = outline.token_delta(sent[1], data)
        edits = [lsp.SemanticTokensEdit(start=start, delete_count=deleted, data=inserted)] \
            if deleted or inserted else []
        return lsp.SemanticTokensDelta(edits=edits, result_id=remember(uri, data))

    @server.feature(lsp.TEXT_DOCUMENT_REFERENCES)
    @guarded
    def references(params: lsp.ReferenceParams) -> list[lsp.Location] | None:
        uri = params.text_document.uri
        analysis = server.analysis(uri)
        found = editing.references(analysis, server.from_client(analysis, params.position),
                                   params.context.include_declaration)
        return [server.location(uri, analysis, where) for where in found]

    @server.feature(lsp.TEXT_DOCUMENT_PREPARE_RENAME)
    @guarded
    def prepare_rename(params: lsp.PrepareRenameParams) -> lsp.Range | None:
        analysis = server.analysis(params.text_document.uri)
        found = editing.rename_range(analysis, server.from_client(analysis, params.position))
        return server.to_client(analysis.lines, found) if found else None

    @server.feature(lsp.TEXT_DOCUMENT_RENAME)
    @guarded
    def rename(params: lsp.RenameParams) -> lsp.WorkspaceEdit | None:
        uri = params.text_document.uri
        analysis = server.analysis(uri)
        try:
            edits = editing.rename(analysis, server.from_client(analysis, params.position),
                                   params.new_name)
        except editing.RenameRefused as exc:  # the client shows this to the user
            raise JsonRpcInvalidParams(f"cannot rename: {exc}") from None
        changes = {server.uri_for(uri, analysis, path):
                   text_edits(server.lines_of(analysis, path), found)
                   for path, found in edits.items()}
        return lsp.WorkspaceEdit(changes=changes) if changes else None

    @server.feature(lsp.TEXT_DOCUMENT_SIGNATURE_HELP, lsp.SignatureHelpOptions(
        trigger_characters=SIGNATURE_TRIGGERS))
    @guarded
    def signature_help(params: lsp.SignatureHelpParams) -> lsp.SignatureHelp | None:
        analysis = server.analysis(params.text_document.uri)
        found = outline.signature_help(analysis, server.from_client(analysis,
                                                                    params.position))
        if found is None:
            return None
        parameters = [lsp.ParameterInformation(
            label=offsets, documentation=lsp.MarkupContent(kind=lsp.MarkupKind.Markdown,
                                                           value=text))
            for offsets, text in found.parameters]
        return lsp.SignatureHelp(signatures=[lsp.SignatureInformation(
            label=found.label, documentation=found.documentation or None,
            parameters=parameters, active_parameter=found.active)],
            active_signature=0, active_parameter=found.active)


def in_client_units(data: list[int], lines: list[str], encoding: str,
                    text: str | None = None) -> list[int]:
    """Relative-encoded semantic tokens counted in code points, in the client's code units:
    `data` itself when no line has a non-ASCII character (on an ASCII line both counts
    agree: the tokens are not walked one by one), else a converted copy (`data` is the
    list `outline.semantic_tokens` keeps for its next pass, never changed). `text`, the
    lines' whole text when known, answers at once: a string knows whether it is ASCII,
    where the lines of a whole device are thousands of calls."""
    if text.isascii() if text is not None else all(map(str.isascii, lines)):
        return data
    data = list(data)
    line = start = 0
    previous = (0, 0)  # the last token's line and client start
    for index in range(0, len(data), 5):
        line += data[index]
        start = data[index + 1] + (start if data[index] == 0 else 0)
        text = lines[line] if 0 <= line < len(lines) else ""
        first = to_client_character(text, start, encoding)
        end = to_client_character(text, start + data[index + 2], encoding)
        data[index + 1] = first - previous[1] if line == previous[0] else first
        data[index + 2] = end - first
        previous = (line, first)
    return data

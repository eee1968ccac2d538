"""`mpc lsp --stdio` reads the nearest mpc.toml as `mpc lint` does (issue 15 item 3): a
project's `[lint] ignore` silences its warnings in the editor too, and a file outside the
project keeps them. A client opens one document in each and reads what is published."""

from __future__ import annotations

import sys
from collections.abc import AsyncIterator
from pathlib import Path

import pytest
import pytest_lsp
from lsprotocol import types as lsp
from pytest_lsp import ClientServerConfig, LanguageClient

ASYNC = pytest.mark.asyncio(loop_scope="module")
WARNS = """MP 1 one
    FOR 0
        FIXED_MOVE X, 100
    NEXT
    FOR 3 (
    NEXT
END MP
"""
"""W102 on line 2 (FOR 0), and the syntax error E101 on line 5, which no ignore silences."""


@pytest.fixture(scope="module")
def folders(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("lsp-ignore")
    quiet, loud = root / "quiet", root / "loud"
    for folder in (quiet, loud):
        folder.mkdir()
        (folder / "job.mp").write_text(WARNS)
    (quiet / "mpc.toml").write_text('[lint]\nignore = ["W102"]\n')
    return quiet, loud


@pytest_lsp.fixture(scope="module", config=ClientServerConfig(
    server_command=[sys.executable, "-m", "mplang", "lsp", "--stdio"]))
async def client(lsp_client: LanguageClient, folders: tuple[Path, Path]
                 ) -> AsyncIterator[None]:
    await lsp_client.initialize_session(lsp.InitializeParams(
        capabilities=pytest_lsp.client_capabilities("neovim"),
        root_uri=folders[0].parent.as_uri()))
    yield
    await lsp_client.shutdown_session()


async def published(client: LanguageClient, path: Path) -> list[str | int | None]:
    uri = path.as_uri()
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(
        uri=uri, language_id="mplang", version=1, text=path.read_text())))
    while uri not in client.diagnostics:
        await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    return sorted((d.code for d in client.diagnostics[uri]), key=str)


@ASYNC
async def test_lint_ignore_of_the_nearest_project_applies_in_the_editor(
        client: LanguageClient, folders: tuple[Path, Path]) -> None:
    quiet, loud = folders
    assert await published(client, quiet / "job.mp") == ["E101"]
    assert await published(client, loud / "job.mp") == ["E101", "W102"]

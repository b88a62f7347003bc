"""`atlas lsp` end to end: a real LSP client (pytest-lsp) talks to the server in its own process.

On the shipped missions: diagnostics as `atlas check` gives them (same message, same
position), hover, go to definition across includes, completion and the outline.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

pytest_lsp = pytest.importorskip("pytest_lsp")
from lsprotocol import types  # noqa: E402
from pytest_lsp import ClientServerConfig, LanguageClient, client_capabilities  # noqa: E402

from cli_process import REPO, atlas  # noqa: E402

DELIVER = REPO / "rap_library" / "missions" / "deliver.rap"
NAVIGATION = REPO / "rap_library" / "navigation.rap"
SERVER_ENV = {**os.environ, "PYTHONPATH": str(REPO)}


@pytest_lsp.fixture(config=ClientServerConfig(server_command=[sys.executable, "-m", "atlas_rap", "lsp"],
                                              server_env=SERVER_ENV))
async def client(lsp_client: LanguageClient):
    await lsp_client.initialize_session(types.InitializeParams(
        capabilities=client_capabilities("visual-studio-code"), root_uri=REPO.as_uri()))
    yield
    await lsp_client.shutdown_session()


async def open_file(client: LanguageClient, path: Path, text: str | None = None) -> str:
    """Open ``path`` in the client (with ``text``, or what is on disk) and wait for its diagnostics."""
    uri = path.resolve().as_uri()
    client.text_document_did_open(types.DidOpenTextDocumentParams(types.TextDocumentItem(
        uri=uri, language_id="rap", version=1, text=text if text is not None else path.read_text())))
    while uri not in client.diagnostics:
        await client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    return uri


def with_navigation(path: Path, *lines: str) -> str:
    """Write a mission at ``path`` that includes the shipped navigation RAPs, then ``lines``; its text."""
    text = "".join([f'(include "{NAVIGATION.as_posix()}")\n', *(line + "\n" for line in lines)])
    path.write_text(text)
    return text


def position_of(text: str, needle: str, offset: int = 0) -> types.Position:
    """Where ``needle`` first occurs in ``text`` (plus ``offset`` characters)."""
    before = text[:text.index(needle) + offset]
    return types.Position(before.count("\n"), len(before) - (before.rfind("\n") + 1))


@pytest.mark.asyncio
async def test_a_shipped_mission_has_no_diagnostics(client: LanguageClient):
    uri = await open_file(client, DELIVER)
    assert list(client.diagnostics[uri]) == []


@pytest.mark.asyncio
async def test_diagnostics_are_atlas_checks_messages_at_its_positions_and_follow_each_edit(client, tmp_path):
    bad = tmp_path / "bad.rap"
    text = with_navigation(bad, "(define-rap (fetch ?thing)", "  (method (task-net (t1 (go-too lab)))))",
                           "(post (fetch cup))")
    checked = atlas("check", str(bad), cwd=tmp_path)
    assert checked.returncode == 1
    uri = await open_file(client, bad)
    (diagnostic,) = client.diagnostics[uri]
    # atlas check says "FILE:3:26: error: MESSAGE": the same message, at line 3, column 26 (1-based)
    assert f"{bad.name}:3:{diagnostic.range.start.character + 1}: error: {diagnostic.message.splitlines()[0]}" \
        in checked.stderr
    assert diagnostic.range.start.line == 2 and diagnostic.severity == types.DiagnosticSeverity.Error
    assert "hint: did you mean 'go-to'?" in diagnostic.message
    # The edit that fixes it clears the diagnostics; one that breaks the syntax brings a new one.
    fixed = text.replace("go-too", "go-to")
    client.text_document_did_change(types.DidChangeTextDocumentParams(
        types.VersionedTextDocumentIdentifier(uri=uri, version=2),
        [types.TextDocumentContentChangeWholeDocument(text=fixed)]))
    while client.diagnostics[uri]:
        await client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    client.text_document_did_change(types.DidChangeTextDocumentParams(
        types.VersionedTextDocumentIdentifier(uri=uri, version=3),
        [types.TextDocumentContentChangeWholeDocument(text=fixed + "(post (fetch")]))
    while not client.diagnostics[uri]:
        await client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    assert "unclosed" in client.diagnostics[uri][0].message or "(" in client.diagnostics[uri][0].message


@pytest.mark.asyncio
async def test_hover_documents_a_form_a_rap_and_a_skill(client: LanguageClient):
    uri = await open_file(client, NAVIGATION)
    text = NAVIGATION.read_text()
    on_form = await client.text_document_hover_async(types.HoverParams(
        types.TextDocumentIdentifier(uri), position_of(text, "(define-rap (go-to", 3)))
    assert "(define-rap (NAME ?ARG ...) CLAUSE ...)" in on_form.contents.value
    on_rap = await client.text_document_hover_async(types.HoverParams(
        types.TextDocumentIdentifier(uri), position_of(text, "(t1 (relocalise))", 6)))
    assert "(relocalise)" in on_rap.contents.value and "RAP, defined at navigation.rap:" in on_rap.contents.value
    assert "Find out where the robot is again" in on_rap.contents.value  # the comment above the RAP
    on_skill = await client.text_document_hover_async(types.HoverParams(
        types.TextDocumentIdentifier(uri), position_of(text, "(navigate-to ?place)", 2)))
    assert "(navigate-to PLACE)" in on_skill.contents.value and "stock skill" in on_skill.contents.value


@pytest.mark.asyncio
async def test_go_to_definition_finds_a_rap_in_an_included_file(client: LanguageClient):
    uri = await open_file(client, DELIVER)
    text = DELIVER.read_text()
    assert "(go-to " in text and "(include" in text
    found = await client.text_document_definition_async(types.DefinitionParams(
        types.TextDocumentIdentifier(uri), position_of(text, "(go-to ", 2)))
    (location,) = found
    assert location.uri == NAVIGATION.resolve().as_uri()
    line = NAVIGATION.read_text().splitlines()[location.range.start.line]
    assert line.startswith("(define-rap (go-to ?place)")


@pytest.mark.asyncio
async def test_completion_offers_rap_skill_and_form_names_at_a_head_and_places_in_an_argument(client, tmp_path):
    mission = tmp_path / "typing.rap"
    text = with_navigation(mission, "(world lab-corridor-office)", "(define-rap (tour)",
                           "  (method (task-net (t1 (go-to office)))))", "(post (tour))")
    uri = await open_file(client, mission)
    heads = await client.text_document_completion_async(types.CompletionParams(
        types.TextDocumentIdentifier(uri), position_of(text, "(go-to office)", 3)))
    labels = {item.label for item in heads.items}  # "(go" typed: what begins so, of what heads a list
    assert {"go-to", "goals"} <= labels and all(label.startswith("go") for label in labels)
    fresh = await client.text_document_completion_async(types.CompletionParams(
        types.TextDocumentIdentifier(uri), position_of(text, "(go-to office)", 1)))
    labels = {item.label for item in fresh.items}  # just after "(": RAPs, skills, forms; no places
    assert {"go-to", "relocalise", "navigate-to", "define-rap", "wait-for"} <= labels and "office" not in labels
    places = await client.text_document_completion_async(types.CompletionParams(
        types.TextDocumentIdentifier(uri), position_of(text, "(go-to office)", 9)))
    assert {item.label for item in places.items} == {"office"}  # "of" typed: the places that begin so


@pytest.mark.asyncio
async def test_document_symbols_outline_the_files_definitions(client: LanguageClient):
    uri = await open_file(client, NAVIGATION)
    found = await client.text_document_document_symbol_async(types.DocumentSymbolParams(
        types.TextDocumentIdentifier(uri)))
    names = [(symbol.name, symbol.detail) for symbol in found]
    assert ("go-to", "RAP") in names and ("relocalise", "RAP") in names
    assert ("at-is-unique", "memory rule") in names

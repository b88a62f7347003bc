"""``atlas lsp``: a Language Server Protocol server for RAP and AP files, over stdio (pygls).

What an editor gets (:mod:`atlas_rap.cli.lsp_index` does the work):

- **diagnostics** as ``atlas check`` gives them, the same messages at the
  same positions (with the hint), on opening a file and on every edit, from
  the editor's text (what it includes is read from disk);
- **hover** on a form (``define-rap``, ``wait-for``, ``:purpose``...), a RAP,
  a skill, an operator, a relation, a memory rule, a predicate or a place;
- **go to definition** of a RAP, virtual skill, memory rule, operator or
  relation, across includes;
- **completion** of forms, RAP and skill names, memory predicates, places of
  the mission's world and outcome keywords;
- **document symbols**: the file's top-level forms, for the outline.

Between edits that do not load (a half-typed form), hover, definition and
completion use the last version of the file that loaded. The server needs
``pygls`` (``pip install 'atlas-rap[lsp]'``); editors start it as ``atlas lsp``
(docs/how-to/editor.md has VS Code, Neovim and Emacs).
"""

from __future__ import annotations

import sys
from pathlib import Path

import click


@click.command("lsp")
def lsp() -> None:
    """Serve the language (diagnostics, hover, definition, completion, symbols) to an editor over
    stdio. Needs atlas-rap[lsp]."""
    try:
        server = build_server()
    except ImportError:
        click.echo("atlas lsp needs pygls: pip install 'atlas-rap[lsp]'", err=True)
        sys.exit(2)
    server.start_io()


def build_server():
    """The language server, its features registered (see the module docstring)."""
    from lsprotocol import types
    from pygls.lsp.server import LanguageServer
    from pygls.uris import to_fs_path

    from atlas_rap import __version__
    from atlas_rap.cli.lsp_index import DocumentIndex, Word, diagnose, outline, word_at
    from atlas_rap.errors import shown_path

    server = LanguageServer("atlas-rap", __version__)
    completion_kinds, symbol_kinds = _kinds(types)
    indexes: dict[str, DocumentIndex] = {}  # uri -> the last version that loaded

    def check(uri: str) -> None:
        document = server.workspace.get_text_document(uri)
        name = shown_path(to_fs_path(uri) or uri)
        problems, program = diagnose(document.source, name)
        if program is not None:
            indexes[uri] = DocumentIndex(program)
        lines = document.source.splitlines()
        diagnostics = [_diagnostic(types, problem, name, lines) for problem in problems]
        server.text_document_publish_diagnostics(
            types.PublishDiagnosticsParams(uri=uri, diagnostics=diagnostics, version=document.version))

    @server.feature(types.TEXT_DOCUMENT_DID_OPEN)
    def did_open(params: types.DidOpenTextDocumentParams) -> None:
        check(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_CHANGE)
    def did_change(params: types.DidChangeTextDocumentParams) -> None:
        check(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(params: types.DidCloseTextDocumentParams) -> None:
        indexes.pop(params.text_document.uri, None)
        server.text_document_publish_diagnostics(
            types.PublishDiagnosticsParams(uri=params.text_document.uri, diagnostics=[]))

    def word(params):
        document = server.workspace.get_text_document(params.text_document.uri)
        return word_at(document.source.splitlines(), params.position.line, params.position.character)

    @server.feature(types.TEXT_DOCUMENT_HOVER)
    def hover(params: types.HoverParams) -> types.Hover | None:
        index, found = indexes.get(params.text_document.uri), word(params)
        text = index.hover(found) if index is not None and found is not None else None
        if text is None:
            return None
        where = types.Range(types.Position(found.line, found.start), types.Position(found.line, found.end))
        return types.Hover(types.MarkupContent(types.MarkupKind.Markdown, text), where)

    @server.feature(types.TEXT_DOCUMENT_DEFINITION)
    def definition(params: types.DefinitionParams) -> list[types.Location]:
        index, found = indexes.get(params.text_document.uri), word(params)
        if index is None or found is None:
            return []
        return [_location(types, where) for where in index.definition(found)]

    @server.feature(types.TEXT_DOCUMENT_COMPLETION, types.CompletionOptions(trigger_characters=["(", ":"]))
    def completion(params: types.CompletionParams) -> types.CompletionList:
        index = indexes.get(params.text_document.uri)
        if index is None:
            return types.CompletionList(is_incomplete=False, items=[])
        document = server.workspace.get_text_document(params.text_document.uri)
        lines = document.source.splitlines()
        line, character = params.position.line, params.position.character
        typed = word_at(lines, line, character)
        if typed is None:  # nothing typed yet: a head right after "(", else an argument
            before = lines[line][:character] if line < len(lines) else ""
            typed = Word("", line, character, character, before.rstrip().endswith("("))
        else:  # what is typed is the word up to the cursor
            typed = Word(typed.text[:character - typed.start], line, typed.start, character, typed.heads_list)
        items = [types.CompletionItem(label, kind=completion_kinds.get(kind, types.CompletionItemKind.Text),
                                      detail=detail)
                 for label, kind, detail in index.completions(typed)]
        return types.CompletionList(is_incomplete=False, items=items)

    @server.feature(types.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    def symbols(params: types.DocumentSymbolParams) -> list[types.DocumentSymbol]:
        document = server.workspace.get_text_document(params.text_document.uri)
        name = shown_path(to_fs_path(params.text_document.uri) or params.text_document.uri)
        found = []
        for symbol in outline(document.source, name):
            line, start, end = symbol.selection
            found.append(types.DocumentSymbol(
                name=symbol.name, detail=symbol.kind, kind=symbol_kinds.get(symbol.kind, types.SymbolKind.Object),
                range=types.Range(types.Position(*symbol.start), types.Position(*symbol.end)),
                selection_range=types.Range(types.Position(line, start), types.Position(line, end))))
        return found

    return server


def _diagnostic(types, problem, name: str, lines: list[str]):
    """An LSP diagnostic for a problem: at its token in this file, or at the top for one in an
    included file (the message says where)."""
    from atlas_rap.cli.lsp_index import token_end

    location = problem.location
    message = problem.message + (f"\nhint: {problem.hint}" if problem.hint else "")
    if location.file == name and 1 <= location.line <= max(len(lines), 1):
        line, start = location.line - 1, max(location.column - 1, 0)
        end = token_end(lines[line] if line < len(lines) else "", start)
    else:
        line, start, end = 0, 0, 0
        message = f"{location}: {message}"
    severity = types.DiagnosticSeverity.Warning if problem.severity == "warning" else types.DiagnosticSeverity.Error
    return types.Diagnostic(range=types.Range(types.Position(line, start), types.Position(line, end)),
                            message=message, severity=severity, source="atlas check")


def _location(types, where):
    from pygls.uris import from_fs_path

    uri = from_fs_path(str(Path(where.file).resolve()))
    position = types.Position(where.line - 1, where.column - 1)
    return types.Location(uri=uri, range=types.Range(position, position))


def _kinds(types):
    """How each kind of name shows in the editor's completion list and outline."""
    completion = {"form": types.CompletionItemKind.Keyword, "RAP": types.CompletionItemKind.Function,
                  "skill": types.CompletionItemKind.Method, "virtual skill": types.CompletionItemKind.Method,
                  "memory rule": types.CompletionItemKind.Event, "operator": types.CompletionItemKind.Function,
                  "relation": types.CompletionItemKind.Interface, "predicate": types.CompletionItemKind.Field,
                  "place": types.CompletionItemKind.Value, "keyword": types.CompletionItemKind.Constant}
    symbol = {"RAP": types.SymbolKind.Function, "virtual skill": types.SymbolKind.Method,
              "memory rule": types.SymbolKind.Event, "operator": types.SymbolKind.Function,
              "relation": types.SymbolKind.Interface}
    return completion, symbol

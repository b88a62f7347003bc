"""The editor's view of the language stays the language: every form the validator knows has hover
text, the VS Code grammar highlights every form, and the extension's files are well formed."""

from __future__ import annotations

import json
import re

from atlas_rap.lang import validator
from atlas_rap.lang.form_docs import FORMS
from cli_process import REPO

VSCODE = REPO / "editors" / "vscode"
GRAMMAR = json.loads((VSCODE / "syntaxes" / "rap.tmLanguage.json").read_text())
KNOWN = set(validator.TOP_LEVEL_FORMS + validator.RAP_CLAUSES + validator.METHOD_PARTS + validator.NET_FORMS
            + validator.ANNOTATIONS + validator.PRIMITIVE_ACTIONS + validator.SCRIPT_LINES
            + validator.SCRIPT_ACTIONS + validator.OPERATOR_PARTS + validator.PLOT_GROUPS)
OPERATOR_KEYWORDS = set(validator.OPERATOR_PARTS)  # written :purpose, :effects ... in the keyword style


def test_every_form_the_validator_knows_has_hover_text():
    assert KNOWN - set(FORMS) == set()


def test_the_grammar_highlights_every_form_at_the_head_of_a_list_and_nothing_else_there():
    form = re.compile(GRAMMAR["repository"]["form"]["match"])
    for name in KNOWN - OPERATOR_KEYWORDS | {"uncontrolled", "constraints"}:
        assert form.search(f"({name} x)"), name
        assert form.search(f"( {name.upper()})"), name  # symbols are case-insensitive
    assert not form.search("(go-to office)") and not form.search("(define-raps x)")
    assert not form.search("my-succeed")  # a form's name inside a word is not the form


def test_the_grammar_names_a_definition_and_marks_variables_keywords_and_comments():
    definition = re.compile(GRAMMAR["repository"]["definition"]["match"])
    assert definition.search("(define-rap (go-to ?place)").group(2) == "go-to"
    assert definition.search("(define-memory-rule at-is-unique").group(4) == "at-is-unique"
    assert re.fullmatch(GRAMMAR["repository"]["variable"]["match"], "?place")
    assert re.fullmatch(GRAMMAR["repository"]["keyword"]["match"], ":succeed")
    comments = GRAMMAR["repository"]["comment"]["patterns"]
    assert re.search(comments[0]["match"], "(post (x)) ; a comment").group() == "; a comment"


def test_the_extension_declares_both_languages_and_starts_atlas_lsp():
    package = json.loads((VSCODE / "package.json").read_text())
    languages = {language["id"]: language["extensions"] for language in package["contributes"]["languages"]}
    assert languages == {"rap": [".rap"], "ap": [".ap"]}
    setting = package["contributes"]["configuration"]["properties"]["atlasRap.server.command"]
    assert setting["default"] == ["atlas", "lsp"]
    assert "vscode-languageclient" in package["dependencies"]
    assert "atlasRap" in (VSCODE / "extension.js").read_text()
    json.loads((VSCODE / "language-configuration.json").read_text())

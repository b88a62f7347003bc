"""The language server's index on its own (atlas_rap.cli.lsp_index): words, problems and outlines from text."""

from __future__ import annotations

from atlas_rap.cli import check, lsp_index
from atlas_rap.plugins import PluginError


def test_the_word_under_the_cursor_and_whether_it_heads_a_list():
    lines = ["(define-rap (go-to ?place)", "  (t1 (navigate-to office)))"]
    word = lsp_index.word_at(lines, 1, 10)
    assert (word.text, word.start, word.end, word.heads_list) == ("navigate-to", 7, 18, True)
    assert lsp_index.word_at(lines, 1, 20).text == "office" and not lsp_index.word_at(lines, 1, 20).heads_list
    assert lsp_index.word_at(lines, 0, 0) is None  # on a parenthesis
    assert lsp_index.word_at(lines, 5, 0) is None  # past the last line


def test_a_token_ends_at_its_closing_parenthesis_or_at_its_last_character():
    assert lsp_index.token_end("  (t1 (go-too lab)))", 6) == 18
    assert lsp_index.token_end("  (t1 (go-too lab)))", 7) == 13


def test_an_installed_plugin_that_does_not_load_is_a_problem_of_the_file_not_a_crash(monkeypatch):
    def broken(program, path, robots=()):
        raise PluginError("plugin ghost (entry point atlas_rap.skills: ghost) failed to load: ModuleNotFoundError")

    monkeypatch.setattr(check, "program_problems", broken)
    problems, program = lsp_index.diagnose("(define-rap (x) (method (task-net (t1 (spin)))))\n", "m.rap")
    (problem,) = problems
    assert program is None and "plugin ghost" in problem.message
    assert (problem.location.file, problem.location.line, problem.location.column) == ("m.rap", 1, 1)


def test_the_outline_names_each_definition_and_spans_its_form():
    text = "; rules\n(define-memory-rule one (on (a ?x)) (retract (b ?x)))\n(define-rap (go ?p)\n  (method (task-net (t1 (spin)))))\n"
    (rule, rap) = lsp_index.outline(text, "m.rap")
    assert (rule.kind, rule.name, rule.start, rule.selection) == ("memory rule", "one", (1, 0), (1, 20, 23))
    assert (rap.kind, rap.name, rap.start, rap.end) == ("RAP", "go", (2, 0), (3, 34))  # to just past its closing parenthesis

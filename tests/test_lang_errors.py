"""Every kind of bad input gets a located, readable error: message, line, column."""

from __future__ import annotations

from pathlib import Path

import pytest

from atlas_rap.errors import SourceError
from atlas_rap.lang import load

from source_problems import at, only_problem, problems_of


def test_an_unclosed_paren_points_at_the_list_that_never_closes():
    problem = only_problem("(define-rap (a)\n  (succeed (b))\n(define-rap (c))\n")
    assert problem.message == "unbalanced '(': this list is never closed"
    assert at(problem) == (1, 1)
    assert "line 3 starts in column 1" in problem.hint


def test_a_stray_close_paren_is_reported_where_it_stands():
    problem = only_problem("(define-rap (a)\n  (succeed (b))))\n")
    assert problem.message == "unbalanced ')': nothing here to close"
    assert at(problem) == (2, 17)


def test_the_report_shows_the_line_with_a_caret_under_the_column():
    text = only_problem("(define-rap (a)\n  (succeed (b))))\n").render()
    assert text.splitlines() == [
        "bad.rap:2:17: error: unbalanced ')': nothing here to close",
        "      (succeed (b))))",
        "                    ^",
        "  hint: delete this ')' or add the '(' it was meant to close",
    ]


def test_an_unterminated_string_points_at_its_opening_quote():
    problem = only_problem('(world "lab)\n(post (go))\n')
    assert problem.message == "unterminated string"
    assert at(problem) == (1, 8)


def test_an_unterminated_block_comment_points_at_its_start():
    problem = only_problem("(a)\n  #| never closed\n(b)\n")
    assert problem.message == "unterminated block comment"
    assert at(problem) == (2, 3)


def test_an_unknown_clause_suggests_the_nearest_clause_name():
    problem = only_problem("(define-rap (go ?x)\n  (sucede (at ?x))\n  (method (primitive (enable (m)))))\n")
    assert problem.message == "unknown clause 'sucede'"
    assert problem.hint == "did you mean 'succeed'?"
    assert at(problem) == (2, 4)


def test_an_unknown_top_level_form_suggests_the_nearest_form():
    problem = only_problem("(define-rapp (go))\n")
    assert problem.message == "unknown top-level form 'define-rapp'"
    assert problem.hint == "did you mean 'define-rap'?"
    assert at(problem) == (1, 2)


def test_a_method_with_no_body_says_so():
    problem = only_problem("(define-rap (go)\n  (method (context (ready))))\n")
    assert problem.message == "method has no body"
    assert at(problem) == (2, 3)
    empty = only_problem("(define-rap (go)\n  (method))\n")
    assert empty.message == "method has no context or body"


def test_a_clause_given_twice_names_the_first_one():
    problem = only_problem("(define-rap (go)\n  (succeed (a))\n  (succeed (b))\n"
                           "  (method (primitive (enable (m)))))\n")
    assert problem.message == "clause 'succeed' given twice in define-rap (first at line 2)"
    assert at(problem) == (3, 4)


def test_a_variable_where_a_name_must_stand_is_an_error():
    problem = only_problem("(define-rap (?task ?x)\n  (method (primitive (enable (m)))))\n")
    assert problem.message == "a variable cannot stand as a name at the head of a RAP head; found ?task"
    assert at(problem) == (1, 14)
    label = only_problem("(define-rap (go)\n  (method (task-net (?t1 (walk)))))\n")
    assert "a variable cannot stand as a task name or step label" in label.message
    assert at(label) == (2, 22)


def test_every_problem_in_a_file_is_reported_not_only_the_first():
    problems = problems_of(
        "(define-rap (go)\n"
        "  (sucede (at robot))\n"
        "  (timeout fast)\n"
        "  (method (context (x))))\n"
        "(operator move :purpos (at ?x))\n"
        "(initial-memory (at robot ?where))\n")
    assert [(p.message, at(p)) for p in problems] == [
        ("unknown clause 'sucede'", (2, 4)),
        ("timeout must be a number, found 'fast'", (3, 12)),
        ("method has no body", (4, 3)),
        ("unknown operator part 'purpos'", (5, 16)),
        ("a fact in initial-memory must be ground, but (at robot ?where) has a variable", (6, 17)),
    ]


def test_a_for_annotation_must_name_a_step_of_the_method():
    problem = only_problem("(define-rap (go)\n  (method (task-net\n    (t1 (a) (for t3))\n    (t2 (b)))))\n")
    assert problem.message == "no step labelled 't3' in this method"
    assert problem.hint == "the labels in this method are t1, t2"
    assert at(problem) == (3, 5)


def test_a_bad_variable_name_is_an_error():
    problem = only_problem("(post (go ?-x))\n")
    assert problem.message == "bad variable name '?-x'"
    assert at(problem) == (1, 11)


def test_wait_for_with_a_bad_timeout_is_an_error():
    problem = only_problem("(define-rap (go)\n  (method (task-net (wait-for (at robot) :timeout soon))))\n")
    assert problem.message == ":timeout must be a number, found 'soon'"
    assert at(problem) == (2, 51)


def write(tmp_path: Path, name: str, content: str | bytes) -> Path:
    path = tmp_path / name
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return path


def load_problems(path: Path) -> list:
    with pytest.raises(SourceError) as caught:
        load(path)
    return caught.value.problems


def test_a_missing_include_is_reported_at_the_include(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "main.rap", '(world none)\n  (include "lib/nav.rap")\n')
    (problem,) = load_problems(tmp_path / "main.rap")
    assert problem.message == "included file not found: lib/nav.rap (looked for lib/nav.rap)"
    assert (problem.location.file, *at(problem)) == ("main.rap", 2, 3)
    assert problem.source_line == '  (include "lib/nav.rap")'


def test_an_include_cycle_is_reported_with_its_chain(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "a.rap", '(include "b.rap")\n')
    write(tmp_path, "b.rap", '(world none)\n(include "a.rap")\n')
    (problem,) = load_problems(tmp_path / "a.rap")
    assert problem.message == "include cycle: a.rap -> b.rap -> a.rap"
    assert (problem.location.file, *at(problem)) == ("b.rap", 2, 1)


def test_a_file_that_is_not_utf8_names_the_bad_byte(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "latin.rap", "(post (greet \"Jos".encode() + b"\xe9\"))\n")
    (problem,) = load_problems(tmp_path / "latin.rap")
    assert problem.message == "file is not UTF-8 text (byte 0xe9 at offset 17)"
    assert at(problem) == (1, 18)


def test_an_empty_file_is_an_error(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "empty.rap", "\n  \n")
    (problem,) = load_problems(tmp_path / "empty.rap")
    assert problem.message == "file is empty"
    write(tmp_path, "comments.rap", "; nothing but a comment\n")
    (problem,) = load_problems(tmp_path / "comments.rap")
    assert problem.message == "file has no forms (only white space and comments)"


def test_a_ten_megabyte_file_is_refused_with_advice(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "huge.rap", "(initial-memory (a b))\n" * (10 * 1024 * 1024 // 23 + 1))
    (problem,) = load_problems(tmp_path / "huge.rap")
    assert problem.message.startswith("file is too large (10.")
    assert "include" in problem.hint


def test_deep_nesting_is_refused_instead_of_crashing():
    problem = only_problem("(post (go " + "(" * 500 + ")" * 500 + "))\n")
    assert problem.message == "lists nested more than 200 deep"

"""Tests of the REPL input layer: completeness, colouring, completion, history, session."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from prompt_toolkit.completion import CompleteEvent
from prompt_toolkit.document import Document
from prompt_toolkit.input import create_pipe_input
from prompt_toolkit.output import DummyOutput

from atlas_rap.cli.repl_input import (
    REPL_STYLE,
    ReplCompleter,
    SexpLexer,
    history_path,
    is_complete,
    make_prompt_session,
)

# --------------------------------------------------------------------------
# is_complete
# --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        "",
        "   \n\t ",
        "; just a comment (",
        "#| a block ( comment |#",
        "; one\n  ; two ((\n",
        "(a)",
        "(define-rap (greet)\n  (method (task-net (t1 (wave)))))",
        "foo",
        "42",
        '"a string"',
        '(say "(")',
        '(say ")(")',
        '(say "a \\" quote (")',
        '(say "back\\\\")',
        "(a ; (\n)",
        "(a #| ( |# )",
        "(a)(b)",
        "(a b) ; trailing (",
        "())",
        ")",
        ")(",
        "(a))(b",
        ":run 5",
        ":agenda",
        "  :memory (at ?x ?y)",
        ':load "f(.rap"',
        "a#|b",
        '(say "two\nlines")',
    ],
)
def test_complete(text: str) -> None:
    assert is_complete(text)


@pytest.mark.parametrize(
    "text",
    [
        "(",
        "(a",
        "(define-rap (greet)",
        "(define-rap (greet)\n  (method (task-net (t1 (wave))))",
        "((a)",
        '"open',
        '(say "a)',
        '(say "a \\")',
        '"ends in a backslash \\',
        "(a ; )",
        "(a #| ) |#",
        "#| unterminated",
        "(a) #| unterminated )",
        ":memory (at ?x",
        ':load "file',
        "; comment\n(a",
    ],
)
def test_incomplete(text: str) -> None:
    assert not is_complete(text)


# --------------------------------------------------------------------------
# SexpLexer
# --------------------------------------------------------------------------


def _lines(text: str) -> list[list[tuple[str, str]]]:
    get_line = SexpLexer().lex_document(Document(text))
    return [[(style, part) for style, part, *_ in get_line(i)] for i in range(text.count("\n") + 1)]


def _classes(line: list[tuple[str, str]]) -> dict[str, str]:
    return {part: style for style, part in line if part.strip()}


def test_lexer_classes_on_a_define_rap() -> None:
    text = (
        "(define-rap (go-to ?place) ; move\n"
        '  (timeout 2.5) (say "hi (there)\n'
        'second line") #| block\n'
        "still |# (priority -3) :outcome)"
    )
    lines = _lines(text)
    assert len(lines) == 4
    # every line's fragments put back together give the line
    assert ["".join(part for _, part in line) for line in lines] == text.split("\n")

    first = _classes(lines[0])
    assert first["("] == "class:paren"
    assert first["define-rap"] == "class:head"
    assert first["go-to"] == "class:head"
    assert first["?place"] == "class:variable"
    assert first["; move"] == "class:comment"

    second = _classes(lines[1])
    assert second["timeout"] == "class:head"
    assert second["2.5"] == "class:number"
    assert second["say"] == "class:head"
    assert second['"hi (there)'] == "class:string"  # the string runs on ...

    third = _classes(lines[2])
    assert third['second line"'] == "class:string"  # ... onto the next line
    assert third["#| block"] == "class:comment"

    fourth = _classes(lines[3])
    assert fourth["still |#"] == "class:comment"
    assert fourth["priority"] == "class:head"
    assert fourth["-3"] == "class:number"
    assert fourth[":outcome"] == "class:keyword"


def test_lexer_command_line_and_stray_paren() -> None:
    (line,) = _lines(":memory (at ?x robot) :limit 3)")
    assert line[0] == ("class:command", ":memory")
    classes = [style for style, part in line if part.strip()]
    assert classes == [
        "class:command",
        "class:paren",
        "class:head",
        "class:variable",
        "",  # a plain symbol
        "class:paren",
        "class:keyword",
        "class:number",
        "class:paren.unmatched",
    ]


def test_lexer_plain_symbols_and_line_past_the_end() -> None:
    get_line = SexpLexer().lex_document(Document("(a b)"))
    assert get_line(0)[3] == ("", "b")
    assert get_line(5) == []


def test_style_has_every_class() -> None:
    rules = {name for name, _ in REPL_STYLE.style_rules}
    assert {"paren", "keyword", "variable", "string", "comment", "number", "head", "command"} <= rules


# --------------------------------------------------------------------------
# ReplCompleter
# --------------------------------------------------------------------------

NAMES = {
    "command": [":agenda", ":memory", ":help"],
    "rap": ["greet", "go-to", "attach-at-site"],
    "skill": ["gripper", "grip-attach", "greet"],
    "predicate": ["at", "docked"],
    "place": ["Garage", "dock-1"],
}


def _complete(text: str, cursor: int | None = None) -> list[tuple[str, str]]:
    completer = ReplCompleter(lambda: NAMES)
    document = Document(text, len(text) if cursor is None else cursor)
    return [
        (c.text, c.display_meta_text)
        for c in completer.get_completions(document, CompleteEvent(completion_requested=True))
    ]


def test_completer_by_prefix_with_meta_in_category_order() -> None:
    assert _complete("(g") == [
        ("go-to", "rap"),
        ("greet", "rap"),
        ("grip-attach", "skill"),
        ("gripper", "skill"),
        ("Garage", "place"),
    ]


def test_completer_ignores_case_and_replaces_the_word() -> None:
    completer = ReplCompleter(lambda: NAMES)
    (completion,) = completer.get_completions(Document("(at robot GAR"), CompleteEvent())
    assert completion.text == "Garage"
    assert completion.start_position == -3
    assert _complete("(DOC") == [("docked", "predicate"), ("dock-1", "place")]


def test_completer_commands_only_at_the_start() -> None:
    assert _complete(":m") == [(":memory", "command")]
    assert _complete("  :a") == [(":agenda", "command")]
    assert _complete("(foo :m") == []
    assert _complete(":memory (d") == [("docked", "predicate"), ("dock-1", "place")]
    assert (":help", "command") not in _complete("(")


def test_completer_no_completion_for_variables_strings_comments() -> None:
    assert _complete("(at ?g") == []
    assert _complete('(say "g') == []
    assert _complete("(a) ; g") == []
    assert _complete("#| g") == []
    assert _complete('(say "g" g') != []


def test_completer_completes_the_word_before_the_cursor() -> None:
    assert _complete("(at dock)", cursor=8) == [("docked", "predicate"), ("dock-1", "place")]


def test_completer_calls_names_each_time() -> None:
    names: dict[str, list[str]] = {"rap": ["alpha"]}
    completer = ReplCompleter(lambda: names)
    assert [c.text for c in completer.get_completions(Document("(a"), CompleteEvent())] == ["alpha"]
    names["rap"].append("apex")
    assert [c.text for c in completer.get_completions(Document("(a"), CompleteEvent())] == ["alpha", "apex"]


# --------------------------------------------------------------------------
# history_path
# --------------------------------------------------------------------------


def test_history_path_honours_atlas_rap_data_dir(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    data_dir = tmp_path / "nested" / "data"
    monkeypatch.setenv("ATLAS_RAP_DATA_DIR", str(data_dir))
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert history_path() == data_dir / "repl-history"
    assert data_dir.is_dir()


def test_history_path_falls_back_to_xdg_then_home(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("ATLAS_RAP_DATA_DIR", raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert history_path() == tmp_path / "xdg" / "atlas-rap" / "repl-history"
    assert (tmp_path / "xdg" / "atlas-rap").is_dir()

    monkeypatch.delenv("XDG_DATA_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert history_path() == tmp_path / "home" / ".local" / "share" / "atlas-rap" / "repl-history"
    assert (tmp_path / "home" / ".local" / "share" / "atlas-rap").is_dir()


# --------------------------------------------------------------------------
# make_prompt_session
# --------------------------------------------------------------------------


def _prompt(keys: str, **kwargs) -> str:
    with create_pipe_input() as pipe:
        session = make_prompt_session(input=pipe, output=DummyOutput(), **kwargs)
        pipe.send_text(keys)
        return session.prompt()


def test_session_enter_submits_only_when_complete(tmp_path: Path) -> None:
    history_file = tmp_path / "repl-history"
    text = _prompt("(define-rap (greet)\r  (method (task-net (t1 (wave)))))\r", history_file=history_file)
    lines = text.split("\n")
    assert len(lines) == 2
    assert lines[0] == "(define-rap (greet)"
    assert lines[1].strip() == "(method (task-net (t1 (wave)))))"
    assert lines[1].startswith("  ")  # indented inside define-rap
    assert "(define-rap (greet)" in history_file.read_text()
    assert "(method (task-net (t1 (wave)))))" in history_file.read_text()


def test_session_lisp_indentation() -> None:
    text = _prompt("(define-rap (greet)\r(method\r(task-net (wave))))\r")
    assert text == "(define-rap (greet)\n  (method\n    (task-net (wave))))"


def test_session_no_indent_inside_a_string() -> None:
    assert _prompt('(say "a\rb")\r') == '(say "a\nb")'


def test_session_commands_and_blank_submit_at_once() -> None:
    assert _prompt(":run 5\r") == ":run 5"
    assert _prompt("\r") == ""


def test_session_escape_enter_always_submits() -> None:
    assert _prompt("(define-rap (half\x1b\r") == "(define-rap (half"


def _send_when(pipe, session, ready: Callable[[str], bool], keys: str) -> threading.Thread:
    """Send ``keys`` once the buffer text satisfies ``ready`` (completion is asynchronous)."""

    def wait_and_send() -> None:
        deadline = time.monotonic() + 10
        while not ready(session.default_buffer.text) and time.monotonic() < deadline:
            time.sleep(0.01)
        pipe.send_text(keys)

    thread = threading.Thread(target=wait_and_send, daemon=True)
    thread.start()
    return thread


def test_session_tab_completes() -> None:
    completer = ReplCompleter(lambda: {"command": [":run"], "rap": ["greet"]})
    with create_pipe_input() as pipe:
        session = make_prompt_session(completer, input=pipe, output=DummyOutput())
        pipe.send_text("(gr\t")
        _send_when(pipe, session, lambda text: text == "(greet", ")\r")
        assert session.prompt() == "(greet)"


def test_session_enter_accepts_a_highlighted_completion() -> None:
    completer = ReplCompleter(lambda: {"rap": ["greet", "grab"]})
    with create_pipe_input() as pipe:
        session = make_prompt_session(completer, input=pipe, output=DummyOutput())
        pipe.send_text("(g\t")  # inserts the common part "gr" and opens the menu
        # a second Tab highlights "grab"; Enter keeps it without submitting
        _send_when(pipe, session, lambda text: text == "(gr", "\t\r")
        _send_when(pipe, session, lambda text: text == "(grab" and session.default_buffer.complete_state is None, ")\r")
        assert session.prompt() == "(grab)"


def test_session_history_is_loaded_from_the_file(tmp_path: Path) -> None:
    history_file = tmp_path / "repl-history"
    _prompt("(first)\r", history_file=history_file)
    _prompt("(second)\r", history_file=history_file)
    # Up arrow twice walks back to the first entry.
    assert _prompt("\x1b[A\x1b[A\r", history_file=history_file) == "(first)"

"""The input layer of ``atlas repl``: completeness, colouring, completion, history.

The REPL engine (``repl_session.py``) and the command (``repl.py``) build on
these pieces; nothing here knows about the sequencer or memory.

Choices made (the lexical rules are in docs/language/index.md):

- One small tokenizer (``_tokens``) mirrors ``lang/grammar.lark``: white
  space; ``;`` comments to end of line; ``#| ... |#`` block comments (not
  nested, like the reader; ``#|`` starts one only where a token may start, so
  ``a#|b`` is one atom, as for the reader); ``(`` and ``)``; ``"..."``
  strings with backslash escapes (they may span lines); and atoms (any run of
  characters other than white space, parentheses, ``"`` and ``;``). An
  unterminated string or block comment runs to the end of the text.
- ``is_complete``: the text is ready to submit when it is blank or only
  comments, or when every ``(`` outside strings and comments is closed and no
  string or block comment is left open. A stray ``)`` (one with no ``(`` to
  close) makes the text complete at once, whatever follows: the reader will
  report it with a caret, and waiting for more input would not help. A REPL
  command (first non-blank character ``:``, e.g. ``:run 5`` or
  ``:memory (at ?x ?y)``) follows the same rule, so it is complete on one
  line unless its parentheses, a string or a block comment are still open.
- ``SexpLexer`` lexes the whole document at each call and splits the
  fragments per line, so multi-line strings and block comments colour
  correctly. The first symbol after ``(`` (white space and comments may come
  between) is the ``head``; numbers follow the reader (what Python's
  ``int``/``float`` accept, except nan/inf); ``?x`` and a lone ``?`` are
  variables; ``:x`` is a keyword, except the first word of a command line,
  which is the ``command``. A ``)`` with nothing to close is styled
  ``class:paren.unmatched`` (shown red; it still matches ``class:paren``).
  Plain symbols and white space have no class.
- ``REPL_STYLE`` uses the terminal's own ANSI colours (they follow the
  user's theme, dark or light) plus a mid grey for comments.
- ``ReplCompleter`` completes the word before the cursor (not inside a
  string or comment, not a ``?variable``); the names of the ``command``
  category are offered only when the word is the first thing in the input;
  a name listed under two categories is offered once, under the first.
- ``make_prompt_session``: Enter accepts a highlighted completion when the
  completion menu is open; otherwise it submits when ``is_complete`` holds,
  else inserts a newline and indents Lisp-style: two spaces past the column
  of the innermost ``(`` still open before the cursor (for a line that opens
  a form this is "the current line's indentation + 2"; after a line that
  closes its own forms it lines up with its siblings, as in the language reference's examples).
  Outside any paren the current line's indentation is kept; inside an open
  string no indentation is added (it would become part of the string).
  Escape Enter always submits. History that cannot be read or written (a
  read-only directory, say) is skipped silently rather than ending the REPL.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any, NamedTuple

from prompt_toolkit import PromptSession
from prompt_toolkit.completion import CompleteEvent, Completer, Completion
from prompt_toolkit.document import Document
from prompt_toolkit.enums import DEFAULT_BUFFER
from prompt_toolkit.filters import emacs_insert_mode, has_focus, vi_insert_mode
from prompt_toolkit.formatted_text import StyleAndTextTuples
from prompt_toolkit.history import FileHistory, History, InMemoryHistory
from prompt_toolkit.key_binding import KeyBindings, KeyPressEvent
from prompt_toolkit.lexers import Lexer
from prompt_toolkit.styles import Style

__all__ = [
    "CONTINUATION",
    "PROMPT",
    "REPL_STYLE",
    "ReplCompleter",
    "SexpLexer",
    "history_path",
    "is_complete",
    "make_prompt_session",
]

PROMPT = "atlas> "
"""The first-line prompt."""

CONTINUATION = "...> "
"""The continuation prompt, right-aligned to the width of ``PROMPT``."""

# --------------------------------------------------------------------------
# Tokens
# --------------------------------------------------------------------------

# Order matters: a terminated string/block comment is tried before the
# unterminated one, and an atom never starts with '#|' because the block
# comment alternatives come first. Every character starts some alternative.
_TOKEN_RE = re.compile(
    r"""
      (?P<ws>\s+)
    | (?P<comment>;[^\n]*)
    | (?P<block>\#\|.*?\|\#)
    | (?P<ublock>\#\|.*\Z)
    | (?P<open>\()
    | (?P<close>\))
    | (?P<string>"(?:[^"\\]|\\.)*")
    | (?P<ustring>"(?:[^"\\]|\\.)*\\?\Z)
    | (?P<atom>[^\s()";]+)
    """,
    re.DOTALL | re.VERBOSE,
)

_TRIVIA = frozenset({"ws", "comment", "block", "ublock"})


class _Token(NamedTuple):
    kind: str  # a group name of _TOKEN_RE
    text: str
    start: int


def _tokens(text: str) -> Iterator[_Token]:
    """Split ``text`` into tokens that cover it exactly, in order."""
    pos = 0
    end = len(text)
    while pos < end:
        match = _TOKEN_RE.match(text, pos)
        assert match is not None and match.lastgroup is not None  # total
        yield _Token(match.lastgroup, match.group(), pos)
        pos = match.end()


def _first_significant(tokens: Iterable[_Token]) -> _Token | None:
    for token in tokens:
        if token.kind not in _TRIVIA:
            return token
    return None


def is_complete(text: str) -> bool:
    """Tell whether ``text`` is ready to submit to the REPL.

    True for blank text or text of white space and comments only; for text
    whose parentheses (outside strings and comments) are all closed and with
    no string or block comment left open; and for text with a stray ``)``
    (the reader reports it). REPL commands (``:run 5``,
    ``:memory (at ?x ?y)``) follow the same rule. See the module docstring.
    """
    depth = 0
    for token in _tokens(text):
        if token.kind in ("ustring", "ublock"):
            return False
        if token.kind == "open":
            depth += 1
        elif token.kind == "close":
            depth -= 1
            if depth < 0:
                return True
    return depth == 0


# --------------------------------------------------------------------------
# Colouring
# --------------------------------------------------------------------------


def _is_number(text: str) -> bool:
    """Whether the reader reads the atom ``text`` as a number."""
    try:
        int(text)
        return True
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        return False
    return math.isfinite(value)


def _atom_class(text: str) -> str:
    if text.startswith("?"):
        return "class:variable"
    if text.startswith(":"):
        return "class:keyword"
    if _is_number(text):
        return "class:number"
    return ""


def _fragments(text: str) -> StyleAndTextTuples:
    """Style the whole of ``text``: one fragment per token."""
    tokens = list(_tokens(text))
    first = _first_significant(tokens)
    command = first if first is not None and first.kind == "atom" and first.text.startswith(":") else None
    fragments: StyleAndTextTuples = []
    depth = 0
    after_open = False  # the previous significant token was '('
    for token in tokens:
        kind = token.kind
        if kind == "ws":
            style = ""
        elif kind in _TRIVIA:
            style = "class:comment"
        elif kind in ("string", "ustring"):
            style = "class:string"
        elif kind == "open":
            depth += 1
            style = "class:paren"
        elif kind == "close":
            if depth > 0:
                depth -= 1
                style = "class:paren"
            else:
                style = "class:paren.unmatched"
        elif token is command:
            style = "class:command"
        else:
            style = _atom_class(token.text)
            if after_open and not style:
                style = "class:head"
        if kind not in _TRIVIA:
            after_open = kind == "open"
        fragments.append((style, token.text))
    return fragments


def _split_lines(fragments: StyleAndTextTuples) -> list[StyleAndTextTuples]:
    lines: list[StyleAndTextTuples] = [[]]
    for style, text, *_ in fragments:
        for index, part in enumerate(text.split("\n")):
            if index:
                lines.append([])
            if part:
                lines[-1].append((style, part))
    return lines


class SexpLexer(Lexer):
    """Colours RAP/AP s-expressions and REPL command lines, line by line.

    Style classes: ``paren`` (``paren.unmatched`` for a stray ``)``),
    ``keyword``, ``variable``, ``string``, ``comment``, ``number``, ``head``
    (the symbol right after ``(``) and ``command`` (the leading ``:word`` of
    a command line). The whole document is lexed at each call, so strings
    and block comments that span lines colour correctly.
    """

    def lex_document(self, document: Document) -> Callable[[int], StyleAndTextTuples]:
        """Lex ``document`` and return a function giving each line's fragments."""
        lines = _split_lines(_fragments(document.text))

        def get_line(lineno: int) -> StyleAndTextTuples:
            return lines[lineno] if 0 <= lineno < len(lines) else []

        return get_line


REPL_STYLE = Style.from_dict(
    {
        "paren": "",
        "paren.unmatched": "bold ansired",
        "keyword": "ansimagenta",
        "variable": "ansicyan",
        "string": "ansigreen",
        "comment": "italic #888888",
        "number": "ansiyellow",
        "head": "bold ansiblue",
        "command": "bold",
        "prompt": "bold",
        "prompt.continuation": "#888888",
    }
)
"""The REPL's colours: the terminal's ANSI palette (so they suit dark and
light themes alike) and a mid grey for comments and the continuation prompt."""


# --------------------------------------------------------------------------
# Completion
# --------------------------------------------------------------------------

_WORD_RE = re.compile(r"[\w\-*+/<>=!?.:]*\Z")


class ReplCompleter(Completer):
    """Completes RAP, skill, predicate and place names and REPL commands.

    ``names`` is called at each completion and returns categories mapped to
    names, e.g. ``{"command": [":agenda", ...], "rap": [...], "skill": [...],
    "predicate": [...], "place": [...]}``. The word before the cursor is
    matched by prefix, ignoring case; each completion shows its category as
    ``display_meta``. Completions come in category order, then by name, each
    name once. The ``command`` category is offered only when the word is the
    first thing in the input; ``?variables``, strings and comments get no
    completion.
    """

    def __init__(self, names: Callable[[], Mapping[str, Iterable[str]]]) -> None:
        self.names = names

    def get_completions(self, document: Document, complete_event: CompleteEvent) -> Iterator[Completion]:
        """Yield the completions of the word before the cursor."""
        before = document.text_before_cursor
        match = _WORD_RE.search(before)
        word = match.group() if match else ""
        if word.startswith("?"):
            return
        head = before[: len(before) - len(word)]
        last = None
        for last in _tokens(head):
            pass
        if last is not None and last.kind in ("comment", "ublock", "ustring"):
            return
        at_start = not head.strip()
        prefix = word.lower()
        seen: set[str] = set()
        for category, names in self.names().items():
            if category == "command" and not at_start:
                continue
            matches = sorted(
                {str(name) for name in names if str(name).lower().startswith(prefix)} - seen,
                key=lambda name: (name.lower(), name),
            )
            for name in matches:
                seen.add(name)
                yield Completion(name, start_position=-len(word), display_meta=category)


# --------------------------------------------------------------------------
# History and the prompt session
# --------------------------------------------------------------------------


def history_path() -> Path:
    """Return the REPL history file, creating its directory.

    ``$ATLAS_RAP_DATA_DIR/repl-history`` when that variable is set, else
    ``$XDG_DATA_HOME/atlas-rap/repl-history`` (an empty or relative
    ``XDG_DATA_HOME`` is ignored, as the XDG spec says), else
    ``~/.local/share/atlas-rap/repl-history``. macOS and Windows use the same
    ``~/.local/share`` fallback. An ``OSError`` from creating the directory
    is left to the caller (who may fall back to in-memory history).
    """
    data_dir = os.environ.get("ATLAS_RAP_DATA_DIR")
    if data_dir:
        directory = Path(data_dir).expanduser()
    else:
        xdg = os.environ.get("XDG_DATA_HOME", "")
        base = Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".local" / "share"
        directory = base / "atlas-rap"
    directory.mkdir(parents=True, exist_ok=True)
    return directory / "repl-history"


class _FileHistory(FileHistory):
    """A ``FileHistory`` that skips a history file it cannot read or write."""

    def load_history_strings(self) -> Iterable[str]:
        try:
            return list(super().load_history_strings())
        except OSError:
            return []

    def store_string(self, string: str) -> None:
        try:
            super().store_string(string)
        except OSError:
            pass


def _newline_indent(text_before_cursor: str) -> str | None:
    """The indentation for a new line at the cursor; None inside a string."""
    open_columns: list[int] = []
    last = None
    for last in _tokens(text_before_cursor):
        if last.kind == "open":
            line_start = text_before_cursor.rfind("\n", 0, last.start) + 1
            open_columns.append(last.start - line_start)
        elif last.kind == "close" and open_columns:
            open_columns.pop()
    if last is not None and last.kind == "ustring":
        return None
    if open_columns:
        return " " * (open_columns[-1] + 2)
    current = text_before_cursor[text_before_cursor.rfind("\n") + 1:]
    return current[: len(current) - len(current.lstrip(" \t"))]


def _key_bindings() -> KeyBindings:
    bindings = KeyBindings()
    editing = has_focus(DEFAULT_BUFFER) & (emacs_insert_mode | vi_insert_mode)

    @bindings.add("enter", filter=editing)
    def _enter(event: KeyPressEvent) -> None:
        buffer = event.current_buffer
        state = buffer.complete_state
        if state is not None and state.current_completion is not None:
            buffer.complete_state = None  # keep the highlighted completion
            return
        if is_complete(buffer.text):
            buffer.validate_and_handle()
            return
        indent = _newline_indent(buffer.document.text_before_cursor)
        buffer.insert_text("\n" + (indent or ""))

    @bindings.add("escape", "enter", filter=editing)
    def _submit(event: KeyPressEvent) -> None:
        event.current_buffer.validate_and_handle()

    return bindings


def _continuation(width: int, line_number: int, is_soft_wrap: bool) -> StyleAndTextTuples:
    return [("class:prompt.continuation", CONTINUATION.rjust(width))]


def make_prompt_session(
    completer: Completer | None = None,
    history_file: Path | None = None,
    *,
    input: Any = None,
    output: Any = None,
) -> PromptSession[str]:
    """Build the REPL's multi-line ``PromptSession``.

    Enter submits when ``is_complete`` holds for the whole input, and
    otherwise inserts a newline with Lisp indentation; Escape Enter always
    submits. The prompt is ``atlas> `` and continuation lines show
    ``  ...> ``. Input is coloured by ``SexpLexer`` with ``REPL_STYLE``
    (not under ``NO_COLOR``, ``cli/console.py``);
    Tab completes with ``completer`` (no completion while typing). History
    goes to ``history_file`` when given, else stays in memory. ``input`` and
    ``output`` go to ``PromptSession`` unchanged (tests pass a pipe input and
    ``DummyOutput``).
    """
    from atlas_rap.cli.console import styles_on

    history: History = _FileHistory(str(history_file)) if history_file is not None else InMemoryHistory()
    styled = styles_on()
    return PromptSession(
        message=[("class:prompt", PROMPT)],
        multiline=True,
        prompt_continuation=_continuation,
        lexer=SexpLexer() if styled else None,
        style=REPL_STYLE if styled else Style([]),
        history=history,
        completer=completer,
        complete_while_typing=False,
        key_bindings=_key_bindings(),
        input=input,
        output=output,
    )

"""The first pass: text to s-expressions (``SList``), with positions.

Use :func:`read_text` (or :func:`read_file`) when you need the raw forms of a
RAP or AP file; the validator turns them into typed AST nodes.

Atoms are read straight into logic terms (``atlas_rap.logic``): symbols and
``:keywords`` are lower-cased ``str``, numbers are ``int``/``float``,
``"strings"`` are :class:`~atlas_rap.logic.String`, ``?x`` is ``Var('x')``.
Each anonymous ``?`` becomes its own variable ``Var('_N')``, numbered in
reading order within one file (a name nobody can write, since a variable's
name must start with a letter or digit), so reading the same text twice
gives equal forms.

Positions live on the lists, not on the atoms: ``SList.locs[i]`` is the
(line, column) of ``SList.items[i]``. That keeps atoms plain values, which
is what makes the reader fast.

Choices (docs/language/index.md, Lexical rules):
- string escapes: ``\\n`` is a newline, ``\\t`` a tab, ``\\`` followed by any
  other character is that character;
- ``()`` reads as an empty list (the validator treats it as ``nil``);
- files larger than :data:`MAX_FILE_BYTES` are refused with advice to split
  them with ``include``; lists nested deeper than :data:`MAX_DEPTH` are
  refused (no legitimate RAP comes close, and it keeps every later pass safe
  from Python's recursion limit);
- a number must be one a float can hold: ``1e400`` and an integer of 400
  digits are errors with a caret (every time, priority and fact value
  becomes a float somewhere, and there it would overflow), while ``nan``
  and ``inf`` are symbols, as before; a number too small to tell from zero
  (``1e-400``) reads as 0.0.
"""

from __future__ import annotations

import math
import re
import sys
import threading
from functools import lru_cache
from pathlib import Path
from typing import Union

from lark import Lark, Token, Transformer
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken
from lark.lexer import Lexer

from atlas_rap.errors import (LanguageError, Problem, SourceLocation, decode_source, line_of, read_at_most,
                              source_lines)
from atlas_rap.logic.terms import String, Term, Var

GRAMMAR = Path(__file__).with_name("grammar.lark")
"""The s-expression grammar of RAP and AP files (and of PDDL, which :mod:`atlas_rap.planner.pddl` reads)."""
MAX_FILE_BYTES = 8 * 1024 * 1024
MAX_DEPTH = 200

Datum = Union["SList", Term]


class SList:
    """One parenthesised list as read: its items and where each starts.

    ``line``/``column`` are those of the opening parenthesis; ``end_line`` and
    ``end_column`` those of the closing one. Items are atoms (logic terms) or
    nested ``SList``s.
    """

    __slots__ = ("items", "locs", "line", "column", "end_line", "end_column", "depth")

    def __init__(self, items: tuple, locs: tuple, line: int, column: int,
                 end_line: int, end_column: int, depth: int) -> None:
        self.items = items
        self.locs = locs
        self.line = line
        self.column = column
        self.end_line = end_line
        self.end_column = end_column
        self.depth = depth

    def __len__(self) -> int:
        return len(self.items)

    def __repr__(self) -> str:
        return f"SList({list(self.items)!r} @{self.line}:{self.column})"

    @property
    def head(self) -> Datum | None:
        """The first item, or None for ``()``."""
        return self.items[0] if self.items else None


class Forms(list):
    """The top-level forms of one file, with ``locs`` parallel to the items."""

    def __init__(self, items: list, locs: list) -> None:
        super().__init__(items)
        self.locs = locs


_ESCAPES = {"n": "\n", "t": "\t"}
_UNDECODED = re.compile("[\udc80-\udcff]")
_NUMBER_START = frozenset("0123456789+-.")


class _AtomReader:
    """Classifies ATOM tokens; caches the values of the ones seen before."""

    def __init__(self) -> None:
        self.cache: dict[str, Term] = {}
        self.anonymous = 0
        self.bad_variables: list[Token] = []
        self.bad_numbers: list[Token] = []

    def atom(self, tok: Token) -> Term:
        text = tok.value  # the plain str: Token's own __eq__ makes dict look-ups slow
        value = self.cache.get(text)
        if value is not None:
            return value
        first = text[0]
        if first == "?":
            if text == "?":
                self.anonymous += 1
                return Var(f"_{self.anonymous}")  # unwritable: names start with a letter or digit
            name = text[1:].lower()
            if not name[0].isalnum():
                self.bad_variables.append(tok)
            value = Var(name)
        elif first in _NUMBER_START:
            value = _number(text)
            if value is _TOO_LARGE:
                self.bad_numbers.append(tok)
                return 0  # never used: the read fails with the located error
            if value is None:
                value = text.lower()
        else:
            value = text.lower()
        self.cache[text] = value
        return value

    @staticmethod
    def string(tok: Token) -> String:
        body = tok[1:-1]
        if "\\" not in body:
            return String(body)
        out = []
        chars = iter(body)
        for ch in chars:
            if ch == "\\":
                nxt = next(chars)
                out.append(_ESCAPES.get(nxt, nxt))
            else:
                out.append(ch)
        return String("".join(out))

    def convert(self, children: list) -> tuple[list, list, int]:
        """Items, locations and maximum list depth of a run of children."""
        items = []
        locs = []
        depth = 0
        cache = self.cache
        for child in children:
            if type(child) is SList:
                items.append(child)
                if child.depth > depth:
                    depth = child.depth
            elif child.type == "ATOM":
                value = cache.get(child.value)
                items.append(self.atom(child) if value is None else value)
            else:
                items.append(self.string(child))
            locs.append((child.line, child.column))
        return items, locs, depth


_TOO_LARGE = object()
_LARGEST = sys.float_info.max


def _number(text: str) -> int | float | None | object:
    """The number an atom stands for; None for a symbol; ``_TOO_LARGE`` for a
    number no float can hold (an integer past about 1.8e308, or ``1e400``)."""
    try:
        value = int(text)
    except ValueError:
        pass
    else:
        return value if -_LARGEST <= value <= _LARGEST else _TOO_LARGE
    try:
        value = float(text)
    except ValueError:
        return None
    if math.isfinite(value):
        return value
    if value != value or "inf" in text.lower():
        return None  # 'nan', 'inf' and friends stay symbols
    return _TOO_LARGE  # digits that overflow: 1e400, or an integer longer than int() reads


class _Builder(Transformer):
    """Builds SLists as the LALR parser reduces rules: no parse tree at all."""

    atoms: _AtomReader | None = None

    def list(self, children: list) -> SList:
        lpar = children[0]
        rpar = children[-1]
        items, locs, depth = self.atoms.convert(children[1] if len(children) == 3 else ())
        return SList(tuple(items), tuple(locs), lpar.line, lpar.column,
                     rpar.line, rpar.column, depth + 1)

    @staticmethod
    def items(children: list) -> list:
        if len(children) == 1:
            return children  # Lark's own list, handed over
        items, item = children
        items.append(item)
        return items

    @staticmethod
    def start(children: list) -> list:
        return children[0] if children else []


class _Scanner(Lexer):
    """The grammar's terminals as one regular expression: Lark's ``basic`` lexer, twice as fast.

    The tokens are the ones Lark's lexer gives for grammar.lark (type, text, line and column;
    the tests compare them on every shipped file). The terminals come from the grammar; only the
    bookkeeping is lighter: the line of a token is counted when a token is yielded, not carried
    through every match, and a run of white space and comments is one match. Reading is half
    the CPU time of planning a small PDDL problem, so this is where that time goes.
    """

    def __init__(self, conf) -> None:
        # Lark's own order: priority, then the longest match first
        terminals = sorted(conf.terminals, key=lambda t: (-t.priority, -t.pattern.max_width,
                                                          -len(t.pattern.value), t.name))
        self.pattern = re.compile("|".join(f"(?P<{t.name}>{t.pattern.to_regexp()})" for t in terminals),
                                  conf.g_regex_flags)
        self.ignore = frozenset(conf.ignore)
        self.allowed = {t.name for t in terminals} - self.ignore

    def lex(self, text: str):
        """Yield the tokens of ``text``; raises Lark's ``UnexpectedCharacters`` where none matches."""
        match = self.pattern.match
        ignore = self.ignore
        new_token = _NEW_TOKEN
        count, rfind = text.count, text.rfind
        pos, end = 0, len(text)
        line, line_start, counted = 1, 0, 0  # the text before `counted` is counted into `line`
        while pos < end:
            found = match(text, pos)
            if found is None:
                line += count("\n", counted, pos)
                raise UnexpectedCharacters(text, pos, line, pos - rfind("\n", 0, pos), allowed=self.allowed)
            kind = found.lastgroup
            if kind not in ignore:
                newlines = count("\n", counted, pos)
                if newlines:
                    line += newlines
                    line_start = rfind("\n", counted, pos) + 1
                counted = pos
                yield new_token(kind, found.group(), pos, line, pos - line_start + 1)
            pos = found.end()


# Token(type, value, start_pos, line, column) without its check for a deprecated keyword (half the
# cost of making a token); a Lark release without that private name gets the public constructor
_NEW_TOKEN = getattr(Token, "_future_new", Token)

# One parser and one builder per process; the lock gives each read its own atom state.
_BUILDER = _Builder()
_READ_LOCK = threading.Lock()


@lru_cache(maxsize=1)
def _parser() -> Lark:
    # beside this module, as shipped.py finds the shipped folders (importlib.resources' first
    # call costs 2 ms, as much as reading a small PDDL problem)
    grammar = GRAMMAR.read_text(encoding="utf-8")
    # cache=True keeps the LALR tables in the temp folder: 1 ms to load instead of 13 ms
    # to build, at every start of the CLI (Lark rebuilds them if the file is unusable).
    return Lark(grammar, parser="lalr", lexer=_Scanner, maybe_placeholders=False,
                transformer=_BUILDER, cache=True)


def read_text(text: str, filename: str = "<input>") -> Forms:
    """Read every top-level form of ``text``.

    Raises :class:`~atlas_rap.errors.LanguageError` (never a Lark exception) for
    unbalanced parentheses, an unterminated string or block comment, a bad
    variable name, or nesting deeper than :data:`MAX_DEPTH`.
    """
    undecoded = _UNDECODED.search(text)
    if undecoded is not None:  # bytes that were not UTF-8, kept as surrogates (the REPL's stdin)
        start = undecoded.start()
        line = text.count("\n", 0, start) + 1
        column = start - (text.rfind("\n", 0, start) + 1) + 1
        raise LanguageError(Problem(
            f"not UTF-8 text (byte 0x{ord(undecoded.group()) - 0xDC00:02x})", SourceLocation(filename, line, column),
            _line(text, line).encode("utf-8", "replace").decode("utf-8"), "type or save the text as UTF-8"))
    atoms = _AtomReader()

    with _READ_LOCK:
        _BUILDER.atoms = atoms
        try:
            children = _parser().parse(text)
        except UnexpectedInput as exc:
            raise LanguageError(_syntax_problem(exc, text, filename)) from None
        finally:
            _BUILDER.atoms = None

    items, locs, depth = atoms.convert(children)
    if atoms.bad_numbers:
        raise LanguageError([_too_large(tok, text, filename) for tok in atoms.bad_numbers])
    if atoms.bad_variables:
        tok = atoms.bad_variables[0]
        raise LanguageError(Problem(
            f"bad variable name '{tok}'", SourceLocation(filename, tok.line, tok.column),
            _line(text, tok.line),
            "a variable is '?' followed by a letter or digit, e.g. ?site; '?' alone is anonymous"))
    if depth > MAX_DEPTH:
        line, column = _deepest_open(text, MAX_DEPTH)
        raise LanguageError(Problem(
            f"lists nested more than {MAX_DEPTH} deep", SourceLocation(filename, line, column),
            _line(text, line), "flatten the form; no RAP or operator needs this depth"))
    return Forms(items, locs)


def _too_large(tok: Token, text: str, filename: str) -> Problem:
    digits = tok.value if len(tok.value) <= 24 else f"{tok.value[:12]}...{tok.value[-6:]} ({len(tok.value)} characters)"
    return Problem(f"number too large: {digits}", SourceLocation(filename, tok.line, tok.column),
                   _line(text, tok.line),
                   f"numbers go up to about {_LARGEST:.1e}: write a smaller one (for no time limit, "
                   f"leave the limit out)")


def read_file(path: str | Path, display_name: str | None = None) -> tuple[Forms, str]:
    """Read a file's forms; returns them with the decoded text.

    The file must be UTF-8, non-empty and at most :data:`MAX_FILE_BYTES`.
    ``display_name`` is how errors name the file (default: the path as given).
    """
    name = display_name or str(path)
    text = decode_source(_read_bytes(Path(path), name), name, error=LanguageError)
    forms = read_text(text, name)
    if not forms:
        raise LanguageError(Problem(
            "file has no forms (only white space and comments)",
            SourceLocation(name, 1, 1), None,
            "a .rap file holds (define-rap ...) and mission forms; an .ap file holds operators"))
    return forms, text


def _read_bytes(path: Path, name: str) -> bytes:
    where = SourceLocation(name, 1, 1)
    try:
        data = read_at_most(path, MAX_FILE_BYTES)
        if len(data) > MAX_FILE_BYTES:
            size = max(path.stat().st_size, len(data))
            raise LanguageError(Problem(
                f"file is too large ({size / 1e6:.1f} MB; the limit is {MAX_FILE_BYTES // (1024 * 1024)} MiB)",
                where, None, "split it into smaller files joined with (include \"part.rap\")"))
    except IsADirectoryError:
        raise LanguageError(Problem("is a directory, not a file", where, None,
                                  "name the .rap or .ap files inside it")) from None
    except FileNotFoundError:
        raise LanguageError(Problem("no such file", where, None, "check the path")) from None
    except PermissionError:
        raise LanguageError(Problem("permission denied", where)) from None
    except OSError as exc:
        raise LanguageError(Problem(f"cannot read file: {exc.strerror}", where)) from None
    if not data.strip():
        raise LanguageError(Problem("file is empty", where, None,
                                  "write at least one form, e.g. (define-rap (my-task) ...)"))
    return data


def _line(text: str, line: int) -> str | None:
    return line_of(source_lines(text), line)


def _syntax_problem(exc: UnexpectedInput, text: str, filename: str) -> Problem:
    if isinstance(exc, UnexpectedCharacters):
        line, column = exc.line, exc.column
        where = SourceLocation(filename, line, column)
        char = text[exc.pos_in_stream]
        if char == '"':
            return Problem("unterminated string", where, _line(text, line),
                           'close it with a matching \'"\' (write \\" for a quote inside a string)')
        if text.startswith("#|", exc.pos_in_stream):
            return Problem("unterminated block comment", where, _line(text, line),
                           "close it with '|#'")
        return Problem(f"unexpected character {char!r}", where, _line(text, line))
    if isinstance(exc, UnexpectedToken) and exc.token.type == "RPAR":
        tok = exc.token
        return Problem("unbalanced ')': nothing here to close", SourceLocation(filename, tok.line, tok.column),
                       _line(text, tok.line), "delete this ')' or add the '(' it was meant to close")
    if isinstance(exc, (UnexpectedEOF, UnexpectedToken)):
        return _unclosed_problem(text, filename)
    return Problem("syntax error", SourceLocation(filename, getattr(exc, "line", 1) or 1,
                                                  getattr(exc, "column", 1) or 1))


def _open_parens(text: str):
    """Yield (event, line, column) for '(' and ')' outside strings and comments."""
    for tok in _parser().lex(text, dont_ignore=False):
        if tok.type in ("LPAR", "RPAR"):
            yield tok.type, tok.line, tok.column


def _unclosed_problem(text: str, filename: str) -> Problem:
    stack: list[tuple[int, int]] = []
    suspicious: tuple[int, int] | None = None
    for kind, line, column in _open_parens(text):
        if kind == "LPAR":
            if stack and column == 1 and suspicious is None:
                suspicious = (line, column)
            stack.append((line, column))
        else:
            stack.pop()
    line, column = stack[0] if stack else (1, 1)
    hint = "add the missing ')'"
    if suspicious is not None:
        hint += (f"; the form at line {suspicious[0]} starts in column 1, so the ')' is "
                 f"probably missing before it")
    return Problem("unbalanced '(': this list is never closed", SourceLocation(filename, line, column),
                   _line(text, line), hint)


def _deepest_open(text: str, limit: int) -> tuple[int, int]:
    depth = 0
    for kind, line, column in _open_parens(text):
        depth += 1 if kind == "LPAR" else -1
        if depth > limit:
            return line, column
    return 1, 1

"""The ``AtlasError`` family: every error a user of atlas-rap can see.

This module is a leaf: it imports nothing of ours, so every subpackage
(``logic`` included) can raise these. The CLI catches ``AtlasError`` and
prints ``str(error)``; anything else reaching the CLI is a bug in atlas-rap.

Errors that point into a source file carry a :class:`SourceLocation` and
render the offending line with a caret under the column, compiler style::

    missions/deliver.rap:3:5: error: unknown clause 'sucede' in define-rap
        (sucede (docked ?thesite))
         ^
      hint: did you mean 'succeed'?
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable


@dataclass(frozen=True, slots=True)
class SourceLocation:
    """Where a form starts: file name, 1-based line and 1-based column."""

    file: str
    line: int
    column: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


NOWHERE = SourceLocation("<input>", 1, 1)


def source_lines(text: str) -> list[str]:
    """The lines of a source text as the lexer numbers them: split at '\n' only
    (not at form feeds or U+2028, which ``str.splitlines`` also splits at)."""
    return text.split("\n")


def line_of(lines: list[str], line: int) -> str | None:
    """Line ``line`` (1-based) of :func:`source_lines`, or None past the end."""
    return lines[line - 1] if 0 < line <= len(lines) else None


def nearest(word: str, choices: Iterable[str]) -> str | None:
    """The closest of ``choices`` to a misspelt ``word``, or None if none is close."""
    import difflib  # only when a name is wrong

    found = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return found[0] if found else None


def suggestion(name: str, quote: str = "'") -> str:
    """The words of every "did you mean" atlas-rap says: ``did you mean 'NAME'?``."""
    return f"did you mean {quote}{name}{quote}?"


def did_you_mean(word: str, choices: Iterable[str], *, quote: str = "'", end: str = "") -> str | None:
    """The hint for a misspelt ``word``: :func:`suggestion` of the :func:`nearest` of ``choices``,
    followed by ``end``; None when no choice is close."""
    near = nearest(word, choices)
    return None if near is None else suggestion(near, quote) + end


class AtlasError(Exception):
    """Base of every error atlas-rap reports to a user.

    ``str(error)`` is the full, human-readable report; ``exit_code`` is what
    the CLI exits with (1: bad input or a failed mission, 2: bad usage).
    """

    exit_code: int = 1


@dataclass(frozen=True, slots=True)
class Problem:
    """One thing wrong at one place in a source file.

    ``source_line`` is the text of the line (without newline) when it is
    known, so the report can show it with a caret; ``hint`` says what to do.
    """

    message: str
    location: SourceLocation
    source_line: str | None = None
    hint: str | None = None
    severity: str = "error"

    def render(self) -> str:
        """The problem as a compiler-style report with a caret."""
        lines = [f"{self.location}: {self.severity}: {self.message}"]
        if self.source_line is not None:
            text, caret = _window(self.source_line.rstrip("\r").expandtabs(1), self.location.column - 1)
            lines.append(f"    {text}")
            lines.append("    " + " " * caret + "^")
        if self.hint:
            lines.append(f"  hint: {self.hint}")
        return "\n".join(lines)


def _window(text: str, caret: int, width: int = 100) -> tuple[str, int]:
    """A long line cut to ``width`` characters around the caret, marked with '...'."""
    if len(text) <= width:
        return text, max(caret, 0)
    start = max(0, min(caret - width // 2, len(text) - width))
    shown = text[start:start + width]
    if start > 0:
        shown = "..." + shown[3:]
    if start + width < len(text):
        shown = shown[:-3] + "..."
    return shown, caret - start


class SourceError(AtlasError):
    """An error with one or more problems located in source files."""

    def __init__(self, problems: list[Problem] | Problem) -> None:
        self.problems: list[Problem] = problems if isinstance(problems, list) else [problems]
        super().__init__("\n".join(p.render() for p in self.problems))

    @property
    def problem(self) -> Problem:
        """The first problem (the only one, for a syntax error)."""
        return self.problems[0]

    @property
    def location(self) -> SourceLocation:
        """Where the first problem is."""
        return self.problems[0].location


def decode_source(data: bytes, name: str, hint: str = "save the file as UTF-8") -> str:
    """Decode a source file's bytes as UTF-8 (a BOM is allowed); bytes that are not UTF-8 are a
    :class:`SourceError` at their line and column, with the line up to them."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        good = data[: exc.start]
        line = good.count(b"\n") + 1
        column = exc.start - (good.rfind(b"\n") + 1) + 1
        shown = good[good.rfind(b"\n") + 1:].decode("utf-8", "replace")
        raise SourceError(Problem(
            f"file is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})",
            SourceLocation(name, line, column), shown + "\N{REPLACEMENT CHARACTER}", hint)) from None
    return text.removeprefix("\ufeff")

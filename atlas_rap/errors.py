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

Each area has its class (lark's manner: catch the area, or all of atlas-rap)::

    AtlasError
    ├── SourceError                  problems located in files, each with its caret
    │   ├── LanguageError            RAP and AP text: reader, validator, loader, REPL input
    │   ├── WorldFileError           (also a WorldError)
    │   ├── MapFileError             (also a MapError)
    │   ├── PlanFileError            (also a PlanError)
    │   └── RunFileError             (also a RunError)
    ├── WorldError                   a world that cannot be had (an unknown shipped name ...)
    ├── MapError                     a grid or topology that cannot be read or built
    ├── PlanError                    a planning problem or plan that cannot be had
    ├── RunError                     a run, experiment or recording that cannot start or go on
    ├── SkillBusError                the skill bus: BusError, DecodeError, TokenError
    └── LogicError                   memory, queries and rules (``atlas_rap.logic.errors``)

An area's error shows its context with the one machinery of :class:`Problem`:
raise the area's ``...FileError`` with located problems, the area's ``...Error``
with a message. The located ones are :class:`SourceError` too, so code that
catches source errors catches them, and plain ones are not, as before.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
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


def shown_path(path: str | os.PathLike[str]) -> str:
    """How a file is named in messages (a problem's location, a plugin's failure): relative to the
    working directory when it is inside it, else absolute."""
    resolved = Path(path).resolve()
    try:
        return str(resolved.relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(resolved)


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


class LanguageError(SourceError):
    """RAP or AP text that does not read or validate: the reader, the validator, the loader, the REPL's input."""


class WorldError(AtlasError):
    """A world that cannot be had: an unknown shipped world, a directory given for a world file."""


class WorldFileError(WorldError, SourceError):
    """Problems located in a world file (and in the ROS map it names)."""


class MapError(AtlasError):
    """A map that cannot be read or built: a grid or topology file of another kind, a grid too large."""


class MapFileError(MapError, SourceError):
    """Problems located in a map file (a ROS map_server YAML)."""


class PlanError(AtlasError):
    """A planning problem or a plan that cannot be had."""


class PlanFileError(PlanError, SourceError):
    """Problems located in a planning problem or a plan: a PDDL file, an IPC plan file, goals no plan reaches."""


class RunError(AtlasError):
    """A run that cannot start or go on: a mission's needs the world does not meet, a recording not written."""


class RunFileError(RunError, SourceError):
    """Problems located in what a run was given (a mission's forms that do not fit the run)."""


class SkillBusError(AtlasError):
    """The skill bus cannot be used: the transport (``BusError``), a message (``DecodeError``), a token
    (``TokenError``)."""


def read_at_most(path: str | os.PathLike[str], limit: int) -> bytes:
    """The bytes of the file ``path``, but no more than ``limit + 1`` of them: one past the limit
    tells the caller the file is too large, and a device such as /dev/zero, which never ends, is
    read no further. Raises the ``OSError`` of opening or reading it.

    Read with ``os.read`` in one call of the file's size: ``open(...).read(limit + 1)`` would
    build a buffered stream and first allocate the whole limit, three times as long in a new
    process (0.2 ms for a 3 KB PDDL file, a tenth of what planning it takes)."""
    descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    try:
        parts = []
        total = 0
        wanted = min(os.fstat(descriptor).st_size, limit) + 1
        while total <= limit:
            part = os.read(descriptor, wanted)
            if not part:
                break
            parts.append(part)
            total += len(part)
            wanted = min(limit + 1 - total, 1 << 16)  # it grew, or a device that says it is empty
    finally:
        os.close(descriptor)
    return b"".join(parts)


def decode_source(data: bytes, name: str, hint: str = "save the file as UTF-8",
                  error: type[SourceError] = SourceError) -> str:
    """Decode a source file's bytes as UTF-8 (a BOM is allowed); bytes that are not UTF-8 are an
    ``error`` (a :class:`SourceError`) at their line and column, with the line up to them."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        good = data[: exc.start]
        line = good.count(b"\n") + 1
        column = exc.start - (good.rfind(b"\n") + 1) + 1
        shown = good[good.rfind(b"\n") + 1:].decode("utf-8", "replace")
        raise error(Problem(
            f"file is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})",
            SourceLocation(name, line, column), shown + "\N{REPLACEMENT CHARACTER}", hint)) from None
    return text.removeprefix("\ufeff")

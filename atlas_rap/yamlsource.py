"""YAML read with locations: every value keeps its file:line:column, so problems can point at it.

Map files (``maps.rosmap``) and world files (``sim.world``) are YAML that
people write by hand; a wrong key should get the same kind of report as a
wrong RAP: the line, a caret and what to do. :class:`YamlSource` reads a
file into PyYAML *nodes* (``yaml.compose``) and offers typed getters that
record a :class:`~atlas_rap.errors.Problem` at the node instead of raising,
so every problem of a file is reported at once (:meth:`YamlSource.check`).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from yaml.constructor import SafeConstructor
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from atlas_rap.errors import (Problem, SourceError, SourceLocation, decode_source, line_of, nearest, read_at_most,
                              source_lines, suggestion)

MAX_YAML_BYTES = 4 * 1024 * 1024

MAX_COORDINATE = 100_000.0
"""The largest coordinate (metres) of a point, wall or pose read by :meth:`YamlSource.numbers`: a world
is far smaller, and past it a simulated robot's metres lose their millimetres."""

# --------------------------------------------------------------------------
# YAML with locations


@dataclass
class YamlSource:
    """A YAML file parsed into PyYAML nodes, with the problems found in it so far.

    The typed readers (:meth:`number`, :meth:`point`, :meth:`keys` ...) take a
    node and the dotted *key path* that names it (``doors.office-door.between``)
    and return the Python value, or None after recording a located
    :class:`Problem` so that reading can go on and report every problem.
    :meth:`check` raises them all as one ``error_class`` (a :class:`SourceError` of the reader's area).
    """

    file: str
    text: str
    root: Node | None = None
    problems: list[Problem] = field(default_factory=list)
    error_class: type[SourceError] = SourceError

    def __post_init__(self) -> None:
        self.lines = source_lines(self.text)
        self._constructor = SafeConstructor()

    # -- reading ------------------------------------------------------------

    @classmethod
    def read(cls, path: Path, shown_as: str | None = None, what: str = "YAML file",
             error_class: type[SourceError] = SourceError) -> YamlSource:
        """Read and compose ``path``; a missing, unreadable or ill-formed file raises ``error_class``."""
        name = shown_as or str(path)
        where = SourceLocation(name, 1, 1)
        try:
            data = read_at_most(path, MAX_YAML_BYTES)
            if len(data) > MAX_YAML_BYTES:
                raise error_class(Problem(f"file is too large for a {what}", where))
        except IsADirectoryError:
            raise error_class(Problem("is a directory, not a file", where, None,
                                      f"name the {what} inside it")) from None
        except FileNotFoundError:
            raise error_class(Problem("no such file", where, None, "check the path")) from None
        except OSError as exc:
            raise error_class(Problem(f"cannot read file: {exc.strerror}", where)) from None
        text = decode_source(data, name, f"a {what} is YAML text, saved as UTF-8; is this a binary file?", error_class)
        return cls.parse(text, name, what, error_class)

    @classmethod
    def parse(cls, text: str, file: str, what: str = "YAML file",
              error_class: type[SourceError] = SourceError) -> YamlSource:
        """Compose ``text``; a YAML syntax error becomes a located ``error_class``."""
        source = cls(file, text, error_class=error_class)
        try:
            source.root = yaml.compose(text, Loader=yaml.SafeLoader)
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            message = f"YAML syntax: {exc.problem or exc.context or 'cannot parse'}"
            if exc.context and exc.problem:
                message += f" ({exc.context}"
                if exc.context_mark is not None and exc.problem_mark is not None \
                        and exc.context_mark.line != exc.problem_mark.line:
                    message += f" at line {exc.context_mark.line + 1}"
                message += ")"
            source.error(mark, message, "check indentation, colons after keys and closing brackets")
            source.check()
        except yaml.reader.ReaderError as exc:  # a control character
            pos = exc.position
            line = text.count("\n", 0, pos) + 1
            column = pos - (text.rfind("\n", 0, pos) + 1) + 1
            loc = SourceLocation(file, line, column)
            source.problems.append(Problem(f"YAML syntax: character {_char(exc.character)!r} is not allowed here",
                                           loc, line_of(source.lines, line), "remove it or write it escaped in quotes"))
            source.check()
        except yaml.YAMLError as exc:
            source.error(None, f"YAML syntax: {exc}")
            source.check()
        except RecursionError:  # PyYAML composes nested lists and mappings recursively
            source.error(_deepest(text), "lists or mappings nested too deeply",
                         f"a {what} needs a few levels: flatten this")
            source.check()
        if source.root is not None:
            source._check_tags(source.root)
            source.check()
        if source.root is None:
            source.error(None, "file is empty", f"a {what} is a YAML mapping of keys to values")
            source.check()
        return source

    def _check_tags(self, root: Node) -> None:
        """Report explicit tags other than YAML's own (``!thing``, ``!!python/...``): they mean nothing here."""
        seen: set[int] = set()
        todo = [root]
        while todo:
            node = todo.pop()
            if id(node) in seen:
                continue
            seen.add(id(node))
            if not node.tag.startswith("tag:yaml.org,2002:") or node.tag.startswith("tag:yaml.org,2002:python/"):
                self.error(node, f"unsupported YAML tag '{node.tag}'", "remove the tag: write plain values")
            if isinstance(node, SequenceNode):
                todo.extend(node.value)
            elif isinstance(node, MappingNode):
                for key, value in node.value:
                    todo += (key, value)

    # -- problems -----------------------------------------------------------

    def location(self, where: Node | Any | None) -> SourceLocation:
        """file:line:column of a node (its start) or a PyYAML mark; 1:1 for None."""
        mark = getattr(where, "start_mark", where)
        if mark is None or not hasattr(mark, "line"):
            return SourceLocation(self.file, 1, 1)
        return SourceLocation(self.file, mark.line + 1, mark.column + 1)

    def error(self, where: Node | Any | None, message: str, hint: str | None = None) -> None:
        """Record a problem at ``where`` (a node or a mark)."""
        loc = self.location(where)
        self.problems.append(Problem(message, loc, line_of(self.lines, loc.line), hint))

    def check(self) -> None:
        """Raise every problem recorded so far, if any: those in other files (a map) first, then in file order."""
        if self.problems:
            other = [p for p in self.problems if p.location.file != self.file]
            own = sorted((p for p in self.problems if p.location.file == self.file),
                         key=lambda p: (p.location.line, p.location.column))
            raise self.error_class(other + own)

    # -- typed readers ------------------------------------------------------

    def value(self, node: Node) -> Any:
        """The plain Python value of a node (None after a problem: an unknown tag)."""
        try:
            return self._constructor.construct_object(node, deep=True)
        except yaml.YAMLError as exc:
            self.error(node, f"cannot read this value: {getattr(exc, 'problem', None) or exc}",
                       "write plain numbers, strings, lists and mappings (no !tags)")
            return None

    def keys(self, node: Node, path: str, allowed: tuple[str, ...] | None,
             required: tuple[str, ...] = (), what: str = "") -> dict[str, tuple[Node, Node]] | None:
        """A mapping's entries ``{key: (key node, value node)}``.

        Reports a node that is not a mapping, keys that are not strings,
        duplicate keys, keys not in ``allowed`` (with the nearest allowed
        name as a hint; None allows any key) and missing ``required`` keys.
        """
        if not isinstance(node, MappingNode):
            self.error(node, f"{path or 'the file'} must be a mapping of keys to values{what}, "
                             f"not {_kind(node)}",
                       _example_hint(path, allowed))
            return None
        entries: dict[str, tuple[Node, Node]] = {}
        misspelt: set[str | None] = set()  # what the unknown keys were probably meant to be
        for key_node, value_node in node.value:
            if not isinstance(key_node, ScalarNode) or not str(key_node.value).strip():
                self.error(key_node, f"a key in {path or 'the file'} must be a name, not {_kind(key_node)}")
                continue
            key = str(key_node.value)
            if key in entries:
                first = self.location(entries[key][0])
                self.error(key_node, f"key '{key}' appears twice in {path or 'the file'} "
                                     f"(first at line {first.line})", "keep one of them")
                continue
            if allowed is not None and key not in allowed:
                near = nearest(key, allowed)
                misspelt.add(near)
                hint = suggestion(near) if near else None
                known = ", ".join(allowed)
                hint = f"{hint} (known keys: {known})" if hint else f"known keys: {known}"
                self.error(key_node, f"unknown key '{key}' in {path or 'the file'}", hint)
                continue
            entries[key] = (key_node, value_node)
        for key in required:
            if key not in entries and key not in misspelt:
                unknown = [k.value for k, _ in node.value if isinstance(k, ScalarNode) and k.value not in entries]
                near = nearest(key, [str(k) for k in unknown]) if unknown else None
                hint = f"is '{near}' a misspelling of it?" if near else f"add '{key}: ...'"
                self.error(node, f"{path or 'the file'} is missing the key '{key}'", hint)
        return entries

    def items(self, node: Node, path: str, hint: str | None = None) -> list[Node] | None:
        """A sequence's item nodes, or None after reporting a node that is not a list."""
        if not isinstance(node, SequenceNode):
            self.error(node, f"{path} must be a list, not {_kind(node)}", hint)
            return None
        return list(node.value)

    def number(self, node: Node, path: str, *, minimum: float | None = None, above: float | None = None,
               maximum: float | None = None, integer: bool = False) -> float | None:
        """A finite number (an int when ``integer``) within the given limits."""
        wanted = "a whole number" if integer else "a number"
        tags = ("tag:yaml.org,2002:int",) if integer else ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")
        if not isinstance(node, ScalarNode) or node.tag not in tags:
            self.error(node, f"{path} must be {wanted}, not {_kind(node)}", _exponent_hint(node))
            return None
        value = self.value(node)
        if value is None:
            return None
        if not -_LARGEST <= value <= _LARGEST:  # nan, inf, or an integer no float can hold
            self.error(node, f"{path} must be a finite number, not {_shown(node.value)}",
                       f"numbers go up to about {_LARGEST:.1e}" if value == value else None)
            return None
        if minimum is not None and value < minimum:
            self.error(node, f"{path} must be at least {minimum:g}, not {value:g}")
            return None
        if above is not None and value <= above:
            self.error(node, f"{path} must be more than {above:g}, not {value:g}")
            return None
        if maximum is not None and value > maximum:
            self.error(node, f"{path} must be at most {maximum:g}, not {value:g}")
            return None
        return int(value) if integer else float(value)

    def numbers(self, node: Node, path: str, counts: tuple[int, ...], shape: str) -> list[float] | None:
        """A list of ``counts`` numbers (one of the allowed lengths), e.g. a wall ``[x1, y1, x2, y2]``."""
        items = self.items(node, path, f"write it as {shape}")
        if items is None:
            return None
        if len(items) not in counts:
            self.error(node, f"{path} must be {shape}: {_count_words(counts)} numbers, not {len(items)}",
                       f"write it as {shape}")
            return None
        values = [self.number(item, f"{path}[{i}]", minimum=-MAX_COORDINATE, maximum=MAX_COORDINATE)
                  for i, item in enumerate(items)]
        return None if any(v is None for v in values) else values  # type: ignore[return-value]

    def point(self, node: Node, path: str) -> tuple[float, float] | None:
        """A point ``[x, y]``."""
        values = self.numbers(node, path, (2,), "[x, y]")
        return None if values is None else (values[0], values[1])

    def points(self, node: Node, path: str, at_least: int, shape: str) -> list[tuple[float, float]] | None:
        """A list of at least ``at_least`` points ``[[x, y], ...]``."""
        items = self.items(node, path, f"write it as {shape}")
        if items is None:
            return None
        if len(items) < at_least:
            self.error(node, f"{path} needs at least {at_least} points [x, y], not {len(items)}",
                       f"write it as {shape}")
            return None
        found = [self.point(item, f"{path}[{i}]") for i, item in enumerate(items)]
        return None if any(p is None for p in found) else found  # type: ignore[return-value]

    def string(self, node: Node, path: str, hint: str | None = None) -> str | None:
        """A non-empty string (a plain name)."""
        if not isinstance(node, ScalarNode) or node.tag != "tag:yaml.org,2002:str" or not node.value.strip():
            self.error(node, f"{path} must be a name or text, not {_kind(node)}", hint)
            return None
        return node.value

    def boolean(self, node: Node, path: str) -> bool | None:
        """``true`` or ``false``."""
        if not isinstance(node, ScalarNode) or node.tag != "tag:yaml.org,2002:bool":
            self.error(node, f"{path} must be true or false, not {_kind(node)}")
            return None
        value = self.value(node)
        if value is None:
            return None
        return value


def _kind(node: Node) -> str:
    """What a node is, in words, for messages."""
    if isinstance(node, MappingNode):
        return "a mapping"
    if isinstance(node, SequenceNode):
        return f"a list of {len(node.value)}"
    tag = node.tag.rsplit(":", 1)[-1]
    if tag == "null":
        return "nothing (null)"
    if tag in ("int", "float"):
        return f"the number {node.value}"
    if tag == "bool":
        return f"'{node.value}' (true/false)"
    shown = node.value if len(node.value) <= 40 else node.value[:37] + "..."
    return f"'{shown}'"


_LARGEST = sys.float_info.max


def _shown(text: str) -> str:
    return text if len(text) <= 24 else f"{text[:12]}...{text[-6:]} ({len(text)} characters)"


def _exponent_hint(node: Node) -> str | None:
    """For ``1e7``, which YAML 1.1 (PyYAML) reads as text: how to write it as a number."""
    if not (isinstance(node, ScalarNode) and node.tag == "tag:yaml.org,2002:str" and node.style is None):
        return None
    try:
        value = float(node.value)
    except ValueError:
        return None
    if not math.isfinite(value) or node.value.strip().lower() in ("nan", "inf", "-inf", "+inf", "infinity"):
        return None
    mantissa, _, exponent = node.value.lower().partition("e")
    if not exponent:
        return None
    dotted = mantissa if "." in mantissa else mantissa + ".0"
    sign = exponent if exponent[:1] in "+-" else "+" + exponent
    return f"YAML reads {node.value} as text: write it {dotted}e{sign} (a dot, and a sign after the e)"


def _deepest(text: str) -> yaml.Mark:
    """Where a file too deeply nested to compose is deepest, as a mark: the deepest flow-style
    bracket, or else the most indented line."""
    depth = best = line = column = best_line = best_column = 0
    for char in text:
        if char in "[{":
            depth += 1
            if depth > best:
                best, best_line, best_column = depth, line, column
        elif char in "]}":
            depth -= 1
        if char == "\n":
            line, column = line + 1, 0
        else:
            column += 1
    if not best:  # block style: the most indented line
        indents = [len(row) - len(row.lstrip(" ")) for row in text.split("\n")]
        best_line = max(range(len(indents)), key=indents.__getitem__)
        best_column = indents[best_line]
    return yaml.Mark("", 0, best_line, best_column, None, None)


def _char(character: object) -> str:
    return chr(character) if isinstance(character, int) else str(character)


def _count_words(counts: tuple[int, ...]) -> str:
    return " or ".join(str(c) for c in counts)


def _example_hint(path: str, allowed: tuple[str, ...] | None) -> str | None:
    if not allowed:
        return None
    return "write it as 'key: value' lines; keys: " + ", ".join(allowed)

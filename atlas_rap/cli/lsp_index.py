"""What the language server knows of a RAP or AP file: its problems, its names and where they are defined.

:func:`diagnose` gives the problems of a document's text exactly as ``atlas
check`` reports them (the loader's, then :func:`atlas_rap.cli.check.program_problems`),
each with the range of the token it points at. :class:`DocumentIndex` is built
from a program that loaded: the definitions (RAPs, virtual skills, memory rules,
operators, relations, across includes), the skills a mission can call (the
stock skills unless it says ``(world none)``, and its virtual skills), the
memory predicates it uses, and the places of its world; it answers hover,
go-to-definition and completion for a word. :func:`outline` lists a text's
top-level forms for the editor's outline (it needs only the text to read).

Positions here are the editor's: 0-based lines and characters. The language's
are 1-based (``SourceLocation``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from atlas_rap.errors import AtlasError, Problem, SourceError, SourceLocation
from atlas_rap.lang import ast
from atlas_rap.lang.form_docs import FORMS
from atlas_rap.lang.loader import Program, load_text
from atlas_rap.lang.reader import SList, read_text
from atlas_rap.logic import EXPRESSION_FORMS, QUERY_FORMS, Compound
from atlas_rap.planner.pddl import ADL_FUNCTORS

__all__ = ["Definition", "DocumentIndex", "Symbol", "Word", "diagnose", "outline", "word_at"]

_DELIMITERS = set(" \t\r\n()\";")
_LOGIC_WORDS = QUERY_FORMS | EXPRESSION_FORMS | ADL_FUNCTORS  # functors of logic, not of facts
_CALL_FIELDS = {"task", "head", "skills"}  # AST fields that hold a call (a task or a skill), not a fact
_KEYWORDS = (":succeed", ":fail", ":timeout", ":priority", ":deadline", ":max-failures", ":above")


def diagnose(text: str, name: str) -> tuple[list[Problem], Program | None]:
    """The problems ``atlas check`` finds in ``text`` (a file named ``name``, as
    :func:`~atlas_rap.errors.shown_path` gives it; its includes read from disk), and the program when it loaded (None when it did not)."""
    from atlas_rap.cli.check import program_problems

    try:
        program = load_text(text, name)
    except SourceError as exc:
        return list(exc.problems), None
    try:
        return program_problems(program, name), program
    except AtlasError as exc:  # an installed plugin that does not load: said on the file, as atlas check says it
        return [Problem(str(exc), SourceLocation(name, 1, 1))], None


@dataclass(frozen=True, slots=True)
class Word:
    """The word at a position: its text, where it starts and ends on its line (0-based, end
    exclusive), and whether it heads a list (``(go-to ...``: a form, a task or a predicate)."""

    text: str
    line: int
    start: int
    end: int
    heads_list: bool


def word_at(lines: list[str], line: int, character: int) -> Word | None:
    """The word under (or just before) the cursor, or None on a delimiter or a blank."""
    if not 0 <= line < len(lines):
        return None
    text = lines[line]
    character = min(character, len(text))
    start = character
    while start > 0 and text[start - 1] not in _DELIMITERS:
        start -= 1
    end = character
    while end < len(text) and text[end] not in _DELIMITERS:
        end += 1
    if start == end:
        return None
    before = text[:start].rstrip()
    return Word(text[start:end], line, start, end, before.endswith("("))


def token_end(line_text: str, start: int) -> int:
    """Where the token starting at ``start`` ends on its line: a whole list when it opens one
    (to its closing parenthesis on the same line, else the line's end), else the atom."""
    if start >= len(line_text):
        return start
    if line_text[start] == "(":
        depth = 0
        for index in range(start, len(line_text)):
            depth += {"(": 1, ")": -1}.get(line_text[index], 0)
            if depth == 0:
                return index + 1
        return len(line_text)
    end = start
    while end < len(line_text) and line_text[end] not in _DELIMITERS:
        end += 1
    return max(end, start + 1)


@dataclass(frozen=True, slots=True)
class Definition:
    """A name defined in a program: what kind of thing, how it is written, where, and the
    comment lines just above it."""

    name: str
    kind: str
    usage: str
    location: SourceLocation
    doc: str = ""

    def markdown(self) -> str:
        where = f"{Path(self.location.file).name}:{self.location.line}"
        text = f"```rap\n{self.usage}\n```\n\n{self.kind}, defined at {where}"
        return text + (f"\n\n{self.doc}" if self.doc else "")


@dataclass(frozen=True, slots=True)
class Symbol:
    """A top-level form for the outline: its kind, name and range (0-based lines and characters)."""

    kind: str
    name: str
    start: tuple[int, int]
    end: tuple[int, int]
    selection: tuple[int, int, int]  # line, start and end characters of the name


class DocumentIndex:
    """The names of one loaded program (see the module docstring)."""

    def __init__(self, program: Program) -> None:
        self.program = program
        self.definitions: dict[str, list[Definition]] = {}
        for form in program.forms:
            found = _definition(form, program)
            if found is not None:
                self.definitions.setdefault(found.name, []).append(found)
        self.skills = self._skills()
        self.predicates = sorted(_predicates(program.forms) - set(self.definitions) - set(self.skills))
        self.places = _places(program)

    def _skills(self) -> dict[str, str]:
        """Each skill a RAP may call, with a line on it."""
        skills: dict[str, str] = {}
        worlds = self.program.of_type(ast.WorldDecl)
        if not worlds or worlds[-1].world != "none":
            from atlas_rap.skills.catalog import catalog

            for skill in catalog():  # the stock skills and the installed plugins'
                call = f"({' '.join((skill.name, *(p.name.upper() for p in skill.params)))})"
                types = ", ".join(str(p) for p in skill.params)
                posts = f"; it posts {', '.join(skill.events)}" if skill.events else ""
                always = " (always on)" if skill.always_on else ""
                origin = "stock skill" if skill.origin == "stock" else f"skill from {skill.origin}"
                skills[skill.name] = (f"```rap\n{call}\n```\n\n{origin}{always}{posts}"
                                      + (f"\n\nparameters: {types}" if types else ""))
        for form in self.program.of_type(ast.VirtualSkillDef):
            skills[form.name] = _definition(form, self.program).markdown()  # type: ignore[union-attr]
        return skills

    def hover(self, word: Word) -> str | None:
        """Markdown on the word: a definition, a skill, a form or a memory predicate."""
        name = word.text.lower()
        if name in self.definitions:
            return "\n\n---\n\n".join(found.markdown() for found in self.definitions[name])
        if name in self.skills:
            return self.skills[name]
        form = FORMS.get(name.lstrip(":"))
        if form is not None:
            return form.markdown()
        if name in self.predicates:
            return f"memory predicate `{name}`"
        if name in self.places:
            return f"place `{name}` of the world"
        return None

    def definition(self, word: Word) -> list[SourceLocation]:
        """Where the word is defined: RAPs, virtual skills, memory rules, operators, relations."""
        return [found.location for found in self.definitions.get(word.text.lower(), [])]

    def completions(self, word: Word) -> list[tuple[str, str, str]]:
        """(label, kind, detail) for the word being typed (its text so far may be empty): at the
        head of a list the forms, RAPs, skills and predicates; elsewhere places, keywords and
        predicates."""
        prefix = word.text.lower()
        items: list[tuple[str, str, str]] = []
        if word.heads_list:
            items += [(name, "form", doc.usage) for name, doc in FORMS.items()]
            items += [(name, found[0].kind, found[0].usage) for name, found in self.definitions.items()]
            items += [(name, "skill", "skill") for name in self.skills if name not in self.definitions]
        else:
            items += [(place, "place", "place") for place in self.places]
            items += [(keyword, "keyword", "outcome or option") for keyword in _KEYWORDS]
        items += [(name, "predicate", "memory predicate") for name in self.predicates]
        seen: set[str] = set()
        return [item for item in items if item[0].startswith(prefix) and not (item[0] in seen or seen.add(item[0]))]


def _definition(form: object, program: Program) -> Definition | None:
    """The definition a top-level form makes, if it makes one."""
    if isinstance(form, ast.RapDef):
        kind, usage = "RAP", str(form.head)
    elif isinstance(form, ast.VirtualSkillDef):
        kind, usage = "virtual skill", str(form.head)
    elif isinstance(form, ast.MemoryRuleDef):
        kind, usage = "memory rule", f"(define-memory-rule {form.name} ...)"
    elif isinstance(form, ast.Operator):
        kind, usage = "operator", f"(operator {form.name} ...)"
    elif isinstance(form, ast.RelationDef):
        kind, usage = "relation", str(form.head)
    else:
        return None
    return Definition(form.name, kind, usage, form.loc, _comment_above(program, form.loc))


def _comment_above(program: Program, loc: SourceLocation) -> str:
    """The ``;`` comment lines right above a form, without their semicolons."""
    lines = program.lines.get(loc.file, [])
    found: list[str] = []
    index = loc.line - 2
    while index >= 0 and lines[index].lstrip().startswith(";"):
        found.append(lines[index].lstrip().lstrip(";").strip())
        index -= 1
    return "\n".join(reversed(found))


def _predicates(nodes: object) -> set[str]:
    """The functors of the facts and queries in the AST (not of task or skill calls)."""
    found: set[str] = set()

    def walk(value: object, call: bool = False) -> None:
        if isinstance(value, Compound):
            if not call and value.functor not in _LOGIC_WORDS:
                found.add(value.functor)
            for arg in value.args:
                walk(arg)
        elif isinstance(value, tuple):
            for item in value:
                walk(item, call)
        elif dataclasses.is_dataclass(value) and not isinstance(value, type):
            for field in dataclasses.fields(value):
                walk(getattr(value, field.name), field.name in _CALL_FIELDS)

    walk(tuple(nodes))  # type: ignore[arg-type]
    return found


def _places(program: Program) -> list[str]:
    """The places of the world the mission names (or ``atlas run``'s default world)."""
    from atlas_rap.layers.system import DEFAULT_WORLD

    worlds = program.of_type(ast.WorldDecl)
    name = worlds[-1].world if worlds else DEFAULT_WORLD
    if name == "none":
        return []
    try:
        from atlas_rap.sim.world import load_world

        return sorted(load_world(name).places)
    except Exception:  # a world that does not load is atlas check's to report, not the editor's to crash on
        return []


_DEFINING = {"define-rap": "RAP", "define-virtual-skill": "virtual skill", "define-memory-rule": "memory rule",
             "operator": "operator", "define-relation": "relation"}


def outline(text: str, name: str) -> list[Symbol]:
    """The top-level forms of ``text``: definitions by name, other forms by their head."""
    try:
        forms = read_text(text, name)
    except SourceError:
        return []
    symbols = []
    for item, (line, column) in zip(forms, forms.locs):
        if not isinstance(item, SList) or not item.items or not isinstance(item.items[0], str):
            continue
        head = item.items[0]
        label, at = head, (line, column)
        if head in _DEFINING and len(item.items) > 1:
            target = item.items[1]
            label = target.items[0] if isinstance(target, SList) and target.items else target
            at = target.locs[0] if isinstance(target, SList) and target.items else item.locs[1]
        label = str(label)
        symbols.append(Symbol(_DEFINING.get(head, head), label, (line - 1, column - 1),
                              (item.end_line - 1, item.end_column), (at[0] - 1, at[1] - 1, at[1] - 1 + len(label))))
    return symbols

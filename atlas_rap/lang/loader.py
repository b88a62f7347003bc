"""Loading whole programs: a file and everything it includes.

Use :func:`load` to read a mission or a planning problem as the sequencer or
the planner will see it: each file read and validated once, ``include``
resolved relative to the including file, cycles reported with the chain
that makes them, and every problem of every file collected into one
:class:`~atlas_rap.errors.LanguageError` (a :class:`~atlas_rap.errors.SourceError`).

The forms of an included file stand where its ``include`` stands (depth
first), so definitions read in the order a person reads the files. A second
``include`` of a file already loaded adds nothing.

:func:`load_text` loads text that a person typed (the REPL) the same way,
as a program of its own; its includes are relative to the working
directory, falling back on the shipped files (``rap_library/...``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from atlas_rap.errors import LanguageError, Problem, SourceError, SourceLocation, line_of, shown_path, source_lines
from atlas_rap.lang import ast
from atlas_rap.lang.reader import Forms, read_file, read_text
from atlas_rap.lang.validator import to_term, validate, validate_partial
from atlas_rap.logic import Term
from atlas_rap.shipped import resolve_user_path


@dataclass(frozen=True, slots=True)
class Program:
    """Everything loaded from one root file: its files in load order and their forms."""

    root: str
    files: tuple[ast.SourceFile, ...]
    forms: tuple[ast.TopLevel, ...]
    lines: dict[str, list[str]] = field(default_factory=dict, compare=False, repr=False)

    def source_line(self, loc: SourceLocation) -> str | None:
        """The text of the source line at ``loc``, for a problem report (None if unknown)."""
        return line_of(self.lines.get(loc.file, []), loc.line)

    def of_type(self, kind: type) -> list:
        """The forms of one AST type, e.g. ``program.of_type(ast.RapDef)``."""
        return [form for form in self.forms if isinstance(form, kind)]


def _expand(root: str, files: dict[str, ast.SourceFile]) -> tuple[ast.TopLevel, ...]:
    """All top-level forms, includes expanded depth first, without the Include nodes."""
    out: list[ast.TopLevel] = []
    seen: set[str] = set()

    def expand(source: ast.SourceFile) -> None:
        seen.add(source.path)
        for form in source.forms:
            if isinstance(form, ast.Include):
                target = shown_path(_resolve(source.path, form.path))
                if target in files and target not in seen:
                    expand(files[target])
            else:
                out.append(form)

    expand(files[root])
    return tuple(out)


def parse_text(text: str, filename: str = "<input>") -> ast.SourceFile:
    """Read and validate one file's text (includes are not followed)."""
    return validate(read_text(text, filename), filename, text)


def parse_term(text: str, filename: str = "<input>") -> Term:
    """One term written as text, e.g. ``"(at robot ?where)"``, as a logic term.

    For queries and facts typed by people and programs (the REPL, tests);
    the text must hold exactly one datum.
    """
    forms = read_text(text, filename)
    if len(forms) != 1:
        line, column = (forms.locs[1] if len(forms) > 1 else (1, 1))
        raise LanguageError(Problem(f"expected one term, found {len(forms)}",
                                  SourceLocation(filename, line, column), line_of(source_lines(text), line)))
    return to_term(forms[0])


def parse_file(path: str | Path) -> ast.SourceFile:
    """Read and validate one file (includes are not followed)."""
    name = shown_path(Path(path))
    forms, text = read_file(path, name)
    return validate(forms, name, text)


def load(path: str | Path) -> Program:
    """Load a file and, recursively, what it includes; report every problem."""
    loader = _Loader()
    root = Path(path)
    loader.visit(root, [])
    return loader.program(shown_path(root))


def load_text(text: str, name: str = "<input>", forms: Forms | None = None) -> Program:
    """Load typed source (named ``name``, e.g. ``"<input 3>"``) and what it includes, as :func:`load` does.

    ``forms``: the top-level forms of ``text`` to load, already read (a caller
    that handles some forms itself, as the REPL does its queries); default all.
    """
    loader = _Loader()
    loader.visit_text(text, name, forms)
    return loader.program(name)


def _resolve(including: str, target: str) -> Path:
    if including.startswith("<"):  # typed text: relative to the working directory, or a shipped file
        return resolve_user_path(target).resolve()
    return (Path(including).resolve().parent / target).resolve()


class _Loader:
    def __init__(self) -> None:
        self.files: dict[str, ast.SourceFile] = {}
        self.order: list[str] = []
        self.problems: list[Problem] = []
        self.failed: set[str] = set()
        self.lines: dict[str, list[str]] = {}  # each loaded file's lines, for problem reports

    def source_line(self, loc: SourceLocation) -> str | None:
        return line_of(self.lines.get(loc.file, []), loc.line)

    def program(self, root: str) -> Program:
        """The loaded program rooted at ``root``; raises every problem found."""
        if self.problems:
            raise LanguageError(self.problems)
        files = tuple(self.files[key] for key in self.order)
        program = Program(root=root, files=files, forms=_expand(root, self.files), lines=self.lines)
        _check_unique_definitions(program, self)
        if self.problems:
            raise LanguageError(self.problems)
        return program

    def visit_text(self, text: str, name: str, forms: Forms | None = None) -> None:
        if forms is None:
            try:
                forms = read_text(text, name)
            except SourceError as exc:
                self.lines[name] = source_lines(text)
                self.problems.extend(exc.problems)
                return
        self._add(name, forms, text, [])

    def visit(self, path: Path, chain: list[tuple[str, ast.Include]]) -> None:
        name = shown_path(path)
        if name in self.files or name in self.failed:
            return
        try:
            forms, text = read_file(path, name)
        except SourceError as exc:
            self.failed.add(name)
            self.problems.extend(exc.problems)
            return
        self._add(name, forms, text, chain)

    def _add(self, name: str, forms, text: str, chain: list[tuple[str, ast.Include]]) -> None:
        self.lines[name] = source_lines(text)
        source, problems = validate_partial(forms, name, text)
        self.problems.extend(problems)
        self.files[name] = source
        self.order.append(name)
        for form in source.forms:
            if isinstance(form, ast.Include):
                self.include(source, form, chain)

    def include(self, source: ast.SourceFile, form: ast.Include,
                chain: list[tuple[str, ast.Include]]) -> None:
        target = _resolve(source.path, form.path)
        target_name = shown_path(target)
        stack = [name for name, _ in chain] + [source.path]
        if target_name in stack:
            cycle = stack[stack.index(target_name):] + [target_name]
            self.problems.append(Problem(
                "include cycle: " + " -> ".join(cycle), form.loc, self.source_line(form.loc),
                "remove one of these includes; each file needs to be included only once"))
            return
        if target.is_dir():
            self.problems.append(Problem(
                f"included path is a directory, not a file: {form.path} (looked for {target_name})", form.loc,
                self.source_line(form.loc), "include one file, e.g. (include \"navigation.rap\")"))
            return
        if not target.exists():
            where = ("the working directory" if source.path.startswith("<")
                     else "the file that includes them")
            self.problems.append(Problem(
                f"included file not found: {form.path} (looked for {target_name})", form.loc,
                self.source_line(form.loc), f"include paths are relative to {where}"))
            return
        self.visit(target, chain + [(source.path, form)])


def _check_unique_definitions(program: Program, loader: _Loader) -> None:
    """Two RAPs (same name and arity), operators, skills or memory rules of one name
    are a mistake. Several ``define-relation``s of one name are alternatives, as in Prolog."""
    seen: dict[tuple[str, str, int], SourceLocation] = {}
    for form in program.forms:
        if isinstance(form, (ast.RapDef, ast.VirtualSkillDef)):
            key = (type(form).__name__, form.name, len(form.head.args))
        elif isinstance(form, ast.Operator):
            key = ("Operator", form.name, 0)
        elif isinstance(form, ast.MemoryRuleDef):
            key = ("MemoryRuleDef", form.name, 0)
        else:
            continue
        if key in seen:
            first = seen[key]
            what = {"RapDef": "define-rap", "VirtualSkillDef": "define-virtual-skill", "Operator": "operator",
                    "MemoryRuleDef": "define-memory-rule"}[key[0]]
            loader.problems.append(Problem(f"{what} '{key[1]}' is defined twice (first at {first})",
                                           form.loc, loader.source_line(form.loc), "rename or remove one of them"))
        else:
            seen[key] = form.loc

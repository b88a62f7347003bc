"""Read a PDDL domain and problem into a :class:`PlanningProblem`.

Use :func:`load_pddl` (files) or :func:`parse_pddl` (text) when the planner
should work on a PDDL benchmark instead of ``.ap`` files. The s-expressions
come from the RAP reader (:func:`atlas_rap.lang.reader.read_file`): PDDL's
``-``, ``:keywords`` and ``?variables`` are plain atoms to it, it folds case
(PDDL is case-insensitive) and it keeps positions, so every error below is a
:class:`~atlas_rap.errors.PlanFileError` with ``file:line:column``, the line,
a caret and a hint.

Supported: STRIPS with ``:typing`` (hierarchy and ``either``),
``:negative-preconditions``, ``:equality``, ``:constants``, FOND
``:non-deterministic`` effects (``oneof``) and ADL (``:adl`` and its parts
``:disjunctive-preconditions``, ``:existential-preconditions``,
``:universal-preconditions``, ``:quantified-preconditions``,
``:conditional-effects``): ``or``, ``imply``, ``exists``, ``forall`` and
``not`` over any formula in preconditions and goals, ``when`` and ``forall``
in effects. ADL is only *read* here; :mod:`atlas_rap.planner.ground` compiles
it away (see its docstring). Action costs (``:action-costs``, the IPC's since
2008): ``(:functions (total-cost) - number ...)``, one ``(increase (total-cost)
COST)`` per action (COST a number >= 0 or a term of a function declared
``- number`` over the action's parameters and constants), ``(= (F OBJECT ...)
N)`` and ``(= (total-cost) 0)`` in ``:init``, ``(:metric minimize
(total-cost))``; the action's cost is :attr:`ast.Operator.cost`, the values
``PlanningProblem.cost_values``. Without the metric, plans are measured by
their length (costs ignored, as Fast Downward does); an action whose cost has
no value in ``:init`` cannot be applied (PDDL 2.1). Everything else (other
numeric fluents and numeric effects, object fluents, durative actions,
derived predicates, constraints, preferences, timed initial literals) is an
error at the form that uses it.

Choices where PDDL leaves room:

- Types are facts. ``?x - T`` becomes the precondition ``(type:T ?x)``,
  placed before the action's own preconditions, in parameter order; an object
  or constant of type T gets ``(type:S o)`` for T and every supertype S
  (never for ``object``, so an untyped parameter or one of type ``object``
  has no type precondition). ``type:...`` cannot be written in a source file,
  so it never collides with a predicate.
- ``(either A B)`` is the derived type ``either:a:b`` (members sorted, so
  ``(either b a)`` is the same type): an object gets ``(type:either:a:b o)``
  when it is of type A or B or one of their subtypes. An ``either``
  containing ``object`` is ``object``. Types in ``:types`` and objects must
  have plain types, not ``either``.
- A supertype named only after ``-`` in ``:types`` is declared by that
  mention (IPC domains do this); an object listed twice with two types has
  both. Predicate argument types are checked to exist, not checked against
  the facts that use the predicate.
- Requirements are checked only for what we cannot honour; a feature used
  without its requirement (``oneof`` without ``:non-deterministic``, ``=``
  without ``:equality``) is accepted, as most planners do.
- Preconditions and goals: an atom, ``(not ATOM)`` (kept as
  ``Compound('not', (atom,))``), ``(= A B)`` and ``(not (= A B))`` (kept as
  those terms, also in goals), flattened out of ``and``.
- Any other formula (ADL) is put in negation normal form (``imply`` written
  with ``or``, ``not`` pushed down to atoms and equalities) and kept as one
  term per conjunct, in written order among the literals above, with the
  functors ``adl:and``, ``adl:or``, ``(adl:forall (?V ...) BODY)`` and
  ``(adl:exists (?V ...) BODY)`` (PDDL names have no ``:``, and an AP
  operator's own ``(or ...)`` stays a test over the initial facts). A
  quantified variable ranges over every object: its type becomes a guard,
  ``(forall (?v - T) F)`` is
  ``(adl:forall (?v) (adl:or (not (type:T ?v)) F))`` and ``exists`` takes
  ``(adl:and (type:T ?v) F)``. A quantified variable that would shadow a
  parameter or an outer quantified variable is renamed ``?NAME~K``. A
  conjunction that becomes plain literals (``(not (or A B))``) is flattened.
  :func:`formula_text` writes these terms back as PDDL.
- Effects: a literal is :class:`ast.Effect` ``(fact, positive)``; a literal
  under ``when`` or ``forall`` is :class:`ast.ConditionalEffect` with the
  conjunction of the conditions of the ``when`` forms around it (a formula as
  above; the ``forall`` types are guards in it) and the ``forall``
  variables. Whoever applies effects must use PDDL semantics: conditions are
  evaluated in the state before the action, deletions first, then additions,
  so an action that deletes and adds the same fact leaves it true.
- FOND: at most one ``oneof`` per action. The controlled operator has the
  common effects plus the nominal outcome: the first with which the action
  changes anything (an action that does nothing at all has failed, which no
  plan intends: FOND blocksworld's ``pick-up-from-table`` lists that outcome
  first; tireworld's empty first outcome, the tyre not going flat, comes
  with the move itself and stays the nominal one); every other
  outcome k is the uncontrolled operator ``ACTION~k`` (same parameters and
  preconditions, ``probability`` 1/n, ``outcome_of`` ACTION), listed right
  after its controlled operator. A ``oneof`` cannot be inside ``when`` or
  ``forall``; an outcome may contain them.
- Action arguments that are names must be domain constants; ``:init`` and
  ``:goal`` arguments must be objects or constants; a goal's only variables
  are those of its quantifiers.

Over 25 KB on purpose: the PDDL reader and writer: one grammar's forms and their located
errors.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from atlas_rap.errors import PlanFileError, Problem, SourceLocation, did_you_mean, line_of, source_lines
from atlas_rap.lang import ast
from atlas_rap.lang.reader import SList, read_file, read_text
from atlas_rap.logic.terms import Compound, Term, Var, term_to_str
from atlas_rap.planner.problem import PlanningProblem

SUPPORTED_REQUIREMENTS = (":strips", ":typing", ":negative-preconditions", ":equality",
                          ":non-deterministic", ":adl", ":disjunctive-preconditions",
                          ":existential-preconditions", ":universal-preconditions",
                          ":quantified-preconditions", ":conditional-effects", ":action-costs")
TYPE_PREFIX = "type:"
# The functors of ADL formulas (module docstring); ADL_TRUE is the empty conjunction.
ADL_AND, ADL_OR, ADL_FORALL, ADL_EXISTS = "adl:and", "adl:or", "adl:forall", "adl:exists"
ADL_FUNCTORS = frozenset({ADL_AND, ADL_OR, ADL_FORALL, ADL_EXISTS})
ADL_TRUE = Compound(ADL_AND, ())

_CONDITION_HINT = ("a precondition or goal is an atom, (= A B), or, of formulas F and G, (and F ...), "
                   "(or F ...), (not F), (imply F G), (exists (?v - TYPE) F) or (forall (?v - TYPE) F)")
_EFFECT_HINT = ("an effect is an atom, (not ATOM), an (and ...) of effects, (when FORMULA EFFECT), "
                "(forall (?v - TYPE) EFFECT), or one (oneof OUTCOME ...) whose outcomes are such effects")
_SUPPORTED = ("supported: STRIPS with typing, negative preconditions, equality, ADL (or, imply, exists, "
              "forall, when), FOND 'oneof' effects and action costs ((increase (total-cost) COST) with "
              "(:metric minimize (total-cost)))")
_COST_HINT = ("an action's cost is (increase (total-cost) N), N a number >= 0 or a static function such as "
              "(road-length ?from ?to) whose values the problem's :init gives as (= (road-length a b) 22)")

# Heads of formulas and effects, and section keywords, that we know and refuse.
_NUMERIC_HEADS = ("increase", "decrease", "assign", "scale-up", "scale-down", "<", ">", "<=", ">=")
_QUANTIFIERS = ("forall", "exists")
_UNSUPPORTED_HEADS = {
    "preference": "preferences ('preference')",
    "probabilistic": "probabilistic effects ('probabilistic')",
    **{head: f"numeric fluents ('{head}')" for head in _NUMERIC_HEADS},
}
_UNSUPPORTED_SECTIONS = {
    ":durative-action": "durative actions (':durative-action')",
    ":derived": "derived predicates (':derived')",
    ":constraints": "constraints (':constraints')",
}
_DOMAIN_SECTIONS = (":requirements", ":types", ":constants", ":predicates", ":functions", ":action")
_PROBLEM_SECTIONS = (":domain", ":requirements", ":objects", ":init", ":goal", ":metric")
TOTAL_COST = "total-cost"

Where = tuple[int, int]  # (line, column)

_CONNECTIVES = ("and", "or", "not", "imply", *_QUANTIFIERS)
_ADL_FALSE = Compound(ADL_OR, ())


def _junction(functor: str, parts: list[Term]) -> Term:
    """``(adl:and PART ...)`` or ``(adl:or PART ...)``, nested ones of the same kind
    flattened, true and false folded in, a single part on its own."""
    unit, zero = (ADL_TRUE, _ADL_FALSE) if functor == ADL_AND else (_ADL_FALSE, ADL_TRUE)
    flat: list[Term] = []
    for part in parts:
        if part == zero:
            return zero
        if type(part) is Compound and part.functor == functor:
            flat.extend(part.args)
        elif part != unit:
            flat.append(part)
    flat = list(dict.fromkeys(flat))
    if len(flat) == 1:
        return flat[0]
    return Compound(functor, tuple(flat))


def _quantifier(functor: str, names: list[Var], body: Term) -> Term:
    if not names or body in (ADL_TRUE, _ADL_FALSE):
        return body
    return Compound(functor, (Compound("", tuple(names)), body))


def formula_text(term: Term) -> str:
    """A precondition, goal or condition as PDDL text: ``(adl:or A B)`` as ``(or A B)``."""
    if type(term) is Compound:
        if term.functor in (ADL_FORALL, ADL_EXISTS) and len(term.args) == 2:
            names = " ".join(map(term_to_str, term.args[0].args))  # type: ignore[union-attr]
            return f"({term.functor[4:]} ({names}) {formula_text(term.args[1])})"
        if term.functor in (ADL_AND, ADL_OR):
            return "(" + " ".join([term.functor[4:], *map(formula_text, term.args)]) + ")"
        if term.functor == "not" and len(term.args) == 1:
            return f"(not {formula_text(term.args[0])})"
    return term_to_str(term)


def load_pddl(domain_path: str | Path, problem_path: str | Path) -> PlanningProblem:
    """The planning problem of a PDDL domain file and problem file.

    Raises :class:`~atlas_rap.errors.PlanFileError` for anything it cannot
    read or does not support (a missing file included), located in the file.
    """
    domain = _Source.from_file(domain_path)
    problem = _Source.from_file(problem_path)
    return _Loader(domain, problem).load()


def parse_pddl(domain_text: str, problem_text: str, domain_file: str = "domain.pddl",
               problem_file: str = "problem.pddl") -> PlanningProblem:
    """:func:`load_pddl` for texts; the file names are for messages."""
    return _Loader(_Source(domain_file, read_text(domain_text, domain_file), domain_text),
                   _Source(problem_file, read_text(problem_text, problem_file), problem_text)).load()


class _Source:
    """One PDDL file: name, top-level forms and lines (for carets)."""

    def __init__(self, name: str, forms: list, text: str) -> None:
        self.name = name
        # most files glue nothing: one search of the text spares a walk over every list
        self.forms = [_unglued(form) for form in forms] if _GLUED.search(text) else list(forms)
        self.locs = tuple(getattr(forms, "locs", ()))  # where each top-level form starts
        self.lines = source_lines(text)

    @classmethod
    def from_file(cls, path: str | Path) -> _Source:
        forms, text = read_file(path)
        return cls(str(path), forms, text)

    def loc(self, where: Where) -> SourceLocation:
        return SourceLocation(self.name, where[0], where[1])

    def error(self, message: str, where: Where, hint: str | None = None) -> PlanFileError:
        return PlanFileError(Problem(message, self.loc(where), line_of(self.lines, where[0]), hint))


# what may be a name glued to a variable, ``aircraft?a``: a '?' inside an atom that does not start
# with '?' or ':' (in a comment or a string too, where the walk then finds nothing to split)
_GLUED = re.compile(r'[^\s()";?:][^\s()";?]*\?')


def _unglued(datum):
    """PDDL's tokens, as Fast Downward's and pyperplan's lexers split them: a name glued to a
    variable, ``(aircraft?a)``, is the name and the variable (zenotravel as the IPC ships it).
    The RAP reader reads ``aircraft?a`` as one symbol; it is split here, keeping positions."""
    if type(datum) is not SList:
        return datum
    items, locs = [], []
    changed = False  # a list with nothing glued in it is kept as it is, not built again
    for item, (line, column) in zip(datum.items, datum.locs):
        if type(item) is str and "?" in item[1:] and not item.startswith(("?", ":")):
            name, *names = item.split("?")
            items.append(name)
            locs.append((line, column))
            column += len(name)
            for var in names:
                items.append(Var(var) if var else Var("_"))
                locs.append((line, column))
                column += len(var) + 1
            changed = True
            continue
        unglued = _unglued(item)
        changed = changed or unglued is not item
        items.append(unglued)
        locs.append((line, column))
    if not changed:
        return datum
    return SList(tuple(items), tuple(locs), datum.line, datum.column, datum.end_line, datum.end_column, datum.depth)


def _at(form: SList) -> Where:
    return form.line, form.column


def _head(form: SList):
    return form.items[0] if form.items else None


def _suggest(name: str, known, what: str) -> str:
    return did_you_mean(name, known) or f"declared {what}: {', '.join(sorted(known)) or 'none'}"


class _Loader:
    """Reads a domain and a problem; holds what the domain declares."""

    def __init__(self, domain: _Source, problem: _Source) -> None:
        self.domain = domain
        self.problem = problem
        self.src = domain                      # the file being read, for errors
        self.parents: dict[str, list[str]] = {}
        self.type_at: dict[str, Where] = {}
        self.closure: dict[str, frozenset[str]] = {"object": frozenset({"object"})}
        self.either: dict[str, frozenset[str]] = {}
        self.predicates: dict[str, tuple[int, Where]] = {}
        self.constants: dict[str, set[str]] = {}
        self.objects: dict[str, set[str]] = {}
        self.functions: dict[str, tuple[int, Where]] = {}  # :functions, by name: arity, where declared
        self.cost: Term | None = None  # the cost of the action being read
        self.cost_values: dict[Compound, float] = {}

    # ------------------------------------------------------------- files and sections

    def _define(self, kind: str) -> tuple[str, list[SList], Where]:
        """The name, sections and place of ``(define (KIND NAME) SECTION ...)``."""
        src = self.src
        for form in src.forms:
            if type(form) is SList and _head(form) == "define":
                break
        else:
            where = src.locs[0] if src.locs else (1, 1)
            raise src.error(f"expected (define ({kind} NAME) ...)", where,
                            f"a PDDL {kind} file is one define form")
        header = form.items[1] if len(form.items) > 1 else None
        if (type(header) is not SList or len(header.items) != 2 or header.items[0] != kind
                or type(header.items[1]) is not str):
            where = _at(header) if type(header) is SList else _at(form)
            raise src.error(f"expected ({kind} NAME) after define", where,
                            f"the file should start (define ({kind} NAME) ...)")
        sections = []
        for i, section in enumerate(form.items[2:], 2):
            if type(section) is not SList or type(_head(section)) is not str:
                raise src.error("expected a section such as (:keyword ...)", form.locs[i])
            sections.append(section)
        return header.items[1], sections, _at(form)

    def _check_sections(self, sections: list[SList], allowed: tuple[str, ...], kind: str) -> None:
        for section in sections:
            key = section.items[0]
            if key in _UNSUPPORTED_SECTIONS:
                raise self.src.error(f"{_UNSUPPORTED_SECTIONS[key]} are not supported", _at(section),
                                     _SUPPORTED)
            if key not in allowed:
                raise self.src.error(f"unknown {kind} section '{key}'", _at(section),
                                     f"a {kind} has the sections {', '.join(allowed)}")

    def load(self) -> PlanningProblem:
        self.src = self.domain
        domain_name, sections, _ = self._define("domain")
        self._check_sections(sections, _DOMAIN_SECTIONS, "domain")
        by_key: dict[str, list[SList]] = {}
        for section in sections:
            by_key.setdefault(section.items[0], []).append(section)
        for section in by_key.get(":requirements", ()):
            self._requirements(section)
        for section in by_key.get(":types", ()):
            self._types(section)
        self._close_types()
        for section in by_key.get(":constants", ()):
            self._declare_objects(section, self.constants)
        for section in by_key.get(":predicates", ()):
            self._predicates(section)
        for section in by_key.get(":functions", ()):
            self._functions(section)
        operators: list[ast.Operator] = []
        names: set[str] = set()
        for section in by_key.get(":action", ()):
            for op in self._action(section):
                if op.name in names:
                    raise self.src.error(f"action '{op.name}' is defined twice", _at(section))
                names.add(op.name)
                operators.append(op)

        self.src = self.problem
        problem_name, sections, define_at = self._define("problem")
        self._check_sections(sections, _PROBLEM_SECTIONS, "problem")
        init: list[SList] = []
        goal: SList | None = None
        metric = False
        for section in sections:
            key = section.items[0]
            if key == ":domain":
                self._check_domain(section, domain_name)
            elif key == ":requirements":
                self._requirements(section)
            elif key == ":objects":
                self._declare_objects(section, self.objects)
            elif key == ":init":
                init.append(section)
            elif key == ":metric":
                metric = self._metric(section)
            else:
                goal = section
        for name, types in self.constants.items():
            self.objects.setdefault(name, set()).update(types)
        facts: dict[Compound, None] = dict.fromkeys(self._type_facts())
        for section in init:
            for fact in self._init(section):
                facts[fact] = None
        if goal is None:
            raise self.src.error("the problem has no (:goal ...)", define_at, "add (:goal (and FACT ...))")
        goals: list[tuple[Term, Where]] = []
        if len(goal.items) != 2 or type(goal.items[1]) is not SList:
            raise self.src.error("expected one formula in (:goal ...)", _at(goal), _CONDITION_HINT)
        self._condition(goal.items[1], None, goals)
        for fact in self._type_facts():  # an (either ...) first met in a goal's quantifier
            facts.setdefault(fact, None)
        return PlanningProblem(
            operators=tuple(operators),
            initial=tuple(facts),
            goals=tuple(g for g, _ in goals),
            objects=tuple(self.objects),
            name=problem_name,
            goal_locations=tuple(self.problem.loc(w) for _, w in goals),
            source_lines={self.domain.name: self.domain.lines, self.problem.name: self.problem.lines},
            action_costs=metric,
            cost_values=self.cost_values,
        )

    def _requirements(self, section: SList) -> None:
        for i, req in enumerate(section.items[1:], 1):
            if req not in SUPPORTED_REQUIREMENTS:
                raise self.src.error(f"requirement {req} is not supported", section.locs[i],
                                     f"supported requirements: {' '.join(SUPPORTED_REQUIREMENTS)}")

    def _check_domain(self, section: SList, domain_name: str) -> None:
        if len(section.items) != 2:
            raise self.src.error("expected (:domain NAME)", _at(section), f"write (:domain {domain_name})")
        if section.items[1] != domain_name:
            where = section.locs[1]
            raise self.src.error(f"the problem is for domain '{section.items[1]}', "
                                 f"not '{domain_name}'", where,
                                 f"the domain file defines '{domain_name}': write (:domain {domain_name})")

    # ------------------------------------------------------------------------- types

    def _typed_list(self, form: SList, start: int, variables: bool) -> list[tuple[Term, object, Where, Where]]:
        """``a b - T c - (either U V) d`` as (item, type spec, where the item is, where the type is);
        untyped items get 'object'."""
        out: list[tuple[Term, object, Where, Where]] = []
        pending: list[tuple[Term, Where]] = []
        items, locs = form.items, form.locs
        i = start
        while i < len(items):
            item = items[i]
            if item == "-":
                if i + 1 >= len(items):
                    raise self.src.error("'-' must be followed by a type", locs[i])
                spec = self._type_spec(items[i + 1], locs[i + 1])
                out.extend((name, spec, where, locs[i + 1]) for name, where in pending)
                pending = []
                i += 2
                continue
            if variables and type(item) is not Var:
                raise self.src.error("expected a ?variable", locs[i], "write parameters as (?x ?y - type)")
            if not variables and type(item) is not str:
                raise self.src.error("expected a name", locs[i], "write names as (a b - type)")
            pending.append((item, locs[i]))
            i += 1
        out.extend((name, "object", where, where) for name, where in pending)
        return out

    def _type_spec(self, spec, where: Where) -> object:
        """A type name (str), or an ``either`` list (SList) checked later."""
        if type(spec) is str or (type(spec) is SList and _head(spec) == "either"):
            return spec
        raise self.src.error("expected a type name or (either TYPE ...)", where)

    def _types(self, section: SList) -> None:
        for name, spec, where, _ in self._typed_list(section, 1, variables=False):
            if type(spec) is not str:
                raise self.src.error("a type's supertype must be one type, not (either ...)", _at(spec))
            if name == "object":
                continue
            self.type_at.setdefault(name, where)
            self.parents.setdefault(name, [])
            if spec not in self.parents[name]:
                self.parents[name].append(spec)
            if spec != "object" and spec not in self.parents:
                self.parents[spec] = ["object"]
                self.type_at.setdefault(spec, where)

    def _close_types(self) -> None:
        """Every declared type's set of itself and its supertypes; a cycle is an error."""
        def close(name: str, visiting: tuple[str, ...]) -> frozenset[str]:
            done = self.closure.get(name)
            if done is not None:
                return done
            if name in visiting:
                raise self.src.error(f"type '{name}' is its own supertype", self.type_at[name],
                                     "the :types hierarchy must not have cycles")
            result = {name}
            for parent in self.parents[name]:
                result |= close(parent, visiting + (name,))
            self.closure[name] = frozenset(result)
            return self.closure[name]
        for name in self.parents:
            close(name, ())

    def _type_name(self, spec, where: Where) -> str:
        """The type a parameter, predicate argument, object or constant is declared with."""
        if type(spec) is str:
            if spec not in self.closure:
                raise self.src.error(f"unknown type '{spec}'", where, _suggest(spec, self.closure, "types"))
            return spec
        members = set()
        for i, member in enumerate(spec.items[1:], 1):
            if type(member) is not str:
                raise self.src.error("expected a type name", spec.locs[i])
            members.add(self._type_name(member, spec.locs[i]))
        if not members:
            raise self.src.error("(either) needs at least one type", _at(spec))
        if "object" in members:
            return "object"
        if len(members) == 1:
            return members.pop()
        name = "either:" + ":".join(sorted(members))
        self.either[name] = frozenset(members)
        return name

    def _declare_objects(self, section: SList, table: dict[str, set[str]]) -> None:
        for name, spec, _, spec_at in self._typed_list(section, 1, variables=False):
            if type(spec) is not str:
                raise self.src.error("an object has one type, not (either ...)", spec_at,
                                     "list the object once per type if it has several")
            table.setdefault(name, set()).add(self._type_name(spec, spec_at))

    def _type_facts(self):
        for name, types in self.objects.items():
            kinds = set().union(*(self.closure[t] for t in types))
            kinds.discard("object")
            for either, members in self.either.items():
                if kinds & members:
                    kinds.add(either)
            for kind in sorted(kinds):
                yield Compound(TYPE_PREFIX + kind, (name,))

    # ----------------------------------------------------------------- predicates, actions

    def _predicates(self, section: SList) -> None:
        for i, decl in enumerate(section.items[1:], 1):
            if type(decl) is not SList or type(_head(decl)) is not str:
                raise self.src.error("expected a predicate declaration (NAME ?arg ...)", section.locs[i])
            args = self._typed_list(decl, 1, variables=True)
            for _, spec, _, spec_at in args:
                self._type_name(spec, spec_at)
            name = decl.items[0]
            known = self.predicates.get(name)
            if known is not None and known[0] != len(args):
                raise self.src.error(f"predicate '{name}' is declared again with {len(args)} arguments",
                                     _at(decl), f"it was declared with {known[0]} at "
                                     f"{self.src.loc(known[1])}")
            self.predicates[name] = (len(args), _at(decl))

    def _action(self, section: SList) -> list[ast.Operator]:
        src = self.src
        items = section.items
        if len(items) < 2 or type(items[1]) is not str or items[1].startswith(":"):
            raise src.error("expected (:action NAME :parameters (...) :precondition ... :effect ...)",
                            _at(section))
        name = items[1]
        parts: dict[str, int] = {}
        i = 2
        while i < len(items):
            key = items[i]
            if key not in (":parameters", ":precondition", ":effect"):
                what = f"unknown action part '{key}'" if type(key) is str else "expected a keyword"
                raise src.error(what, section.locs[i], "an action is (:action NAME :parameters (...) "
                                ":precondition FORMULA :effect EFFECT)")
            if i + 1 >= len(items):
                raise src.error(f"{key} needs a value", section.locs[i])
            parts[key] = i + 1
            i += 2
        parameters: list[Var] = []
        preconditions: list[Term] = []
        if ":parameters" in parts:
            form = items[parts[":parameters"]]
            if type(form) is not SList:
                raise src.error("expected a list of parameters", section.locs[parts[":parameters"]])
            for var, spec, where, spec_at in self._typed_list(form, 0, variables=True):
                if var in parameters:
                    raise src.error(f"parameter {var} is declared twice", where)
                parameters.append(var)
                kind = self._type_name(spec, spec_at)
                if kind != "object":
                    preconditions.append(Compound(TYPE_PREFIX + kind, (var,)))
        params = frozenset(parameters)
        conditions: list[tuple[Term, Where]] = []
        if ":precondition" in parts:
            self._condition(self._list_at(section, parts[":precondition"], _CONDITION_HINT),
                            params, conditions)
        preconditions.extend(c for c, _ in conditions)
        common: list[ast.Effect] = []
        outcomes: list[list[ast.Effect]] = []
        self.cost = None
        if ":effect" in parts:
            self._effect(self._list_at(section, parts[":effect"], _EFFECT_HINT), params, common, outcomes)
        loc = src.loc(_at(section))
        # the nominal outcome: the first in which the action changes anything (doing nothing is failing)
        nominal_at = next((k for k, outcome in enumerate(outcomes) if common or outcome), 0)
        nominal = outcomes[nominal_at] if outcomes else []
        ops = [ast.Operator(name, preconditions=tuple(preconditions), effects=tuple(common + nominal),
                            parameters=tuple(parameters), cost=self.cost, loc=loc)]
        for k, outcome in enumerate(outcomes, 1):
            if k == nominal_at + 1:
                continue
            ops.append(ast.Operator(f"{name}~{k}", preconditions=tuple(preconditions),
                                    effects=tuple(common + outcome), uncontrolled=True,
                                    probability=1 / len(outcomes), parameters=tuple(parameters),
                                    outcome_of=name, cost=self.cost, loc=loc))
        return ops

    # ------------------------------------------------------------------ action costs

    def _functions(self, section: SList) -> None:
        """``(:functions (total-cost) - number (NAME ?arg - TYPE ...) - number ...)``: the cost
        functions of ``:action-costs``; a function of any other type is an object fluent."""
        items = section.items
        i = 1
        while i < len(items):
            decl = items[i]
            if type(decl) is not SList or type(_head(decl)) is not str:
                raise self.src.error("expected a function declaration (NAME ?arg ...)", section.locs[i],
                                     _COST_HINT)
            i += 1
            if i < len(items) and items[i] == "-":
                if i + 1 >= len(items) or items[i + 1] != "number":
                    where = section.locs[i + 1] if i + 1 < len(items) else section.locs[i]
                    raise self.src.error("object fluents (functions that are not '- number') are not supported",
                                         where, _SUPPORTED)
                i += 2
            args = self._typed_list(decl, 1, variables=True)
            for _, spec, _, spec_at in args:
                self._type_name(spec, spec_at)
            name = decl.items[0]
            if name in self.predicates:
                raise self.src.error(f"'{name}' is a predicate and a function", _at(decl),
                                     "give the function another name")
            if name == TOTAL_COST and args:
                raise self.src.error("(total-cost) takes no arguments", _at(decl), _COST_HINT)
            self.functions[name] = (len(args), _at(decl))

    def _increase(self, form: SList, params: frozenset) -> None:
        """``(increase (total-cost) COST)``: the action's cost (:attr:`ast.Operator.cost`)."""
        items = form.items
        if len(items) != 3 or type(items[1]) is not SList or _head(items[1]) != TOTAL_COST:
            raise self.src.error("numeric fluents are not supported: the only numeric effect is the action's "
                                 "cost, (increase (total-cost) COST)", _at(form), _COST_HINT)
        self._total_cost_declared(_at(items[1]))
        if self.cost is not None:
            raise self.src.error("the action increases (total-cost) twice", _at(form),
                                 "give its cost in one (increase (total-cost) COST)")
        cost = items[2]
        if type(cost) in (int, float):
            if not 0 <= cost < math.inf:
                raise self.src.error(f"an action's cost must be a number >= 0, not {cost}", form.locs[2],
                                     _COST_HINT)
            self.cost = float(cost)
        elif type(cost) is SList:
            self.cost = self._function_term(cost, params)
        else:
            raise self.src.error("expected a number or a function term as the cost", form.locs[2], _COST_HINT)

    def _function_term(self, form: SList, params: frozenset | None) -> Compound:
        """``(NAME ARG ...)`` of a declared function other than total-cost: arguments are the
        action's parameters and constants (``params``), or objects in :init (None)."""
        name = _head(form)
        declared = self.functions.get(name) if type(name) is str else None
        if declared is None or name == TOTAL_COST:
            raise self.src.error(f"unknown function '{name}'", _at(form),
                                 _suggest(str(name), [f for f in self.functions if f != TOTAL_COST], "functions"))
        if len(form.items) - 1 != declared[0]:
            raise self.src.error(f"'{name}' takes {declared[0]} argument{'s' * (declared[0] != 1)}, not "
                                 f"{len(form.items) - 1}", _at(form),
                                 f"'{name}' is declared at {self.domain.loc(declared[1])}")
        for i, arg in enumerate(form.items[1:], 1):
            if type(arg) is Var and params is not None and arg in params:
                continue
            known = self.objects if params is None else self.constants
            if type(arg) is not str or arg not in known:
                what = "an object" if params is None else "a parameter of the action or a constant"
                raise self.src.error(f"'{term_to_str(arg) if not isinstance(arg, SList) else '(...)'}' is not "
                                     f"{what}", form.locs[i], _COST_HINT)
        return Compound(name, tuple(form.items[1:]))

    def _function_value(self, fact: SList) -> None:
        """``(= (NAME OBJECT ...) N)`` in :init: a cost function's value; ``(= (total-cost) 0)``."""
        items = fact.items
        if len(items) != 3 or type(items[1]) is not SList or type(items[2]) not in (int, float):
            raise self.src.error("expected (= (FUNCTION OBJECT ...) NUMBER) in :init", _at(fact), _COST_HINT)
        term, value = items[1], items[2]
        if _head(term) == TOTAL_COST:
            self._total_cost_declared(_at(term))
            if value != 0:
                raise self.src.error("the plan's total cost starts at 0", fact.locs[2], "write (= (total-cost) 0)")
            return
        key = self._function_term(term, None)
        if not 0 <= value < math.inf:
            raise self.src.error(f"a cost must be a number >= 0, not {value}", fact.locs[2], _COST_HINT)
        self.cost_values[key] = float(value)

    def _metric(self, section: SList) -> bool:
        """``(:metric minimize (total-cost))``, the one metric of ``:action-costs``."""
        items = section.items
        if (len(items) != 3 or items[1] != "minimize" or type(items[2]) is not SList
                or len(items[2].items) != 1 or _head(items[2]) != TOTAL_COST):
            raise self.src.error("plan metrics other than (:metric minimize (total-cost)) are not supported",
                                 _at(section), _SUPPORTED)
        self._total_cost_declared(section.locs[2])
        return True

    def _total_cost_declared(self, where: Where) -> None:
        """``(total-cost)`` is used at ``where``: the domain must declare it."""
        if TOTAL_COST not in self.functions:
            raise self.src.error("(total-cost) is not declared in the domain", where,
                                 "declare it there: (:functions (total-cost) - number)")

    def _list_at(self, form: SList, i: int, hint: str) -> SList:
        item = form.items[i]
        if type(item) is not SList:
            raise self.src.error("expected a (list)", form.locs[i], hint)
        return item

    # ------------------------------------------------------------ formulas and effects

    def _unsupported(self, form: SList) -> PlanFileError:
        return self.src.error(f"{_UNSUPPORTED_HEADS[form.items[0]]} are not supported", _at(form), _SUPPORTED)

    def _condition(self, form: SList, params: frozenset | None, out: list[tuple[Term, Where]]) -> None:
        """Append the conjuncts of a precondition (``params``: the action's) or goal (None):
        literals as they are, other formulas in negation normal form (module docstring)."""
        head = _head(form)
        if head is None:
            return
        if head == "and":
            for i in range(1, len(form.items)):
                self._condition(self._list_at(form, i, _CONDITION_HINT), params, out)
        elif head in ("or", "imply", *_QUANTIFIERS) or (
                head == "not" and len(form.items) == 2 and type(form.items[1]) is SList
                and _head(form.items[1]) in _CONNECTIVES):
            term = self._formula(form, params, {}, True)
            for conjunct in (term.args if type(term) is Compound and term.functor == ADL_AND else (term,)):
                out.append((conjunct, _at(form)))
        elif head == "not":
            if len(form.items) != 2:
                raise self.src.error("(not ...) takes one formula", _at(form), _CONDITION_HINT)
            inner = self._list_at(form, 1, _CONDITION_HINT)
            if _head(inner) in _UNSUPPORTED_HEADS:
                raise self._unsupported(inner)
            out.append((Compound("not", (self._atom(inner, params, _CONDITION_HINT),)), _at(form)))
        elif head in _UNSUPPORTED_HEADS:
            raise self._unsupported(form)
        else:
            out.append((self._atom(form, params, _CONDITION_HINT), _at(form)))

    def _formula(self, form: SList, params: frozenset | None, scope: dict[Var, Var], positive: bool) -> Term:
        """``form`` (or its negation, when not ``positive``) in negation normal form;
        ``scope`` maps the quantified variables around it to their names in the term."""
        head = _head(form)
        items = form.items
        if head is None:
            return ADL_TRUE if positive else _ADL_FALSE
        if head in ("and", "or"):
            parts = [self._formula(self._list_at(form, i, _CONDITION_HINT), params, scope, positive)
                     for i in range(1, len(items))]
            return _junction(ADL_AND if (head == "and") == positive else ADL_OR, parts)
        if head == "not":
            if len(items) != 2:
                raise self.src.error("(not ...) takes one formula", _at(form), _CONDITION_HINT)
            return self._formula(self._list_at(form, 1, _CONDITION_HINT), params, scope, not positive)
        if head == "imply":
            if len(items) != 3:
                raise self.src.error("(imply A B) takes two formulas", _at(form), _CONDITION_HINT)
            a = self._formula(self._list_at(form, 1, _CONDITION_HINT), params, scope, not positive)
            b = self._formula(self._list_at(form, 2, _CONDITION_HINT), params, scope, positive)
            return _junction(ADL_OR if positive else ADL_AND, [a, b])
        if head in _QUANTIFIERS:
            if len(items) != 3 or type(items[1]) is not SList:
                raise self.src.error(f"expected ({head} (?v - TYPE ...) FORMULA)", _at(form), _CONDITION_HINT)
            names, guards, inner = self._quantified(items[1], params, scope)
            body = self._formula(self._list_at(form, 2, _CONDITION_HINT), params, inner, positive)
            if (head == "forall") == positive:  # for every v: guards imply body
                body = _junction(ADL_OR, [*(Compound("not", (g,)) for g in guards), body])
                return _quantifier(ADL_FORALL, names, body)
            return _quantifier(ADL_EXISTS, names, _junction(ADL_AND, [*guards, body]))
        if head in _UNSUPPORTED_HEADS:
            raise self._unsupported(form)
        if head in ("when", "oneof"):
            raise self.src.error(f"({head} ...) is an effect, not a formula", _at(form), _CONDITION_HINT)
        atom = self._atom(form, params, _CONDITION_HINT, scope=scope)
        return atom if positive else Compound("not", (atom,))

    def _quantified(self, form: SList, params: frozenset | None,
                    scope: dict[Var, Var]) -> tuple[list[Var], list[Compound], dict[Var, Var]]:
        """The variables of a quantifier's ``(?v - TYPE ...)`` (renamed when they would
        shadow a parameter or an outer variable), their type guards and the inner scope."""
        names: list[Var] = []
        guards: list[Compound] = []
        inner = dict(scope)
        taken = set(params or ()) | set(scope.values())
        written: set[Var] = set()
        for var, spec, where, spec_at in self._typed_list(form, 0, variables=True):
            if var in written:
                raise self.src.error(f"variable {var} is declared twice", where)
            written.add(var)
            name, k = var, 0
            while name in taken:
                k += 1
                name = Var(f"{var.name}~{k}")
            taken.add(name)
            inner[var] = name
            names.append(name)
            kind = self._type_name(spec, spec_at)
            if kind != "object":
                guards.append(Compound(TYPE_PREFIX + kind, (name,)))
        return names, guards, inner

    def _effect(self, form: SList, params: frozenset, out: list, outcomes: list[list] | None,
                scope: dict[Var, Var] | None = None, condition: Term | None = None,
                variables: tuple[Var, ...] = ()) -> None:
        """Append the literals of an effect to ``out``; a ``oneof``'s outcomes go to
        ``outcomes`` (None inside a oneof, where another one is an error). Under ``when``
        and ``forall`` (``condition`` not None) a literal is an :class:`ast.ConditionalEffect`."""
        head = _head(form)
        scope = scope or {}
        if head is None:
            return
        if head == "and":
            for i in range(1, len(form.items)):
                self._effect(self._list_at(form, i, _EFFECT_HINT), params, out, outcomes, scope, condition,
                             variables)
        elif head == "oneof":
            if condition is not None:
                raise self.src.error("(oneof ...) inside when or forall is not supported", _at(form),
                                     "put the when or forall inside each outcome of the oneof")
            if outcomes is None or outcomes:
                raise self.src.error("only one (oneof ...) per action is supported, not nested",
                                     _at(form), "write the outcomes of every combination in one oneof")
            if len(form.items) < 2:
                raise self.src.error("(oneof) needs at least one outcome", _at(form), _EFFECT_HINT)
            for i in range(1, len(form.items)):
                outcome: list = []
                self._effect(self._list_at(form, i, _EFFECT_HINT), params, outcome, None)
                outcomes.append(outcome)
        elif head == "when":
            if len(form.items) != 3:
                raise self.src.error("expected (when FORMULA EFFECT)", _at(form), _EFFECT_HINT)
            cond = self._formula(self._list_at(form, 1, _CONDITION_HINT), params, scope, True)
            both = cond if condition is None else _junction(ADL_AND, [condition, cond])
            self._effect(self._list_at(form, 2, _EFFECT_HINT), params, out, outcomes, scope, both, variables)
        elif head == "forall":
            if len(form.items) != 3 or type(form.items[1]) is not SList:
                raise self.src.error("expected (forall (?v - TYPE ...) EFFECT)", _at(form), _EFFECT_HINT)
            names, guards, inner = self._quantified(form.items[1], params, scope)
            both = _junction(ADL_AND, [ADL_TRUE if condition is None else condition, *guards])
            self._effect(self._list_at(form, 2, _EFFECT_HINT), params, out, outcomes, inner, both,
                         variables + tuple(names))
        elif head == "not":
            if len(form.items) != 2:
                raise self.src.error("(not ...) takes one atom", _at(form), _EFFECT_HINT)
            inner_form = self._list_at(form, 1, _EFFECT_HINT)
            if _head(inner_form) in _UNSUPPORTED_HEADS:
                raise self._unsupported(inner_form)
            fact = self._atom(inner_form, params, _EFFECT_HINT, effect=True, scope=scope)
            out.append(self._literal(fact, False, form, condition, variables))
        elif head == "increase" and condition is None and outcomes is not None:
            self._increase(form, params)
        elif head in _UNSUPPORTED_HEADS:
            raise self._unsupported(form)
        else:
            fact = self._atom(form, params, _EFFECT_HINT, effect=True, scope=scope)
            out.append(self._literal(fact, True, form, condition, variables))

    def _literal(self, fact: Compound, positive: bool, form: SList, condition: Term | None,
                 variables: tuple[Var, ...]):
        loc = self.src.loc(_at(form))
        if condition is None:
            return ast.Effect(fact, positive, loc)
        return ast.ConditionalEffect(fact, positive, condition, variables, loc)

    def _atom(self, form: SList, params: frozenset | None, hint: str, effect: bool = False,
              scope: dict[Var, Var] | None = None) -> Compound:
        """``(PRED ARG ...)`` checked against the declarations; ``params`` None for goals,
        whose only variables are those of the quantifiers around (``scope``)."""
        src = self.src
        items = form.items
        head = _head(form)
        if type(head) is not str or head.startswith(":"):
            raise src.error("expected an atom (PREDICATE ARG ...)", _at(form), hint)
        if head in ("and", "not", "oneof", "either", "or", "imply", "when", *_QUANTIFIERS):
            raise src.error(f"({head} ...) is not allowed here", _at(form), hint)
        if head == "=":
            if effect:
                raise src.error("equality cannot be an effect", _at(form), hint)
            arity, declared_at = 2, "equality is (= A B)"
        else:
            declared = self.predicates.get(head)
            if declared is None:
                raise src.error(f"unknown predicate '{head}'", _at(form),
                                _suggest(head, self.predicates, "predicates"))
            arity, declared_at = declared[0], f"'{head}' is declared at {self.domain.loc(declared[1])}"
        if len(items) - 1 != arity:
            raise src.error(f"'{head}' takes {arity} argument{'s' * (arity != 1)}, not {len(items) - 1}",
                            _at(form), declared_at)
        args = list(items[1:])
        for i in range(1, len(items)):
            arg = items[i]
            kind = type(arg)
            if kind is Var:
                if scope and arg in scope:
                    args[i - 1] = scope[arg]
                elif params is None:
                    raise src.error(f"variable {arg} in a ground formula", form.locs[i],
                                    "goals and :init facts name objects; a goal's variables must be "
                                    "those of a forall or exists around it")
                elif arg not in params:
                    raise src.error(f"variable {arg} is not a parameter of the action", form.locs[i],
                                    "declare it in :parameters, or in a forall or exists around it")
            elif kind is str:
                if params is None:
                    if arg not in self.objects:
                        raise src.error(f"unknown object '{arg}'", form.locs[i],
                                        "declare it in the problem's :objects or the domain's :constants")
                elif arg not in self.constants:
                    raise src.error(f"unknown constant '{arg}'", form.locs[i],
                                    "declare it in the domain's :constants, or make it a ?parameter")
            elif kind is SList:
                raise src.error("numeric fluents and object fluents (function terms such as (fuel ?x)) "
                                "are not supported", form.locs[i], _SUPPORTED)
            else:
                raise src.error("expected an object name or a ?variable", form.locs[i], hint)
        return Compound(head, tuple(args))

    # ------------------------------------------------------------------------- problem

    def _init(self, section: SList):
        for i in range(1, len(section.items)):
            fact = self._list_at(section, i, "an :init entry is a ground atom (PREDICATE OBJECT ...)")
            items = fact.items
            head = _head(fact)
            if head == "at" and len(items) == 3 and type(items[1]) in (int, float) and type(items[2]) is SList:
                raise self.src.error("timed initial literals ('at' with a time) are not supported",
                                     _at(fact), _SUPPORTED)
            if head == "=":
                self._function_value(fact)
                continue
            if head == "not":
                raise self.src.error("(not ...) in :init: the initial state lists only true facts",
                                     _at(fact), "every fact not listed is false; delete this entry")
            yield self._atom(fact, None, "an :init entry is a ground atom (PREDICATE OBJECT ...)")

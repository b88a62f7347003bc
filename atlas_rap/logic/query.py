"""Queries: asking memory whether something holds, and with which bindings.

A query is a term (docs/language/index.md, Terms, facts and queries):

- ``(pred arg ...)``: a pattern, matched against the facts in memory;
- ``(and Q ...)``, ``(or Q ...)``: left to right; ``(and)`` is true,
  ``(or)`` is false;
- ``(not Q)``: negation as failure, under the bindings so far; variables
  still unbound inside are fine (``(not (at ?x lab))``: nothing is at lab);
- ``(< a b)`` ``(<= a b)`` ``(> a b)`` ``(>= a b)`` on numbers;
- ``(= a b)``: unification, so ``(= ?x EXPR)`` binds an unbound ``?x``;
- ``(/= a b)``: true when the two (bound) terms differ;
- ``t`` is true, ``nil`` is false;
- a pattern whose predicate is a defined :class:`Relation` is proved from
  the relation's clauses instead of from facts (relations shadow facts).

The arguments of comparisons, ``=`` and ``/=`` are *expressions*:
arithmetic ``(+ a b ...)`` ``(- a b ...)`` ``(* a b ...)`` ``(/ a b ...)``
(nested as deep as you like; ``(- a)`` negates) and ``(get-value OBJ
ATTR)``, the value ``V`` of the first fact ``(ATTR OBJ V)`` in memory (no
such fact: the query fails). A variable bound to an expression (a
relation's argument such as ``(/ ?size 2)``) is evaluated when a
comparison reads it. ``/`` of two integers is an integer when it divides
exactly. The arithmetic itself is ``logic.arithmetic``, shared with facts.

Facts are evaluated too: a fact asserted or retracted through a
``RuleEngine`` (outside changes, and memory-rule effects) has its
arithmetic replaced by its value (``(assert (counter (+ ?n 1)))`` with ?n
= 3 stores ``(counter 4)``; see :func:`~atlas_rap.logic.arithmetic.evaluated_fact`).
So memory never holds an arithmetic form, and a query pattern is *not*
evaluated: in ``(counter (+ ?n 1))`` the form is matched as data and
matches nothing. Bind the value first: ``(and (= ?y (+ ?x 1)) (counter ?y))``.

Arithmetic on a non-number, a comparison (or ``/=``) of an unbound
variable, or a form that is not a query raises :class:`QueryError` naming
the query. Answers come in a deterministic order: memory order for
patterns, left to right for ``and`` and ``or``, clause order for relations.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass, field
from typing import Any, Callable, Iterator, Mapping, Protocol, Sequence

from atlas_rap.logic.arithmetic import ARITHMETIC, ArithmeticUndefined, combine
from atlas_rap.logic.errors import QueryError, RelationDepthError
from atlas_rap.logic.terms import (
    Compound,
    Subst,
    Term,
    Var,
    fresh_var,
    is_ground,
    substitute,
    term_to_str,
    variables,
    walk,
)
from atlas_rap.logic.unify import unify

COMPARISONS: dict[str, Callable[[Any, Any], bool]] = {
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}
"""The numeric comparisons, by name."""

EXPRESSION_FORMS: frozenset[str] = ARITHMETIC | {"get-value"}
"""Functors evaluated (not matched) in the arguments of comparisons, ``=`` and ``/=``."""

QUERY_FORMS: frozenset[str] = frozenset({"and", "or", "not", "=", "/="}) | frozenset(COMPARISONS)
"""Functors that a query treats as logic, not as a predicate of facts."""

DEFAULT_MAX_DEPTH = 64
"""How deeply defined relations may call each other before :class:`RelationDepthError`."""


class Facts(Protocol):
    """What a query reads facts from: ``Memory``, or any object with its ``matches``.

    Declared here, not imported from ``memory`` (which evaluates queries with this
    module), so that the two modules do not import each other.
    """

    def matches(self, pattern: Compound, subst: Subst | None = None) -> Iterator[Subst]:
        """The answers of one pattern ``(pred arg ...)`` under ``subst``, in memory order."""
        ...


@dataclass(frozen=True, slots=True)
class Relation:
    """One clause of a defined relation (``define-relation``, docs/language/ap.md).

    ``(define-relation (can-lift ?agent ?weight) (>= (get-value ?agent max-lift) ?weight))``
    is ``Relation(head=(can-lift ?agent ?weight), body=(>= ...))``. A
    pattern whose predicate names a relation holds when it unifies with a
    clause's head and the clause's body holds (like a Prolog clause);
    several clauses are tried in order. ``body`` defaults to ``t``.
    """

    head: Compound
    body: Term = "t"
    _variables: tuple[Var, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        found = variables(Compound("", (self.head, self.body)))
        object.__setattr__(self, "_variables", tuple(found))

    def renamed(self) -> tuple[Compound, Term]:
        """The clause with every variable replaced by a fresh one (renamed apart)."""
        if not self._variables:
            return self.head, self.body
        fresh: Subst = {var: fresh_var(var.name) for var in self._variables}
        return substitute(self.head, fresh), substitute(self.body, fresh)  # type: ignore[return-value]


def evaluate(
    query: Term,
    memory: Facts,
    subst: Subst | None = None,
    relations: Mapping[str, Sequence[Relation]] | None = None,
    *,
    max_depth: int = DEFAULT_MAX_DEPTH,
) -> Iterator[Subst]:
    """Every answer of ``query`` over ``memory``: substitutions extending ``subst``.

    The core of ``Memory.query`` (which adds a fast path for a bare
    pattern); call it directly with any object that has ``Memory.matches``.
    Answers are new dicts, yours to keep; ``subst`` is not changed.
    ``relations`` maps a predicate name to its clauses; relation calls
    nested deeper than ``max_depth`` raise :class:`RelationDepthError`.
    """
    solver = _Solver(memory, relations or {}, max_depth)
    start: Subst = dict(subst) if subst else {}
    for answer in solver.solve(query, start, ()):
        yield dict(answer)


class _NoValue(Exception):
    """A ``get-value`` found no fact: the comparison that needed it fails."""


_VALUE = Var("value")


class _Solver:
    """One evaluation: the memory, the relations and the depth bound."""

    def __init__(self, memory: Facts, relations: Mapping[str, Sequence[Relation]], max_depth: int) -> None:
        self.memory = memory
        self.relations = relations
        self.max_depth = max_depth

    def solve(self, query: Term, s: Subst, calls: tuple[Compound, ...]) -> Iterator[Subst]:
        """The answers of ``query`` under ``s``; ``calls`` is the stack of relation calls."""
        if type(query) is Var:
            query = walk(query, s)
        if type(query) is not Compound:
            if type(query) is str and query == "t":
                yield s
                return
            if type(query) is str and query == "nil":
                return
            raise QueryError(_not_a_query(query))
        functor = query.functor
        args = query.args
        if functor == "and":
            yield from self._conjunction(args, 0, s, calls)
        elif functor == "or":
            for disjunct in args:
                yield from self.solve(disjunct, s, calls)
        elif functor == "not":
            if len(args) != 1:
                raise QueryError(f"(not Q) takes one query, not {len(args)}: {term_to_str(query)}")
            for _ in self.solve(args[0], s, calls):
                return
            yield s
        elif functor in COMPARISONS or functor == "=" or functor == "/=":
            yield from self._compare(query, s)
        elif not functor:
            yield from self.solve(self._with_predicate(query, s), s, calls)
        elif functor in self.relations:
            yield from self._call(query, s, calls)
        else:
            yield from self.memory.matches(query, s)

    def _conjunction(self, conjuncts: tuple[Term, ...], i: int, s: Subst, calls: tuple[Compound, ...]) -> Iterator[Subst]:
        if i == len(conjuncts):
            yield s
        elif i == len(conjuncts) - 1:
            yield from self.solve(conjuncts[i], s, calls)
        else:
            for answer in self.solve(conjuncts[i], s, calls):
                yield from self._conjunction(conjuncts, i + 1, answer, calls)

    def _with_predicate(self, query: Compound, s: Subst) -> Compound:
        """``(?p a b)`` with ``?p`` bound to a symbol, as the pattern ``(p a b)``."""
        head = walk(query.args[0], s) if query.args else None
        if type(head) is not str or not head:
            raise QueryError(
                f"a query must start with a predicate name, not {term_to_str(head) if head is not None else 'nothing'}: "
                f"{term_to_str(query)}"
            )
        return Compound(head, query.args[1:])

    def _call(self, query: Compound, s: Subst, calls: tuple[Compound, ...]) -> Iterator[Subst]:
        """Prove ``query`` from the clauses of its defined relation."""
        if len(calls) >= self.max_depth:
            chain = " -> ".join(term_to_str(substitute(call, s)) for call in calls[-4:])
            raise RelationDepthError(
                f"defined relations called each other more than {self.max_depth} deep "
                f"(last calls: {chain} -> {term_to_str(substitute(query, s))}); "
                f"is a recursive relation missing a base case?"
            )
        inner = calls + (query,)
        for clause in self.relations[query.functor]:
            head, body = clause.renamed()
            answer = unify(query, head, s)
            if answer is not None:
                yield from self.solve(body, answer, inner)

    def _compare(self, query: Compound, s: Subst) -> Iterator[Subst]:
        functor = query.functor
        if len(query.args) != 2:
            raise QueryError(f"({functor} a b) compares two terms, not {len(query.args)}: {term_to_str(query)}")
        left, right = query.args
        try:
            if functor == "=":
                answer = unify(self._value(left, s, query), self._value(right, s, query), s)
                if answer is not None:
                    yield answer
                return
            if functor == "/=":
                a = self._ground_value(left, s, query)
                b = self._ground_value(right, s, query)
                if a != b:
                    yield s
                return
            if COMPARISONS[functor](self._number(left, s, query), self._number(right, s, query)):
                yield s
        except _NoValue:
            return

    # -- expressions -------------------------------------------------------

    def _value(self, term: Term, s: Subst, query: Compound) -> Term:
        """The term under ``s``, evaluated when it is an expression."""
        term = walk(term, s)
        if type(term) is Compound and term.functor in EXPRESSION_FORMS:
            return self._evaluate(term, s, query)
        return term

    def _ground_value(self, term: Term, s: Subst, query: Compound) -> Term:
        value = substitute(self._value(term, s, query), s)
        if not is_ground(value):
            raise QueryError(_not_ground(query, term, value))
        return value

    def _number(self, term: Term, s: Subst, query: Compound) -> int | float:
        value = self._value(term, s, query)
        kind = type(value)
        if kind is int or kind is float:
            return value  # type: ignore[return-value]
        raise QueryError(_not_a_number(query, term, substitute(value, s)))

    def _evaluate(self, expression: Compound, s: Subst, query: Compound) -> int | float | Term:
        """The value of an arithmetic or ``get-value`` expression."""
        functor = expression.functor
        if functor == "get-value":
            return self._get_value(expression, s, query)
        numbers = [self._number(arg, s, query) for arg in expression.args]
        try:
            return combine(functor, numbers)
        except ArithmeticUndefined as exc:
            where = f" in {term_to_str(substitute(expression, s))}" if numbers else ""
            raise QueryError(f"{term_to_str(query)}: {exc}{where}") from None

    def _get_value(self, expression: Compound, s: Subst, query: Compound) -> Term:
        if len(expression.args) != 2:
            raise QueryError(f"{term_to_str(query)}: (get-value OBJECT ATTRIBUTE) takes two arguments")
        obj = substitute(self._value(expression.args[0], s, query), s)
        attribute = walk(expression.args[1], s)
        if not is_ground(obj) or type(attribute) is not str:
            raise QueryError(
                f"{term_to_str(query)}: {term_to_str(substitute(expression, s))} needs a bound object "
                f"and an attribute name"
            )
        for answer in self.memory.matches(Compound(attribute, (obj, _VALUE))):
            return answer[_VALUE]
        raise _NoValue


def _not_a_number(query: Compound, term: Term, value: Term) -> str:
    if type(value) is Var:
        problem = f"{term_to_str(term)} is unbound"
    elif type(term) is Var:
        problem = f"{term_to_str(term)} is {term_to_str(value)}, not a number"
    else:
        problem = f"{term_to_str(value)} is not a number"
    return f"{term_to_str(query)}: {problem}; arithmetic and {query.functor} need numbers"


def _not_ground(query: Compound, term: Term, value: Term) -> str:
    if type(value) is Var:
        problem = f"{term_to_str(term)} is unbound"
    else:
        problem = f"{term_to_str(value)} has unbound variables"
    return f"{term_to_str(query)}: {problem}; /= compares bound terms (use (not (= a b)) to test unifiability)"


def _not_a_query(term: Term) -> str:
    if type(term) is Var:
        return f"the query {term_to_str(term)} is an unbound variable"
    return (
        f"not a query: {term_to_str(term)} "
        f"(a query is (pred arg ...), and, or, not, a comparison, t or nil)"
    )

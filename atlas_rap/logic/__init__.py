"""Terms, unification, memory, queries and memory rules: the one logic
implementation shared by the RAP sequencer and the AP planner.

- ``terms``: :class:`Compound`, :class:`Var`, :class:`String`, symbols
  (``str``) and numbers; substitutions (:data:`Subst`) and printing.
- ``unify``: :func:`unify` (two-sided, occurs check) and :func:`match`
  (one-sided, against ground terms).
- ``memory``: :class:`Memory`, indexed ground facts with times.
- ``arithmetic``: the one evaluation of ``+ - * /``, for queries and for
  facts (:func:`evaluated_fact`: ``(counter (+ 3 1))`` is ``(counter 4)``).
- ``query``: :func:`evaluate`, the query language, and defined relations
  (:class:`Relation`).
- ``rules``: :class:`MemoryRule` and the :class:`RuleEngine` that runs them;
  :func:`rule_cycles`, the rules that can trigger each other for ever.

This package imports nothing of atlas-rap but ``atlas_rap.errors``.
"""

from __future__ import annotations

from atlas_rap.logic.arithmetic import evaluated_fact
from atlas_rap.logic.errors import (
    FactError,
    LogicError,
    QueryError,
    RelationDepthError,
    RuleCycleError,
    RuleError,
)
from atlas_rap.logic.memory import Listener, Memory
from atlas_rap.logic.query import (
    ARITHMETIC,
    COMPARISONS,
    DEFAULT_MAX_DEPTH,
    EXPRESSION_FORMS,
    QUERY_FORMS,
    Relation,
    evaluate,
)
from atlas_rap.logic.rules import DEFAULT_MAX_FIRINGS, Change, MemoryRule, RuleEngine, rule_cycles
from atlas_rap.logic.terms import (
    Compound,
    String,
    Subst,
    Term,
    Var,
    fresh_var,
    is_anonymous,
    is_ground,
    is_keyword,
    is_number,
    is_symbol,
    substitute,
    term_to_str,
    variables,
    walk,
)
from atlas_rap.logic.unify import match, match_into, unify

__all__ = [
    "ARITHMETIC",
    "COMPARISONS",
    "Change",
    "Compound",
    "DEFAULT_MAX_DEPTH",
    "DEFAULT_MAX_FIRINGS",
    "EXPRESSION_FORMS",
    "FactError",
    "Listener",
    "LogicError",
    "Memory",
    "MemoryRule",
    "QUERY_FORMS",
    "QueryError",
    "Relation",
    "RelationDepthError",
    "RuleCycleError",
    "RuleEngine",
    "RuleError",
    "String",
    "Subst",
    "Term",
    "Var",
    "evaluate",
    "evaluated_fact",
    "fresh_var",
    "is_anonymous",
    "is_ground",
    "is_keyword",
    "is_number",
    "is_symbol",
    "match",
    "match_into",
    "rule_cycles",
    "substitute",
    "term_to_str",
    "unify",
    "variables",
    "walk",
]

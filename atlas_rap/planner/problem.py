"""A planning problem: the operators, agents, relations, initial state and goals
that the planner works on, whether they came from AP files or from PDDL.

Use :func:`problem_from_program` for a loaded ``.ap`` program and
:func:`atlas_rap.planner.pddl.load_pddl` for a PDDL domain and problem; both
give a :class:`PlanningProblem`, so everything after reading (grounding,
search, partial order, counterplanning) is written once.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from typing import Iterable, Mapping

from atlas_rap.errors import SourceLocation
from atlas_rap.lang import ast
from atlas_rap.logic import Compound, Relation, Term, Var, substitute, unify


@dataclass(frozen=True)
class PlanningProblem:
    """Everything a plan is made from.

    - ``operators``: controlled and uncontrolled operators (:class:`ast.Operator`).
      A PDDL action is an operator with ``parameters`` in declared order, its
      typed parameters written as unary preconditions ``(TYPE ?x)``.
    - ``controlled`` / ``uncontrolled``: agent names (empty for PDDL).
    - ``relations``: defined relations by name, for constraints.
    - ``objects``: names the grounder may bind a variable to that no fact
      binds (PDDL objects and constants); more are taken from facts and goals.
    - ``initial``: ground facts; ``goals``: facts, or ``(not FACT)``.
    - ``name``: for messages; ``goal_locations``: where each goal was written.
    - ``source_lines``: source text by file name, so later errors can show a caret.
    - ``deadlines``: ``(GOAL, SECONDS)`` pairs from ``(deadline GOAL SECONDS)`` forms:
      GOAL must be achieved within SECONDS of the plan's start;
      ``deadline_locations``: where each GOAL is written.
    - ``deadline``: the ``:deadline`` of a plan request (:meth:`asked`), for the
      whole request: every goal within it. None when there is none.
      :meth:`deadline_for` combines both.
    - ``avoid``: ground actions ``(OPERATOR-NAME VALUE ...)`` the plan may not use
      (a plan being repaired leaves out what already failed; see
      ``layers.deliberation``).
    - ``action_costs``: the problem's plans are measured by their actions' costs (PDDL
      ``:action-costs``, ``(:metric minimize (total-cost))``; each operator's ``cost``);
      ``cost_values``: the values of the static functions costs are written with, e.g.
      ``(road-length a b)`` -> 22, from ``(= (road-length a b) 22)`` in ``:init``.
    """

    operators: tuple[ast.Operator, ...]
    initial: tuple[Compound, ...]
    goals: tuple[Term, ...]
    controlled: tuple[str, ...] = ()
    uncontrolled: tuple[str, ...] = ()
    relations: dict[str, list[Relation]] = field(default_factory=dict)
    objects: tuple[str, ...] = ()
    name: str = "problem"
    goal_locations: tuple[SourceLocation | None, ...] = ()
    agents_location: SourceLocation | None = None
    source_lines: dict[str, list[str]] = field(default_factory=dict)
    deadlines: tuple[tuple[Term, float], ...] = ()
    deadline_locations: tuple[SourceLocation | None, ...] = ()
    deadline: float | None = None
    avoid: frozenset[Term] = frozenset()
    action_costs: bool = False
    cost_values: dict[Compound, float] = field(default_factory=dict)

    def action_cost(self, op: ast.Operator, binding: Mapping[Var, Term]) -> float | None:
        """The cost of ``op`` with its variables bound: 1 when it has none (or the problem does not
        measure plans by cost, as PDDL without a ``:metric``), its number, or the
        value of its function term in ``cost_values``; None when that value is not given (PDDL:
        an action whose cost is undefined cannot be applied)."""
        cost = op.cost
        if cost is None or not self.action_costs:
            return 1.0
        if type(cost) is Compound:
            return self.cost_values.get(substitute(cost, binding))  # type: ignore[arg-type]
        return float(cost)  # type: ignore[arg-type]

    def operator(self, name: str) -> ast.Operator:
        """The operator called ``name``."""
        for op in self.operators:
            if op.name == name:
                return op
        raise KeyError(name)

    def asked(self, goals: tuple[Term, ...], initial: tuple[Compound, ...],
              loc: SourceLocation | None = None, deadline: float | None = None) -> PlanningProblem:
        """The same operators, agents, relations and ``deadlines``, asked for ``goals``
        from ``initial`` (a mission's ``(plan ...)``, the REPL's memory); ``loc`` is
        where the goals were asked; ``deadline`` the request's ``:deadline`` (for all
        its goals; it replaces that of an earlier request)."""
        return dataclasses.replace(self, goals=tuple(goals), initial=tuple(dict.fromkeys(initial)),
                                   goal_locations=(loc,) * len(goals), deadline=deadline)

    def deadline_for(self, goals: Iterable[Term] | None = None) -> float | None:
        """The time by which ``goals`` (the problem's goals when None) must all be
        achieved: the smallest of the request's ``deadline`` and the ``deadlines``
        whose goal unifies with one of ``goals``; None when there is none."""
        goals = self.goals if goals is None else tuple(goals)
        found = [seconds for goal, seconds in self.deadlines
                 if any(unify(goal, asked) is not None for asked in goals)]
        if self.deadline is not None:
            found.append(self.deadline)
        return min(found, default=None)

    def line(self, loc: SourceLocation | None) -> str | None:
        """The source line at ``loc``, for a caret under a problem."""
        if loc is None:
            return None
        lines = self.source_lines.get(loc.file)
        if lines is None or not 0 < loc.line <= len(lines):
            return None
        return lines[loc.line - 1]


def problem_from_program(program, name: str = "problem") -> PlanningProblem:
    """The planning problem of a loaded ``.ap`` program (:func:`atlas_rap.lang.load`):
    its operators, ``agents``, ``define-relation``s, ``initial``, ``goals`` and
    ``deadline``s (every ``initial``, ``goals`` and ``deadline`` form, in order)."""
    relations: dict[str, list[Relation]] = {}
    for rel in program.of_type(ast.RelationDef):
        relations.setdefault(rel.name, []).append(Relation(rel.head, rel.body))
    agents = program.of_type(ast.Agents)
    controlled = tuple(a for form in agents for a in form.controlled)
    uncontrolled = tuple(a for form in agents for a in form.uncontrolled)
    goals_forms = program.of_type(ast.Goals)
    goals = tuple(g for form in goals_forms for g in form.goals)
    goal_locations = tuple(loc for form in goals_forms
                           for loc in (form.goal_locs or (form.loc,) * len(form.goals)))
    deadline_forms = program.of_type(ast.Deadline)
    return PlanningProblem(
        operators=tuple(program.of_type(ast.Operator)),
        initial=tuple(f for form in program.of_type(ast.Initial) for f in form.facts),
        goals=goals,
        controlled=controlled,
        uncontrolled=uncontrolled,
        relations=relations,
        name=name,
        goal_locations=goal_locations,
        agents_location=agents[0].loc if agents else None,
        source_lines=dict(program.lines),
        deadlines=tuple((form.goal, form.seconds) for form in deadline_forms),
        deadline_locations=tuple(form.goal_loc or form.loc for form in deadline_forms),
    )

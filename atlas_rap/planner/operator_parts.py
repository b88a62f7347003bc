"""What an operator's form says beyond its fields: its variables in order, the leaf steps of its
plot, the variables that name its agents, the agents that must differ, and the purposes a plot
step may name as a goal.

Grounding (:mod:`~atlas_rap.planner.ground`), the load-time checks
(:mod:`~atlas_rap.planner.checks`) and the plan file reader read operators
through these; they need nothing of grounding itself.
"""

from __future__ import annotations

from typing import Sequence

from atlas_rap.lang import ast
from atlas_rap.logic import Compound, Term, Var, unify, variables
from atlas_rap.planner.pddl import ADL_EXISTS, ADL_FORALL, ADL_FUNCTORS
from atlas_rap.planner.problem import PlanningProblem

__all__ = ["agent_variables", "operator_purposes", "plot_steps", "simultaneous_pairs", "variable_order"]


def variable_order(op: ast.Operator) -> tuple[Var, ...]:
    """An operator's variables: its declared ``parameters``, else in order of first
    appearance in purpose, agent, arguments, preconditions, constraints, plot, effects."""
    if op.parameters:
        return op.parameters
    parts: list[Term] = []
    if op.purpose is not None:
        parts.append(op.purpose)
    if op.agent is not None:
        parts.append(op.agent)
    for arg in op.arguments:
        parts.extend((arg.var, arg.expr))
    parts.extend(op.preconditions)
    parts.extend(op.constraints)
    parts.extend(step.term for step in plot_steps(op.plot))
    parts.extend(e.fact for e in op.effects)
    found = variables(Compound("", tuple(parts)))
    bound = _quantified_variables(op)
    return tuple(v for v in found if v not in bound)


def _quantified_variables(op: ast.Operator) -> set[Var]:
    """The variables of an operator's PDDL quantifiers (never its own variables)."""
    bound: set[Var] = set()

    def collect(term: Term) -> None:
        if type(term) is Compound and term.functor in ADL_FUNCTORS:
            if term.functor in (ADL_FORALL, ADL_EXISTS):
                bound.update(term.args[0].args)  # type: ignore[union-attr]
            for arg in term.args:
                collect(arg)

    for pre in op.preconditions:
        collect(pre)
    for effect in op.effects:
        if type(effect) is ast.ConditionalEffect:
            bound.update(effect.variables)
            collect(effect.condition)
    return bound


def plot_steps(plot: ast.Plot | None) -> list[ast.PlotStep]:
    """The leaf steps of a plot, in order."""
    if plot is None:
        return []
    if isinstance(plot, ast.PlotStep):
        return [plot]
    return [step for part in plot.parts for step in plot_steps(part)]


def agent_variables(op: ast.Operator, purposes: Sequence[Term] = ()) -> tuple[Var, ...]:
    """The ``:agent`` variable and the first argument of each plot *action*, when a
    variable. A plot step that unifies with one of ``purposes`` (other operators'
    purposes) is a goal, not an action, so it names no agent."""
    found: dict[Var, None] = {}
    if op.agent is not None:
        found[op.agent] = None
    for step in plot_steps(op.plot):
        if any(unify(step.term, purpose) is not None for purpose in purposes):
            continue
        if step.term.args and type(step.term.args[0]) is Var:
            found[step.term.args[0]] = None
    return tuple(found)


def operator_purposes(problem: PlanningProblem) -> list[Term]:
    """The purposes of our operators: what a plot step may name as a goal."""
    return [op.purpose for op in problem.operators if op.purpose is not None and not op.uncontrolled]


def simultaneous_pairs(plot: ast.Plot | None) -> list[tuple[Var, Var]]:
    """Pairs of agent variables that must differ: agents of different steps of one
    ``simultaneous`` group."""
    pairs: list[tuple[Var, Var]] = []
    if plot is None or isinstance(plot, ast.PlotStep):
        return pairs
    if plot.kind == "simultaneous":
        groups = [[s.term.args[0] for s in plot_steps(part) if s.term.args and type(s.term.args[0]) is Var]
                  for part in plot.parts]
        for i, first in enumerate(groups):
            for second in groups[i + 1:]:
                pairs.extend((a, b) for a in first for b in second)
    for part in plot.parts:
        pairs.extend(simultaneous_pairs(part))
    return pairs

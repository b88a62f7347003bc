"""Plan files in the IPC format, and a plan validator that does not trust the planner.

Use :func:`write_plan_file` / :func:`read_plan_file` to save and load a
sequential plan (one ``(action arg ...)`` a line, ``;`` comments), and
:func:`validate_plan` (or :func:`validate_plan_file`) to check a plan
against a :class:`PlanningProblem`, as VAL does for PDDL.

The validator is deliberately independent of the planner's grounding: it
binds the action's arguments to the lifted operator's ``parameters`` in
order, evaluates each precondition in the current state (type facts,
atoms, ``(not ATOM)``, ``(= A B)``, ``(not (= A B))``, and the ADL formulas
as the PDDL reader writes them: ``and``, ``or``, ``forall`` and ``exists``
over the problem's objects), applies the effects with PDDL semantics
(conditional and universal effects expanded over the objects, their
conditions evaluated in the state before the step; all deletions, then all
additions) and checks the goals, ADL ones included, at the end. It reads the
lifted operators only, never the grounder's compilation of ADL into STRIPS
variants, so it checks that compilation too. Only preconditions and effects
are checked: AP constraints, derived arguments and plots are not (PDDL
operators have none).

Choices:

- Uncontrolled operators (FOND outcomes such as ``move-car~2``) are never
  valid plan actions.
- ``adversarial=True`` is the worst case for a FOND plan: after each step it
  also applies the deletions of every uncontrolled outcome of that step's
  operator (same arguments), so a plan passes only if no bad outcome can
  defeat it. Additions of bad outcomes are ignored: this is exact for
  domains whose preconditions and goals are positive (deleting a fact never
  helps them), and conservative otherwise.
- A plan file's last line is ``; cost = N (unit cost)``, or ``; cost = N
  (general cost)`` for a problem with action costs (as Fast Downward writes
  it); reading skips every comment, so the cost line is informational.
  :attr:`PlanCheck.cost` is the cost the validator works out itself.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from itertools import product
from pathlib import Path
from typing import Iterable, Sequence

from atlas_rap.errors import PlanFileError, Problem, SourceLocation
from atlas_rap.lang import ast
from atlas_rap.outputs import write_text
from atlas_rap.logic.terms import Compound, Term, substitute, term_to_str
from atlas_rap.planner.ground import variable_order
from atlas_rap.planner.pddl import (ADL_AND, ADL_EXISTS, ADL_FORALL, ADL_OR, TYPE_PREFIX, formula_text,
                                     load_pddl)
from atlas_rap.planner.problem import PlanningProblem

_PLAN_LINE = re.compile(r"\(\s*([^\s();]+)((?:\s+[^\s();]+)*)\s*\)\s*(?:;.*)?")
_PLAN_HINT = "a plan line is one action such as (pick ball1 rooma left); ';' starts a comment"


@dataclass(frozen=True)
class PlanCheck:
    """The verdict on a plan: ``failed_step`` is the 1-based step whose action
    is not applicable, or None (the plan is valid, or it runs but misses a goal);
    ``cost`` the cost of the steps run, the number of steps without action costs."""

    ok: bool
    message: str
    failed_step: int | None = None
    cost: float = 0.0


def format_action(action: Compound) -> str:
    """``(name arg ...)`` in lower case, as an IPC plan line."""
    return "(" + " ".join([action.functor, *map(term_to_str, action.args)]).lower() + ")"


def write_plan_file(path: str | Path, actions: Iterable[Compound], cost: float | None = None) -> None:
    """Write a plan, one action a line, and a final ``; cost = N (unit cost)`` line, or ``(general
    cost)`` with the ``cost`` of a problem with action costs (whole or not at all)."""
    lines = [format_action(action) for action in actions]
    if cost is None:
        lines.append(f"; cost = {len(lines)} (unit cost)")
    else:
        lines.append(f"; cost = {cost:g} (general cost)")
    write_text(path, "\n".join(lines) + "\n")


def read_plan_file(path: str | Path) -> list[Compound]:
    """The actions of a plan file; blank lines and ``;`` comments are skipped.

    Raises :class:`~atlas_rap.errors.PlanFileError` for a missing or unreadable
    file and, located with a caret, for a line that is not one action.
    """
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise PlanFileError(Problem("no such file", SourceLocation(name, 1, 1), None, "check the path")) from None
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise PlanFileError(Problem(f"cannot read plan file: {reason}", SourceLocation(name, 1, 1))) from None
    actions = []
    for number, line in enumerate(text.split("\n"), 1):
        stripped = line.strip()
        if not stripped or stripped.startswith(";"):
            continue
        match = _PLAN_LINE.fullmatch(stripped)
        if match is None:
            column = len(line) - len(line.lstrip()) + 1
            raise PlanFileError(Problem("not a plan action", SourceLocation(name, number, column), line, _PLAN_HINT))
        actions.append(Compound(match.group(1).lower(), tuple(match.group(2).lower().split())))
    return actions


def validate_plan(problem: PlanningProblem, actions: Sequence[Compound],
                  adversarial: bool = False) -> PlanCheck:
    """Run ``actions`` from the initial state; see the module docstring."""
    state = set(problem.initial)
    objects = problem.objects
    by_name = {op.name: op for op in problem.operators}
    outcomes: dict[str, list[ast.Operator]] = {}
    for op in problem.operators:
        if op.uncontrolled and op.outcome_of is not None:
            outcomes.setdefault(op.outcome_of, []).append(op)
    cost = 0.0
    for step, action in enumerate(actions, 1):
        shown = format_action(action)
        op = by_name.get(action.functor)
        if op is None:
            return PlanCheck(False, f"step {step}: {shown}: no action named '{action.functor}'", step)
        if op.uncontrolled:
            return PlanCheck(False, f"step {step}: {shown}: '{op.name}' is an uncontrolled outcome, "
                                    f"not an action a plan can choose", step)
        parameters = variable_order(op)
        if len(parameters) != len(action.args):
            return PlanCheck(False, f"step {step}: {shown}: '{op.name}' takes {len(parameters)} "
                                    f"arguments, not {len(action.args)}", step)
        binding = dict(zip(parameters, action.args))
        for condition in op.preconditions:
            ground = substitute(condition, binding)
            if not _holds(ground, state, objects):
                return PlanCheck(False, f"step {step}: {shown}: precondition {_describe(ground)} "
                                        f"does not hold", step, cost)
        step_cost = problem.action_cost(op, binding)
        if step_cost is None:
            return PlanCheck(False, f"step {step}: {shown}: its cost {term_to_str(substitute(op.cost, binding))} "
                                    f"is not given in :init", step, cost)
        cost += step_cost
        before = frozenset(state)
        _apply(state, op.effects, binding, deletions_only=False, before=before, objects=objects)
        if adversarial:
            for outcome in outcomes.get(op.name, ()):
                _apply(state, outcome.effects, binding, deletions_only=True, before=before, objects=objects)
    unmet = [goal for goal in problem.goals if not _holds(goal, state, objects)]
    if unmet:
        return PlanCheck(False, f"goal {formula_text(unmet[0])} is not met after {len(actions)} steps"
                                + (f" ({len(unmet)} goals unmet)" if len(unmet) > 1 else ""), cost=cost)
    worst = " even when every bad outcome happens" if adversarial else ""
    costed = f", cost {cost:g}" if problem.action_costs else ""
    return PlanCheck(True, f"plan valid: {len(actions)} steps reach the goals{worst}{costed}", cost=cost)


def validate_plan_file(domain_path: str | Path, problem_path: str | Path, plan_path: str | Path,
                       adversarial: bool = False) -> PlanCheck:
    """:func:`validate_plan` on PDDL files and a plan file."""
    return validate_plan(load_pddl(domain_path, problem_path), read_plan_file(plan_path), adversarial)


def _holds(condition: Term, state: set | frozenset, objects: Sequence[Term] = ()) -> bool:
    """Whether ``condition`` holds in ``state``; quantifiers range over ``objects``."""
    if type(condition) is not Compound:
        return False
    functor = condition.functor
    if functor == "not" and len(condition.args) == 1:
        return not _holds(condition.args[0], state, objects)
    if functor == "=" and len(condition.args) == 2:
        return condition.args[0] == condition.args[1]
    if functor == ADL_AND:
        return all(_holds(part, state, objects) for part in condition.args)
    if functor == ADL_OR:
        return any(_holds(part, state, objects) for part in condition.args)
    if functor in (ADL_FORALL, ADL_EXISTS) and len(condition.args) == 2:
        names = condition.args[0].args  # type: ignore[union-attr]
        body = condition.args[1]
        cases = (_holds(substitute(body, dict(zip(names, values))), state, objects)
                 for values in product(objects, repeat=len(names)))
        return all(cases) if functor == ADL_FORALL else any(cases)
    return condition in state


def _describe(condition: Compound) -> str:
    """A failed precondition in words: type facts read as types."""
    if condition.functor.startswith(TYPE_PREFIX) and len(condition.args) == 1:
        kind = condition.functor[len(TYPE_PREFIX):]
        return f"{term_to_str(condition)} ('{condition.args[0]}' is not of type {kind})"
    return formula_text(condition)


def _apply(state: set, effects: Sequence, binding: dict, deletions_only: bool,
           before: frozenset | None = None, objects: Sequence[Term] = ()) -> None:
    """PDDL semantics: every deletion first, then every addition. A conditional or
    universal effect (:class:`ast.ConditionalEffect`) applies for each value of its
    variables over ``objects`` whose condition holds in ``before`` (the state before
    the step)."""
    ground = []
    for e in effects:
        if type(e) is not ast.ConditionalEffect:
            ground.append((substitute(e.fact, binding), e.positive))
            continue
        for values in product(objects, repeat=len(e.variables)):
            s = {**binding, **dict(zip(e.variables, values))}
            if _holds(substitute(e.condition, s), state if before is None else before, objects):
                ground.append((substitute(e.fact, s), e.positive))
    state.difference_update(fact for fact, positive in ground if not positive)
    if not deletions_only:
        state.update(fact for fact, positive in ground if positive)

"""The planner from end to end: ground, search, shorten, protect, deorder, expand.

Use :func:`solve` on a :class:`PlanningProblem` (from ``.ap`` files with
:func:`problem_from_program`, or from PDDL with ``load_pddl``); it returns a
:class:`~atlas_rap.planner.plan.Plan`. The steps:

1. :func:`~atlas_rap.planner.ground.ground` the operators;
2. greedy best-first search with hFF and helpful actions
   (:mod:`~atlas_rap.planner.search`), ties to the shallower node; when it
   wandered (evaluated more than WANDERED states per step of its plan), the
   same search with ties in order of generation, within twice the first
   one's evaluations (a portfolio of two: each finds shorter plans on some
   domains); redundant actions dropped from both and the shorter kept; then a
   lazy weighted-A* searches for a shorter plan, each bounded by the best
   plan so far and by a count of evaluations (100 more than four times the
   first search's, at most IMPROVE_BUDGET), as LAMA's later iterations do;
3. :func:`~atlas_rap.planner.counterplan.counterplan` against uncontrolled agents;
4. :func:`~atlas_rap.planner.partial_order.deorder` into a partial order,
   checked valid in every linearisation;
5. :func:`~atlas_rap.planner.plan.build_plan`: plots, agents, schedule.
"""

from __future__ import annotations

import time

from atlas_rap.errors import Problem, SourceLocation
from atlas_rap.logic import Term, term_to_str
from atlas_rap.planner.counterplan import (
    Protected,
    assess,
    counterplan,
    shorten_exposure,
)
from atlas_rap.planner.ground import ground
from atlas_rap.planner.partial_order import check_every_linearisation, deorder
from atlas_rap.planner.plan import Plan, build_plan
from atlas_rap.planner.problem import PlanningProblem
from atlas_rap.planner.search import (
    eliminate_redundant,
    greedy_best_first,
    shorter_plan,
)

DEFAULT_TIMEOUT = 60.0
WANDERED = 4  # a first search that evaluated this many states per plan step wandered: try the other ties
IMPROVE_BUDGET = 20000  # heuristic evaluations of each plan-shortening search
IMPROVE_WEIGHTS = (3.0,)  # its weights, in turn, each bounded by the best plan so far


class PlannerBug(AssertionError):
    """The planner produced a plan its own validator rejects: a bug, never bad input."""


def solve(problem: PlanningProblem, timeout: float | None = DEFAULT_TIMEOUT, protect: bool = True) -> Plan:
    """Plan for ``problem`` within ``timeout`` CPU seconds (None: no limit).

    ``protect`` False skips counterplanning (the risk is still reported).
    """
    started = time.process_time()
    task = ground(problem)
    grounded = time.process_time()
    stats: dict[str, float | int] = {"facts": len(task.facts), "actions": len(task.actions),
                                     "uncontrolled_actions": len(task.nature)}
    timing = {"ground_seconds": round(grounded - started, 4)}
    if task.unreachable_goals:
        goals = ", ".join(term_to_str(g) for g in task.unreachable_goals)
        return Plan(status="unsolvable", stats=stats, timing=timing,
                    reason=f"no sequence of actions can make {goals} true",
                    problems=_unreachable(problem, task.unreachable_goals))
    left = None if timeout is None else max(0.0, timeout - (grounded - started))
    found = greedy_best_first(task, timeout=left)
    stats.update(expanded=found.expanded, evaluated=found.evaluated)
    timing["search_seconds"] = round(found.seconds, 4)
    if found.status != "solved":
        reason = ("the reachable states were searched and none meets the goals" if found.status == "unsolvable"
                  else f"no plan found within {timeout:g} s")
        return Plan(status=found.status, stats=stats, timing=timing, reason=reason)
    sequence = eliminate_redundant(task, found.plan)
    if found.evaluated > WANDERED * max(1, len(sequence)):
        other = greedy_best_first(task, timeout=left, shallow_first=False, heuristic=found.heuristic,
                                  max_evaluations=100 + 2 * found.evaluated)
        if other.status == "solved":
            sequence = _shorter(task, other.plan, sequence)
    for weight in IMPROVE_WEIGHTS:
        left = None if timeout is None else max(0.0, timeout - (time.process_time() - started))
        better = shorter_plan(task, sequence, budget=min(IMPROVE_BUDGET, 100 + 4 * found.evaluated),
                              weight=weight, timeout=left, heuristic=found.heuristic)
        if better is not None:
            sequence = _shorter(task, better, sequence)
    left = None if timeout is None else max(1.0, timeout - (time.process_time() - started))
    if protect:
        protected = counterplan(task, sequence, timeout=left)
    else:
        first = assess(task, sequence)
        protected = Protected(sequence, [], first, first.risk)
    order = deorder(task, protected.plan, fixed={c.step for c in protected.counters})
    if protected.assessment.risk > 0 and not protected.counters:
        reordered = shorten_exposure(task, order.steps, order.closure())
        if reordered != order.steps:
            protected = Protected(reordered, [], assess(task, reordered), protected.first_risk)
            order = deorder(task, reordered)
    problems = check_every_linearisation(task, order)
    if problems:
        raise PlannerBug("the partial order is not valid in every linearisation: " + "; ".join(problems))
    stats.update(length=len(order.steps), parallel_length=order.parallel_length())
    timing["seconds"] = round(time.process_time() - started, 4)
    plan = build_plan(task, order, protected, stats)
    plan.timing = timing
    plan.deadline = problem.deadline_for()
    return plan


def _unreachable(problem: PlanningProblem, goals: tuple[Term, ...]) -> list[Problem]:
    """A located problem for each goal that no sequence of actions can make true."""
    where = dict(zip(problem.goals, problem.goal_locations))
    found = []
    for goal in goals:
        loc = where.get(goal) or SourceLocation(problem.name, 1, 1)
        found.append(Problem(f"goal {term_to_str(goal)}: no sequence of actions can make it true", loc,
                             problem.line(where.get(goal)),
                             "check the initial facts and the preconditions of the operators that achieve it"))
    return found


def _shorter(task, candidate: list, current: list) -> list:
    """``candidate`` without its redundant actions, if that is shorter than ``current``."""
    candidate = eliminate_redundant(task, candidate)
    return candidate if len(candidate) < len(current) else current

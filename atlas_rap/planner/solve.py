"""The planner from end to end: ground, search, shorten, protect, deorder, expand.

Use :func:`solve` on a :class:`PlanningProblem` (from ``.ap`` files with
:func:`problem_from_program`, or from PDDL with ``load_pddl``); it returns a
:class:`~atlas_rap.planner.plan.Plan`. The steps:

1. :func:`~atlas_rap.planner.ground.ground` the operators;
2. search as Fast Downward's ``lama-first`` does
   (:func:`~atlas_rap.planner.lama.lama_search`: lazy greedy best-first
   search alternating hFF and the landmark count, with preferred operators
   and boosts), hFF from the layered relaxed exploration; when neither
   heuristic has improved for STAGNATION evaluations in a row, a restart
   from the start with hFF by h_add's best supporters (Fast Downward's
   ``ff()``) and the landmarks found again with the task's fact mutexes
   (:mod:`~atlas_rap.planner.mutexes`), which a first search without them
   does not pay for: their reasonable orderings (LAMA's
   ``lm_reasonable_orders_hps``) order towers of crates from the bottom up
   (depot), and ``lm_rhw``'s lookahead on a variable's transition graph
   adds landmarks such as freecell's "a card is clear before it goes home"
   (:mod:`~atlas_rap.planner.landmarks`), at the cost of an h² fixpoint over
   every action (0.05-1 s on the shared domains' p20s). The layered hFF is
   the cheaper to compute and guides as well on most domains; h_add's
   guides far better where the layered one sits on a plateau (mprime, large
   transport problems), at twice the cost per evaluation. (1,000
   evaluations is the one value tried, chosen before measuring: the
   thirteen IPC domains' p01-p20 gained six problems and lost none,
   2026-12-05.) Redundant actions are dropped (greedy action
   elimination, cheap);
   then, only with ``shorten=True`` (``atlas plan --shorten``), a lazy
   weighted-A* (weight SHORTEN_WEIGHT) restarted from the start searches for
   a shorter plan, bounded by that plan's length and by a count of
   evaluations (100 more than SHORTEN_FACTOR times the first search's, at
   most SHORTEN_BUDGET), as LAMA's later iterations restart. It is not the
   default: on the thirteen IPC domains (p01-p10, 2026-12-05) it cost more
   CPU than the search itself (in-process CPU 1.73x Fast Downward's with it,
   1.24x without), for plans 1.4 % shorter, and the first plans are already
   3 % shorter than lama-first's.
   With PDDL action costs the searches count actions, as Fast Downward's
   lama-first does (``cost_type=one``, its heuristics ``adapt_costs(one)``):
   a first plan found fast, its cost (``Plan.cost``, the sum of its actions')
   reported beside its length;
3. :func:`~atlas_rap.planner.counterplan.counterplan` against uncontrolled agents;
4. :func:`~atlas_rap.planner.partial_order.deorder` into a partial order,
   checked valid in every linearisation;
5. :func:`~atlas_rap.planner.plan.build_plan`: plots, agents, schedule.

One :class:`~atlas_rap.planner.limits.Limits` (``timeout``, ``memory``) holds
across all of it: grounding stops between joins, the searches every 8
expansions, shortening is anytime and has at most half the time left after
the search (its bounds are counts, so the same input gives the same plan
unless time is that short; then the last valid plan is kept), and a
counterplanning cut short while threats are left is reported as such, never
as a safe plan. ``--timing`` shows each phase's CPU seconds.
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
from atlas_rap.planner.lama import lama_search
from atlas_rap.planner.landmarks import find_landmarks
from atlas_rap.planner.limits import LimitReached, Limits
from atlas_rap.planner.mutexes import fact_mutexes
from atlas_rap.planner.partial_order import check_every_linearisation, deorder
from atlas_rap.planner.plan import Plan, build_plan
from atlas_rap.planner.problem import PlanningProblem
from atlas_rap.planner.relaxation import relaxed_plan_heuristic
from atlas_rap.planner.search import eliminate_redundant, shorter_plan

DEFAULT_TIMEOUT = 60.0
SHORTEN_BUDGET = 20000  # heuristic evaluations of the plan-shortening search (shorten=True), at most
SHORTEN_FACTOR = 3  # ... and at most this many times the first search's, plus 100
SHORTEN_WEIGHT = 2.0  # its weight on hFF
STAGNATION = 1000  # evaluations in a row without progress after which the search restarts (a count)
SHORTEN_SHARE = 0.5  # of the time left after the search, at most, for shortening (its counts bind first, as a rule)


class PlannerBug(AssertionError):
    """The planner produced a plan its own validator rejects: a bug, never bad input."""


def solve(problem: PlanningProblem, timeout: float | None = DEFAULT_TIMEOUT, protect: bool = True,
          memory: float | None = None, limits: Limits | None = None, *, shorten: bool = False) -> Plan:
    """Plan for ``problem`` within ``timeout`` CPU seconds and ``memory`` MiB (None: no limit),
    or within ``limits`` already running (``atlas plan`` starts them before it reads the files).

    The limits bound the whole run, every phase (:mod:`~atlas_rap.planner.limits`):
    past them, a plan whose shortening was cut is returned as it is, marked
    (``Plan.limited``); a plan whose counterplanning was cut while threats were
    left is not returned as safe (status ``timeout`` or ``memory``); without a
    plan, the status says which limit ran out. ``protect`` False skips
    counterplanning (the risk is still reported). ``shorten`` searches again for a
    shorter plan after the first (module docstring).
    """
    limits = limits if limits is not None else Limits(timeout, memory)
    timing: dict[str, float] = {}
    phase = _Phases(limits, timing)
    phase("grounding", "ground")
    try:
        task = ground(problem, stop=limits.expired)
    except LimitReached:
        return _without_plan(limits, phase, {}, "while grounding")
    stats: dict[str, float | int] = {"facts": len(task.facts), "actions": len(task.actions),
                                     "uncontrolled_actions": len(task.nature)}
    if task.unreachable_goals:
        goals = ", ".join(term_to_str(g) for g in task.unreachable_goals)
        phase.end()
        return Plan(status="unsolvable", stats=stats, timing=timing, limits=limits.to_dict(),
                    reason=f"no sequence of actions can make {goals} true",
                    problems=_unreachable(problem, task.unreachable_goals))
    if limits.expired():
        return _without_plan(limits, phase, stats, "before the search began")
    phase("search", "search")
    heuristic = relaxed_plan_heuristic(task)
    landmarks = find_landmarks(task, heuristic)
    found = lama_search(task, heuristic, landmarks=landmarks, stop=limits.expired, stagnation=STAGNATION)
    if found.status == "stuck":  # restart with hFF by h_add's best supporters, landmarks ordered by mutexes
        first = found
        mutexes = fact_mutexes(task, heuristic, stop=limits.expired)
        if mutexes is not None:  # back-chained again, with the lookahead only mutexes allow
            landmarks = find_landmarks(task, heuristic, mutexes)
            stats["reasonable_orderings"] = landmarks.reasonable
        found = lama_search(task, relaxed_plan_heuristic(task, additive=True), landmarks=landmarks,
                            stop=limits.expired)
        found.expanded += first.expanded
        found.evaluated += first.evaluated
        stats["restarted_after"] = first.evaluated
    stats.update(expanded=found.expanded, evaluated=found.evaluated, **found.stats)
    if found.status == "unsolvable":
        phase.end()
        return Plan(status="unsolvable", stats=stats, timing=timing, limits=limits.to_dict(),
                    reason="the reachable states were searched and none meets the goals")
    if found.status != "solved":
        return _without_plan(limits, phase, stats, "before a plan was found")
    phase("shortening", "shorten")
    share = limits.share(SHORTEN_SHARE)
    sequence = eliminate_redundant(task, found.plan, deadline=share)
    if shorten and not share.expired():
        better = shorter_plan(task, sequence, budget=min(SHORTEN_BUDGET, 100 + SHORTEN_FACTOR * found.evaluated),
                              weight=SHORTEN_WEIGHT, heuristic=found.heuristic, stop=share.expired)
        if better is not None:
            sequence = _shorter(task, better, sequence, share)
    phase("counterplanning", "counterplan")
    if protect:
        try:
            protected = counterplan(task, sequence, stop=limits.expired)
        except LimitReached:
            return _without_plan(limits, phase, stats, "while counterplanning, before the plan's threats were "
                                 "known: it is not returned as safe")
    else:
        first = assess(task, sequence)
        protected = Protected(sequence, [], first, first.risk)
    if not protected.complete and protected.assessment.risk > 0:
        return _without_plan(limits, phase, stats, f"while counterplanning: the best plan so far has risk "
                             f"{protected.assessment.risk:g} and is not returned as safe")
    phase("ordering", "order")
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
    plan = build_plan(task, order, protected, stats)
    phase.end()
    plan.timing = timing
    plan.limits = limits.to_dict()
    if limits.reached is not None:
        plan.limited = (f"{limits.describe()} ran out during {limits.during}: this is the best plan found "
                        f"by then" + (", protected as well as it could be" if protect and protected.counters else ""))
    plan.deadline = problem.deadline_for()
    return plan


class _Phases:
    """Names the phase a run is in (for the limits) and times each one (``--timing``)."""

    def __init__(self, limits: Limits, timing: dict[str, float]) -> None:
        self.limits = limits
        self.timing = timing
        self.key: str | None = None
        self.since = time.process_time()
        if limits.started == 0.0:  # the limits count the whole process: say what came before solving
            timing["startup_seconds"] = round(self.since, 4)

    def __call__(self, name: str, key: str) -> None:
        """Begin phase ``name`` (as messages say it), timed as ``KEY_seconds``."""
        self.end()
        self.limits.phase, self.key = name, key
        self.since = time.process_time()

    def end(self) -> None:
        """Close the current phase: add its CPU seconds, and the total so far."""
        now = time.process_time()
        if self.key is not None:
            self.timing[f"{self.key}_seconds"] = round(now - self.since, 4)
        self.timing["seconds"] = round(now - self.limits.started, 4)
        self.key = None


def _without_plan(limits: Limits, phase: _Phases, stats: dict, when: str) -> Plan:
    """The result when a limit ran out with no plan that can be given as safe."""
    phase.end()
    status = limits.reached or "timeout"
    return Plan(status=status, stats=stats, timing=phase.timing, limits=limits.to_dict(),
                reason=f"{limits.describe()} ran out {when}")


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


def _shorter(task, candidate: list, current: list, limits: Limits | None = None) -> list:
    """``candidate`` without its redundant actions, if that is shorter than ``current``."""
    candidate = eliminate_redundant(task, candidate, deadline=limits)
    return candidate if len(candidate) < len(current) else current

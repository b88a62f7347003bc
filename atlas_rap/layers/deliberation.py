"""The planner beside the robot: plans made while the sequencer and skills keep going.

The sequencer's ``(plan GOAL ...)`` steps ask a :class:`Deliberation` for
plans (the ``Deliberator`` seam of ``sequencer.deliberation``). It builds the
planning problem on the caller's thread, from RAP memory *as it is now* (one
memory: the prior map's places and doors, what skills and RAPs asserted, the
program's ``initial`` facts) and the operators, agents and relations loaded
so far, leaving out lost agents; then it plans in one of two ways:

- **Simulated time** (the default; same files and seed, same trace): the
  planner runs at once, and its result is delivered after a simulated
  latency charged by a deterministic rule, :func:`charged_latency`:
  ``BASE_LATENCY`` plus ``LATENCY_PER_STATE`` for each state its first
  search evaluated (the planner's own count, the same on every machine).
  Meanwhile simulated time goes on: the robot keeps driving and the
  running steps keep running.
- **A worker** (``--realtime``, and the REPL on a terminal): the planner runs
  on a worker thread and the result is delivered at the first sequencer tick
  after it is ready (polled every ``POLL`` simulated seconds), so the clock
  keeps ticking, the skills keep running and the REPL keeps answering while
  it plans. ``latency`` is then the simulated time that really passed.

Either way the plan arrives through the sequencer's timers, never from
inside the request, and a cancelled request delivers nothing.
"""

from __future__ import annotations

import dataclasses
import threading
from typing import Callable

from atlas_rap.errors import AtlasError
from atlas_rap.logic import Term
from atlas_rap.planner.plan import Plan, plan_of_error
from atlas_rap.planner.problem import PlanningProblem
from atlas_rap.skillbus.timers import Timer, Timers

BASE_LATENCY = 0.2
"""Simulated seconds charged for any plan (grounding, set-up)."""

LATENCY_PER_STATE = 0.001
"""Simulated seconds charged per state the planner's search evaluated."""

POLL = 0.05
"""How often (simulated seconds) a worker's plan is looked for."""

PLAN_TIMEOUT = 60.0
"""CPU seconds the planner may take for one plan."""

Deliver = Callable[[Plan, float], None]
"""``deliver(plan, latency)``: the plan, and the simulated seconds it took."""
ProblemFor = Callable[[tuple[Term, ...], frozenset[str]], PlanningProblem]
"""``problem_for(goals, lost_agents)``: the planning problem from memory now."""


def charged_latency(plan: Plan) -> float:
    """The simulated seconds a plan is charged in simulated time: a count, never a clock."""
    return BASE_LATENCY + LATENCY_PER_STATE * int(plan.stats.get("evaluated", 0))


def plan_for(problem: PlanningProblem, timeout: float = PLAN_TIMEOUT) -> Plan:
    """Solve ``problem``; bad input becomes a plan of status ``error`` with its reason.
    When no plan avoids ``problem.avoid`` (the actions that failed), plan with them."""
    from atlas_rap.planner.checks import raise_problems
    from atlas_rap.planner.solve import solve

    try:
        raise_problems(problem)
        plan = solve(problem, timeout=timeout)
        if plan.status == "unsolvable" and problem.avoid:
            first = plan.stats.get("evaluated", 0)
            plan = solve(dataclasses.replace(problem, avoid=frozenset()), timeout=timeout)
            plan.stats["evaluated"] = int(plan.stats.get("evaluated", 0)) + int(first)
        return plan
    except AtlasError as exc:
        return plan_of_error(exc)


class _Request:
    """One plan being made: its delivery timer, or its worker thread and result."""

    def __init__(self) -> None:
        self.cancelled = False
        self.timer: Timer | None = None
        self.result: Plan | None = None

    def cancel(self) -> None:
        self.cancelled = True
        if self.timer is not None:
            self.timer.cancel()


class Deliberation:
    """Makes plans for the sequencer, in simulated time or on a worker (module docstring).

    ``problem_for(goals, lost_agents)`` builds the problem from memory now;
    ``timers`` are the sequencer's. ``worker`` True plans on a thread.
    ``planner(problem, timeout)`` makes the plan (:func:`plan_for`).
    """

    def __init__(self, problem_for: ProblemFor, timers: Timers, *, worker: bool = False,
                 timeout: float = PLAN_TIMEOUT, planner: Callable[[PlanningProblem, float], Plan] | None = None) -> None:
        self.problem_for = problem_for
        self.timers = timers
        self.worker = worker
        self.timeout = timeout
        self.planner = planner if planner is not None else plan_for

    def deadline_for(self, goals: tuple[Term, ...]) -> float | None:
        """The AP ``(deadline GOAL SECONDS)`` that binds these goals soonest, if any."""
        try:
            return self.problem_for(goals, frozenset()).deadline_for(goals)
        except AtlasError:
            return None

    def request(self, goals: tuple[Term, ...], lost: frozenset[str], avoid: frozenset[Term],
                deliver: Deliver) -> _Request:
        """Start a plan for ``goals`` without ``lost`` agents and, when it can, without the actions
        in ``avoid``; ``deliver(plan, latency)`` later."""
        request = _Request()
        asked = self.timers.now
        try:
            problem = dataclasses.replace(self.problem_for(goals, lost), avoid=avoid)
        except AtlasError as exc:
            plan = plan_of_error(exc)
            request.timer = self.timers.after(0.0, lambda: deliver(plan, 0.0))
            return request
        if not self.worker:
            plan = self.planner(problem, self.timeout)
            latency = charged_latency(plan)
            request.timer = self.timers.after(latency, lambda: deliver(plan, latency))
            return request

        def work() -> None:
            request.result = self.planner(problem, self.timeout)

        threading.Thread(target=work, name="atlas-planner", daemon=True).start()

        def poll() -> None:
            if request.cancelled:
                return
            if request.result is None:
                request.timer = self.timers.after(POLL, poll)
                return
            deliver(request.result, self.timers.now - asked)

        request.timer = self.timers.after(POLL, poll)
        return request

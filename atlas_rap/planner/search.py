"""Forward search: greedy best-first search guided by the FF heuristic.

What the best satisficing planners do, in Python:

- **hFF** (Hoffmann & Nebel's relaxed plan), from
  :mod:`~atlas_rap.planner.relaxation` (pure Python on small tasks, numpy
  on large ones). States are frozensets of fact numbers, so set operations
  run in C.
- **Helpful actions**: the applicable actions that add a fact the relaxed
  plan needs at its first layer. Successors reached by them also go into a
  *preferred* queue, and the search alternates between the two queues,
  with a boost of the preferred one whenever the heuristic improves
  (Fast Downward's dual-queue, as in LAMA's first iteration).
- The evaluation that computes h also finds the applicable actions (the
  first layer of the relaxed exploration), so generating successors costs
  nothing more.
- Lazy evaluation (a state is evaluated when it is taken from the queue,
  and enters it with its parent's value), as in LAMA: far fewer
  evaluations than eager search on these domains, at a few more
  expansions. Duplicate detection; ties are broken by order of generation,
  so the same task always gives the same plan.

Then :func:`eliminate_redundant` drops actions the plan does not need
(greedy action elimination), which shortens what greedy search leaves in.
Negative preconditions and negative goals are ignored by the relaxation and
checked exactly on real states.
"""

from __future__ import annotations

import heapq
import time
from dataclasses import dataclass, field
from typing import Callable, Collection, Sequence

from atlas_rap.planner.ground import GroundAction, GroundTask
from atlas_rap.planner.relaxation import INFINITY, RelaxedPlanHeuristic, relaxed_plan_heuristic

BOOST = 1000


@dataclass
class SearchResult:
    """``status``: ``solved``, ``unsolvable`` (the reachable space was exhausted) or
    ``timeout``; ``plan`` the actions in order when solved."""

    status: str
    plan: list[GroundAction]
    expanded: int = 0
    evaluated: int = 0
    seconds: float = 0.0
    heuristic: RelaxedPlanHeuristic | None = None
    stats: dict[str, int] = field(default_factory=dict)  # what else the search counted, for Plan.stats


Settle = Callable[[frozenset[int], GroundAction], frozenset[int]]


def greedy_best_first(task: GroundTask, timeout: float | None = None,
                      actions: Sequence[GroundAction] | None = None,
                      init: frozenset[int] | None = None, settle: Settle | None = None, *,
                      max_evaluations: int | None = None,
                      heuristic: RelaxedPlanHeuristic | None = None,
                      stop: Callable[[], bool] | None = None) -> SearchResult:
    """Search ``task`` from ``init`` (default the task's initial state) with ``actions``
    (default the task's own). Stops with ``timeout`` after that many CPU seconds,
    when ``stop()`` says so (a run's :class:`~atlas_rap.planner.limits.Limits`),
    or (status ``timeout``) after ``max_evaluations`` heuristic evaluations.

    ``settle(state, action)``, when given, changes each state an action
    reaches before it is evaluated: counterplanning passes the worst that
    uncontrolled agents can do there. Ties between equal heuristic values go
    to the shallower node, then in order of generation.
    """
    started = time.process_time()
    heuristic = heuristic or relaxed_plan_heuristic(task, actions)
    acts = heuristic.actions
    start = task.init if init is None else init
    is_goal = task.is_goal
    negs, deletes, adds = heuristic.negs, heuristic.deletes, heuristic.add_sets
    parents: dict[frozenset[int], tuple[frozenset[int] | None, int]] = {start: (None, -1)}
    depth: dict[frozenset[int], int] = {start: 0}
    regular: list[tuple[float, int, int, frozenset[int], int]] = []
    preferred: list[tuple[float, int, int, frozenset[int], int]] = []
    tick = 0
    expanded = evaluated = 0

    def result(status: str, goal_state: frozenset[int] | None = None) -> SearchResult:
        plan = _path_to(goal_state, parents, acts) if goal_state is not None else []
        return SearchResult(status, plan, expanded, evaluated, time.process_time() - started, heuristic)

    def open_successors(h: float, state: frozenset[int], applicable: list[int], helpful: set[int]) -> None:
        nonlocal tick
        g = depth[state] + 1
        for a in applicable:
            neg = negs[a]
            if neg and any(n in state for n in neg):
                continue
            tick += 1
            entry = (h, g, tick, state, a)
            heapq.heappush(regular, entry)
            if a in helpful:
                heapq.heappush(preferred, entry)

    if is_goal(start):
        return result("solved", start)
    best_h, applicable, helpful = heuristic.evaluate(start)
    evaluated = 1
    if best_h == INFINITY:
        return result("unsolvable")
    open_successors(best_h, start, applicable, helpful)
    boost = 0
    use_preferred = True
    while regular or preferred:
        if boost > 0 and preferred:
            queue = preferred
            boost -= 1
        elif preferred and (use_preferred or not regular):
            queue = preferred
            use_preferred = False
        else:
            queue = regular
            use_preferred = True
        _, g, _, state, a = heapq.heappop(queue)
        child = (state - deletes[a]) | adds[a]
        if settle is not None:
            child = settle(child, acts[a])
        if child in parents:
            continue
        parents[child] = (state, a)
        depth[child] = g
        expanded += 1
        if expanded % 8 == 0 and ((timeout is not None and time.process_time() - started > timeout)
                                   or (stop is not None and stop())):
            return result("timeout")
        if is_goal(child):
            return result("solved", child)
        if max_evaluations is not None and evaluated >= max_evaluations:
            return result("timeout")
        h, applicable, helpful = heuristic.evaluate(child)
        evaluated += 1
        if h == INFINITY:
            continue
        if h < best_h:
            best_h = h
            boost += BOOST
        open_successors(h, child, applicable, helpful)
    return result("unsolvable")


def _path_to(state: frozenset[int], parents: dict[frozenset[int], tuple[frozenset[int] | None, int]],
             acts: Sequence[GroundAction]) -> list[GroundAction]:
    """The actions that led from the start to ``state``, following ``parents`` back."""
    plan: list[GroundAction] = []
    node: frozenset[int] | None = state
    while node is not None:
        parent, a = parents[node]
        if a >= 0:
            plan.append(acts[a])
        node = parent
    plan.reverse()
    return plan


@dataclass
class EliminationWork:
    """The work :func:`eliminate_redundant` did, counted (so a test can check its cost
    without a clock): ``applied``, actions applied to a state (each a copy of the
    state and a ``settle`` call: the expensive operation); ``copied``, other
    copies of a whole state (moving on to the next step, confirming that two
    states are equal); ``checked``, applicability tests (a few membership tests
    each); ``trials``, candidate removals tried. Pass one as ``work=``; it is
    added to, never reset."""

    applied: int = 0
    copied: int = 0
    checked: int = 0
    trials: int = 0


_MASK = (1 << 64) - 1


def _fact_key(fact: int) -> int:
    """A pseudo-random 64-bit number for a fact (splitmix64): a state's fingerprint is
    the sum of its facts' numbers, so it follows a state's changes at their cost."""
    z = (fact * 0x9E3779B97F4A7C15 + 0x632BE59BD9B4E019) & _MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK
    return z ^ (z >> 31)


def eliminate_redundant(task: GroundTask, plan: list[GroundAction],
                        init: frozenset[int] | None = None, settle: Settle | None = None, *,
                        deadline: object | None = None, work: EliminationWork | None = None,
                        settle_adds: Collection[int] | None = None) -> list[GroundAction]:
    """The plan without the actions it does not need: repeatedly drop the first action
    whose removal (with the actions that then become inapplicable) leaves a valid plan.

    Greedy action elimination. The *trial* for step ``i`` runs the plan from the
    start without step ``i``: a later action that has become inapplicable is
    dropped too (an earlier one ends the trial: the plan was not executable
    there), and the trial succeeds when its last state meets the goals. A
    success replaces the plan by what the trial kept, and step ``i`` (now
    another action) is tried again; a failure moves on to ``i + 1``.

    Doing each trial from the start costs O(length) applications, each a copy
    of the state (and a ``settle``): O(length² × state) in all. Instead one run
    of the current plan is kept (:class:`_KeptRun`: each action skipped when
    inapplicable, as a trial does), as what each step changed and a fingerprint
    of the state before it (``settle`` must be a function of state and action),
    and the state before the candidate step ``i``. A trial computes the same
    outcome from there on, stopping as soon as it is known:

    - **Prefix.** Before ``i`` a trial runs the unchanged steps from the same
      state, so it reaches the kept run's state before ``i`` exactly when every
      step before ``i`` was applicable (else it fails, as does every later ``i``).
    - **Meeting the kept run.** If the trial's state before step ``j`` equals the
      kept run's (same fingerprint, then confirmed fact by fact), the rest of it
      is the kept run from there (the same state, the same actions): it keeps
      the actions that run applied and ends in its last state, so it succeeds
      exactly when the kept run reached the goals.
    - **A goal no one can add.** If a (positive) goal is missing from the trial's
      state and no later step has it in its ``add`` (nor can ``settle`` add it:
      when ``settle`` is given, only goals outside ``settle_adds``, the facts it
      may add, count; by default none), the trial fails: a state gains facts
      only from the adds of the actions applied and from ``settle``.

    So every trial has the outcome, and keeps the actions, that it has when run
    from the start, and the plans are the same, step for step. Only a success
    changes the kept run (the trial's changes replace those of the steps it
    covered). A redundant step is mostly found by the second test within a
    few steps (a detour), a needed one by the second or the third (what
    depended on it is dropped until a goal has no adder left), so the
    applications and copies of states are about linear in the length, not
    quadratic, and the memory is a few states and the changes. Applicability
    tests (a few membership tests each) can still add up to length² when what
    depends on a needed step runs to the end of the plan (a route: every later
    move is tested and dropped). What is counted goes into ``work``.

    ``deadline`` (an object with ``expired()``, such as the run's ``Limits``, or
    a callable returning True once time is up) is asked before each trial; when
    it has expired the plan so far is returned, valid if the given one was:
    plan shortening is anytime.
    """
    plan = list(plan)
    stop = getattr(deadline, "expired", deadline)
    if stop is not None and stop():
        return plan
    run = _KeptRun(task, plan, task.init if init is None else init, settle, settle_adds,
                   work if work is not None else EliminationWork())
    trial, accept, reject = run.trial, run.accept, run.reject
    i = 0
    while i < len(plan) and i <= run.last_candidate:
        if stop is not None and stop():
            break
        kept = trial(i)
        if kept is not None:
            accept(i, *kept)
        else:
            reject(i)
            i += 1
    return plan


Change = tuple[tuple[int, ...], tuple[int, ...]]  # the facts one step added and removed


Trial = tuple[int, list[GroundAction], list[Change], list[int], list[GroundAction]]
"""What a trial without step ``i`` that reached the goals kept: the step ``end`` where it stopped
(met the kept run, or ran out), and of ``plan[i + 1:end]`` the actions it applied (``kept``), their
changes and the fingerprints after them, and the actions it dropped (``skipped``, with step ``i``).
A plain tuple: one is made for most trials, and it is read once, by :meth:`_KeptRun.accept`."""


class _KeptRun:
    """One run of :func:`eliminate_redundant`'s current plan (its docstring), and the trials against it.

    ``changes[j]`` is what step ``j`` changed (nothing when it was not applied,
    ``done[j]`` False), ``marks[j]`` the fingerprint of the state before step
    ``j`` relative to the start's (``marks[-1]`` the last state's), ``here``
    the state before the candidate step, ``adds_goals[action]`` the goals an
    action adds (of those no ``settle`` may add), and ``rest[g]`` how many
    steps from the candidate on add the goal ``g``. The plan is changed in place.
    """

    def __init__(self, task: GroundTask, plan: list[GroundAction], start: frozenset[int], settle: Settle | None,
                 settle_adds: Collection[int] | None, work: EliminationWork) -> None:
        self.plan, self.work, self.here = plan, work, start
        self._applicable, self._step = task.applicable, _stepper(task.apply, settle, work)
        # the plan only ever loses actions: the goals each of its actions adds are known once for all
        self.adds_goals, self.rest = _goal_adders(plan, _goals_settle_cannot_add(task, settle, settle_adds))
        state = self._run_once(start)
        self.executable = all(self.done)
        self.last_candidate = len(plan) if self.executable else self.done.index(False)
        self.reaches = task.is_goal(state)
        self._is_goal = task.is_goal

    def _run_once(self, state: frozenset[int]) -> frozenset[int]:
        """Run the plan from ``state``, skipping the inapplicable steps, noting what each step
        changed and the fingerprints; the last state."""
        changes: list[Change] = []
        marks = [0]
        done: list[bool] = []
        applicable, step, work = self._applicable, self._step, self.work
        for action in self.plan:
            work.checked += 1
            if applicable(action, state):
                state, added, removed, shift = step(state, action)
                changes.append((added, removed))
                marks.append((marks[-1] + shift) & _MASK)
                done.append(True)
            else:
                changes.append(((), ()))
                marks.append(marks[-1])
                done.append(False)
        self.changes, self.marks, self.done = changes, marks, done
        return state

    def _kept_state(self, i: int, j: int) -> frozenset[int]:
        """The kept run's state before step ``j``, from ``here`` (before step ``i``)."""
        self.work.copied += 1
        facts = set(self.here)
        for added, removed in self.changes[i:j]:
            facts.difference_update(removed)
            facts.update(added)
        return frozenset(facts)

    def _loses_a_goal(self, goals_added: tuple[int, ...], used: dict[int, int], state: frozenset[int]) -> bool:
        """Count a step's ``goals_added`` as passed (in ``used``): whether it was the last step that
        could add a goal ``state`` lacks."""
        lost = False
        for g in goals_added:
            used[g] = used.get(g, 0) + 1
            if used[g] == self.rest[g] and g not in state:
                lost = True
        return lost

    def trial(self, i: int) -> Trial | None:
        """Run the plan without step ``i`` from the state before it, until its outcome is known:
        what it kept when it reaches the goals, else None."""
        self.work.trials += 1
        plan, marks, applicable, step, work = self.plan, self.marks, self._applicable, self._step, self.work
        adds_goals, loses_a_goal = self.adds_goals, self._loses_a_goal
        n = len(plan)
        removed_step = plan[i]
        state, mark = self.here, marks[i]
        kept: list[GroundAction] = []
        kept_changes: list[Change] = []
        kept_marks: list[int] = []
        skipped = [removed_step]
        used: dict[int, int] = {}
        goals_added = adds_goals[removed_step]
        succeeded: bool | None = False if goals_added and loses_a_goal(goals_added, used, state) else None
        j = i + 1
        while succeeded is None and j < n:
            if mark == marks[j] and state == self._kept_state(i, j):
                succeeded = self.reaches  # the kept run from here on
                break
            action = plan[j]
            work.checked += 1
            if applicable(action, state):
                state, added, removed, shift = step(state, action)
                mark = (mark + shift) & _MASK
                kept.append(action)
                kept_changes.append((added, removed))
                kept_marks.append(mark)
            else:
                skipped.append(action)
            goals_added = adds_goals[action]
            if goals_added and loses_a_goal(goals_added, used, state):
                succeeded = False
            j += 1
        if succeeded is None:
            succeeded = self._is_goal(state)  # the trial ran to the end
        return (j, kept, kept_changes, kept_marks, skipped) if succeeded else None

    def reject(self, i: int) -> None:
        """Step ``i`` is needed: keep it and move the candidate on to step ``i + 1``."""
        for g in self.adds_goals[self.plan[i]]:
            self.rest[g] -= 1
        if i < self.last_candidate:
            added, removed = self.changes[i]
            if added or removed:
                self.work.copied += 1
                self.here = self.here.difference(removed).union(added)

    def accept(self, i: int, end: int, kept: list[GroundAction], kept_changes: list[Change], kept_marks: list[int],
               skipped: list[GroundAction]) -> None:
        """Step ``i`` is redundant: the plan and the kept run become what its trial kept (:data:`Trial`)."""
        plan, changes, marks, j, n = self.plan, self.changes, self.marks, end, len(self.plan)
        if self.executable or j == n:
            plan[i:j] = kept
            changes[i:j] = kept_changes
            marks[i + 1:j + 1] = kept_marks
        else:  # met a kept run that skips inapplicable steps: keep the ones it applied
            done = self.done
            tail = [m for m in range(j, n) if done[m]]
            skipped.extend(plan[m] for m in range(j, n) if not done[m])
            plan[i:] = kept + [plan[m] for m in tail]
            changes[i:] = kept_changes + [changes[m] for m in tail]
            marks[i + 1:] = kept_marks + [marks[m + 1] for m in tail]
        rest, adds_goals = self.rest, self.adds_goals
        for action in skipped:
            for g in adds_goals[action]:
                rest[g] -= 1
        self.executable = self.reaches = True
        self.last_candidate = len(plan)


Step = Callable[[frozenset[int], GroundAction], tuple[frozenset[int], tuple[int, ...], tuple[int, ...], int]]


def _stepper(apply: Callable[[GroundAction, frozenset[int]], frozenset[int]], settle: Settle | None,
             work: EliminationWork) -> Step:
    """The function that applies an action (and ``settle``) to a state, counted in ``work``."""

    def step(state: frozenset[int],
             action: GroundAction) -> tuple[frozenset[int], tuple[int, ...], tuple[int, ...], int]:
        """The state after ``action``, the facts it added and removed, and the change of fingerprint."""
        after = apply(action, state)
        if settle is not None:
            after = settle(after, action)
        work.applied += 1
        changed = state.symmetric_difference(after)
        added = tuple(f for f in changed if f in after)
        removed = tuple(f for f in changed if f not in after)
        return after, added, removed, sum(map(_fact_key, added)) - sum(map(_fact_key, removed))

    return step


def _goal_adders(plan: list[GroundAction],
                 goals: set[int]) -> tuple[dict[GroundAction, tuple[int, ...]], dict[int, int]]:
    """The ``goals`` each action of ``plan`` adds, and how many steps of the plan add each goal."""
    adds_goals: dict[GroundAction, tuple[int, ...]] = {}
    count: dict[int, int] = {}
    for action in plan:
        found = adds_goals.get(action)
        if found is None:
            found = adds_goals[action] = tuple(f for f in action.add if f in goals)
        for g in found:
            count[g] = count.get(g, 0) + 1
    return adds_goals, count


def _goals_settle_cannot_add(task: GroundTask, settle: Settle | None,
                             settle_adds: Collection[int] | None) -> set[int]:
    """The task's (positive) goals that no ``settle`` may add: all without one; with one, those outside
    ``settle_adds`` (none when it is not given)."""
    goals = set(task.goal)
    if settle is not None:
        goals = goals.difference(settle_adds) if settle_adds is not None else set()
    return goals


def shorter_plan(task: GroundTask, plan: list[GroundAction], budget: int, weight: float = 3.0,
                 timeout: float | None = None,
                 heuristic: RelaxedPlanHeuristic | None = None,
                 stop: Callable[[], bool] | None = None) -> list[GroundAction] | None:
    """A plan shorter than ``plan``, or None: lazy weighted A* (f = g + weight * hFF,
    helpful actions first among equals) that prunes every node that cannot beat
    ``plan``'s length, within ``budget`` heuristic evaluations (a count, so the
    result does not depend on the machine's speed). A later iteration of a
    LAMA-style planner; pass the first search's ``heuristic`` to reuse it.
    ``timeout`` (CPU seconds) and ``stop()`` end it early, with None."""
    started = time.process_time()
    heuristic = heuristic or relaxed_plan_heuristic(task)
    acts = heuristic.actions
    bound = len(plan)
    start = task.init
    h0, applicable0, helpful0 = heuristic.evaluate(start)
    if h0 == INFINITY or bound <= 1:
        return None
    best_g: dict[frozenset[int], int] = {start: 0}
    parents: dict[frozenset[int], tuple[frozenset[int] | None, int]] = {start: (None, -1)}
    queue: list[tuple[float, int, int, frozenset[int], int, int]] = []
    negs, deletes, adds = heuristic.negs, heuristic.deletes, heuristic.add_sets
    tick = 0

    def open_successors(state: frozenset[int], g: int, h: float, applicable: list[int], helpful: set[int]) -> None:
        nonlocal tick
        for a in applicable:
            neg = negs[a]
            if neg and any(n in state for n in neg):
                continue
            tick += 1
            heapq.heappush(queue, (g + 1 + weight * h, 0 if a in helpful else 1, tick, state, a, g + 1))

    open_successors(start, 0, h0, applicable0, helpful0)
    evaluated = 0
    while queue and evaluated < budget:
        _, _, _, state, a, g = heapq.heappop(queue)
        child = (state - deletes[a]) | adds[a]
        if g >= bound or g >= best_g.get(child, bound):
            continue
        best_g[child] = g
        parents[child] = (state, a)
        if task.is_goal(child):
            return _path_to(child, parents, acts)
        if evaluated % 8 == 0 and ((timeout is not None and time.process_time() - started > timeout)
                                    or (stop is not None and stop())):
            return None
        h, applicable, helpful = heuristic.evaluate(child)
        evaluated += 1
        if h == INFINITY or g + h >= bound:
            continue
        open_successors(child, g, h, applicable, helpful)
    return None

"""Forward search: greedy best-first search guided by the FF heuristic.

What the best satisficing planners do, in plain Python:

- **hFF** (Hoffmann & Nebel's relaxed plan) computed on a layered relaxed
  planning graph by counting unsatisfied preconditions: each evaluation
  touches every (fact, action) incidence at most once, and states are
  frozensets of fact numbers, so set operations run in C.
- **Helpful actions**: the applicable actions that add a fact the relaxed
  plan needs at its first layer. Successors reached by them also go into a
  *preferred* queue, and the search alternates between the two queues,
  with a boost of the preferred one whenever the heuristic improves
  (Fast Downward's dual-queue, as in LAMA's first iteration).
- The evaluation that computes h also finds the applicable actions (those
  whose counter reaches zero in the first layer), so generating successors
  costs nothing more.
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
from dataclasses import dataclass
from typing import Callable, Sequence

from atlas_rap.planner.ground import GroundAction, GroundTask

INFINITY = float("inf")
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


class RelaxedPlanHeuristic:
    """hFF over a task's actions, with helpful actions and the applicable set.

    It also holds, once, what the searches need to apply an action by number:
    ``negs`` (negative preconditions), ``deletes`` and ``add_sets`` (frozensets).
    """

    def __init__(self, task: GroundTask, actions: Sequence[GroundAction] | None = None) -> None:
        self.actions = list(task.actions if actions is None else actions)
        n_facts = len(task.facts)
        self.pre_of: list[list[int]] = [[] for _ in range(n_facts)]
        self.pre_count: list[int] = []
        self.adds: list[tuple[int, ...]] = []
        self.pres: list[tuple[int, ...]] = []
        self.no_pre: list[int] = []
        for i, action in enumerate(self.actions):
            for f in action.pre:
                self.pre_of[f].append(i)
            self.pre_count.append(len(action.pre))
            self.adds.append(action.add)
            self.pres.append(action.pre)
            if not action.pre:
                self.no_pre.append(i)
        self.goal = task.goal
        self.negs = [a.neg for a in self.actions]
        self.deletes = [frozenset(a.delete) for a in self.actions]
        self.add_sets = [frozenset(a.add) for a in self.actions]

    def evaluate(self, state: frozenset[int]) -> tuple[float, list[int], set[int]]:
        """(h, applicable action numbers, helpful action numbers) of ``state``."""
        counter = self.pre_count[:]
        pre_of = self.pre_of
        adds = self.adds
        level: dict[int, int] = dict.fromkeys(state, 0)
        achiever: dict[int, int] = {}
        goals = self.goal
        missing = sum(1 for g in goals if g not in level)
        current: list[int] = list(state)
        applicable: list[int] = []
        layer = 0
        while True:
            fired: list[int] = list(self.no_pre) if layer == 0 else []
            for f in current:
                for a in pre_of[f]:
                    c = counter[a] - 1
                    counter[a] = c
                    if c == 0:
                        fired.append(a)
            if layer == 0:
                applicable = fired
                if missing == 0:
                    return 0, applicable, set()
            following: list[int] = []
            nxt = layer + 1
            for a in fired:
                for g in adds[a]:
                    if g not in level:
                        level[g] = nxt
                        achiever[g] = a
                        following.append(g)
            if not following:
                return INFINITY, applicable, set()
            missing -= sum(1 for g in goals if level.get(g) == nxt)
            if missing <= 0:
                break
            current = following
            layer = nxt
        # Extract the relaxed plan backwards from the goals.
        pres = self.pres
        relaxed: set[int] = set()
        marked: set[int] = set(goals)
        stack = [g for g in goals if level[g] > 0]
        first_layer_needs: set[int] = set()
        while stack:
            g = stack.pop()
            if level[g] == 1:
                first_layer_needs.add(g)
            a = achiever[g]
            if a in relaxed:
                continue
            relaxed.add(a)
            for p in pres[a]:
                if p not in marked and level[p] > 0:
                    marked.add(p)
                    stack.append(p)
        helpful = {a for a in applicable if not first_layer_needs.isdisjoint(adds[a])}
        return len(relaxed), applicable, helpful


Settle = Callable[[frozenset[int], GroundAction], frozenset[int]]


def greedy_best_first(task: GroundTask, timeout: float | None = None,
                      actions: Sequence[GroundAction] | None = None,
                      init: frozenset[int] | None = None, settle: Settle | None = None, *,
                      shallow_first: bool = True, max_evaluations: int | None = None,
                      heuristic: RelaxedPlanHeuristic | None = None) -> SearchResult:
    """Search ``task`` from ``init`` (default the task's initial state) with ``actions``
    (default the task's own). Stops with ``timeout`` after that many CPU seconds,
    or (status ``timeout``) after ``max_evaluations`` heuristic evaluations.

    ``settle(state, action)``, when given, changes each state an action
    reaches before it is evaluated: counterplanning passes the worst that
    uncontrolled agents can do there. ``shallow_first`` breaks ties between
    equal heuristic values towards the shallower node, else in order of
    generation; the two find different plans, which the planner uses as a
    small portfolio.
    """
    started = time.process_time()
    heuristic = heuristic or RelaxedPlanHeuristic(task, actions)
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
        g = depth[state] + 1 if shallow_first else 0
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
        if timeout is not None and expanded % 64 == 0 and time.process_time() - started > timeout:
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


def eliminate_redundant(task: GroundTask, plan: list[GroundAction],
                        init: frozenset[int] | None = None, settle: Settle | None = None) -> list[GroundAction]:
    """The plan without the actions it does not need: repeatedly drop the first action
    whose removal (with the actions that then become inapplicable) leaves a valid plan."""
    start = task.init if init is None else init
    i = 0
    while i < len(plan):
        trial = _without(task, plan, i, start, settle)
        if trial is not None:
            plan = trial
        else:
            i += 1
    return plan


def _without(task: GroundTask, plan: list[GroundAction], i: int,
             start: frozenset[int], settle: Settle | None) -> list[GroundAction] | None:
    state = start
    kept: list[GroundAction] = []
    for j, action in enumerate(plan):
        if j == i:
            continue
        if task.applicable(action, state):
            state = task.apply(action, state)
            if settle is not None:
                state = settle(state, action)
            kept.append(action)
        elif j < i:
            return None
    return kept if task.is_goal(state) else None


def shorter_plan(task: GroundTask, plan: list[GroundAction], budget: int, weight: float = 3.0,
                 timeout: float | None = None,
                 heuristic: RelaxedPlanHeuristic | None = None) -> list[GroundAction] | None:
    """A plan shorter than ``plan``, or None: lazy weighted A* (f = g + weight * hFF,
    helpful actions first among equals) that prunes every node that cannot beat
    ``plan``'s length, within ``budget`` heuristic evaluations (a count, so the
    result does not depend on the machine's speed). A later iteration of a
    LAMA-style planner; pass the first search's ``heuristic`` to reuse it."""
    started = time.process_time()
    heuristic = heuristic or RelaxedPlanHeuristic(task)
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
        if timeout is not None and evaluated % 64 == 0 and time.process_time() - started > timeout:
            return None
        h, applicable, helpful = heuristic.evaluate(child)
        evaluated += 1
        if h == INFINITY or g + h >= bound:
            continue
        open_successors(child, g, h, applicable, helpful)
    return None

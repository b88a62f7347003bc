"""Landmarks, and the search LAMA makes with them: the restart for a search that wanders.

A *landmark* is a fact every plan makes true at some point. They are found
by back-chaining from the goals in the delete relaxation (Hoffmann, Porteous
and Sebastia 2004; Richter, Helmert and Westphal 2008, simplified to facts):
for a landmark L not true at the start, the actions that could first achieve
it are those whose preconditions are reachable without achieving L; the
preconditions they all share are landmarks too.

The **landmark count** of a state, on the path that reached it, is the number
of landmarks not yet reached on that path, plus the goals reached before but
false now (they must be made true again). :func:`landmark_search` is LAMA's
first iteration: lazy greedy best-first search alternating four queues,
hFF and the landmark count each with and without preferred operators (for
hFF its helpful actions; for landmarks the applicable actions that reach a
landmark not yet reached), boosting the preferred queues whenever either
heuristic improves. Ties go by order of generation, so the same task gives
the same plan. :mod:`~atlas_rap.planner.solve` restarts with it when the
plain hFF search has evaluated many states without finding a plan.
"""

from __future__ import annotations

import heapq
import time
from typing import Callable

from atlas_rap.planner.ground import GroundTask
from atlas_rap.planner.relaxation import INFINITY, RelaxedPlanHeuristic, relaxed_plan_heuristic
from atlas_rap.planner.search import BOOST, SearchResult, _path_to


def find_landmarks(task: GroundTask, heuristic: RelaxedPlanHeuristic) -> frozenset[int]:
    """The fact landmarks of ``task`` (its goals included), by back-chaining in the relaxation."""
    achievers: dict[int, list[int]] = {}
    for i, adds in enumerate(heuristic.adds):
        for f in adds:
            achievers.setdefault(f, []).append(i)
    found = set(task.goal)
    pending = sorted(found)
    while pending:
        landmark = pending.pop()
        if landmark in task.init:
            continue
        reachable = _reachable_without(task, heuristic, landmark)
        first = [a for a in achievers.get(landmark, ()) if all(p in reachable for p in heuristic.pres[a])]
        if not first:
            continue
        shared = set(heuristic.pres[first[0]])
        for a in first[1:]:
            shared &= set(heuristic.pres[a])
        for fact in sorted(shared - found):
            found.add(fact)
            pending.append(fact)
    return frozenset(found)


def _reachable_without(task: GroundTask, heuristic: RelaxedPlanHeuristic, fact: int) -> set[int]:
    """The facts reachable in the relaxation from the start without making ``fact`` true."""
    counter = heuristic.pre_count[:]
    reached = set(task.init)
    frontier = list(reached)
    for a in heuristic.no_pre:
        counter[a] = -1
        frontier.extend(f for f in heuristic.adds[a] if f != fact and f not in reached)
        reached.update(f for f in heuristic.adds[a] if f != fact)
    while frontier:
        f = frontier.pop()
        for a in heuristic.pre_of[f]:
            counter[a] -= 1
            if counter[a] == 0:
                if fact in heuristic.add_sets[a]:
                    continue
                for g in heuristic.adds[a]:
                    if g not in reached:
                        reached.add(g)
                        frontier.append(g)
    return reached


def landmark_search(task: GroundTask, heuristic: RelaxedPlanHeuristic | None = None, *,
                    stop: Callable[[], bool] | None = None,
                    max_evaluations: int | None = None) -> SearchResult:
    """LAMA's first search (module docstring): hFF and the landmark count, with preferred operators."""
    started = time.process_time()
    heuristic = heuristic or relaxed_plan_heuristic(task)
    landmarks = find_landmarks(task, heuristic)
    goals = frozenset(task.goal)
    adds, negs, deletes = heuristic.add_sets, heuristic.negs, heuristic.deletes
    acts = heuristic.actions
    start = task.init
    parents: dict[frozenset[int], tuple[frozenset[int] | None, int]] = {start: (None, -1)}
    reached: dict[frozenset[int], frozenset[int]] = {start: landmarks & start}
    queues: list[list] = [[], [], [], []]  # hFF, hFF preferred, landmarks, landmarks preferred
    tick = expanded = evaluated = 0

    def result(status: str, goal_state: frozenset[int] | None = None) -> SearchResult:
        plan = _path_to(goal_state, parents, acts) if goal_state is not None else []
        return SearchResult(status, plan, expanded, evaluated, time.process_time() - started, heuristic)

    def count(state: frozenset[int], seen: frozenset[int]) -> int:
        return len(landmarks) - len(seen) + len((goals & seen) - state)

    def push(state: frozenset[int], h_ff: float, h_lm: int, applicable: list[int], helpful: set[int],
             seen: frozenset[int]) -> None:
        nonlocal tick
        missing = landmarks - seen
        for a in applicable:
            neg = negs[a]
            if neg and any(n in state for n in neg):
                continue
            tick += 1
            heapq.heappush(queues[0], (h_ff, tick, state, a))
            heapq.heappush(queues[2], (h_lm, tick, state, a))
            if a in helpful:
                heapq.heappush(queues[1], (h_ff, tick, state, a))
            if not missing.isdisjoint(adds[a]):
                heapq.heappush(queues[3], (h_lm, tick, state, a))

    if task.is_goal(start):
        return result("solved", start)
    h_ff, applicable, helpful = heuristic.evaluate(start)
    evaluated = 1
    if h_ff == INFINITY:
        return result("unsolvable")
    best = [h_ff, count(start, reached[start])]
    push(start, h_ff, best[1], applicable, helpful, reached[start])
    priority = [0, 0, 0, 0]
    turn = 0
    while any(queues):
        live = [q for q in range(4) if queues[q]]
        boosted = [q for q in live if priority[q] > 0]
        q = boosted[0] if boosted else live[turn % len(live)]
        turn += 1
        if boosted:
            priority[q] -= 1
        _, _, state, a = heapq.heappop(queues[q])
        child = (state - deletes[a]) | adds[a]
        if child in parents:
            continue
        parents[child] = (state, a)
        seen = reached[state] | (landmarks & child)
        reached[child] = seen
        expanded += 1
        if expanded % 8 == 0 and stop is not None and stop():
            return result("timeout")
        if task.is_goal(child):
            return result("solved", child)
        if max_evaluations is not None and evaluated >= max_evaluations:
            return result("timeout")
        h_ff, applicable, helpful = heuristic.evaluate(child)
        evaluated += 1
        if h_ff == INFINITY:
            continue
        h_lm = count(child, seen)
        if h_ff < best[0] or h_lm < best[1]:
            best = [min(best[0], h_ff), min(best[1], h_lm)]
            priority[1] += BOOST
            priority[3] += BOOST
        push(child, h_ff, h_lm, applicable, helpful, seen)
    return result("unsolvable")

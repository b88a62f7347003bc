"""LAMA's first search: lazy greedy best-first search with hFF and the landmark count.

What Fast Downward's ``lama-first`` runs (Richter & Westphal 2010), in Python:

- two heuristics, **hFF** (:mod:`~atlas_rap.planner.relaxation`) and the
  **landmark count** (:mod:`~atlas_rap.planner.landmarks`, with its
  orderings), both counting actions (unit costs, as ``lama-first``'s
  ``adapt_costs(one)``);
- **four queues**, one per heuristic and one per heuristic holding only the
  successors reached by *preferred operators*: hFF's (the relaxed plan's
  applicable actions) and, with ``landmark_preferred`` (LAMA 2008's
  original; ``lama-first`` leaves it out, ``pref=false``), the actions that
  add a landmark whose predecessors have all been reached. Left out by
  default: on the thirteen IPC domains (p01-p10, 2026-12-05) it changed the
  total CPU by under 1 % and made transport 13 % slower;
- **alternation** as Fast Downward's alternation open list: the next entry
  comes from the queue with the lowest priority, which goes up by one per
  entry taken; whenever either heuristic reaches a new best value the
  preferred queues are **boosted** (their priority lowered by :data:`BOOST`);
- **deferred evaluation** (lazy search): a successor enters the queues with
  its parent's values and is evaluated when it is taken out, so the
  heuristics are computed once per expanded state, not per generated one;
  closed states are not reopened;
- ``stagnation``: after that many evaluations in a row that improved neither
  heuristic's best value, the search gives up (status ``stuck``) so that
  :func:`~atlas_rap.planner.solve.solve` can restart it with another hFF;
- ties go by order of generation, so the same task always gives the same plan;
  the successors of a state share one heap entry per queue (their values and
  their place in the order are the same), taken one at a time.

``settle`` is not supported here: counterplanning searches with
:func:`~atlas_rap.planner.search.greedy_best_first`.
"""

from __future__ import annotations

import heapq
import time
from typing import Callable

from atlas_rap.planner.ground import GroundTask
from atlas_rap.planner.landmarks import LandmarkGraph, find_landmarks
from atlas_rap.planner.relaxation import INFINITY, RelaxedPlanHeuristic, relaxed_plan_heuristic
from atlas_rap.planner.search import BOOST, SearchResult, _path_to

FF, FF_PREFERRED, LANDMARKS, LANDMARKS_PREFERRED = range(4)
PREFERRED_QUEUES = (FF_PREFERRED, LANDMARKS_PREFERRED)


def lama_search(task: GroundTask, heuristic: RelaxedPlanHeuristic | None = None, *,
                landmarks: LandmarkGraph | None = None, landmark_preferred: bool = False,
                stop: Callable[[], bool] | None = None, max_evaluations: int | None = None,
                stagnation: int | None = None) -> SearchResult:
    """Search ``task`` as LAMA's first iteration (module docstring). Stops (status ``timeout``)
    when ``stop()`` says so or after ``max_evaluations`` evaluations, and (status ``stuck``)
    after ``stagnation`` evaluations in a row that improved neither heuristic's best value."""
    started = time.process_time()
    heuristic = heuristic or relaxed_plan_heuristic(task)
    graph = landmarks if landmarks is not None else find_landmarks(task, heuristic)
    evaluate, progress, lm_count, ready_facts = heuristic.evaluate, graph.progress, graph.count, graph.ready_facts
    adds, negs, deletes = heuristic.add_sets, heuristic.negs, heuristic.deletes
    acts = heuristic.actions
    is_goal = task.is_goal
    start = task.init
    parents: dict[frozenset[int], tuple[frozenset[int] | None, int]] = {start: (None, -1)}
    reached: dict[frozenset[int], int] = {}
    # an entry is [h, tick, state, actions, next]: the successors of one state by those actions, taken
    # one at a time from the top of the heap; in order of generation as entries per successor would be
    queues: list[list[list]] = [[], [], [], []]
    priority = [0, 0, 0, 0]
    tick = expanded = evaluated = 0

    def result(status: str, goal_state: frozenset[int] | None = None) -> SearchResult:
        plan = _path_to(goal_state, parents, acts) if goal_state is not None else []
        return SearchResult(status, plan, expanded, evaluated, time.process_time() - started, heuristic,
                            {"landmarks": len(graph),
                             "landmark_orderings": graph.greedy_necessary + graph.natural + graph.reasonable})

    def push(state: frozenset[int], h_ff: float, h_lm: int, applicable: list[int], helpful: set[int],
             seen: int) -> None:
        nonlocal tick
        actions = [a for a in applicable if not negs[a] or not any(n in state for n in negs[a])]
        if not actions:
            return
        ready = ready_facts(seen) if landmark_preferred else ()
        preferred = [a for a in actions if a in helpful or (ready and not adds[a].isdisjoint(ready))]
        tick += 1
        ff, ff_pref, lm, lm_pref = queues
        heapq.heappush(ff, [h_ff, tick, state, actions, 0])
        heapq.heappush(lm, [h_lm, tick, state, actions, 0])
        if preferred:
            heapq.heappush(ff_pref, [h_ff, tick, state, preferred, 0])
            heapq.heappush(lm_pref, [h_lm, tick, state, preferred, 0])

    if is_goal(start):
        return result("solved", start)
    h_ff, applicable, helpful = evaluate(start)
    evaluated = 1
    if h_ff == INFINITY:
        return result("unsolvable")
    seen = graph.initially_reached(start)
    reached[start] = seen
    h_lm = lm_count(seen, graph.true_in(start))
    best_ff, best_lm = h_ff, h_lm
    progressed = evaluated
    push(start, h_ff, h_lm, applicable, helpful, seen)
    while True:
        q = -1
        for i in range(4):
            if queues[i] and (q < 0 or priority[i] < priority[q]):
                q = i
        if q < 0:
            return result("unsolvable")
        priority[q] += 1
        queue = queues[q]
        entry = queue[0]
        _, _, state, actions, taken = entry
        a = actions[taken]
        if taken + 1 == len(actions):
            heapq.heappop(queue)
        else:
            entry[4] = taken + 1
        child = (state - deletes[a]) | adds[a]
        if child in parents:
            continue
        parents[child] = (state, a)
        expanded += 1
        if expanded % 8 == 0 and stop is not None and stop():
            return result("timeout")
        if is_goal(child):
            return result("solved", child)
        if max_evaluations is not None and evaluated >= max_evaluations:
            return result("timeout")
        h_ff, applicable, helpful = evaluate(child)
        evaluated += 1
        if h_ff == INFINITY:
            continue
        seen, true = progress(reached[state], child)
        reached[child] = seen
        h_lm = lm_count(seen, true)
        if h_ff < best_ff or h_lm < best_lm:
            best_ff, best_lm = min(best_ff, h_ff), min(best_lm, h_lm)
            for i in PREFERRED_QUEUES:
                priority[i] -= BOOST
            progressed = evaluated
        elif stagnation is not None and evaluated - progressed > stagnation:
            return result("stuck")
        push(child, h_ff, h_lm, applicable, helpful, seen)

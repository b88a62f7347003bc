"""From a sequential plan to a partial order, and the check that a partial
order is valid in every linearisation.

:func:`deorder` keeps only the orderings a plan needs (deordering by causal
links and threats, as in Bäckström's and Kambhampati's work):

- a **causal link** ``i --p--> j`` from the last step before ``j`` that adds
  ``p`` (or from the initial state, ``INIT``) to ``j``, for each
  precondition ``p``; the goals are the preconditions of ``GOAL``;
- a step that deletes ``p`` is kept before the link's producer or after its
  consumer, whichever it was in the sequence (it *threatens* the link);
- negative preconditions ``(not p)`` get the mirror image: the last step
  that deletes ``p`` supports them, and steps that add ``p`` stay out of the
  interval.

:func:`check_every_linearisation` decides, without enumerating them, whether
every precondition and goal holds in every linearisation: a fact ``p`` holds
before ``j`` in all of them exactly when every step that may come before
``j`` and deletes ``p`` is followed, before ``j``, by a step that adds it
(and, if ``p`` is not initially true, some step that adds it precedes ``j``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

from atlas_rap.planner.ground import GroundAction, GroundTask

INIT = -1


@dataclass(frozen=True)
class Link:
    """Step ``producer`` (or INIT) supplies ``fact`` (a fact number) to step
    ``consumer`` (or GOAL, the plan's length); ``positive`` False for ``(not fact)``."""

    producer: int
    consumer: int
    fact: int
    positive: bool = True


@dataclass
class PartialOrder:
    """Steps (a sequential plan's actions, numbered 0..n-1), the orderings
    ``(before, after)`` between them, and the causal links."""

    steps: list[GroundAction]
    orderings: set[tuple[int, int]]
    links: list[Link]

    @property
    def goal(self) -> int:
        return len(self.steps)

    def predecessors(self) -> list[set[int]]:
        """For each step, the steps ordered directly before it."""
        before: list[set[int]] = [set() for _ in self.steps]
        for a, b in self.orderings:
            if b < len(self.steps):
                before[b].add(a)
        return before

    def closure(self) -> list[set[int]]:
        """For each step, every step that must come before it (transitively).
        Steps are in a topological order (the sequence they came from)."""
        direct = self.predecessors()
        result: list[set[int]] = []
        for j in range(len(self.steps)):
            found: set[int] = set()
            for i in direct[j]:
                found.add(i)
                found |= result[i]
            result.append(found)
        return result

    def reduced_orderings(self) -> list[tuple[int, int]]:
        """The orderings without those implied by others (transitive reduction)."""
        closure = self.closure()
        direct = self.predecessors()
        kept = []
        for a, b in sorted(self.orderings):
            if b >= len(self.steps):
                continue
            if not any(a in closure[c] for c in direct[b] if c != a):
                kept.append((a, b))
        return kept

    def parallel_length(self) -> int:
        """The number of steps on the longest chain of orderings."""
        depth: list[int] = []
        direct = self.predecessors()
        for j in range(len(self.steps)):
            depth.append(1 + max((depth[i] for i in direct[j]), default=0))
        return max(depth, default=0)


def _touching(steps: list[GroundAction]) -> tuple[dict[int, list[int]], dict[int, list[int]]]:
    """For each fact, the steps that add it and the steps that delete it, in order."""
    adders: dict[int, list[int]] = {}
    deleters: dict[int, list[int]] = {}
    for i, action in enumerate(steps):
        for f in action.add:
            adders.setdefault(f, []).append(i)
        for f in action.delete:
            deleters.setdefault(f, []).append(i)
    return adders, deleters


def deorder(task: GroundTask, plan: list[GroundAction], fixed: Iterable[int] = ()) -> PartialOrder:
    """The partial order that ``plan`` (valid, in sequence) needs; see the module docstring.

    Steps in ``fixed`` keep their place in the sequence relative to every other
    step: counterplanning fixes its counter steps, since what they protect
    against depends on the states around them, not only on causal links.
    """
    n = len(plan)
    adders, deleters = _touching(plan)
    orderings: set[tuple[int, int]] = set()
    links: list[Link] = []

    def needs(j: int, fact: int, positive: bool) -> None:
        supporters = adders if positive else deleters
        breakers = deleters if positive else adders
        producer = max((i for i in supporters.get(fact, ()) if i < j), default=INIT)
        links.append(Link(producer, j, fact, positive))
        if producer != INIT:
            orderings.add((producer, j))
        for k in breakers.get(fact, ()):
            if k == j or k == producer:
                continue
            if k < j and (producer == INIT or k < producer):
                if producer != INIT:
                    orderings.add((k, producer))
            elif k > j:
                if j < n:
                    orderings.add((j, k))

    for j, action in enumerate(plan):
        for f in action.pre:
            needs(j, f, True)
        for f in action.neg:
            needs(j, f, False)
    for f in task.goal:
        needs(n, f, True)
    for f in task.goal_neg:
        needs(n, f, False)
    for f in fixed:
        orderings.update((i, f) for i in range(f))
        orderings.update((f, j) for j in range(f + 1, n))
    return PartialOrder(list(plan), orderings, links)


def check_every_linearisation(task: GroundTask, order: PartialOrder) -> list[str]:
    """What fails in some linearisation of ``order``: an empty list when every
    precondition and goal holds in every ordering-consistent sequence."""
    steps = order.steps
    n = len(steps)
    closure = order.closure()
    problems: list[str] = []
    adders, deleters = _touching(steps)

    def before(a: int, b: int) -> bool:
        return b == n or a in closure[b]

    def holds_always(j: int, fact: int, positive: bool) -> bool:
        supporters = adders if positive else deleters
        breakers = deleters if positive else adders
        initially = (fact in task.init) == positive
        if not initially and not any(before(a, j) for a in supporters.get(fact, ()) if a != j):
            return False
        for k in breakers.get(fact, ()):
            if k == j or (j < n and j in closure[k]):  # k comes after j
                continue
            if not any(before(k, a) and before(a, j) for a in supporters.get(fact, ()) if a not in (j, k)):
                return False
        return True

    for j, action in enumerate(steps):
        for f in action.pre:
            if not holds_always(j, f, True):
                problems.append(f"step {j} {action.term}: {task.facts[f]} may not hold")
        for f in action.neg:
            if not holds_always(j, f, False):
                problems.append(f"step {j} {action.term}: (not {task.facts[f]}) may not hold")
    for f in task.goal:
        if not holds_always(n, f, True):
            problems.append(f"goal {task.facts[f]} may not hold at the end")
    for f in task.goal_neg:
        if not holds_always(n, f, False):
            problems.append(f"goal (not {task.facts[f]}) may not hold at the end")
    return problems

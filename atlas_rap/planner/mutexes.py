"""Fact-pair mutexes: pairs of facts that no reachable state holds together (h², Haslum & Geffner 2000).

LAMA's reasonable landmark orderings (:mod:`~atlas_rap.planner.landmarks`)
ask which landmarks *interfere*, and that is a question about mutexes: can
two facts be true at once? Fast Downward answers it from the mutex groups
its translator finds by invariant synthesis on the lifted domain. Here the
answer comes from the ground task, by h² reachability: the pairs of facts
some sequence of actions can make true together, found as a fixpoint from
the pairs of the initial state. An action whose preconditions are reached
pairwise reaches

- every pair of the facts it adds, and
- each fact it adds with every fact ``g`` it does not delete that is
  reached together with each of its preconditions (``g`` survives the action).

Every pair left unreached is a mutex. The test is sound, never complete: a
pair called mutex is false together in every reachable state (negative
preconditions are ignored, which can only lose mutexes), and it finds what
invariant synthesis finds on STRIPS domains such as depot's
``(on c1 c2)`` / ``(clear c2)``.

The fixpoint is semi-naive: an action is looked at again only when a pair
with one of its preconditions has been reached since it was last looked
at, so after the first sweep only the few actions near what changed are.
Each fact's partners are one Python ``int`` used as a bit set, so looking
at an action is a few integer operations whatever the number of facts
(rows of a numpy matrix cost 25 microseconds an action in calls alone:
1.2 s on mprime prob20's 44,000 actions, against 0.2 s; transport p20,
the largest of the shared domains' p20s, takes 1 s).
"""

from __future__ import annotations

from typing import Callable

from atlas_rap.planner.ground import GroundTask
from atlas_rap.planner.relaxation import RelaxedPlanHeuristic

__all__ = ["Mutexes", "fact_mutexes"]


class Mutexes:
    """The reachable pairs of a task's facts (see the module docstring); ask :meth:`mutex`."""

    def __init__(self, partners: list[int]) -> None:
        self.partners = partners  # bit g of partners[f]: f and g can be true together; bit f: f can be true

    def mutex(self, f: int, g: int) -> bool:
        """Whether no reachable state holds both facts (two different facts that are each reachable)."""
        partners = self.partners
        return f != g and bool(partners[f] >> f & 1 and partners[g] >> g & 1 and not partners[f] >> g & 1)

    def count(self) -> int:
        """How many unordered pairs of reachable facts are mutex."""
        partners = self.partners
        reached = 0
        for f, row in enumerate(partners):
            reached |= (row >> f & 1) << f
        return sum((reached & ~row).bit_count() for f, row in enumerate(partners) if row >> f & 1) // 2


def fact_mutexes(task: GroundTask, heuristic: RelaxedPlanHeuristic,
                 stop: Callable[[], bool] | None = None) -> Mutexes | None:
    """The h² mutexes of ``task``'s actions (module docstring); None when ``stop()`` says to stop
    (it is asked at each sweep over the actions and after every 1,024 actions looked at)."""
    partners = [0] * len(task.facts)
    reached = _mask(task.init)
    for f in task.init:
        partners[f] = reached
    pres = heuristic.pres
    pre_masks = [_mask(pre) for pre in pres]
    adds = [tuple(sorted(set(add))) for add in heuristic.adds]
    add_masks = [_mask(add) for add in adds]
    kill_masks = [_mask(deletes - add) for deletes, add in zip(heuristic.deletes, heuristic.add_sets)]
    grown = [0] * len(partners)  # the tick at which a pair with this fact was last reached
    reached_grown = 0  # ... and at which a fact was last reached (what actions without preconditions see)
    looked = [0] * len(pres)  # the tick at which each action was last looked at (0: never)
    tick, since_asked = 1, 0
    changed = True
    while changed:
        if stop is not None and stop():
            return None
        changed = False
        for a, pre in enumerate(pres):
            seen = looked[a]
            if seen and (max(grown[p] for p in pre) <= seen if pre else reached_grown <= seen):
                continue  # nothing it depends on has grown since
            since_asked += 1
            if since_asked >= 1024:
                since_asked = 0
                if stop is not None and stop():
                    return None
            looked[a] = tick
            if pre:
                needed = pre_masks[a]
                survives = -1
                for p in pre:
                    row = partners[p]
                    if needed & ~row:
                        survives = 0  # a pair of its preconditions is not reached (yet)
                        break
                    survives &= row
                if not survives:
                    continue
                survives = (survives & ~kill_masks[a]) | add_masks[a]
            else:
                survives = (reached & ~kill_masks[a]) | add_masks[a]
            for f in adds[a]:
                new = survives & ~partners[f]
                if not new:
                    continue
                tick += 1
                changed = True
                bit = 1 << f
                partners[f] |= new
                grown[f] = tick
                if new & bit:
                    reached |= bit
                    reached_grown = tick
                others = new & ~bit
                while others:
                    low = others & -others
                    g = low.bit_length() - 1
                    partners[g] |= bit
                    grown[g] = tick
                    others ^= low
    return Mutexes(partners)


def _mask(facts) -> int:
    """The bit set of ``facts`` (numbers)."""
    mask = 0
    for f in facts:
        mask |= 1 << f
    return mask

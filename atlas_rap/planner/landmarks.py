"""Landmarks: what every plan passes through, their orderings, and the landmark count.

A *landmark* is a fact every plan makes true at some point, or (a
*disjunctive* landmark) a set of facts one of which every plan makes true.
They are found as Fast Downward's ``lm_rhw`` finds them (Richter, Helmert and
Westphal 2008; Hoffmann, Porteous and Sebastia 2004), by back-chaining from
the goals in the delete relaxation, simplified:

- for a landmark L not true at the start, its *first achievers* are the
  actions that add a fact of L and whose preconditions are reachable in the
  relaxation without making any fact of L true;
- a precondition all first achievers share is a landmark P, ordered
  **greedy-necessarily** before L (P is true in the state in which L is first
  made true);
- **lookahead** (only given the task's fact mutexes, as the search's restart
  has them): a precondition of *some* first achievers of a single-fact
  landmark L, not true at the start, that lies on every path to L in the
  transition graph of their *variable* is a landmark, ordered **naturally**
  before L. This is ``lm_rhw``'s lookahead on a domain transition graph,
  without SAS+ variables: the variable is the facts that share an object
  with both and are pairwise mutex with them (taken greedily, in fact order),
  and its graph has an edge u -> w for each action needing u and adding w,
  ignoring every precondition on other facts, from every value for an
  action needing none of them, through values reachable without L's
  achievers. In freecell, a card must be clear before it goes home, whether
  straight from its column or through a free cell: no first achiever of
  ``(home c)`` shares ``(clear c)``, yet both paths of c's variable pass it.
  In depot, a crate stacked on another crate can be lifted by any hoist in
  its variable's graph, so its first lift is not a landmark, as in Fast
  Downward: on depot p11 the same 70 landmarks, on freecell p19 the same
  152;
- where they share none, a predicate every first achiever has a precondition
  of gives a disjunctive landmark (at most :data:`MAX_DISJUNCTION` facts, none
  true at the start, none already a landmark), ordered the same way: in
  gripper, ``(carry ball1 left)`` or ``(carry ball1 right)`` before
  ``(at ball1 roomb)``;
- **reasonable orderings** (``lm_reasonable_orders_hps``, Hoffmann, Porteous
  and Sebastia 2004): L is ordered before L' when reaching L' first is
  wasted, because reaching L then makes L' false and it must be made true
  again. Without mutexes, only for a goal L' and an L every action adding
  which deletes L'. Given the task's fact mutexes
  (:mod:`~atlas_rap.planner.mutexes`), as Fast Downward approximates them:
  L *interferes* with L' when L and L' are mutex, every action adding L
  deletes L', an effect every action adding L shares is mutex with L', or
  a landmark greedy-necessarily before L is mutex with L'; then L is
  ordered before a goal L' it interferes with, and before a landmark L'
  that is greedy-necessarily before some landmark M when L is another of
  M's predecessors (or one of theirs) and interferes with L'.

An ordering that would close a cycle is left out, so every landmark can be
reached (Fast Downward breaks cycles too).

The **landmark count** of a state (Richter & Westphal 2010's LAMA, as Fast
Downward's ``lmcount``) depends on the path that reached it: a landmark is
*reached* once it is true in a state on the path in which every landmark
ordered before it had been reached. The count is the landmarks not reached,
plus those reached but false now that must be true again: goals, and
landmarks greedy-necessarily ordered before one not yet reached.
:class:`LandmarkGraph` holds the landmarks as bits of a Python ``int``, so a
path's reached set is one integer and the count is a few integer operations.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Iterable, Iterator

from atlas_rap.planner.ground import GroundTask
from atlas_rap.planner.mutexes import Mutexes
from atlas_rap.planner.relaxation import RelaxedPlanHeuristic

MAX_DISJUNCTION = 4  # facts in a disjunctive landmark, at most (as lm_rhw)


@dataclass
class LandmarkGraph:
    """The landmarks of a task and their orderings, as bit masks over landmark numbers.

    ``nodes[i]`` is landmark ``i``'s facts (one, or several for a disjunctive
    landmark); ``parents[i]`` the mask of the landmarks ordered before it (any
    ordering), ``gn_children[i]`` of those it is greedy-necessarily ordered
    before; ``goal_mask`` the goal landmarks; ``fact_mask[f]`` the landmarks
    fact ``f`` makes true; ``facts`` every fact of a landmark.
    """

    nodes: list[frozenset[int]] = field(default_factory=list)
    parents: list[int] = field(default_factory=list)
    gn_children: list[int] = field(default_factory=list)
    goal_mask: int = 0
    fact_mask: dict[int, int] = field(default_factory=dict)
    facts: frozenset[int] = frozenset()
    greedy_necessary: int = 0  # orderings of each kind, for the statistics
    natural: int = 0
    reasonable: int = 0

    def __len__(self) -> int:
        return len(self.nodes)

    def true_in(self, state: frozenset[int]) -> int:
        """The mask of the landmarks true in ``state``."""
        fact_mask = self.fact_mask
        mask = 0
        for f in self.facts.intersection(state):
            mask |= fact_mask[f]
        return mask

    def initially_reached(self, state: frozenset[int]) -> int:
        """The landmarks reached at the start of a path from ``state``: those true in it."""
        return self.true_in(state)

    def progress(self, reached: int, state: frozenset[int]) -> tuple[int, int]:
        """The reached mask after a step into ``state`` from a state with ``reached``, and the
        mask of the landmarks true in ``state``."""
        true = self.true_in(state)
        new = true & ~reached
        if new:
            parents = self.parents
            grown = reached
            for i in _bits(new):
                if parents[i] & ~reached == 0:
                    grown |= 1 << i
            reached = grown
        return reached, true

    def count(self, reached: int, true: int) -> int:
        """The landmark count of a state with ``reached`` on its path and ``true`` landmarks true in it."""
        missing = len(self.nodes) - reached.bit_count()
        lost = reached & ~true
        if lost:
            again = lost & self.goal_mask
            rest = lost & ~again
            if rest:
                gn_children = self.gn_children
                for i in _bits(rest):
                    if gn_children[i] & ~reached:
                        again |= 1 << i
            missing += again.bit_count()
        return missing

    def ready_facts(self, reached: int) -> set[int]:
        """The facts of the landmarks not reached whose every predecessor is reached: an action
        adding one makes progress (LAMA's preferred operators for the landmark count)."""
        parents, nodes = self.parents, self.nodes
        facts: set[int] = set()
        for i in _bits(((1 << len(nodes)) - 1) & ~reached):
            if parents[i] & ~reached == 0:
                facts.update(nodes[i])
        return facts


def _bits(mask: int) -> Iterator[int]:
    """The numbers of the bits set in ``mask``, lowest first."""
    while mask:
        low = mask & -mask
        yield low.bit_length() - 1
        mask ^= low


def find_landmarks(task: GroundTask, heuristic: RelaxedPlanHeuristic,
                   mutexes: Mutexes | None = None) -> LandmarkGraph:
    """The landmark graph of ``task`` (module docstring); given ``mutexes``, with the lookahead's
    landmarks and the reasonable orderings they allow."""
    return back_chain(task, heuristic, mutexes).graph(mutexes)


def back_chain(task: GroundTask, heuristic: RelaxedPlanHeuristic, mutexes: Mutexes | None = None) -> LandmarkFinder:
    """The landmarks of ``task`` and their greedy-necessary orderings, back-chained from the goals
    once (given ``mutexes``, the lookahead's too, with their natural orderings):
    :meth:`LandmarkFinder.graph` adds the reasonable orderings, with or without mutexes, as
    often as asked."""
    finder = LandmarkFinder(task, heuristic)
    finder.back_chain(mutexes)
    return finder


class LandmarkFinder:
    """Back-chains from the goals (module docstring), one landmark at a time."""

    def __init__(self, task: GroundTask, heuristic: RelaxedPlanHeuristic) -> None:
        self.task, self.h = task, heuristic
        self.mutexes: Mutexes | None = None
        self.goals = sorted(set(task.goal))
        self.achievers: dict[int, list[int]] = {}
        for a, adds in enumerate(heuristic.adds):
            for f in adds:
                self.achievers.setdefault(f, []).append(a)
        self.nodes: list[frozenset[int]] = []
        self.index: dict[int, int] = {}  # fact -> its landmark
        self.parents: list[set[int]] = []
        self.gn: list[tuple[int, int]] = []
        # once back-chained: each landmark's greedy-necessary predecessors, as sets and as lists
        self.chained_parents: list[frozenset[int]] = []  # the greedy-necessary orderings only
        self.natural: list[tuple[int, int]] = []  # (before, after): the lookahead's orderings
        self._gn_parents: dict[int, list[int]] = {}
        self._shared: dict[int, set[int]] = {}  # fact -> the effects every action adding it has, when asked

    def add(self, facts: frozenset[int]) -> int:
        """A new landmark of ``facts``; its number."""
        number = len(self.nodes)
        self.nodes.append(facts)
        self.parents.append(set())
        for f in facts:
            self.index[f] = number
        return number

    def order(self, before: int, after: int) -> bool:
        """Order ``before`` before ``after`` unless that closes a cycle; whether it did."""
        if before == after or before in self.parents[after]:
            return False
        if self._precedes(after, before):
            return False
        self.parents[after].add(before)
        return True

    def _precedes(self, first: int, second: int) -> bool:
        """Whether ``first`` is ordered (transitively) before ``second``."""
        seen, stack = {second}, [second]
        while stack:
            for p in self.parents[stack.pop()]:
                if p == first:
                    return True
                if p not in seen:
                    seen.add(p)
                    stack.append(p)
        return False

    def graph(self, mutexes: Mutexes | None = None) -> LandmarkGraph:
        """The landmarks back-chained, with their natural orderings and their reasonable orderings by
        ``mutexes`` (or, without, only before the goals) added to the greedy-necessary ones."""
        self.parents = [set(parents) for parents in self.chained_parents]
        natural = [(before, after) for before, after in self.natural if self.order(before, after)]
        self.mutexes = mutexes
        reasonable = self._reasonable_orderings(self.goals)
        return self._packed(self.goals, len(natural), reasonable)

    def back_chain(self, mutexes: Mutexes | None = None) -> None:
        """Every landmark back-chained from the goals, breadth first, and the greedy-necessary
        orderings between them; given ``mutexes``, the lookahead's landmarks too (module docstring)."""
        task, h = self.task, self.h
        init = task.init
        self.mutexes = mutexes
        for g in self.goals:
            self.add(frozenset((g,)))
        pending = deque(range(len(self.nodes)))
        while pending:
            node = pending.popleft()
            facts = self.nodes[node]
            if not facts.isdisjoint(init):
                continue
            adders = {a for f in facts for a in self.achievers.get(f, ())}
            reachable = _reachable_without(task, h, adders)
            first = sorted(a for a in adders if all(reachable[p] for p in h.pres[a]))
            if not first:
                continue
            shared = set(h.pres[first[0]])
            for a in first[1:]:
                shared &= set(h.pres[a])
            for fact in sorted(shared - facts):
                known = self.index.get(fact)
                if known is None:
                    known = self.add(frozenset((fact,)))
                    pending.append(known)
                elif len(self.nodes[known]) > 1:
                    continue  # the fact is in a disjunction already: not a landmark of its own here
                if self.order(known, node):
                    self.gn.append((known, node))
            if mutexes is not None and len(facts) == 1:
                self._lookahead(node, first, shared, reachable, pending)
            for disjunction in self._disjunctions(first, shared):
                new = self.add(disjunction)
                pending.append(new)
                if self.order(new, node):
                    self.gn.append((new, node))
        self.chained_parents = [frozenset(parents) for parents in self.parents]
        for before, after in self.gn:
            self._gn_parents.setdefault(after, []).append(before)

    def _lookahead(self, node: int, first: list[int], shared: set[int], reached: bytearray,
                   pending: deque[int]) -> None:
        """The preconditions of some first achievers of landmark ``node`` (not all: those are
        ``shared``), not true at the start, on every path to it in their variable's transition
        graph: landmarks, ordered naturally before it (module docstring)."""
        init, facts = self.task.init, self.nodes[node]
        landmark = next(iter(facts))
        candidates = {p for a in first for p in self.h.pres[a]} - shared - facts - init
        for fact in sorted(candidates):
            if not self._crucial(fact, landmark, reached):
                continue
            known = self.index.get(fact)
            if known is None:
                known = self.add(frozenset((fact,)))
                pending.append(known)
            elif len(self.nodes[known]) > 1:
                continue  # in a disjunction already
            self.natural.append((known, node))

    def _crucial(self, fact: int, landmark: int, reached: bytearray) -> bool:
        """Whether ``fact`` lies on every path from the start to ``landmark`` in the transition graph
        of their variable, through facts ``reached`` without the landmark's achievers (module
        docstring); never when the two share no object."""
        mutexes = self.mutexes
        assert mutexes is not None
        facts = self.task.facts
        objects = set(facts[landmark].args) & set(facts[fact].args)
        if not objects:
            return False
        partners = mutexes.partners
        values = [landmark, fact]
        clique = ((1 << len(partners)) - 1) & ~partners[landmark] & ~partners[fact]
        while clique:
            f = (clique & -clique).bit_length() - 1
            clique &= clique - 1
            if partners[f] >> f & 1 and reached[f] and not objects.isdisjoint(facts[f].args):
                values.append(f)
                clique &= ~partners[f]
        variable = set(values)
        h = self.h
        frontier = [f for f in values if f in self.task.init]
        for g in (landmark, *values[2:]):  # a value some action makes true whatever the variable's value was
            if any(variable.isdisjoint(h.pres[a]) for a in self.achievers.get(g, ())):
                if g == landmark:
                    return False
                frontier.append(g)
        seen = set(frontier)
        while frontier:
            for a in h.pre_of[frontier.pop()]:
                for g in h.adds[a]:
                    if g in variable and g not in seen and g != fact:
                        if g == landmark:
                            return False
                        seen.add(g)
                        frontier.append(g)
        return True

    def _disjunctions(self, first: list[int], shared: set[int]) -> list[frozenset[int]]:
        """For each predicate every first achiever needs a fact of (not a shared one), the facts
        of it they need, when few, none true at the start and none a landmark already."""
        facts_of = self.task.facts
        by_predicate: list[dict[tuple[str, int], set[int]]] = []
        for a in first:
            grouped: dict[tuple[str, int], set[int]] = {}
            for p in self.h.pres[a]:
                if p not in shared:
                    fact = facts_of[p]
                    grouped.setdefault((fact.functor, len(fact.args)), set()).add(p)
            by_predicate.append(grouped)
        common = set(by_predicate[0])
        for grouped in by_predicate[1:]:
            common &= set(grouped)
        found = []
        for predicate in sorted(common):
            facts = frozenset().union(*(grouped[predicate] for grouped in by_predicate))
            if (len(facts) <= MAX_DISJUNCTION and len(facts) > 1 and facts.isdisjoint(self.task.init)
                    and all(f not in self.index for f in facts)):
                found.append(facts)
        return found

    def _reasonable_orderings(self, goals: list[int]) -> list[tuple[int, int]]:
        """The reasonable orderings (module docstring), each added unless it closes a cycle."""
        nodes = self.nodes
        single = [node for node, facts in enumerate(nodes) if len(facts) == 1]
        goal_nodes = {self.index[g] for g in goals}
        if self.mutexes is None:
            candidates = {goal: single for goal in sorted(goal_nodes)}
        else:
            candidates = self._candidates(single, goal_nodes)
        found = []
        for later, earlier_ones in candidates.items():
            for earlier in earlier_ones:
                if earlier != later and self._interferes(earlier, later) and self.order(earlier, later):
                    found.append((earlier, later))
        return found

    def _candidates(self, single: list[int], goal_nodes: set[int]) -> dict[int, list[int]]:
        """For each landmark L', the landmarks that may be reasonably ordered before it: every other
        one for a goal; else the other predecessors of the landmarks L' is greedy-necessarily before,
        and theirs (Fast Downward's ``approximate_reasonable_orders``)."""
        parents = self.chained_parents  # the greedy-necessary orderings only
        children: dict[int, list[int]] = {}
        for before, after in self.gn:
            children.setdefault(before, []).append(after)
        candidates = {}
        for later in single:
            if later in goal_nodes:
                candidates[later] = single
                continue
            found: set[int] = set()
            for child in children.get(later, ()):
                stack = [p for p in parents[child] if p != later and p not in found]
                found.update(stack)
                while stack:
                    for p in parents[stack.pop()]:
                        if p not in found:
                            found.add(p)
                            stack.append(p)
            candidates[later] = sorted(node for node in found if len(self.nodes[node]) == 1)
        return candidates

    def _interferes(self, earlier: int, later: int) -> bool:
        """Whether reaching landmark ``later`` before ``earlier`` is wasted (module docstring)."""
        (a,), (b,) = self.nodes[earlier], self.nodes[later]
        if a == b:
            return False
        adders = self.achievers.get(a, ())
        deletes = self.h.deletes
        if adders and all(b in deletes[action] for action in adders):
            return True
        mutexes = self.mutexes
        if mutexes is None:
            return False
        if mutexes.mutex(a, b):
            return True
        shared = self._shared.get(a)
        if shared is None:
            adds = self.h.add_sets
            shared = set(adds[adders[0]]).intersection(*(adds[action] for action in adders[1:])) if adders else set()
            self._shared[a] = shared
        if any(e != a and e != b and mutexes.mutex(e, b) for e in shared):
            return True
        return any(mutexes.mutex(x, b) for before in self._gn_parents.get(earlier, ()) for x in self.nodes[before])

    def _packed(self, goals: list[int], natural: int, reasonable: list[tuple[int, int]]) -> LandmarkGraph:
        count = len(self.nodes)
        graph = LandmarkGraph(nodes=self.nodes, parents=[0] * count, gn_children=[0] * count,
                              greedy_necessary=len(self.gn), natural=natural, reasonable=len(reasonable))
        for node, parents in enumerate(self.parents):
            for p in parents:
                graph.parents[node] |= 1 << p
        for before, after in self.gn:
            graph.gn_children[before] |= 1 << after
        for g in goals:
            graph.goal_mask |= 1 << self.index[g]
        for node, facts in enumerate(self.nodes):
            for f in facts:
                graph.fact_mask[f] = graph.fact_mask.get(f, 0) | (1 << node)
        graph.facts = frozenset(graph.fact_mask)
        return graph


def _reachable_without(task: GroundTask, heuristic: RelaxedPlanHeuristic, forbidden: Iterable[int]) -> bytearray:
    """Which facts are reachable in the relaxation from the start without the ``forbidden``
    actions (those making a landmark's facts true): a flag for each fact. A forbidden action's
    counter starts below zero, so it never fires and no action is asked about its effects."""
    counter = heuristic.pre_count[:]
    for a in forbidden:
        counter[a] = -1
    reached = bytearray(heuristic.n_facts)
    frontier = list(task.init)
    for f in frontier:
        reached[f] = 1
    adds = heuristic.adds
    for a in heuristic.no_pre:
        if counter[a] == 0:
            for g in adds[a]:
                if not reached[g]:
                    reached[g] = 1
                    frontier.append(g)
    pre_of = heuristic.pre_of
    while frontier:
        for a in pre_of[frontier.pop()]:
            left = counter[a] - 1
            counter[a] = left
            if left == 0:
                for g in adds[a]:
                    if not reached[g]:
                        reached[g] = 1
                        frontier.append(g)
    return reached

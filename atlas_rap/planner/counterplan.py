"""Counterplanning: protect a plan from what uncontrolled agents may do.

An uncontrolled action (a person closing a door, nature flattening a tyre)
is never planned, but it may happen. The model, where the language reference (docs/language/ap.md) leaves it open:

- Uncontrolled agents act *between* our steps: in the state after each of
  our steps, any uncontrolled action whose preconditions hold there may
  happen. (The state the plan starts in has been observed, so nothing
  happens before the first step.) A FOND bad outcome (``outcome_of``) is
  tied to its step: it can happen only as that step's outcome, instead of
  the nominal one, so what the step would have added and the outcome does
  not counts as deleted (a block dropped on the table is not on the other:
  FOND blocksworld's ``put-on-block``; conservative for a fact that was
  already true before the step).
- It **threatens** a causal link ``i --p--> j`` when it deletes ``p`` in one
  of the states from the producer ``i`` up to just before the consumer ``j``.
- The **risk** of a plan is the probability that at least one threatening
  action happens: ``1 - prod(1 - probability)`` over distinct (event,
  state) pairs, an event being an uncontrolled operator with its agent and
  the values its preconditions bind; 0 when nothing can defeat the plan.

:func:`counterplan` first plans without regard to them; if that plan is
threatened it searches again under the *worst case*: after each step, every
uncontrolled action that can happen deletes what it deletes (its additions
are not relied on). A plan found so cannot be defeated: it prevents the
threat (achieves a fact that disables the action), re-achieves the fact
after the threat and before it is needed (the safe tireworld route changes
a tyre wherever it may go flat), orders the need before the danger, or takes
another way. When no such plan exists for every threat, it protects against
as many threatening actions as it can, one kind at a time (each search
bounded by TRIAL_EVALUATIONS), and reports the risk that remains.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Callable, Iterable

from atlas_rap.logic import Compound, variables
from atlas_rap.planner.ground import GroundAction, GroundTask
from atlas_rap.planner.limits import LimitReached
from atlas_rap.planner.search import Settle, eliminate_redundant, greedy_best_first


@dataclass(frozen=True)
class Threat:
    """``action`` (uncontrolled) may delete ``fact`` in the state after step ``after``
    (1-based position in the sequential plan), while step ``consumer`` (0-based;
    the plan's length for the goals) still needs it."""

    action: GroundAction
    fact: int
    after: int
    consumer: int


@dataclass(frozen=True)
class Counter:
    """Step ``step`` (0-based) is there to answer ``threat`` by protecting ``fact``."""

    step: int
    threat: GroundAction
    fact: int


@dataclass
class Assessment:
    """The threats to a plan."""

    threats: list[Threat] = field(default_factory=list)

    @property
    def risk(self) -> float:
        """1 - prod(1 - p) over distinct (event, state) pairs that threaten the plan.

        An event is an uncontrolled operator with the values of the variables of
        its agent and preconditions: groundings that differ only in a variable
        of the effects (where the person leaves the tool) are one event, which
        happens with the operator's probability, not once per object.
        """
        survive = 1.0
        for action in {happening(t): t.action for t in self.threats}.values():
            survive *= 1.0 - action.probability
        return round(max(0.0, 1.0 - survive), 12)

    def actions(self) -> list[GroundAction]:
        """The uncontrolled actions that threaten the plan, first seen first."""
        return list({t.action.index: t.action for t in self.threats}.values())


def happening(threat: Threat) -> tuple:
    """What the risk counts once: the threat's event (:func:`_event`) in the state it
    may happen in. Threats with the same happening are one chance of defeat, even
    when that one action breaks several links."""
    return (_event(threat.action), threat.after)


def _event(action: GroundAction) -> tuple:
    """What identifies an uncontrolled action's happening: its operator and the values
    of the variables of its agent and preconditions."""
    op = action.operator
    deciding = set(variables(Compound("", tuple(op.preconditions) + ((op.agent,) if op.agent else ()))))
    return (op.name, tuple(sorted((v.name, str(value)) for v, value in action.binding.items() if v in deciding)))


class Adversary:
    """The uncontrolled actions of a task, and what they can do to a state."""

    def __init__(self, task: GroundTask, allowed: Iterable[GroundAction] | None = None) -> None:
        self.task = task
        chosen = list(task.nature if allowed is None else allowed)
        self.actions = chosen
        self.anytime = [u for u in chosen if u.operator.outcome_of is None]
        self.tied: dict[tuple[str, tuple], list[GroundAction]] = {}
        self.missed: dict[tuple[str, tuple], set[int]] = {}  # a step -> what an outcome of it may not add
        for u in chosen:
            if u.operator.outcome_of is not None:
                key = (u.operator.outcome_of, u.args)
                step = task.step_by_name.get(key)
                missed = tuple(f for f in step.add if f not in u.add and f not in u.delete) if step else ()
                if missed:  # it happens instead of the step: what the step would have added is not there
                    u = dataclasses.replace(u, delete=u.delete + missed)
                    self.missed.setdefault(key, set()).update(missed)
                self.tied.setdefault(key, []).append(u)

    def possible_after(self, state: frozenset[int], step: GroundAction | None) -> list[GroundAction]:
        """Uncontrolled actions that may happen in ``state``, reached by ``step``."""
        found = [u for u in self.anytime if self.task.applicable(u, state)]
        if step is not None:
            found.extend(self.tied.get((step.operator.name, step.args), ()))
        return found

    def worst_case(self, state: frozenset[int], step: GroundAction) -> frozenset[int]:
        """``state`` after everything that may happen there has deleted what it deletes
        (to a fixpoint: a deletion can enable an action with a negative precondition)."""
        while True:
            lost: set[int] = set()
            for u in self.possible_after(state, step):
                lost.update(u.delete)
            lost &= state
            if not lost:
                return state
            state = state - lost
            step = None  # a tied outcome happens once

    def robust_task(self) -> tuple[GroundTask, Settle]:
        """A copy of the task to search under the worst case, and its ``settle``.

        An uncontrolled deletion only *may* happen: a fact it takes is not
        there for a positive need, but may still be there for a negative one
        (``(not F)`` in a precondition or goal). Such a fact therefore leaves a
        *shadow* ("F may still hold") that negative needs also require to be
        absent, and that only our own deletion of F removes.

        A step an outcome of which may not add a fact does not add it here:
        so where every way to a goal may fail, the relaxation says so at once,
        rather than a search through every state.
        """
        task = self.task
        deletable = {f for u in self.actions for f in u.delete}
        negative = {f for a in task.actions for f in a.neg} | set(task.goal_neg)
        shadow = {f: len(task.facts) + i for i, f in enumerate(sorted(deletable & negative))}
        missed = self.missed
        if not shadow and not missed:
            return task, self.worst_case

        def with_shadows(ids: tuple[int, ...]) -> tuple[int, ...]:
            return ids + tuple(shadow[f] for f in ids if f in shadow)

        def sure(a: GroundAction) -> tuple[int, ...]:
            lost = missed.get((a.operator.name, a.args))
            return tuple(f for f in a.add if f not in lost) if lost else a.add

        actions = [dataclasses.replace(a, neg=with_shadows(a.neg), delete=with_shadows(a.delete), add=sure(a))
                   for a in task.actions]
        facts = task.facts + [Compound("may-still-hold", (task.facts[f],)) for f in shadow]
        robust = dataclasses.replace(task, facts=facts, actions=actions, goal_neg=with_shadows(task.goal_neg))

        def settle(state: frozenset[int], step: GroundAction) -> frozenset[int]:
            after = self.worst_case(state, step)
            taken = state - after
            return after | {shadow[f] for f in taken if f in shadow}

        return robust, settle


TRIAL_EVALUATIONS = 5000
"""Heuristic evaluations, at most, of each search for a plan safe from one more threatening action
when no plan is safe from all of them (a count, so the same task gives the same plan): on FOND
blocksworld, where any stacking may drop the block, every threat has its trial, and p7-p10 ran out
of 60 s unbounded."""


def assess(task: GroundTask, plan: list[GroundAction], adversary: Adversary | None = None,
           stop: Callable[[], bool] | None = None) -> Assessment:
    """The threats to ``plan`` (see the module docstring) and so its risk. ``stop()`` (a
    run's limits) is asked every 16 steps; when it says so, :class:`LimitReached`."""
    adversary = adversary or Adversary(task)
    assessment = Assessment()
    if not task.nature:
        return assessment
    states = [task.init]
    for k, action in enumerate(plan):
        if stop is not None and k % 16 == 0 and stop():
            raise LimitReached("counterplanning")
        states.append(task.apply(action, states[-1]))
    possible = [adversary.possible_after(states[k], plan[k - 1]) if k > 0 else [] for k in range(len(states))]
    last_added: dict[int, int] = {}
    n = len(plan)
    for j in range(n + 1):
        needed = task.goal if j == n else plan[j].pre
        for fact in needed:
            producer = last_added.get(fact, 0)  # state index: after step `producer`
            for k in range(max(producer, 1), j + 1):
                for u in possible[k]:
                    if fact in u.delete:
                        assessment.threats.append(Threat(u, fact, k, j))
        if j < n:
            for fact in plan[j].add:
                last_added[fact] = j + 1
    return assessment


def counters(task: GroundTask, plan: list[GroundAction], adversary: Adversary) -> list[Counter]:
    """Which steps of a plan protect it, found by running it in the worst case: a
    step that re-adds a fact an uncontrolled action took, or that disables an
    uncontrolled action that could have taken a fact still needed."""
    found: list[Counter] = []
    needed_later: list[set[int]] = []
    later: set[int] = set(task.goal)
    for action in reversed(plan):
        needed_later.append(set(later))
        later |= set(action.pre)
    needed_later.reverse()
    state = task.init
    taken: dict[int, GroundAction] = {}
    previous: GroundAction | None = None
    for m, action in enumerate(plan):
        possible_before = adversary.possible_after(state, previous)
        after = task.apply(action, state)
        for fact in action.add:
            if fact in taken:
                found.append(Counter(m, taken.pop(fact), fact))
        disabled = [u for u in possible_before if u.operator.outcome_of is None and not task.applicable(u, after)]
        for u in disabled:
            for fact in u.delete:
                if fact in after and fact in needed_later[m]:
                    found.append(Counter(m, u, fact))
                    break
        settled = adversary.worst_case(after, action)
        for u in adversary.possible_after(after, action):
            for fact in u.delete:
                if fact in after and fact not in settled and fact not in taken:
                    taken[fact] = u
        state, previous = settled, action
    return list(dict.fromkeys(found))


@dataclass
class Protected:
    """A plan after counterplanning: the steps, which of them are counters, and the
    threats left (``assessment.risk``). ``first_risk`` is the risk of the plan
    before counterplanning; ``complete`` is False when a limit cut it short."""

    plan: list[GroundAction]
    counters: list[Counter]
    assessment: Assessment
    first_risk: float
    complete: bool = True


def counterplan(task: GroundTask, plan: list[GroundAction], timeout: float | None = None,
                stop: Callable[[], bool] | None = None) -> Protected:
    """Protect ``plan`` (a valid sequential plan of ``task``) from uncontrolled actions;
    see the module docstring. ``timeout`` bounds each extra search (CPU seconds);
    ``stop()`` (a run's limits) ends all of them, and the result then says it is not
    ``complete``: a safer plan might have been found with more time; stopped while
    it assesses a plan's threats, :class:`LimitReached`."""
    full = Adversary(task)
    first = assess(task, plan, full, stop)
    if not first.threats:
        return Protected(plan, [], first, 0.0)
    cut = False

    def robust(adversary: Adversary, budget: int | None = None) -> list[GroundAction] | None:
        nonlocal cut
        if stop is not None and stop():
            cut = True
            return None
        worst, settle = adversary.robust_task()
        found = greedy_best_first(worst, timeout=timeout, settle=settle, stop=stop, max_evaluations=budget)
        if found.status == "timeout" and (budget is None or found.evaluated < budget):
            cut = True  # stopped by the time limit, not by its own budget
        if found.status != "solved":
            return None
        shortened = eliminate_redundant(worst, found.plan, settle=settle)
        return [task.actions[a.index] for a in shortened]

    best, best_adversary = robust(full), full
    if best is None:
        allowed: list[GroundAction] = []
        for u in first.actions():
            trial_adversary = Adversary(task, allowed + [u])
            trial = robust(trial_adversary, TRIAL_EVALUATIONS)
            if trial is not None:
                allowed.append(u)
                best, best_adversary = trial, trial_adversary
    if best is None:
        return Protected(plan, [], first, first.risk, complete=not cut)
    final = assess(task, best, full, stop)
    if final.risk >= first.risk:
        return Protected(plan, [], first, first.risk, complete=not cut)
    return Protected(best, counters(task, best, best_adversary), final, first.risk, complete=not cut)


def shorten_exposure(task: GroundTask, plan: list[GroundAction], before: list[set[int]]) -> list[GroundAction]:
    """A linearisation of the partial order (``before[j]``: the steps ordered before
    step ``j``) that keeps protected intervals short, when that lowers the risk:
    built from the end, each time placing the step whose nearest successor is
    closest, so producers come right before their consumers (re-ordering, the
    cheapest counter to a threat that cannot be prevented)."""
    n = len(plan)
    successors: list[set[int]] = [set() for _ in range(n)]
    for j, preds in enumerate(before):
        for i in preds:
            successors[i].add(j)
    position: dict[int, int] = {}
    placed_from_end: list[int] = []
    while len(placed_from_end) < n:
        ready = [i for i in range(n) if i not in position and successors[i] <= position.keys()]

        def distance(i: int) -> tuple[int, int]:
            nearest = min((len(placed_from_end) - position[s] for s in successors[i]), default=n + 1)
            return (nearest, -i)

        chosen = min(ready, key=distance)
        position[chosen] = len(placed_from_end)
        placed_from_end.append(chosen)
    reordered = [plan[i] for i in reversed(placed_from_end)]
    if assess(task, reordered).risk < assess(task, plan).risk:
        return reordered
    return plan

"""Skills are resources: who holds each skill instance, who waits for it, and who is served next.

A skill instance (``SkillLink.instance``: the robot base for every
``navigate-to``, one instance per call of a virtual skill) belongs to the
task whose step enabled it. This module is the bookkeeping of that and
nothing more; the interpreter (``Sequencer.enable_skill``) decides who
takes, who waits and who is halted, and it traces those decisions:

- :attr:`Resources.holders` maps an instance to the method run that holds
  it and the call it enabled;
- a step that finds its instance held waits as a :class:`Claim` in the
  instance's queue; a step that lost its instance to a task of higher
  priority waits there too, marked ``preempted``;
- :meth:`Resources.release` notes an instance that was let go while claims
  wait for it, and :meth:`Resources.take_released` hands those instances to
  the interpreter at the end of each settle, which serves each queue best
  claim first: the agenda's order (:func:`~atlas_rap.sequencer.agenda.agenda_key`:
  priority, then deadline, then age), so who is served is deterministic.

Claims that end while they wait (their task halted, failed or timed out)
are withdrawn at once; serving also skips any claim no longer current.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass, field
from itertools import count
from typing import TYPE_CHECKING, Hashable

from atlas_rap.logic import Compound
from atlas_rap.sequencer.agenda import agenda_key

if TYPE_CHECKING:
    from atlas_rap.sequencer.net import MethodRun, Node
    from atlas_rap.sequencer.task import Task


@dataclass(eq=False, slots=True)
class Claim:
    """A step waiting for a skill instance: ``node`` of ``task``'s method wants ``call``.

    ``preempted``: the step held the instance and a task of higher priority
    took it (it resumes when served); ``since``: when the wait began.
    """

    node: Node
    task: Task
    call: Compound
    instance: Hashable
    since: float
    preempted: bool = False
    live: bool = field(default=True)

    def key(self) -> tuple:
        """Where the claim stands in its queue: the agenda's order of its task."""
        return agenda_key(self.task)


class Resources:
    """The holders of skill instances and the claims queued for them.

    Each queue is a heap on the agenda's order (a task's priority, deadline
    and age do not change while it waits); a withdrawn claim is marked and
    dropped when it reaches the top, so queueing, withdrawing and serving
    cost O(log n) whatever the number of waiters.
    """

    __slots__ = ("holders", "queues", "released", "waiting_runs", "_order")

    def __init__(self) -> None:
        self.holders: dict[Hashable, tuple[MethodRun, Compound]] = {}
        self.queues: dict[Hashable, list[tuple[tuple, int, Claim]]] = {}
        self.released: list[Hashable] = []
        self.waiting_runs: dict[MethodRun, Claim] = {}  # each method run with a step that waits, and its claim
        self._order = count()

    def queue(self, claim: Claim) -> None:
        """Put ``claim`` in its instance's queue."""
        heapq.heappush(self.queues.setdefault(claim.instance, []), (claim.key(), next(self._order), claim))
        self.waiting_runs[claim.node.run] = claim

    def withdraw(self, claim: Claim) -> None:
        """Take a claim out of its queue (its step stopped waiting, or is served)."""
        claim.live = False
        if self.waiting_runs.get(claim.node.run) is claim:
            del self.waiting_runs[claim.node.run]
        self._prune(claim.instance)

    def best(self, instance: Hashable) -> Claim | None:
        """The claim the instance goes to next, without taking it from the queue."""
        heap = self._prune(instance)
        return heap[0][2] if heap else None

    def pop_best(self, instance: Hashable) -> Claim | None:
        """The claim the instance goes to next, taken from the queue."""
        claim = self.best(instance)
        if claim is not None:
            self.withdraw(claim)
        return claim

    def release(self, instance: Hashable) -> None:
        """The instance's holder let it go: note it for serving if claims wait for it."""
        if instance in self.queues and instance not in self.released:
            self.released.append(instance)

    def take_released(self) -> list[Hashable]:
        """The instances let go since the last call, in the order they were let go."""
        released, self.released = self.released, []
        return released

    def claims(self) -> list[Claim]:
        """Every waiting claim, queue by queue, best first."""
        return [claim for heap in self.queues.values() for _, _, claim in sorted(heap, key=_rank) if claim.live]

    def _prune(self, instance: Hashable) -> list[tuple[tuple, int, Claim]] | None:
        heap = self.queues.get(instance)
        if heap is None:
            return None
        while heap and not heap[0][2].live:
            heapq.heappop(heap)
        if not heap:
            del self.queues[instance]
            return None
        return heap


def _rank(entry: tuple[tuple, int, Claim]) -> tuple[tuple, int]:
    return entry[0], entry[1]

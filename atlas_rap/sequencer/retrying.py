"""Retries that wait for a change: a failed attempt is not tried again against the same world.

A method that failed, tried again at once with nothing changed in memory,
fails the same way: the task would spend every retry in one instant (a
skill host gone, a door closed, a busy skill). So a task whose attempt
failed, which has retries left and whose next choice would repeat a method
(every applicable method has been tried; an untried one is another way, and
is tried at once), waits before its next method choice until either

- a fact changes that its RAP's ``succeed``, ``constraints`` or a method's
  ``context`` reads (the choice could now differ), or
- its back-off ends: the RAP's ``(retry-backoff S)``, else
  :data:`DEFAULT_RETRY_BACKOFF` (1 s of simulated time), as nav2's
  recovery behaviours wait before they try again.

``(retry-backoff 0)`` retries at once, as before. The wait is a
``task-waiting`` record (``until`` the back-off's end, ``watching`` the
patterns it waits on) and a ``task-resumed`` record when it ends (``by``
``a change`` or ``the back-off``). The task's ``timeout`` and deadline
still count while it waits.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Mapping, Sequence

from atlas_rap.logic import Relation, Subst, Term, term_to_str
from atlas_rap.sequencer.waiting import WaitIndex, Waiter, change_waiter

if TYPE_CHECKING:
    from atlas_rap.skillbus.timers import Timer, Timers

DEFAULT_RETRY_BACKOFF = 1.0
"""Seconds a failed task waits for a change before it tries again, unless its RAP sets ``retry-backoff``."""


class RetryWait:
    """One failed task's pause before its next attempt: ``queries`` are what it watches (already
    substituted); ``on_end(self, by)`` is called once when it ends, ``by`` saying what ended it."""

    __slots__ = ("watching", "until", "since", "_waits", "_waiter", "_timer", "_on_end")

    def __init__(self, queries: Sequence[Term], backoff: float, *, waits: WaitIndex, timers: Timers,
                 relations: Mapping[str, Sequence[Relation]], on_end: Callable[[RetryWait, str], None]) -> None:
        self.watching = [term_to_str(query) for query in queries]
        self.since = timers.now
        self.until = timers.now + backoff
        self._waits = waits
        self._on_end = on_end
        self._waiter: Waiter | None = None
        if queries:
            self._waiter = change_waiter(queries, self, relations)
            waits.add(self._waiter)
        self._timer: Timer | None = timers.at(self.until, lambda: self._end("the back-off"))

    def woken(self, waiter: Waiter, answer: Subst) -> None:
        self._end("a change")

    def broken(self, waiter: Waiter, message: str) -> None:  # a change waiter never asks its query
        self._end("a change")

    def cancel(self) -> None:
        """Stop waiting without ending (the task ended another way)."""
        if self._waiter is not None:
            self._waits.remove(self._waiter)
            self._waiter = None
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def describe(self) -> str:
        """What the task waits for, for the task tree."""
        changes = f"a change of {', '.join(self.watching)} or " if self.watching else ""
        return f"its next attempt: {changes}t={self.until:g} s"

    def _end(self, by: str) -> None:
        if self._timer is None:
            return
        self.cancel()
        self._on_end(self, by)

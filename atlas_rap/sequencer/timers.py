"""Timers on the simulated clock: the one queue of things due at a time.

The sequencer's timeouts and deadlines, virtual skills' script lines and
``at-time`` events all schedule here. Whoever drives time (the run loop for
``--world none``, the multirate executive with a world) asks for
:meth:`Timers.next_time`, moves the clock there and calls :meth:`Timers.fire_due`.

Timers due at the same time fire in the order they were scheduled, so a run
is deterministic.
"""

from __future__ import annotations

import heapq
from itertools import count
from typing import Callable


class Timer:
    """A scheduled callback; :meth:`cancel` it to stop it from firing."""

    __slots__ = ("time", "callback", "cancelled")

    def __init__(self, time: float, callback: Callable[[], object]) -> None:
        self.time = time
        self.callback = callback
        self.cancelled = False

    def cancel(self) -> None:
        """Stop this timer from firing (cancelling a fired timer does nothing)."""
        self.cancelled = True


class Timers:
    """A deterministic queue of timers in simulated seconds, with the current time."""

    def __init__(self, now: float = 0.0) -> None:
        self.now = now
        self._heap: list[tuple[float, int, Timer]] = []
        self._order = count()

    def at(self, time: float, callback: Callable[[], object]) -> Timer:
        """Call ``callback()`` when the clock reaches ``time`` (at once, at the next fire, if past)."""
        timer = Timer(max(time, self.now), callback)
        heapq.heappush(self._heap, (timer.time, next(self._order), timer))
        return timer

    def after(self, delay: float, callback: Callable[[], object]) -> Timer:
        """Call ``callback()`` ``delay`` seconds from now."""
        return self.at(self.now + delay, callback)

    def next_time(self) -> float | None:
        """When the next live timer is due, or None when nothing is scheduled."""
        heap = self._heap
        while heap and heap[0][2].cancelled:
            heapq.heappop(heap)
        return heap[0][0] if heap else None

    def fire_due(self, now: float) -> int:
        """Move the clock to ``now`` and fire every timer due by then, in order; how many fired.

        A timer scheduled by a callback for a time already due fires in this call too.
        """
        self.now = max(self.now, now)
        heap = self._heap
        fired = 0
        while heap and heap[0][0] <= self.now:
            _, _, timer = heapq.heappop(heap)
            if not timer.cancelled:
                timer.cancelled = True
                fired += 1
                timer.callback()
        return fired

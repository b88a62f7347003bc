"""Timers on the simulated clock: the one queue of things due at a time.

The sequencer's timeouts and deadlines, virtual skills' script lines and
``at-time`` events all schedule here. Whoever drives time (the run loop for
``--world none``, the multirate executive with a world) asks for
:meth:`Timers.next_time`, moves the clock there and calls :meth:`Timers.fire_due`.

Timers due at the same time fire in the order they were scheduled, so a run
is deterministic; *late* timers (timeouts and deadlines) fire after the
others due at the same instant, so that something arriving exactly on time
is on time.
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
        self._heap: list[tuple[float, int, int, Timer]] = []
        self._order = count()

    def at(self, time: float, callback: Callable[[], object], *, late: bool = False) -> Timer:
        """Call ``callback()`` when the clock reaches ``time`` (at once, at the next fire, if past).

        A ``late`` timer fires after the ordinary timers due at the same time.
        """
        timer = Timer(max(time, self.now), callback)
        heapq.heappush(self._heap, (timer.time, int(late), next(self._order), timer))
        return timer

    def after(self, delay: float, callback: Callable[[], object], *, late: bool = False) -> Timer:
        """Call ``callback()`` ``delay`` seconds from now."""
        return self.at(self.now + delay, callback, late=late)

    def next_time(self) -> float | None:
        """When the next live timer is due, or None when nothing is scheduled."""
        heap = self._heap
        while heap and heap[0][3].cancelled:
            heapq.heappop(heap)
        return heap[0][0] if heap else None

    def fire_due(self, now: float, *, late: bool = True) -> int:
        """Move the clock to ``now`` and fire every timer due by then, in order; how many fired.

        With ``late=False`` the late timers are left for a second call, so
        the caller can let the ordinary ones take effect first. A timer
        scheduled by a callback for a time already due fires in this call too.
        """
        self.now = max(self.now, now)
        heap = self._heap
        fired = 0
        phase = int(late)
        while heap and heap[0][0] <= self.now and heap[0][1] <= phase:
            timer = heapq.heappop(heap)[3]
            if not timer.cancelled:
                timer.cancelled = True
                fired += 1
                timer.callback()
        return fired

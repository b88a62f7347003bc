"""Changes to the simulated world that wait: for their time (door schedules, disturbances appearing
and leaving) or for the robot to move out of their way (a door closing, a box or a person appearing).

:class:`~atlas_rap.sim.physics.Simulation` owns one of each and steps them;
its doors and disturbances (:mod:`~atlas_rap.sim.doors`,
:mod:`~atlas_rap.sim.disturbances`) put their changes in them.
"""

from __future__ import annotations

import math
from collections.abc import Callable

__all__ = ["EVENT_EPS", "TimedEvents", "WaitingChanges"]

EVENT_EPS = 1e-9  # events at time t fire on the step whose end time is >= t - eps


class TimedEvents:
    """Actions due at given times, fired in time order (ties in the order they were added).

    :meth:`add` them all, then :meth:`start`; :attr:`next_time` is when the
    next one is due (less :data:`EVENT_EPS`; infinity when none is left), so
    a caller can skip :meth:`fire` until then.
    """

    def __init__(self) -> None:
        self._events: list[tuple[float, int, Callable[..., None], tuple]] = []
        self._at = 0
        self.next_time = math.inf

    def add(self, when: float, action: Callable[..., None], *args: object) -> None:
        """Call ``action(*args)`` at time ``when`` (seconds)."""
        self._events.append((float(when), len(self._events), action, args))

    def start(self) -> None:
        """Put the events in order; none has fired yet."""
        events = self._events
        events.sort(key=lambda e: (e[0], e[1]))
        self._at = 0
        self.next_time = events[0][0] - EVENT_EPS if events else math.inf

    def fire(self, now: float) -> None:
        """Fire every event due at ``now``, in order."""
        events = self._events
        while self._at < len(events) and events[self._at][0] - EVENT_EPS <= now:
            _, _, action, args = events[self._at]
            self._at += 1
            action(*args)
        self.next_time = events[self._at][0] - EVENT_EPS if self._at < len(events) else math.inf


Key = tuple[str, object]  # what a change is to: ("door", name), ("box", name), ("person", id)


class WaitingChanges:
    """Changes that wait until the robot is clear of them.

    :attr:`pending` is the list of ``(key, is the robot clear?, apply)``
    waiting (changed in place, so a caller may hold it and test it cheaply).
    """

    def __init__(self) -> None:
        self.pending: list[tuple[Key, Callable[[], bool], Callable[[], None]]] = []

    def when_clear(self, key: Key, clear: Callable[[], bool], apply: Callable[[], None]) -> None:
        """Apply a change now if the robot is clear of it, else as soon as it is."""
        if clear():
            apply()
        else:
            self.pending.append((key, clear, apply))

    def cancel(self, key: Key) -> None:
        """Drop the changes to ``key`` that are waiting."""
        self.pending[:] = [w for w in self.pending if w[0] != key]

    def retry(self) -> None:
        """Apply the waiting changes the robot is now clear of."""
        still = []
        for key, clear, apply in self.pending:
            if clear():
                apply()
            else:
                still.append((key, clear, apply))
        self.pending[:] = still

"""The one clock every layer of a run keeps time by.

Time is counted in base ticks (the physics step, 100 Hz by default), so the
layers' periods never drift apart and a run is deterministic: the same files
and seed give the same trace. :class:`Clock` is simulated time, as fast as
the computer goes; :class:`WallClock` (``atlas run --realtime``) is the same
clock held back so that simulated time keeps pace with the wall clock.
"""

from __future__ import annotations

import time as wall
from typing import Callable


class Clock:
    """Simulated time in ticks, ``rate`` ticks a second."""

    def __init__(self, rate: float = 100.0) -> None:
        self.rate = rate
        self.ticks = 0

    @property
    def now(self) -> float:
        return self.ticks / self.rate

    def every(self, period: float) -> int:
        """How many ticks make ``period`` seconds (at least one)."""
        return max(1, round(period * self.rate))

    def tick(self) -> None:
        self.ticks += 1

    def keep_pace(self) -> None:
        """Called at each operational tick; simulated time does not wait."""


class WallClock(Clock):
    """Simulated time that runs ``speed`` times the wall clock (it sleeps when ahead)."""

    def __init__(self, rate: float = 100.0, speed: float = 1.0) -> None:
        super().__init__(rate)
        self._pace = wall_clock_pacer(speed)

    def keep_pace(self) -> None:
        self._pace(self.now)


def wall_clock_pacer(speed: float = 1.0) -> Callable[[float], None]:
    """A function ``pace(t)`` that sleeps until simulated time ``t`` is due on the wall
    clock, running ``speed`` times the wall clock from its first call."""
    start: list[float] = []

    def pace(sim_time: float) -> None:
        if not start:
            start.append(wall.monotonic() - sim_time / speed)
        delay = start[0] + sim_time / speed - wall.monotonic()
        if delay > 0:
            wall.sleep(delay)

    return pace

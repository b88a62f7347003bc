"""What moves time for a run: the multirate executive of a world, or the timers alone.

DESIGN.md §3: each periodic process has a period and all run on one thread
in simulated time. :class:`Executive` steps the physics at its rate (100 Hz
by default) and, on the same clock, runs the skill manager (20 Hz: Layers
I-II, the reactive tier) and the sequencer (10 Hz: Layer II, RAPs). Time
is counted in physics steps, so the rates never drift apart, and a run is
deterministic. The tactical and strategic layers (III, IV) join when the
maps do.

:class:`VirtualExecutive` is the same interface for a run with no world
(``(world none)``): virtual skills and scripted events are timers, so time
jumps from one due timer to the next and a ten-minute mission takes
milliseconds.

Both offer :meth:`run` (until the posted tasks end) and :meth:`advance`
(for a while, whether or not tasks are live); ``pace(t)`` is called before
the clock moves to ``t`` (:func:`wall_clock_pacer` for ``--realtime``) and
``stop()`` ends either early (the REPL's Ctrl-C).
"""

from __future__ import annotations

import time as wall
from dataclasses import dataclass
from typing import Any, Callable, Protocol

Pace = Callable[[float], None]
Stop = Callable[[], bool]


class Driver(Protocol):
    """Whatever moves time for a run (see the module docstring)."""

    def run(self, until: float, pace: Pace | None = None, stop: Stop | None = None) -> str:
        """Run until every posted task has ended: "done", "stalled", "time-limit" or "stopped"."""

    def advance(self, seconds: float, pace: Pace | None = None, stop: Stop | None = None) -> None:
        """Let ``seconds`` of simulated time pass, whether or not tasks are live."""


@dataclass(frozen=True, slots=True)
class Rates:
    """How often each process runs, in Hz of simulated time."""

    physics: float = 100.0
    skills: float = 20.0
    sequencer: float = 10.0


class Executive:
    """Runs a simulation, a skill manager and a sequencer together on one clock."""

    def __init__(self, simulation: Any, manager: Any, sequencer: Any, rates: Rates = Rates()) -> None:
        self.simulation = simulation
        self.manager = manager
        self.sequencer = sequencer
        self.rates = rates
        self.skill_every = max(1, round(rates.physics / rates.skills))
        self.sequencer_every = max(1, round(rates.physics / rates.sequencer))
        self.steps = 0

    @property
    def time(self) -> float:
        return self.steps / self.rates.physics

    def run(self, until: float, pace: Pace | None = None, stop: Stop | None = None) -> str:
        """Run until every posted task has ended ("done"), ``until`` ("time-limit") or ``stop()``."""
        self._begin()
        while self.sequencer.live_roots():
            if stop is not None and stop():
                return "stopped"
            if self.time >= until:
                return "time-limit"
            self.step(pace)
        return "done"

    def advance(self, seconds: float, pace: Pace | None = None, stop: Stop | None = None) -> None:
        """Let the world run ``seconds`` of simulated time, whether or not tasks are live."""
        until = self.time + seconds
        self._begin()
        while self.time < until - 1e-9 and not (stop is not None and stop()):
            self.step(pace)

    def _begin(self) -> None:
        """Skills due now run (their events reach memory) before the agenda settles."""
        self.manager.tick(self.time)
        self.sequencer.settle()

    def step(self, pace: Pace | None = None) -> None:
        """One physics step, and the skills and the sequencer when their periods come round."""
        self.simulation.step()
        self.steps += 1
        now = self.time
        if self.steps % self.skill_every == 0:
            self.sequencer.timers.fire_due(now, late=False)
            self.manager.tick(now)
        if self.steps % self.sequencer_every == 0:
            if pace is not None:
                pace(now)
            self.sequencer.advance_to(now)


class VirtualExecutive:
    """Moves time for a run with no world: from one due timer to the next."""

    def __init__(self, sequencer: Any) -> None:
        self.sequencer = sequencer

    @property
    def time(self) -> float:
        return self.sequencer.now()

    def run(self, until: float, pace: Pace | None = None, stop: Stop | None = None) -> str:
        """Run until every posted task has ended ("done"), no timer is due ("stalled"),
        ``until`` ("time-limit") or ``stop()`` ("stopped")."""
        seq = self.sequencer
        timers = seq.timers
        seq.settle()
        while seq.live_roots():
            if stop is not None and stop():
                return "stopped"
            due = timers.next_time()
            if due is None:
                return "stalled"
            if due > until:
                timers.fire_due(until)
                return "time-limit"
            if pace is not None:
                pace(due)
            seq.advance_to(due)
        return "done"

    def advance(self, seconds: float, pace: Pace | None = None, stop: Stop | None = None) -> None:
        """Fire every timer due in the next ``seconds``, then move the clock to their end."""
        seq = self.sequencer
        until = seq.now() + seconds
        seq.settle()
        while not (stop is not None and stop()):
            due = seq.timers.next_time()
            if due is None or due > until:
                break
            if pace is not None:
                pace(due)
            seq.advance_to(due)
        if not (stop is not None and stop()):
            seq.advance_to(until)


def wall_clock_pacer(speed: float = 1.0) -> Pace:
    """A ``pace`` function that sleeps so simulated time runs ``speed`` times the wall clock."""
    start = wall.monotonic()

    def pace(sim_time: float) -> None:
        delay = start + sim_time / speed - wall.monotonic()
        if delay > 0:
            wall.sleep(delay)

    return pace

"""The ATLAS multirate executive (first cut): physics, skills and sequencer on one clock.

DESIGN.md §3: each periodic process has a period and all run on one thread
in simulated time. The executive steps the physics at its rate (100 Hz by
default) and, on the same clock, runs the skill manager (20 Hz: Layers
I-II, the reactive tier) and the sequencer (10 Hz: Layer II, RAPs). Time
is counted in physics steps, so the rates never drift apart, and a run is
deterministic. ``pace`` slows the loop to the wall clock (``--realtime``).
The tactical and strategic layers (III, IV) join when the maps do.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable


@dataclass(frozen=True, slots=True)
class Rates:
    """How often each process runs, in Hz of simulated time."""

    physics: float = 100.0
    skills: float = 20.0
    sequencer: float = 10.0


class Executive:
    """Runs a simulation, a skill manager and a sequencer together until the posted tasks end."""

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

    def run(self, sequencer: Any, until: float, pace: Callable[[float], None] | None = None) -> str:
        """Run until every posted task has ended ("done") or ``until`` seconds ("time-limit")."""
        self.manager.tick(self.time)
        self.sequencer.settle()
        while self.sequencer.live_roots():
            if self.time >= until:
                return "time-limit"
            self.step(pace)
        return "done"

    def advance(self, seconds: float, pace: Callable[[float], None] | None = None,
                stop: Callable[[], bool] | None = None) -> None:
        """Let the world run ``seconds`` of simulated time, whether or not tasks are live
        (the REPL's :run and its background clock); ``stop()`` ends it early."""
        until = self.time + seconds
        self.sequencer.settle()
        while self.time < until - 1e-9 and not (stop is not None and stop()):
            self.step(pace)

    def step(self, pace: Callable[[float], None] | None = None) -> None:
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

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
        sim, manager, seq = self.simulation, self.manager, self.sequencer
        timers = seq.timers
        skill_every, sequencer_every = self.skill_every, self.sequencer_every
        manager.tick(self.time)
        seq.settle()
        while seq.live_roots():
            if self.time >= until:
                return "time-limit"
            sim.step()
            self.steps += 1
            now = self.time
            if self.steps % skill_every == 0:
                timers.fire_due(now, late=False)
                manager.tick(now)
            if self.steps % sequencer_every == 0:
                if pace is not None:
                    pace(now)
                seq.advance_to(now)
        return "done"

"""What moves time for a run: the multirate executive of the ATLAS layers, or the timers alone.

The time model (docs/explanation/architecture.md, "Time"): each periodic process has a period and all run on one thread
on one :class:`~atlas_rap.layers.clock.Clock`, counted in physics steps
(100 Hz by default), so the rates never drift apart and a run is
deterministic. At each step :class:`Executive` runs, in this order, what is
due:

- the physics of the world (the :class:`Body`'s step: the simulation's, or
  the ``step`` of a robot served by :class:`atlas_rap.host.SkillHost`);
- the skill manager (20 Hz; the reactive skills: sensors, the safety
  reflex, motion, event monitors), then **Layer I** (monitoring) at the
  same rate;
- the sequencer (10 Hz), in **Layer II**'s slot: RAPs run at the
  operational rate, then Layer II's own tick;
- **Layer III** (tactical, 4 Hz) and **Layer IV** (strategic, 2 Hz): as in the seed
  (Fig. 2), each layer above is slower than the one below.

The layers, and which of them is primary, are :mod:`atlas_rap.layers.layer`'s.

:class:`VirtualExecutive` is the same interface for a run with no world
(``(world none)``): virtual skills and scripted events are timers, so time
jumps from one due timer to the next and a ten-minute mission takes
milliseconds.

Both offer :meth:`run` (until the posted tasks end) and :meth:`advance`
(for a while, whether or not tasks are live); ``pace(t)`` is called before
the sequencer moves to ``t`` (a progress bar) and ``stop()`` ends either
early (the REPL's Ctrl-C).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Protocol

from atlas_rap.layers.clock import Clock

if TYPE_CHECKING:  # same tier and below
    from atlas_rap.layers.layer import Layer, LayerStack
    from atlas_rap.sequencer import Task
    from atlas_rap.skills.manager import SkillManager

Pace = Callable[[float], None]
Stop = Callable[[], bool]


class Body(Protocol):
    """What moves with the clock, one physics step at a time: the simulation
    (:class:`atlas_rap.sim.physics.Simulation`), or the body of a robot a
    :class:`atlas_rap.host.SkillHost` serves."""

    def step(self) -> None:
        """One physics period (``1 / Rates.physics`` seconds) of the world."""


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


class DueTimers(Protocol):
    """The timers of the sequencer's side, as the executive fires them at each skills tick."""

    def fire_due(self, now: float, *, late: bool = True) -> object: ...


class SequencerSide(Protocol):
    """What moving time asks of the sequencer's side: the :class:`~atlas_rap.sequencer.Sequencer`
    in one process, or, on a skill host, the session that stands for the remote one."""

    @property
    def timers(self) -> DueTimers: ...

    def live_roots(self) -> list[Task]: ...

    def settle(self) -> None: ...

    def advance_to(self, now: float) -> None: ...


class Executive:
    """Runs a body (the simulation), a skill manager, a sequencer and the layers together on one clock."""

    def __init__(self, simulation: Body, manager: SkillManager, sequencer: SequencerSide,
                 rates: Rates = Rates(), *, stack: LayerStack | None = None, clock: Clock | None = None) -> None:
        self.simulation = simulation
        self.manager = manager
        self.sequencer = sequencer
        self.rates = rates
        self.stack = stack
        self.clock = clock if clock is not None else Clock(rates.physics)
        self.skill_every = self.clock.every(1.0 / rates.skills)
        self.sequencer_every = self.clock.every(1.0 / rates.sequencer)
        self.started = False
        self._fast: list[Layer] = []
        self._operational: list[Layer] = []
        self._slow: list[tuple[int, Layer]] = []

    @property
    def time(self) -> float:
        return self.clock.now

    @property
    def steps(self) -> int:
        return self.clock.ticks

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
        """Skills due now run (their events reach memory), the layers start, the agenda settles."""
        self.manager.tick(self.time)
        if not self.started:
            self.started = True
            if self.stack is not None:
                self.stack.start()
                for layer in self.stack.active():  # I in the skills' slot, II in the sequencer's, III-IV their own
                    if layer.name == "I":
                        self._fast.append(layer)
                    elif layer.name == "II":
                        self._operational.append(layer)
                    else:
                        self._slow.append((self.clock.every(layer.period), layer))
        self.sequencer.settle()

    def step(self, pace: Pace | None = None) -> None:
        """One physics step, and every process whose period has come round."""
        self.simulation.step()
        clock = self.clock
        clock.tick()
        ticks, now = clock.ticks, clock.now
        stack = self.stack
        if ticks % self.skill_every == 0:
            self.sequencer.timers.fire_due(now, late=False)
            self.manager.tick(now)
            if stack is not None:
                stack.observe()  # skills' events may have made the rules choose another layer
            for layer in self._fast:
                layer.tick(now)
        if ticks % self.sequencer_every == 0:
            clock.keep_pace()
            if pace is not None:
                pace(now)
            self.sequencer.advance_to(now)
            if stack is not None:
                stack.observe()  # and so may the RAPs' changes
            for layer in self._operational:
                layer.tick(now)
        for every, layer in self._slow:
            if ticks % every == 0:
                layer.tick(now)


class VirtualExecutive:
    """Moves time for a run with no world: from one due timer to the next.

    ``pace`` (``--realtime``: :func:`~atlas_rap.layers.clock.wall_clock_pacer`) is called
    before every move of the clock, with any ``pace`` given to :meth:`run`."""

    def __init__(self, sequencer: SequencerSide, pace: Pace | None = None) -> None:
        self.sequencer = sequencer
        self.own_pace = pace

    @property
    def time(self) -> float:
        return self.sequencer.now()

    def run(self, until: float, pace: Pace | None = None, stop: Stop | None = None) -> str:
        """Run until every posted task has ended ("done"), no timer is due ("stalled"),
        ``until`` ("time-limit") or ``stop()`` ("stopped")."""
        seq = self.sequencer
        timers = seq.timers
        pace = _both(self.own_pace, pace)
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
        pace = _both(self.own_pace, pace)
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


def _both(first: Pace | None, second: Pace | None) -> Pace | None:
    if first is None or second is None:
        return first or second
    return lambda t: (first(t), second(t))

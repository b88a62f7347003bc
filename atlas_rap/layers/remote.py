"""What moves time when the skills run on other hosts: the lock step over the skill bus.

:class:`RemoteExecutive` is the :class:`~atlas_rap.layers.executive.Driver`
of a run whose robots are served by skill hosts (``atlas run --connect``).
The sequencer's side drives the clock (``skillbus.protocol``): it tells
each host "advance to t", where t is the next position at which the
sequencer must act, as the in-process executive would have it act:

- a skills tick at which a timer of the sequencer is due (timers fire
  before the skills run);
- a sequencer tick while tasks wait on the agenda, or a timer is due
  (the RAPs run there);
- the end of a tick, when the posted tasks have all ended, the time limit
  or a stride of :data:`STRIDE` seconds (so ``stop()`` is looked at) is reached.

Between those points the sequencer would do nothing but watch the clock,
so the host runs freely; whatever facts its skills and layers change on the
way come back at once and are applied as in one process, and may bring the
next point closer. A run over the bus gives the same trace, byte for byte,
as the same run in one process.

Pacing: ``--realtime`` (and the REPL on a terminal, through ``pace``) holds
simulated time to the wall clock at every sequencer tick, the strides then
one sequencer period long. With several robots the strides are one skills
period long, and the hosts take their turns robot by robot. While no host
is there (all lost), simulated time follows the wall clock, so a host that
comes back finds the mission still running; the lost hosts are looked for
at every stride.
"""

from __future__ import annotations

import math
from pathlib import Path

from atlas_rap.errors import Problem, RunError, WorldFileError
from atlas_rap.layers.clock import Clock, wall_clock_pacer
from atlas_rap.layers.executive import Pace, Stop
from atlas_rap.layers.deliberation import ProblemFor
from atlas_rap.layers.layer import LAYER_NAMES
from atlas_rap.layers.system import NamedWorld, RunOptions, System, WorldChoice, planning_beside
from atlas_rap.sequencer import Sequencer, Trace
from atlas_rap.skillbus.protocol import BEGIN, END, SEQUENCER, SKILLS, Position
from atlas_rap.skillbus.remote import CONNECT_TIMEOUT, HostLink, HostLost, RemoteSkills
from atlas_rap.skillbus.skill_link import CombinedSkills
from atlas_rap.skillbus.zenoh_bus import BusError
from atlas_rap.skills.virtual import VirtualSkills

STRIDE = 1.0
"""Longest stride (simulated seconds) a host runs without the sequencer looking at ``stop()``."""


class RemoteExecutive:
    """Drives the skill hosts of a :class:`RemoteSkills` and a sequencer in lock step (module docstring)."""

    def __init__(self, sequencer: Sequencer, fleet: RemoteSkills, *, realtime: bool = False) -> None:
        self.sequencer = sequencer
        self.fleet = fleet
        physics, skills, rate = fleet.rates
        self.clock = Clock(physics)
        self.skill_every = self.clock.every(1.0 / skills)
        self.sequencer_every = self.clock.every(1.0 / rate)
        self.position: Position = (0, END)
        self.realtime = realtime
        self._own_pace = wall_clock_pacer() if realtime else None
        self._lost_pace: Pace | None = None
        self._run_mode = True
        self._end_tick = 0
        fleet.horizon = self._horizon
        fleet.clock_to = self._clock_to

    @property
    def time(self) -> float:
        return self.position[0] / self.clock.rate

    # -- the Driver interface ---------------------------------------------------------

    def run(self, until: float, pace: Pace | None = None, stop: Stop | None = None) -> str:
        """Run until every posted task has ended ("done"), ``until`` ("time-limit") or ``stop()``."""
        self._run_mode = True
        self._end_tick = self._first_tick_at(until)
        self._begin(pace)
        seq = self.sequencer
        while True:
            if self.position[1] >= END:
                if not seq.live_roots():
                    return "done"
                if stop is not None and stop():
                    return "stopped"
                if self.time >= until:
                    return "time-limit"
            self._stride(pace)

    def advance(self, seconds: float, pace: Pace | None = None, stop: Stop | None = None) -> None:
        """Let ``seconds`` of simulated time pass, whether or not tasks are live."""
        until = self.time + seconds
        self._run_mode = False
        self._end_tick = self._first_tick_at(until - 1e-9)
        self._begin(pace)
        while not (self.position[1] >= END and (self.time >= until - 1e-9 or (stop is not None and stop()))):
            self._stride(pace)

    # -- strides ---------------------------------------------------------------------------

    def _begin(self, pace: Pace | None) -> None:
        """Each host ticks its skills once and (the first time) starts its layers; the agenda settles."""
        self._look_after_hosts()
        tick = self.position[0]
        self._to((tick, BEGIN))
        self.position = (tick, BEGIN)
        self.sequencer.settle()

    def _stride(self, pace: Pace | None) -> None:
        """Let the hosts run to the next position the sequencer must act at, and act there."""
        self._look_after_hosts()
        target = self._horizon(self.position)
        reached = self._to(target)
        self.position = reached
        tick, phase = reached
        now = tick / self.clock.rate
        seq = self.sequencer
        if not self.fleet.alive():
            if self._lost_pace is None:
                self._lost_pace = wall_clock_pacer()
            self._lost_pace(now)
        else:
            self._lost_pace = None
        if phase == SKILLS and tick % self.skill_every == 0:
            seq.timers.fire_due(now, late=False)
        elif phase == SEQUENCER and tick % self.sequencer_every == 0:
            if self._own_pace is not None:
                self._own_pace(now)
            if pace is not None:
                pace(now)
            seq.advance_to(now)
        else:
            if phase == END and tick % self.sequencer_every == 0:  # a stride over a sequencer tick: paced too
                if self._own_pace is not None:
                    self._own_pace(now)
                if pace is not None:
                    pace(now)
            self._clock_to(reached)
        self._look_after_hosts()

    def _to(self, target: Position) -> Position:
        """Every live host runs to ``target`` (or where the sequencer came to need it sooner)."""
        reached: list[Position] = []
        for link in self.fleet.alive():
            try:
                reached.append(link.tick_to(target))
            except HostLost:
                continue
            target = min(target, reached[-1])  # it had to stop sooner: so do the others
        return min(reached) if reached else target

    def _look_after_hosts(self) -> None:
        """Lost hosts: fail the skills they ran, and (after the grace) those waiting for them. Hosts
        come back: a new session at this time, which serves the skills that waited."""
        for link in self.fleet.links.values():
            link.poll()
            if link.lost is not None:
                self._clock_to(self.position)
                link.fail_running()
            elif link.returned and self.position[1] >= END:
                self._rejoin(link)
            link.give_up_waiting(self.time)

    def _rejoin(self, link: HostLink) -> None:
        tick = self.position[0]
        try:
            link.handshake(tick, CONNECT_TIMEOUT)
            link.tick_to((tick, BEGIN))
        except (BusError, HostLost):
            link.alive = False
            return
        link.resume_waiting()

    # -- where to stop next ----------------------------------------------------------------

    def _horizon(self, after: Position) -> Position:
        """The first position after ``after`` at which the sequencer must act (module docstring)."""
        tick, phase = after
        seq = self.sequencer
        if self._run_mode and not seq.live_roots():
            return (tick, END) if phase < END else (tick + 1, END)
        stride = self.sequencer_every if (self.realtime or not self.fleet.alive()) else \
            self.skill_every if len(self.fleet.links) > 1 else round(STRIDE * self.clock.rate)
        best = (max(min(tick + stride, self._end_tick), tick + 1), END)
        if len(seq.agenda):
            best = min(best, self._next(after, tick, self.sequencer_every, SEQUENCER))
        due = seq.timers.next_time()
        if due is not None:
            first = self._first_tick_at(due)
            best = min(best, self._next(after, first, self.skill_every, SKILLS),
                       self._next(after, first, self.sequencer_every, SEQUENCER))
        return best

    def _next(self, after: Position, from_tick: int, every: int, phase: int) -> Position:
        """The first ``phase`` point of a tick that is a multiple of ``every``, at or after
        ``from_tick`` and after ``after``."""
        tick = max(from_tick, after[0] if after[1] < phase else after[0] + 1)
        tick = -(-tick // every) * every
        return (tick, phase)

    def _first_tick_at(self, t: float) -> int:
        """The first tick whose time is ``t`` or later, as the executive compares them."""
        rate = self.clock.rate
        tick = max(0, math.ceil(t * rate))
        while tick > 0 and (tick - 1) / rate >= t:
            tick -= 1
        while tick / rate < t:
            tick += 1
        return tick

    def _clock_to(self, position: Position) -> None:
        """The sequencer's clock as the in-process executive leaves it at ``position``: the time
        of the last skills or sequencer tick passed (timers due by then would have fired)."""
        tick = position[0]
        passed = max(tick - tick % self.skill_every, tick - tick % self.sequencer_every)
        now = passed / self.clock.rate
        timers = self.sequencer.timers
        if now > timers.now:
            timers.fire_due(now, late=False)


def build_remote(options: RunOptions, choice: WorldChoice, trace: Trace, virtual: VirtualSkills,
                 problem_for: ProblemFor, worker: bool) -> System:
    """A run on the robots' skill hosts (``options.bus``): their skills beside the program's virtual
    ones, the sequencer, the planner and the lock-step executive. The world is the hosts'; a
    program that names another (``choice.form``) is a located error."""
    unsupported = [flag for flag, used in (
        ("--map", options.topology is not None), ("--no-prior-map", not options.prior_map),
        ("--map-in", options.map_in is not None), ("mapping (atlas map build)", options.mapping),
        ("--layers", tuple(options.layers) != LAYER_NAMES)) if used]
    if unsupported:
        raise RunError(f"{', '.join(unsupported)}: not supported with --connect yet (the skill host runs "
                         f"the world and the layers with its prior map)")
    form, line = choice.form, choice.line
    if form is not None and choice.name == "none":
        raise WorldFileError(Problem("this program runs with no world ((world none)); --connect runs programs on "
                                  "a skill host's world", form.loc, line,
                                  "run it without --connect, or name the host's world"))
    assert options.bus is not None, "build_remote needs the bus settings (--connect)"
    fleet = RemoteSkills(options.bus)
    try:
        if form is not None and Path(choice.name).stem != fleet.world:
            raise WorldFileError(Problem(f"this program names the world '{form.world}', but the skill host runs "
                                      f"'{fleet.world}'", form.loc, line,
                                      f"start the host in that world (atlas skills serve --world {form.world}), "
                                      f"or remove the (world ...) form"))
    except BaseException:
        fleet.close()
        raise
    skills = CombinedSkills(fleet, virtual)
    sequencer = Sequencer(skills=skills, trace=trace)
    deliberation = planning_beside(sequencer, problem_for, options, worker)
    driver = RemoteExecutive(sequencer, fleet, realtime=options.realtime)
    return System(options, trace, virtual, skills, sequencer, deliberation, driver, world=NamedWorld(fleet.world),
                  remote=fleet)

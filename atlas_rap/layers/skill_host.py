"""A skill host: a robot's world, skills and map layers, serving a sequencer on another host.

``atlas skills serve`` runs one :class:`SkillHostServer`. What runs where
(docs/explanation/architecture.md, "The 3T tiers"):

- **on the skill host**: the simulation (pymunk physics, sonar, doors,
  disturbances), the skill manager with the stock skills, and the ATLAS
  layer stack (Layers I-III: the monitoring reflexes, route planning on the
  prior map, the tactical re-routing), since they read the sonar and answer
  ``navigate-to``'s "route to office?" inside a skills tick;
- **on the sequencer's side** (``atlas run --connect``, ``atlas repl
  --connect``): RAP memory and its rules (the layer-switching rules of
  ``rap_library/layers.rap`` too: the host's layers read the sequencer's
  memory, copied to them over the bus), the agenda, the virtual skills of
  the mission, the planner, the timers and the trace.

Each sequencer's session gets a fresh world, built when the sequencer says
hello, at the sequencer's time; the executive is the in-process one
(``layers.executive``), whose sequencer is the :class:`~atlas_rap.skillbus.host.HostSession`.
So the host steps physics and skills exactly as a run in one process does
and stops where the sequencer needs to act, and a run over the bus gives
the same trace as in one process.

Recording (``atlas skills serve --record HOST.mcap``, ``--live``): the host
records its world (pose, tf, path, sonar, scene, topology, route) with a
:class:`~atlas_rap.views.recording.HostRecorder`, sampled at the host's
sequencer ticks as a run in one process samples it, one file per session,
closed when the session ends however it ends; the sequencer's side records
the trace and the primary layer (``atlas run --connect --record``).

Not on the bus yet: mapping while driving (``--no-prior-map``, ``--map-in``,
Layer IV), a topological map file (``--map``), ``--layers``, pictures of
the world (``--render``), and the REPL's ``:map`` and ``:layers``; each
needs the host's world on the sequencer's side.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from atlas_rap.layers.builders import simulated_robot
from atlas_rap.layers.clock import Clock
from atlas_rap.layers.executive import Body, Executive, Rates
from atlas_rap.layers.layer import LayerStack
from atlas_rap.layers.monitoring import MonitoringLayer
from atlas_rap.layers.operational import OperationalLayer
from atlas_rap.layers.tactical import TacticalLayer
from atlas_rap.logic import Compound
from atlas_rap.skillbus import keys
from atlas_rap.skillbus.auth import Secret
from atlas_rap.skillbus.host import LEASE, HostDoor, HostSession, SessionEnded, Superseded, await_hello
from atlas_rap.skillbus.messages import MAX_MESSAGE, Frame, Welcome
from atlas_rap.skillbus.protocol import BEGIN, END, log
from atlas_rap.skillbus.zenoh_bus import Conversation, close_session, open_session

if TYPE_CHECKING:  # downward only: the sim is imported when a session starts
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.sim.world import World
    from atlas_rap.skills.manager import SkillManager



class Paced(Protocol):
    """What records a session as it runs: its ``pace`` hook, called at each sequencer tick."""

    def pace(self, now: float) -> None: ...


class SessionRecorder(Protocol):
    """A recording of each sequencer's session on this host (``atlas skills serve --record``:
    :class:`atlas_rap.views.recording.HostRecorder`)."""

    def begin(self, source: SessionWorld, number: int, start: float) -> Paced: ...

    def end(self) -> Path | None: ...

    def close(self) -> object: ...


@dataclass
class SessionWorld:
    """What one session's world is made of, as a recording reads it
    (:class:`~atlas_rap.views.recording.WorldSampler`'s ``source``)."""

    simulation: Simulation
    manager: SkillManager
    world: World
    stack: LayerStack
    clock: Clock

    def now(self) -> float:
        return self.clock.now


@dataclass
class HostedRobot:
    """What one session serves: the ``body`` that steps with the clock, the skill ``manager``, the
    layers that run beside the skills (``stack``, or None), the ``world``'s name the sequencer is
    told, the ``facts`` its memory starts from (in the host's words: ``robot`` for the robot), and
    ``pace``, called at each sequencer tick (a recording), or None."""

    body: Body
    manager: SkillManager
    stack: LayerStack | None
    world: str
    facts: tuple[Compound, ...] = ()
    pace: Callable[[float], None] | None = None


class BusHost:
    """Serves one robot's skills on the bus, to one sequencer at a time (see the module docstring):
    the door, the sessions one after another, and each session's ticks. What a session serves is
    :meth:`hosted`'s: :class:`SkillHostServer` simulates a world; :class:`atlas_rap.host.SkillHost`
    serves a user's own skills on their own robot.

    ``listen`` / ``connect``: Zenoh endpoints; ``robot``: the robot's name on the bus; ``secret``:
    the bus's secret (``skillbus.auth.host_secret``), which every sequencer must hold (None: no
    authentication, for measuring what it costs); ``zenoh_config``: Zenoh's own configuration
    file; ``lease``: seconds a silent sequencer keeps the host; ``max_message``: the largest
    message taken, in bytes.
    """

    def __init__(self, *, robot: str = keys.DEFAULT_ROBOT, secret: Secret | None,
                 listen: Sequence[str] = (), connect: Sequence[str] = (), zenoh_config: str | None = None,
                 lease: float = LEASE, max_message: int = MAX_MESSAGE, rates: Rates = Rates()) -> None:
        self.robot = keys.check_robot(robot)
        self.rates = rates
        self.lease = lease
        self.session = open_session(listen=listen, connect=connect, config_file=zenoh_config,
                                    max_message=max_message)
        self.conversation = Conversation(self.session, keys.to_host(robot), keys.sequencer_token(robot),
                                         max_message=max_message, robot=robot)
        self.door = HostDoor(self.conversation, self.robot, secret)
        self.conversation.declare_token(keys.host_token(robot))  # after the subscriptions: seen only when ready
        self.sessions = 0
        self.current: HostSession | None = None

    def hosted(self, session: HostSession, clock: Clock) -> HostedRobot:
        """What a new session serves, built at the sequencer's time (``clock``)."""
        raise NotImplementedError

    def session_ended(self) -> Path | None:
        """A session has ended, however it ended: the file of its recording, if one was written."""
        return None

    def serve(self, stop: Callable[[], bool] = lambda: False,
              on_session: Callable[[str], None] | None = None) -> None:
        """Serve sequencers one after another until ``stop()``; ``on_session`` hears of each start and end."""
        hello: tuple[Frame, bytes] | None = None
        while not stop():
            hello = hello or await_hello(self.door, stop)
            if hello is None:
                return
            self.sessions += 1
            if on_session is not None:
                on_session(f"session {self.sessions} started at t={hello[0].last.tick / self.rates.physics:g} s")
            reason, taken_by = "stopped: the host stops", None
            try:
                self._run(hello)
                reason = "ended"
            except Superseded as exc:
                reason, taken_by = str(exc), exc.hello
            except SessionEnded as exc:
                reason = str(exc)
            finally:  # also when the host is stopped mid-session (Ctrl-C, SIGTERM): a whole file
                self.current = None
                written = self.session_ended()
                if on_session is not None:
                    on_session(f"session {self.sessions} {reason}")
                    if written is not None:
                        on_session(f"recording written to {written}")
            hello = taken_by

    def _run(self, hello: tuple[Frame, bytes]) -> None:
        """One sequencer's session: a fresh robot at its time, then its ticks until it goes."""
        tick = hello[0].last.tick  # type: ignore[union-attr]
        clock = Clock(self.rates.physics)
        clock.ticks = tick
        session = self.current = HostSession(self.door, hello, tick, lambda: clock.ticks, lease=self.lease)
        session.timers.now = clock.now
        robot = self.hosted(session, clock)
        executive = Executive(robot.body, robot.manager, session, self.rates, stack=robot.stack, clock=clock)
        manager = robot.manager
        welcome = Welcome(self.robot, robot.world, {name: tuple(sorted(a)) for name, a in manager.skills().items()},
                          tuple(sorted(manager.produces())), tuple(session._out(fact) for fact in robot.facts),
                          (self.rates.physics, self.rates.skills, self.rates.sequencer))
        session.welcome(welcome)
        session.first_tick()
        while True:
            target = session.target
            if target[1] == BEGIN and target[0] == clock.ticks and session.position < target:
                executive._begin()
            elif session.position >= target:
                session.reach(session.position[1])
            else:
                executive.step(robot.pace)
                session.reach(END)

    def close(self) -> None:
        """Leave the bus (the token goes: a sequencer using this host sees it lost)."""
        self.conversation.declare_token(None)
        self.conversation.close()
        close_session(self.session)


class SkillHostServer(BusHost):
    """Serves a simulated robot's stock skills and Layers I-III (``atlas skills serve``).

    ``world``: a shipped world's name or a world file, simulated afresh for each session;
    ``seed``: the simulation's; ``recorder``: a :class:`~atlas_rap.views.recording.HostRecorder`
    that records each session's world (or None); it is told of each session's start and end, and
    closed by :meth:`close`. The other arguments are :class:`BusHost`'s.
    """

    def __init__(self, world: str, *, robot: str = keys.DEFAULT_ROBOT, secret: Secret | None, seed: int = 0,
                 listen: Sequence[str] = (), connect: Sequence[str] = (), zenoh_config: str | None = None,
                 lease: float = LEASE, max_message: int = MAX_MESSAGE, rates: Rates = Rates(),
                 recorder: SessionRecorder | None = None) -> None:
        from atlas_rap.sim.world import load_world

        self.world = load_world(world)
        self.seed = seed
        self.recorder = recorder
        super().__init__(robot=robot, secret=secret, listen=listen, connect=connect, zenoh_config=zenoh_config,
                         lease=lease, max_message=max_message, rates=rates)

    def hosted(self, session: HostSession, clock: Clock) -> HostedRobot:
        """The world simulated afresh, the stock skills on it and Layers I-III; recorded if asked."""
        from atlas_rap.sim.prior import prior_facts

        simulation, manager = simulated_robot(self.world, self.world, self.seed, self.rates)
        session.manager = manager
        manager.connect(session)
        stack = LayerStack(session, manager.context.beliefs, self.world)  # type: ignore[arg-type]
        stack.add(MonitoringLayer(stack))
        stack.add(OperationalLayer(stack))
        stack.add(TacticalLayer(stack))
        pace = None
        if self.recorder is not None:
            pace = self.recorder.begin(SessionWorld(simulation, manager, self.world, stack, clock),
                                       self.sessions, clock.now).pace
        facts = (*prior_facts(self.world), Compound("map", ("prior",)))
        return HostedRobot(simulation, manager, stack, self.world.name, facts, pace)

    def session_ended(self) -> Path | None:
        return self.recorder.end() if self.recorder is not None else None

    def close(self) -> None:
        """Finish the recording (if any), and leave the bus."""
        if self.recorder is not None:
            self.recorder.close()
        super().close()


__all__ = ["BusHost", "HostedRobot", "SessionWorld", "SkillHostServer", "log"]

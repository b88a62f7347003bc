"""Serve your own robot's skills to a sequencer: the skill-host library.

``atlas skills serve`` hosts the stock skills on a simulated robot. A real
robot has skills of its own, in a process of its own (a ROS 2 node, a motor
controller's driver): embed a :class:`SkillHost` in that process and
``atlas run --connect`` drives them as it drives the stock ones::

    from atlas_rap.host import Skill, SkillHost

    class Beep(Skill):
        name = "beep"                    # how RAPs call it: (beep 3)
        params = ("times",)
        events = ("beeped",)             # the predicates it asserts (atlas check reads them)
        rate = 10.0                      # transform() runs this often while enabled (Hz)

        def enable(self, args):
            self.left = int(args[0])

        def transform(self, inputs):
            self.context.robot.buzzer(on=self.left % 2 == 1)   # your robot's own driver
            self.left -= 1
            if self.left <= 0:
                self.context.assert_fact(Compound("beeped", ("robot",)))
                self.context.finish(self)                      # (done (beep 3) :succeed)
            return {}

    with SkillHost("rover", [Beep], body=my_robot) as host:
        host.serve()                     # one sequencer at a time, until Ctrl-C

What it keeps from ``atlas skills serve`` (the same door and the same turns
on the bus, :mod:`atlas_rap.skillbus`):

- **Security.** Only a sequencer holding the host's secret gets in: the
  token file made at the first start (``token_file``, default a file per
  robot in your runtime folder; :attr:`SkillHost.token_source` says where)
  or ``ATLAS_BUS_TOKEN``. Every frame is authenticated; a stranger's
  messages change nothing. Listening beyond this machine without TLS is
  allowed but :attr:`SkillHost.exposure` says why it is unwise; give a Zenoh
  configuration with certificates (``zenoh_config``) for a network you do
  not trust.
- **Liveliness.** The host declares the token ``atlas/NAME/host`` when it is
  ready and withdraws it when it closes; a sequencer that loses it stops
  with a clear error. A sequencer that falls silent for ``lease`` seconds
  loses the host to the next one.
- **Time: lock-step or real time.** The host keeps the sequencer's clock:
  ``rates.physics`` times a second of it, the robot's ``body.step(dt)`` is
  called (a fake robot moves itself there; a real one has nothing to do),
  then the skills' ticks at ``rates.skills``. By default the sequencer runs
  in simulated time and the host steps as fast as the turns go (lock-step:
  same mission, same trace). A real robot moves in real time: run the
  sequencer with ``atlas run --connect ... --realtime``, and the clock is
  paced to the wall clock.

The robot (``body``) is yours: any object. Skills reach it as
``self.context.robot``. If it has ``step(dt)``, the host calls it each
physics period of the clock. No simulator is imported: the skills, the
manager and the bus are all a host needs.

Each sequencer's session gets fresh skills (one instance of each class
given) on the same body. ``facts`` are what the sequencer's memory starts
with, in the host's words (``robot`` for the robot itself: on the bus it is
called by its name). ``world`` is the name the sequencer is told (a mission
with ``(world NAME)`` must name the same); by default the robot's name.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import Any

from atlas_rap.errors import LanguageError
from atlas_rap.layers.clock import Clock
from atlas_rap.layers.executive import Rates
from atlas_rap.layers.skill_host import BusHost, HostedRobot
from atlas_rap.lang.loader import parse_term
from atlas_rap.logic import Compound
from atlas_rap.skillbus.auth import host_secret
from atlas_rap.skillbus.host import LEASE, HostSession
from atlas_rap.skillbus.keys import check_robot
from atlas_rap.skillbus.messages import MAX_MESSAGE
from atlas_rap.skillbus.zenoh_bus import exposure_warning, host_endpoints
from atlas_rap.plugins import Contribution, PluginError
from atlas_rap.skills.catalog import SkillSpec, spec_of
from atlas_rap.skills.manager import SkillManager
from atlas_rap.skills.skill import HALTED, Skill, SkillContext

__all__ = ["HALTED", "Compound", "Rates", "Skill", "SkillContext", "SkillHost"]


class _Body:
    """The user's robot as the executive steps it: ``robot.step(dt)`` each physics period, if it has one."""

    def __init__(self, robot: Any, dt: float) -> None:
        self._step: Callable[[float], Any] | None = getattr(robot, "step", None)
        self.dt = dt

    def step(self) -> None:
        if self._step is not None:
            self._step(self.dt)


class SkillHost(BusHost):
    """One robot's own skills served on the Zenoh skill bus (see the module docstring).

    ``robot``: the robot's name on the bus (``atlas run --connect ... --robot NAME``);
    ``skills``: the :class:`Skill` classes, each declared as a plugin's skill is (a ``name``,
    ``params`` such as ``("x: number",)``, ``events``, ``rate``); ``body``: the robot the skills
    drive (``self.context.robot``); ``facts``: what the sequencer's memory starts from (terms or
    their text); ``world``: the name the sequencer is told; ``seed``: of the skills' random
    generator (``self.context.rng``). ``listen`` / ``connect`` / ``zenoh_config``: where on
    Zenoh (default: listen on ``tcp/127.0.0.1:7447``, this machine only); ``token_file``: the
    host's secret (see :func:`atlas_rap.skillbus.auth.host_secret`); ``lease``, ``max_message``,
    ``rates``: as ``atlas skills serve``'s. A ``ValueError`` says what is wrong with a skill or a
    fact; :class:`~atlas_rap.errors.BusError` what is wrong with an endpoint or the configuration.
    """

    def __init__(self, robot: str, skills: Sequence[type[Skill]], *, body: Any = None,
                 facts: Iterable[Compound | str] = (), world: str | None = None, seed: int = 0,
                 listen: Sequence[str] = (), connect: Sequence[str] = (), zenoh_config: str | None = None,
                 token_file: str | None = None, lease: float = LEASE, max_message: int = MAX_MESSAGE,
                 rates: Rates = Rates()) -> None:
        check_robot(robot)
        self.skill_classes = _checked_skills(skills)
        self.facts = tuple(_fact(fact) for fact in facts)
        self.body = body
        self.world_name = world or robot
        self.seed = seed
        self.endpoints = host_endpoints(listen, connect, zenoh_config)
        self.exposure: str | None = exposure_warning(self.endpoints, zenoh_config)
        """Why listening where the host listens is unwise (beyond this machine without TLS), or None."""
        secret = host_secret(robot, token_file)
        self.token_source = secret.source
        """Where the secret a sequencer needs comes from: the token file's path, or ATLAS_BUS_TOKEN."""
        super().__init__(robot=robot, secret=secret, listen=self.endpoints, connect=connect,
                         zenoh_config=zenoh_config, lease=lease, max_message=max_message, rates=rates)

    def hosted(self, session: HostSession, clock: Clock) -> HostedRobot:
        """Fresh skills on the robot's body for a new session."""
        import numpy as np

        manager = SkillManager([skill() for skill in self.skill_classes], robot=self.body,
                               rng=np.random.default_rng(self.seed))
        session.manager = manager
        manager.connect(session)
        return HostedRobot(_Body(self.body, 1.0 / self.rates.physics), manager, None, self.world_name, self.facts)

    def __enter__(self) -> SkillHost:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _checked_skills(skills: Sequence[type[Skill]]) -> tuple[type[Skill], ...]:
    """The skill classes, each declared as a plugin's skill must be (:func:`~atlas_rap.skills.catalog.spec_of`:
    a :class:`Skill` subclass, its name a RAP symbol, typed parameters, a rate), no name twice."""
    taken: dict[str, SkillSpec] = {}
    for skill in skills:
        name = getattr(skill, "name", "") if isinstance(skill, type) else ""
        try:
            taken[name] = spec_of(Contribution("skills", name, skill, "this host", "SkillHost"), taken)
        except PluginError as exc:
            raise ValueError(str(exc)) from None
    if not taken:
        raise ValueError("a skill host needs at least one skill")
    return tuple(skills)


def _fact(fact: Compound | str) -> Compound:
    """A fact for the sequencer's memory: a term, or its text."""
    try:
        term = parse_term(fact, "<SkillHost facts>") if isinstance(fact, str) else fact
    except LanguageError as exc:
        raise ValueError(f"the fact {fact!r} does not read as a term:\n{exc}") from None
    if not isinstance(term, Compound):
        raise ValueError(f"{fact!r} is not a fact: write it as (predicate arg ...)")
    return term

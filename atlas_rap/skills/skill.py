"""The Skill: a reactive piece of the robot's control system, enabled and disabled by RAPs.

3T's skills (seed 003 §3.1) have declared inputs and outputs so that a skill
manager can wire them into networks: the outputs of one skill become the
inputs of others, by name. A skill is *enabled* with arguments by a RAP
primitive (or a skill-step), runs at its rate while enabled, and is
*disabled* when the RAP is done with it. Some skills are always on (the
sensors, the safety reflex, the event monitors).

Life of a skill, and what belongs in each hook (the py_trees ``Behaviour``
lifecycle, in 3T's words):

- :meth:`Skill.init` runs once, when the skill manager is built: keep the
  :class:`SkillContext` (the world's prior map, the robot, events), set up
  what does not depend on arguments.
- :meth:`Skill.enable` runs when a RAP enables the skill, with the
  arguments as written in the RAP (``(move-to 2.0 3.5)`` gives
  ``(2.0, 3.5)``): reset state, check the arguments. Enabling a running
  skill enables it again, with the new arguments.
- :meth:`Skill.transform` runs every period (``1 / rate`` seconds of
  simulated time) while enabled: read ``inputs`` (the latest value of each
  declared input), return a dict of outputs. Keep it short and never block.
  Report completion with ``self.context.finish(self, outcome, reason)`` and
  post facts with ``self.context.assert_fact`` / ``retract_fact``.
- :meth:`Skill.disable` runs when the RAP disables the skill (or its task
  ends), told why, as py_trees' ``terminate(new_status)`` is: the outcome it
  finished with (``":succeed"``, ``":fail"``, ...) when it had finished, or
  :data:`HALTED` when it was stopped while still running. Stop actuators,
  drop state. An override that takes no reason (``def disable(self)``)
  still works: the manager calls it without one.

A skill runs in a :class:`SkillContext`, given to :meth:`Skill.init` by the
skill manager that runs it; the context reaches the manager only through
the narrow :class:`SkillRunner`, so this module imports nothing of the manager.

A skill's ``name`` is how RAPs call it; ``params`` names its arguments and
their types (``"x: number"``; for messages, the arity check and ``atlas
skills list``); ``events`` lists the predicates it may assert, so ``atlas
check`` can tell a wait-for that nothing can produce; ``rate`` is how many
times a second it runs. A stock skill takes these from its entry in
:mod:`atlas_rap.skills.catalog`; a plugin's skill (:mod:`atlas_rap.plugins`)
writes them as class attributes, which the catalog reads and checks.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Mapping, Protocol

from atlas_rap.logic import Compound
from atlas_rap.skills.beliefs import Beliefs

if TYPE_CHECKING:
    import numpy as np

    from atlas_rap.sim.world import World
    from atlas_rap.skillbus.skill_link import SkillHost
    from atlas_rap.skills.robot import Robot

HALTED = ":halted"
"""The reason :meth:`Skill.disable` is given when the skill is stopped before it finished."""


class SkillRunner(Protocol):
    """What a :class:`SkillContext` needs of the skill manager that runs its skill
    (``manager.SkillManager``): the time, the sequencer it serves, and where events go."""

    now: float
    host: SkillHost | None

    def post(self, changes: list[tuple[str, Compound]]) -> None:
        """Send fact changes (events) to RAP memory."""
        ...

    def finish(self, skill: Skill, outcome: str, reason: str | None) -> None:
        """The skill is done with ``outcome`` (and says why): post its ``done`` fact; stop running it."""
        ...


@dataclass
class SkillContext:
    """What a skill may use: the world's prior map, the robot, shared beliefs and the event channel.

    ``world`` is what the robot believes of the world (a
    :class:`~atlas_rap.sim.world.World`), ``robot`` the body the skills sense and
    drive (:class:`~atlas_rap.skills.robot.Robot`: the simulation, or a real
    robot's driver with the same methods); ``beliefs`` is shared
    state that is not a data flow, under typed keys (:mod:`atlas_rap.skills.beliefs`:
    the doors observed closed, the grid, the route); ``rng`` the run's one random generator.
    """

    manager: SkillRunner
    world: World | None = None
    robot: Robot | None = None
    rng: np.random.Generator | None = None
    beliefs: Beliefs = field(default_factory=Beliefs)

    def now(self) -> float:
        return self.manager.now

    def assert_fact(self, fact: Compound) -> None:
        """Post a fact to RAP memory (an event)."""
        self.manager.post([("assert", fact)])

    def retract_fact(self, fact: Compound) -> None:
        self.manager.post([("retract", fact)])

    def retract_matching(self, pattern: Compound) -> None:
        """Retract every fact in memory that matches ``pattern``."""
        host = self.manager.host
        if host is not None:
            facts = list(host.memory.facts(pattern))
            if facts:
                self.manager.post([("retract", fact) for fact in facts])

    def finish(self, skill: Skill, outcome: str = ":succeed", reason: str | None = None) -> None:
        """The skill is done: post ``(done CALL OUTCOME)`` (and why); it stops being run."""
        self.manager.finish(skill, outcome, reason)


class Skill:
    """Base class of every skill; see the module docstring for the lifecycle."""

    name: ClassVar[str] = ""
    params: ClassVar[tuple[Any, ...]] = ()  # names ("x", "x: number"), or catalog.Param
    inputs: ClassVar[tuple[str, ...]] = ()
    outputs: ClassVar[tuple[str, ...]] = ()
    rate: ClassVar[float] = 20.0
    always_on: ClassVar[bool] = False
    events: ClassVar[tuple[str, ...]] = ()
    origin: ClassVar[str] = ""  # "stock", or the plugin that gave it (set by the catalog)

    def __init__(self) -> None:
        self.context: SkillContext | None = None
        self.args: tuple[Any, ...] = ()

    def init(self, context: SkillContext) -> None:
        """Once, when the skill manager is built."""
        self.context = context

    def enable(self, args: tuple[Any, ...]) -> None:
        """When a RAP enables the skill with ``args``."""
        self.args = args

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        """Every period while enabled: inputs in, outputs out."""
        return {}

    def disable(self, reason: str = HALTED) -> None:
        """When the skill is disabled: ``reason`` is the outcome it finished with, or
        :data:`HALTED` when it was stopped while still running."""

    def __repr__(self) -> str:
        return f"<Skill {self.name}>"

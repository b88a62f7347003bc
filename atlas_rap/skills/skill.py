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
  ends): stop actuators, drop state.

A skill's ``name`` is how RAPs call it; ``params`` names its arguments (for
messages and the arity check); ``events`` lists the predicates it may
assert, so ``atlas check`` can tell a wait-for that nothing can produce.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, Mapping

if TYPE_CHECKING:
    from atlas_rap.skills.manager import SkillContext


class Skill:
    """Base class of every skill; see the module docstring for the lifecycle."""

    name: ClassVar[str] = ""
    params: ClassVar[tuple[str, ...]] = ()
    inputs: ClassVar[tuple[str, ...]] = ()
    outputs: ClassVar[tuple[str, ...]] = ()
    rate: ClassVar[float] = 20.0
    always_on: ClassVar[bool] = False
    events: ClassVar[tuple[str, ...]] = ()

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

    def disable(self) -> None:
        """When the skill is disabled."""

    def __repr__(self) -> str:
        return f"<Skill {self.name}>"

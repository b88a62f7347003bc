"""The narrow link between the sequencer and the skills (3T's sequencer ↔ skill manager).

The sequencer needs only three things from whatever runs skills:

- :meth:`SkillLink.enable` a skill with arguments, e.g. ``(move-to 2.0 3.5)``;
- :meth:`SkillLink.disable` it again;
- facts coming back: the link asserts and retracts facts through the
  :class:`SkillHost` it is connected to (events such as ``(at robot office)``
  and a skill's completion ``(done (move-to 2.0 3.5) :succeed)``).

For load-time checks it also says which skills it knows (:meth:`skills`)
and which predicates its events may assert (:meth:`produces`). The virtual
skills of ``atlas_rap.skills.virtual`` implement it for runs without
physics; the skill manager of the simulator implements it with a world.
Keeping the link this small is what lets the skill manager run elsewhere
later (docs/explanation/architecture.md).

A skill *instance* is what runs as one and can serve one task at a time
(:meth:`SkillLink.instance`): for the stock skills of a world, one per skill
name (there is one robot base to drive, one ``navigate-to``); for virtual
skills, one per call (scripts share nothing). Enabling an instance that is
already enabled starts it again with the new arguments. The sequencer gives
instances owners: the task that enabled one holds it until its step ends,
and a second live task that enables it takes it or is refused by priority
(``Sequencer.enable_skill``). Always-on skills (the safety reflex, monitors,
the map builder) are not offered to tasks at all, so nobody owns them.
"""

from __future__ import annotations

from typing import Hashable, Iterable, Protocol

from atlas_rap.logic import Compound, Memory
from atlas_rap.skillbus.timers import Timers


class SkillHost(Protocol):
    """What a skill link may use of the sequencer: the clock, memory, and changing memory."""

    timers: Timers
    memory: Memory

    def change(self, changes: Iterable[tuple[str, Compound]], source: str, *,
               skill: Compound | None = None) -> None:
        """Assert or retract facts (``('assert', fact)``), running memory rules and waking waiters.

        ``skill`` is the skill call whose work these changes are (a finish, a
        script line), so a failure they cause is charged to the task that runs it.
        """


class SkillLink(Protocol):
    """Enables and disables skills for the sequencer; see the module docstring."""

    def connect(self, host: SkillHost) -> None:
        """Called once by the sequencer before anything runs."""

    def skills(self) -> dict[str, set[int]]:
        """The skills this link can enable: name → the arities it accepts."""

    def produces(self) -> set[str]:
        """Predicates the skills' events may assert (``done`` is always among them)."""

    def instance(self, call: Compound) -> Hashable:
        """The instance ``call`` runs on: two calls with the same instance cannot run for two tasks at once."""

    def enable(self, call: Compound) -> None:
        """Turn the skill ``call`` (name and ground arguments) on."""

    def disable(self, call: Compound) -> None:
        """Turn the skill ``call`` off; what it has not done yet is cancelled."""


class CombinedSkills:
    """Several links as one: each skill is served by the first link that knows it.

    A mission in a world uses the simulator's skill manager and, beside
    it, the virtual skills the mission file defines (for what the
    simulation does not model, such as handing over the mail).
    """

    def __init__(self, *links: SkillLink) -> None:
        self.links = links

    def connect(self, host: SkillHost) -> None:
        for link in self.links:
            link.connect(host)

    def skills(self) -> dict[str, set[int]]:
        names: dict[str, set[int]] = {}
        for link in reversed(self.links):
            names.update(link.skills())
        return names

    def produces(self) -> set[str]:
        return set().union(*(link.produces() for link in self.links))

    def _link(self, call: Compound) -> SkillLink:
        for link in self.links:
            if len(call.args) in link.skills().get(call.functor, ()):
                return link
        raise KeyError(call.functor)

    def instance(self, call: Compound) -> Hashable:
        return self._link(call).instance(call)

    def enable(self, call: Compound) -> None:
        self._link(call).enable(call)

    def disable(self, call: Compound) -> None:
        self._link(call).disable(call)


class NoSkills:
    """A link with no skills at all: for programs whose RAPs only use memory."""

    def connect(self, host: SkillHost) -> None:
        pass

    def skills(self) -> dict[str, set[int]]:
        return {}

    def produces(self) -> set[str]:
        return {"done"}

    def instance(self, call: Compound) -> Hashable:
        return call

    def enable(self, call: Compound) -> None:
        raise KeyError(call.functor)

    def disable(self, call: Compound) -> None:
        pass

"""The skill manager: wires skills output→input by name and runs them at their rates.

3T's skill manager (seed 003 §3.1) connects skills into networks: a
skill's outputs go to every skill that declares an input of the same name
(here through a blackboard, ``SkillManager.data``), and skills run in
dependency order, producers before consumers, each at its own rate.
Towards the sequencer it is a :class:`~atlas_rap.skillbus.skill_link.SkillLink`:
RAPs enable and disable skills by name with arguments, and skills' events
come back as facts in RAP memory:

- ``(done (SKILL ARG ...) OUTCOME)`` when a skill finishes, preceded by
  ``(why (SKILL ARG ...) "reason")`` when it says why (the sequencer puts
  the reason in the failure chain);
- whatever facts event skills assert (``(at robot office)``,
  ``(door-closed office-door)``, ``(bumped robot)``, ``(blocked robot X)``).

When a skill is disabled or finishes, its outputs are cleared, so a
stopped motion skill leaves no stale velocity command behind. A plugin's
skill that raises in one of its hooks stops the run with a
:class:`~atlas_rap.errors.RunError` naming the skill, its plugin, the
exception and the line of the plugin it came from (:func:`plugin_fault`);
a stock skill's exception is a bug in atlas-rap and is raised as it is. When two
enabled skills write the same output, the one later in dependency order
(then the later enabled) wins.
"""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable

from atlas_rap.errors import AtlasError, RunError
from atlas_rap.plugins import failure
from atlas_rap.logic import Compound, String
from atlas_rap.skillbus.skill_link import SkillHost
from atlas_rap.skills.skill import HALTED, Skill, SkillContext

if TYPE_CHECKING:  # downward only
    import numpy as np

    from atlas_rap.sim.world import World
    from atlas_rap.skills.robot import Robot

__all__ = ["SkillContext", "SkillManager", "dependency_order"]  # SkillContext lives in skills.skill now


class SkillManager:
    """Runs skills for the sequencer: enable/disable by name, routing, rates, events.

    Build it with skill instances, then let the sequencer ``connect`` to it
    (which calls each skill's ``init`` and turns on the always-on skills);
    the executive calls :meth:`tick` at the skills' base rate.
    """

    def __init__(self, skills: Iterable[Skill], *, world: World | None = None, robot: Robot | None = None,
                 rng: np.random.Generator | None = None) -> None:
        self.catalog: dict[str, Skill] = {}
        for skill in skills:
            if not skill.name:
                raise AtlasError(f"{type(skill).__name__} has no name")
            if skill.name in self.catalog:
                raise AtlasError(f"two skills are named {skill.name}")
            self.catalog[skill.name] = skill
        self.order = dependency_order(list(self.catalog.values()))
        self.context = SkillContext(self, world, robot, rng)
        self.data: dict[str, Any] = {}
        self.enabled: dict[str, Compound | None] = {}  # name -> call (None for always-on skills)
        self.finished: dict[str, str] = {}  # name -> the outcome it finished with, until disabled or enabled again
        self.due: dict[str, float] = {}
        self.host: SkillHost | None = None
        self.now = 0.0

    # -- the SkillLink side ------------------------------------------------------

    def connect(self, host: SkillHost) -> None:
        self.host = host
        for skill in self.order:
            try:
                skill.init(self.context)
            except Exception as exc:
                raise plugin_fault(skill, "init", exc)
        for skill in self.order:
            if skill.always_on:
                try:
                    skill.enable(())
                except Exception as exc:
                    raise plugin_fault(skill, "enable", exc)
                self.enabled[skill.name] = None
                self.due[skill.name] = self.now

    def skills(self) -> dict[str, set[int]]:
        return {name: {len(skill.params)} for name, skill in self.catalog.items() if not skill.always_on}

    def produces(self) -> set[str]:
        found = {"done", "why"}
        for skill in self.catalog.values():
            found.update(skill.events)
        return found

    def instance(self, call: Compound) -> str:
        """A skill is one instance whatever its arguments: there is one robot to drive."""
        return call.functor

    def enable(self, call: Compound) -> None:
        skill = self.catalog[call.functor]
        if skill.always_on:
            raise KeyError(f"{call.functor} is always on")
        self._clear_outputs(skill)
        self.finished.pop(skill.name, None)
        try:
            skill.enable(tuple(_value(arg) for arg in call.args))
        except Exception as exc:
            raise plugin_fault(skill, "enable", exc)
        self.enabled.pop(skill.name, None)
        self.enabled[skill.name] = call
        self.due[skill.name] = self.now

    def disable(self, call: Compound) -> None:
        """Stop the skill ``call``, telling it why: the outcome it finished with, or
        :data:`~atlas_rap.skills.skill.HALTED` when it still ran."""
        skill = self.catalog.get(call.functor)
        if skill is None or self.enabled.get(skill.name) != call:
            return  # enabled again since, with other arguments: that one stays
        del self.enabled[skill.name]
        reason = self.finished.pop(skill.name, HALTED)
        try:
            if _takes_reason(skill):
                skill.disable(reason)
            else:
                skill.disable()  # type: ignore[call-arg]  # an override written before disable had a reason
        except Exception as exc:
            raise plugin_fault(skill, "disable", exc)
        self._clear_outputs(skill)

    def running(self) -> list[Compound]:
        """The skill calls enabled by RAPs now (always-on skills not included)."""
        return [call for call in self.enabled.values() if call is not None]

    # -- running -------------------------------------------------------------------

    def tick(self, now: float) -> None:
        """Run every enabled skill that is due at ``now``, producers before consumers."""
        self.now = now
        data = self.data
        for skill in self.order:
            name = skill.name
            if name not in self.enabled or name in self.finished:
                continue
            due = self.due[name]
            if now + 1e-9 < due:
                continue
            self.due[name] = max(due + 1.0 / skill.rate, now)
            try:
                outputs = skill.transform({key: data.get(key) for key in skill.inputs})
            except Exception as exc:
                raise plugin_fault(skill, "transform", exc)
            if outputs and name not in self.finished:
                data.update(outputs)

    def post(self, changes: list[tuple[str, Compound]]) -> None:
        if self.host is not None:
            self.host.change(changes, "skills")

    def finish(self, skill: Skill, outcome: str, reason: str | None) -> None:
        call = self.enabled.get(skill.name)
        if call is None or skill.name in self.finished:
            return
        self.finished[skill.name] = outcome
        self._clear_outputs(skill)
        changes: list[tuple[str, Compound]] = []
        if reason:
            changes.append(("assert", Compound("why", (call, String(reason)))))
        changes.append(("assert", Compound("done", (call, outcome))))
        if self.host is not None:
            self.host.change(changes, f"skill {_text(call)}", skill=call)

    def _clear_outputs(self, skill: Skill) -> None:
        for key in skill.outputs:
            self.data.pop(key, None)


def dependency_order(skills: list[Skill]) -> list[Skill]:
    """Skills sorted so that each comes after the skills whose outputs it reads (stable).

    Raises :class:`AtlasError` naming the skills of a cycle.
    """
    producers: dict[str, list[Skill]] = {}
    for skill in skills:
        for key in skill.outputs:
            producers.setdefault(key, []).append(skill)
    order: list[Skill] = []
    state: dict[str, int] = {}

    def visit(skill: Skill, chain: list[str]) -> None:
        if state.get(skill.name) == 2:
            return
        if state.get(skill.name) == 1:
            cycle = chain[chain.index(skill.name):] + [skill.name]
            raise AtlasError("skills feed each other in a circle: " + " -> ".join(cycle))
        state[skill.name] = 1
        for key in skill.inputs:
            for producer in producers.get(key, ()):
                if producer is not skill:
                    visit(producer, chain + [skill.name])
        state[skill.name] = 2
        order.append(skill)

    for skill in skills:
        visit(skill, [])
    return order


def plugin_fault(skill: Skill, hook: str, exc: Exception) -> Exception:
    """What to raise for ``exc``, raised by ``skill``'s ``hook``: for a plugin's skill, a RunError naming the
    skill, its plugin, the exception and where in the plugin's files; else ``exc`` itself (a bug of ours)."""
    if skill.origin in ("", "stock"):
        return exc
    folder = Path(inspect.getfile(type(skill))).parent
    return RunError(failure(f"skill {skill.name} (plugin {skill.origin}) failed in {hook}", exc, folder))


def _takes_reason(skill: Skill) -> bool:
    """Whether the skill's ``disable`` takes the reason it is stopped (overrides written before it did not)."""
    method = type(skill).disable
    takes = _TAKES_REASON.get(method)
    if takes is None:
        takes = _TAKES_REASON[method] = len(inspect.signature(method).parameters) > 1  # more than self
    return takes


_TAKES_REASON: dict[Any, bool] = {}  # each disable method seen, and whether it takes a reason


def _value(term: Any) -> Any:
    """A term as a skill argument: numbers and symbols as they are, strings as str, lists as tuples."""
    if isinstance(term, String):
        return term.value
    if isinstance(term, Compound) and term.functor == "":
        return tuple(_value(arg) for arg in term.args)
    return term


def _text(call: Compound) -> str:
    from atlas_rap.logic import term_to_str

    return term_to_str(call)

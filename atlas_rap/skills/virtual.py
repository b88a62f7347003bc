"""Virtual skills: skills whose behaviour is a script (the language reference, docs/language/rap.md, define-virtual-skill).

The 3T team tested RAPs against "virtual skills" before the robot was
ready; so do we. ::

    (define-virtual-skill (grip-attach ?site)
      (when (not (gripper-ok)) (after 0.5 (finish :fail)))
      (after 1.0 (assert (docked ?site)) (finish :succeed)))

Enabling ``(grip-attach hull-7)`` binds ``?site`` to ``hull-7``, evaluates
each ``when`` guard against memory once, and schedules every script line
on the simulated clock, that many seconds after the enable.
``(finish OUTCOME)`` asserts ``(done (grip-attach hull-7) OUTCOME)``.
Disabling the skill cancels what it has not done yet; enabling it again
starts the script over.
"""

from __future__ import annotations

from typing import Iterable

from atlas_rap.lang import ast
from atlas_rap.logic import Compound, Subst, substitute, term_to_str, unify
from atlas_rap.skillbus.skill_link import SkillHost
from atlas_rap.skillbus.timers import Timer


class VirtualSkills:
    """A :class:`~atlas_rap.skillbus.skill_link.SkillLink` of scripted skills."""

    def __init__(self, definitions: Iterable[ast.VirtualSkillDef] = ()) -> None:
        self.definitions: dict[tuple[str, int], ast.VirtualSkillDef] = {}
        self._host: SkillHost | None = None
        self._running: dict[Compound, list[Timer]] = {}
        self.define(definitions)

    def define(self, definitions: Iterable[ast.VirtualSkillDef]) -> None:
        """Add or replace scripts (by name and arity); a running skill keeps its old script."""
        for definition in definitions:
            self.definitions[(definition.name, len(definition.head.args))] = definition

    @classmethod
    def from_program(cls, program) -> VirtualSkills:
        """The virtual skills a loaded program defines."""
        return cls(program.of_type(ast.VirtualSkillDef))

    def connect(self, host: SkillHost) -> None:
        self._host = host

    def skills(self) -> dict[str, set[int]]:
        return skill_names(self.definitions.values())

    def produces(self) -> set[str]:
        found = {"done"}
        for definition in self.definitions.values():
            for line in _lines(definition.lines):
                found.update(a.fact.functor for a in line.actions
                             if isinstance(a, ast.MemoryOp) and a.kind == "assert")
        return found

    def running(self) -> list[Compound]:
        """The skill calls enabled now, in the order they were enabled."""
        return list(self._running)

    def instance(self, call: Compound) -> Compound:
        """Each call is an instance of its own: scripts share no state."""
        return call

    def enable(self, call: Compound) -> None:
        host = self._host
        assert host is not None, "connect() the skills to a sequencer first"
        definition = self.definitions[(call.functor, len(call.args))]
        bindings = unify(definition.head, call)
        if bindings is None:
            raise ValueError(f"{term_to_str(call)} does not match {term_to_str(definition.head)}")
        self.disable(call)
        timers: list[Timer] = []
        for line in definition.lines:
            if isinstance(line, ast.When):
                if host.memory.holds(line.condition, bindings):
                    timers.extend(self._schedule(call, after, bindings) for after in line.lines)
            else:
                timers.append(self._schedule(call, line, bindings))
        self._running[call] = timers

    def disable(self, call: Compound) -> None:
        for timer in self._running.pop(call, ()):
            timer.cancel()

    def _schedule(self, call: Compound, line: ast.After, bindings: Subst) -> Timer:
        host = self._host
        assert host is not None
        changes = []
        for action in line.actions:
            if isinstance(action, ast.Finish):
                changes.append(("assert", Compound("done", (call, action.outcome))))
            else:
                changes.append((action.kind, substitute(action.fact, bindings)))
        source = f"skill {term_to_str(call)}"
        return host.timers.after(line.delay, lambda: host.change(changes, source, skill=call))


def skill_names(definitions: Iterable[ast.VirtualSkillDef]) -> dict[str, set[int]]:
    """Skill name → the arities defined, the shape a skill link reports its skills in."""
    names: dict[str, set[int]] = {}
    for definition in definitions:
        names.setdefault(definition.name, set()).add(len(definition.head.args))
    return names


def _lines(lines: Iterable[ast.ScriptLine]) -> Iterable[ast.After]:
    for line in lines:
        if isinstance(line, ast.When):
            yield from line.lines
        else:
            yield line

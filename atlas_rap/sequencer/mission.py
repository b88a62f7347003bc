"""Missions: a loaded RAP program with its posts, initial memory and scripted events, run.

A mission file (LANGUAGE.md §2.7) is RAP definitions plus ``initial-memory``,
``post``, ``at-time`` and ``world`` forms. :func:`load_mission` loads and
checks one; :meth:`Mission.run` runs it on the simulated clock until every
posted task has ended, nothing more can happen, or a time limit passes.

With ``(world none)`` the skills are the program's virtual skills and time
jumps from one due timer to the next, so a ten-minute mission takes
milliseconds; ``pace`` slows it to the wall clock (``--realtime``).
"""

from __future__ import annotations

import time as wall
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Protocol

from atlas_rap.errors import Problem, SourceError
from atlas_rap.lang import ast, load
from atlas_rap.sequencer.checks import check_program
from atlas_rap.sequencer.interpreter import Sequencer
from atlas_rap.sequencer.introspect import waiting_for
from atlas_rap.sequencer.skill_link import SkillLink
from atlas_rap.sequencer.task import SUCCEEDED, Task
from atlas_rap.sequencer.trace import Trace
from atlas_rap.skills.virtual import VirtualSkills, skill_names

DEFAULT_TIME_LIMIT = 3600.0
"""Simulated seconds a mission may run before its remaining tasks fail (``--until``)."""


@dataclass
class RunResult:
    """How a run ended: the posted tasks (with their outcomes) and the time."""

    tasks: list[Task]
    time: float
    ended_by: str = "done"  # done | stalled | time-limit | interrupted
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when every posted task succeeded."""
        return bool(self.tasks) and all(task.status == SUCCEEDED for task in self.tasks)


class Mission:
    """A checked program ready to run: its sequencer, skills and top-level forms."""

    def __init__(self, program, skills: SkillLink | None = None, *, trace: Trace | None = None,
                 warnings: list[Problem] | None = None) -> None:
        self.program = program
        self.skills = skills if skills is not None else VirtualSkills.from_program(program)
        self.sequencer = Sequencer.from_program(program, self.skills, trace=trace)
        self.warnings = warnings or []
        worlds = program.of_type(ast.WorldDecl)
        self.world: str | None = worlds[-1].world if worlds else None
        self.started = False

    @property
    def trace(self) -> Trace:
        return self.sequencer.trace

    def start(self) -> None:
        """Put initial memory in place, schedule ``at-time`` events and post the tasks."""
        if self.started:
            return
        self.started = True
        seq = self.sequencer
        for form in self.program.of_type(ast.InitialMemory):
            seq.change([("assert", fact) for fact in form.facts], "initial-memory")
        for event in self.program.of_type(ast.AtTime):
            changes = [(op.kind, op.fact) for op in event.actions]
            seq.timers.at(event.time, lambda changes=changes, t=event.time: seq.change(changes, f"at-time {t:g}"))
        for post in self.program.of_type(ast.Post):
            seq.post(post.task, post.priority, post.deadline)

    def reload(self, path: str | Path) -> list[str]:
        """Load a RAP file again (and what it includes) and replace definitions; the names replaced or added.

        RAPs, memory rules and virtual skills are replaced by name; a running
        task keeps its current method and uses the new RAP at its next
        method choice. Posts, initial memory and ``at-time`` forms in the
        file are ignored: reloading changes what the robot knows how to
        do, not what it is doing. The file is checked first; on an error
        nothing changes.
        """
        program = load(path)
        new_skills = program.of_type(ast.VirtualSkillDef) if isinstance(self.skills, VirtualSkills) else []
        known = self.skills.skills()
        for name, arities in skill_names(new_skills).items():
            known[name] = known.get(name, set()) | arities
        problems = check_program(program, known, self.skills.produces())
        if any(problem.severity == "error" for problem in problems):
            raise SourceError(problems)
        if new_skills:
            self.skills.define(new_skills)  # type: ignore[attr-defined]
        seq = self.sequencer
        seq.refresh_skills()
        raps = program.of_type(ast.RapDef)
        seq.define(raps)
        rules = [form.rule for form in program.of_type(ast.MemoryRuleDef)]
        seq.define_rules(rules)
        return [rap.name for rap in raps] + [rule.name for rule in rules] + [skill.name for skill in new_skills]

    def run(self, until: float = DEFAULT_TIME_LIMIT, pace: Callable[[float], None] | None = None,
            driver: Driver | None = None) -> RunResult:
        """Run until every posted task has ended (or nothing more can happen, or ``until``).

        Without a ``driver`` time jumps from one due timer to the next (the
        virtual world); with one (the multirate executive of a simulated
        world) the driver moves time. Tasks still running at the end fail,
        saying what they were waiting for. ``pace(t)`` is called before the
        clock moves to ``t``.
        """
        self.start()
        seq = self.sequencer
        if driver is not None:
            ended_by = driver.run(seq, until, pace)
        else:
            ended_by = self._run_timers(until, pace)
        result = RunResult(list(seq.roots), seq.timers.now, ended_by)
        for task in seq.live_roots():
            waits = waiting_for(task)
            waiting = f"; it was waiting for {', '.join(waits)}" if waits else ""
            if ended_by == "stalled":
                why = f"nothing more can happen (no timer is due and no event can arrive){waiting}"
            else:
                why = f"still running at the time limit of {until:g} s{waiting}"
            seq.cancel(task, why)
        return result


    def _run_timers(self, until: float, pace: Callable[[float], None] | None) -> str:
        seq = self.sequencer
        timers = seq.timers
        seq.settle()
        while seq.live_roots():
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


class Driver(Protocol):
    """Whatever moves time for a mission in a world (the multirate executive)."""

    def run(self, sequencer: Sequencer, until: float, pace: Callable[[float], None] | None) -> str:
        """Run until the posted tasks have ended ("done") or ``until`` ("time-limit")."""


def load_mission(path: str | Path, skills: SkillLink | Callable[[Any], SkillLink] | None = None, *,
                 trace: Trace | None = None, require_post: bool = True,
                 planner: Callable[[Any], Any] | None = None) -> Mission:
    """Load and check a mission; raises :class:`SourceError` listing every error.

    ``skills`` is the skill link, or a function that makes one from the
    loaded program (to combine a world's skills with the file's virtual
    ones); by default the program's virtual skills. Warnings (a wait-for
    nothing can wake) are kept on ``mission.warnings``. ``planner`` turns
    each ``(plan GOAL ...)`` of the program into RAPs and posts
    (``atlas_rap.planner.execute.expand_plan_requests``; the sequencer does
    not import the planner); without it, a ``(plan ...)`` is an error.
    """
    program = load(path)
    requests = program.of_type(ast.PlanRequest)
    if requests and planner is None:
        raise SourceError([Problem("(plan ...) needs the planner, and none was given to this mission loader",
                                   r.loc, program.source_line(r.loc), "run the mission with `atlas run`")
                           for r in requests])
    if requests:
        program = planner(program)
    if skills is None:
        link: SkillLink = VirtualSkills.from_program(program)
    elif callable(skills) and not hasattr(skills, "enable"):
        link = skills(program)
    else:
        link = skills  # type: ignore[assignment]
    problems = check_program(program, link.skills(), link.produces(), require_post=require_post)
    errors = [p for p in problems if p.severity == "error"]
    if errors:
        raise SourceError(problems)
    return Mission(program, link, trace=trace, warnings=problems)


def wall_clock_pacer(speed: float = 1.0) -> Callable[[float], None]:
    """A ``pace`` function that sleeps so simulated time runs ``speed`` times the wall clock."""
    start = wall.monotonic()

    def pace(sim_time: float) -> None:
        delay = start + sim_time / speed - wall.monotonic()
        if delay > 0:
            wall.sleep(delay)

    return pace

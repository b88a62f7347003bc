"""Loading programs into a running System: what they define (:class:`Library`) and the steps that load them.

A mission file, a file given to the REPL and a submission typed at its
prompt are all *programs*; the mission engine loads each in one pass
(:meth:`atlas_rap.layers.engine.MissionEngine.load`, whose module docstring
lists the steps). The steps are functions over the running
:class:`~atlas_rap.layers.system.System` and the :class:`Library` of what the
programs loaded so far define, so each can be called, and tested, alone:

- :func:`carry_out_plans`: each ``(plan GOAL ...)`` is checked and becomes a
  RAP that makes the plan and carries it out when it runs;
- :func:`check`: the sequencer's load-time checks, beside what is defined;
- :func:`define`: the definitions take effect (replacing earlier ones by name);
- :func:`act`: initial memory, ``at-time`` events and posts;
- :func:`planning_problem`: the planning problem of a plan step, from memory now.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from atlas_rap.errors import LanguageError, PlanFileError, Problem, RunError, SourceError, SourceLocation
from atlas_rap.lang import ast
from atlas_rap.lang.loader import Program
from atlas_rap.layers.running import take_fault
from atlas_rap.layers.system import System
from atlas_rap.logic import Compound, Relation, Term
from atlas_rap.model import World
from atlas_rap.sequencer import Task
from atlas_rap.sequencer.checks import check_program
from atlas_rap.sequencer.place_checks import place_problems
from atlas_rap.skills.catalog import param_types
from atlas_rap.skills.virtual import VirtualSkills, skill_names

if TYPE_CHECKING:  # downward only: the planner is imported when a plan is asked for
    from atlas_rap.planner.problem import PlanningProblem

__all__ = ["Library", "PLAN_TASK", "act", "carry_out_plans", "check", "define", "planning_problem"]

PLAN_TASK = "carry-out-plan-{n}"
"""The RAP that a top-level ``(plan GOAL ...)`` of a mission becomes: one plan step."""

_PLANNING_FORMS = (ast.Operator, ast.Agents, ast.RelationDef, ast.Initial, ast.Goals, ast.Deadline)


@dataclass
class Library:
    """What the programs loaded into a run define so far, and what was read to load them.

    ``definitions``: the RAPs, virtual skills, memory rules and relation
    clauses, keyed by what a new definition replaces; ``planning``: the
    planner's forms (operators, agents, relations, initial facts, goals,
    deadlines); ``lines``: every source file's lines (for located errors);
    ``files``: the files read; ``plans_made``: how many ``(plan ...)``
    requests became RAPs; ``warnings``: every warning of the programs loaded.
    """

    definitions: dict[tuple[str, str, int], ast.TopLevel] = field(default_factory=dict)
    planning: list[ast.TopLevel] = field(default_factory=list)
    lines: dict[str, list[str]] = field(default_factory=dict)
    files: set[str] = field(default_factory=set)
    plans_made: int = 0
    warnings: list[Problem] = field(default_factory=list)


def check(system: System, library: Library, program: Program, require_post: bool) -> list[Problem]:
    """Step 3: the sequencer's load-time checks of ``program`` beside what ``library`` defines; the warnings.
    Raises :class:`SourceError` with every problem when one is an error."""
    seq = system.sequencer
    new_skills = program.of_type(ast.VirtualSkillDef)
    skills = {name: set(arities) for name, arities in system.skills.skills().items()}
    for name, arities in skill_names(new_skills).items():
        skills[name] = skills.get(name, set()) | arities
    produces = system.skills.produces() | VirtualSkills(new_skills).produces()
    produces |= {fact.functor for fact in seq.memory}
    redefined = {_definition_key(form) for form in program.forms}
    earlier = tuple(form for key, form in library.definitions.items() if key not in redefined)
    combined = dataclasses.replace(program, forms=earlier + program.forms, lines={**library.lines, **program.lines})
    mine = {source.path for source in program.files} | {program.root}
    types = {}
    if system.manager is not None:  # the skills here, as declared (not those a virtual skill's name hides)
        hidden = set(system.virtual.skills()) | set(skill_names(new_skills))
        types = {name: typed for name, typed in param_types(system.manager.catalog.values()).items()
                 if name not in hidden}
    problems = check_program(combined, skills, produces, require_post=require_post, param_types=types)
    if types and isinstance(system.world, World):  # the places named, against the world's
        problems += place_problems(combined, system.world.name, set(system.world.places), types)
    problems = [p for p in problems if p.location.file in mine or p.location.file not in library.files]
    for event in program.of_type(ast.AtTime):
        if event.time < seq.now():
            problems.append(Problem(f"at-time {event.time:g} is in the past (the time is {seq.now():g} s)",
                                    event.loc, program.source_line(event.loc),
                                    "at-time takes an absolute simulated time; give a later one"))
    if any(problem.severity == "error" for problem in problems):
        raise LanguageError(sorted(problems, key=lambda p: p.severity != "error"))
    return problems



def define(system: System, library: Library, program: Program) -> list[str]:
    """Step 4: the program's definitions take effect in the sequencer and join ``library``; the names defined."""
    seq = system.sequencer
    library.lines.update(program.lines)
    library.files |= {source.path for source in program.files} | {program.root}
    new_skills = program.of_type(ast.VirtualSkillDef)
    if new_skills:
        system.virtual.define(new_skills)
        seq.refresh_skills()
    raps = program.of_type(ast.RapDef)
    seq.define(raps)
    rules = program.of_type(ast.MemoryRuleDef)
    seq.define_rules([form.rule for form in rules])
    relations: dict[str, list[Relation]] = {}
    for form in program.of_type(ast.RelationDef):
        relations.setdefault(form.name, []).append(Relation(form.head, form.body))
    seq.define_relations(relations)
    for name in relations:  # a program's clauses of a relation replace the earlier ones
        library.definitions = {key: form for key, form in library.definitions.items()
                            if key[:2] != ("RelationDef", name)}
    for form in program.forms:
        key = _definition_key(form)
        if key is not None:
            library.definitions.pop(key, None)
            library.definitions[key] = form
    library.planning = [form for form in library.planning if not _replaced(form, program)]
    library.planning += [form for form in program.forms if isinstance(form, _PLANNING_FORMS)]
    return [rap.name for rap in raps] + [form.name for form in rules] + [skill.name for skill in new_skills]



def act(system: System, program: Program) -> list[Task]:
    """Step 6: initial memory, at-time events and posts, in that order; the tasks posted.
    The planner's ``(initial ...)`` facts are what the robot believes too: they go into
    memory with the program's ``initial-memory``, each once."""
    seq = system.sequencer
    believed = tuple(f for f in dict.fromkeys(f for form in program.of_type(ast.Initial) for f in form.facts)
                     if f not in seq.memory)
    batches = [("initial", believed)] + [("initial-memory", form.facts)
                                         for form in program.of_type(ast.InitialMemory)]
    for source, facts in batches:
        if facts:
            seq.change([("assert", fact) for fact in facts], source)
        fault = take_fault(system)
        if fault is not None:
            raise RunError(f"{program.root}: the {source} facts broke a memory rule: {fault}")
    for event in program.of_type(ast.AtTime):
        changes = [(op.kind, op.fact) for op in event.actions]
        seq.timers.at(event.time, lambda changes=changes, t=event.time: seq.change(changes, f"at-time {t:g}"))
    return [seq.post(post.task, post.priority, post.deadline) for post in program.of_type(ast.Post)]



def planning_problem(system: System, library: Library, goals: tuple[Term, ...], lost: frozenset[str] = frozenset(),
                     loc: SourceLocation | None = None, program: Program | None = None,
                     facts: tuple[Compound, ...] = ()) -> PlanningProblem:
    """The planning problem for ``goals`` from memory now and ``facts``, with the operators,
    agents and relations loaded so far (and those of ``program``, being loaded), without
    the ``lost`` agents. One memory: the ``initial`` facts of the programs loaded are in
    it (:func:`act`), beside the prior map and what skills and RAPs asserted since, and
    the planner starts from memory alone."""
    from atlas_rap.planner.problem import problem_from_program

    forms = [form for form in library.planning if program is None or not _replaced(form, program)]
    if program is not None:
        forms += [form for form in program.forms if isinstance(form, _PLANNING_FORMS)]
    lines = {**library.lines, **(program.lines if program is not None else {})}
    problem_program = Program(root=program.root if program is not None else "<plan>", files=(),
                              forms=tuple(forms), lines=lines)
    base = problem_from_program(problem_program, name=problem_program.root)
    if lost:
        base = dataclasses.replace(base, controlled=tuple(a for a in base.controlled if a not in lost))
    return base.asked(goals, tuple(system.sequencer.memory) + facts, loc)  # initial facts are in memory (act)



def carry_out_plans(system: System, library: Library, program: Program) -> Program:
    """Step 2: each ``(plan GOAL ...)`` of ``program`` is checked (every goal achievable by
    some operator, the operators' constraints sound) and replaced by a RAP
    ``(carry-out-plan-N)`` whose task net is that plan step, and a post of it. The plan
    itself is made when the task runs, from memory as it is then (``layers.deliberation``)."""
    from atlas_rap.planner.checks import raise_problems

    facts = tuple(f for form in program.of_type(ast.InitialMemory) + program.of_type(ast.Initial)
                  for f in form.facts)
    replaced: dict[int, list] = {}
    problems = []
    for request in program.of_type(ast.PlanRequest):
        try:
            raise_problems(planning_problem(system, library, request.goals, frozenset(), request.loc, program, facts))
        except SourceError as exc:
            problems += exc.problems
            continue
        library.plans_made += 1
        name = PLAN_TASK.format(n=library.plans_made)
        rap = ast.RapDef(head=Compound(name, ()), loc=request.loc, retries=1,  # the plan step repairs itself
                         methods=(ast.Method(body=ast.TaskNet(nets=(request,), loc=request.loc),
                                             loc=request.loc),))
        replaced[id(request)] = [rap, ast.Post(task=Compound(name, ()), loc=request.loc)]
    if problems:
        raise PlanFileError(problems)
    forms = tuple(new for form in program.forms for new in replaced.get(id(form), [form]))
    return dataclasses.replace(program, forms=forms)



def _definition_key(form: ast.TopLevel) -> tuple[str, str, int] | None:
    """What a definition replaces: RAPs and virtual skills by name and arity, rules by name."""
    if isinstance(form, (ast.RapDef, ast.VirtualSkillDef)):
        return (type(form).__name__, form.name, len(form.head.args))
    if isinstance(form, ast.MemoryRuleDef):
        return ("MemoryRuleDef", form.name, 0)
    if isinstance(form, ast.RelationDef):  # each clause its own entry; define drops a redefined relation's
        return ("RelationDef", form.name, id(form))
    return None


def _replaced(form: ast.TopLevel, program: Program) -> bool:
    """An earlier planning form that ``program`` replaces: an operator, or a relation's
    clauses, of the same name."""
    kind = type(form)
    return kind in (ast.Operator, ast.RelationDef) and any(
        type(new) is kind and new.name == form.name for new in program.forms)

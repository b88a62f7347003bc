"""The mission engine: one running system that programs are loaded into, for `atlas run` and `atlas repl` alike.

A :class:`MissionEngine` is a sequencer with its skills, in a simulated world
or in none, on one clock. A mission file (``atlas run``), a file given to the
REPL, and a submission typed at the REPL's prompt are all *programs*, and
:meth:`MissionEngine.load` loads each the same way, in one pass, so a RAP
may use a virtual skill or RAP defined further down:

1. its ``(world ...)`` form chooses the world, if none runs yet (a path is
   relative to the file); ``--world`` overrides every such form, and a
   program naming another world than the one running is a located error;
2. its ``(plan GOAL ...)`` requests are checked against the operators loaded
   so far and replaced by RAPs ``(carry-out-plan-N)`` whose one step is that
   plan request: the plan is made when the task runs, from memory as it is
   then, and carried out, watched and repaired beside the running robot
   (``layers.deliberation``, ``sequencer.deliberation``);
3. it is checked whole, against the skills and the RAPs, rules and virtual
   skills defined before it; any error and nothing of it takes effect;
4. its definitions take effect: virtual skills, RAPs, memory rules,
   relations, planning operators; each replaces an earlier definition of the
   same name (a running task uses a new RAP at its next method choice);
5. the world starts, once: its prior map (places, doors) goes into memory;
6. its ``initial`` (the planner's) and ``initial-memory`` facts, ``at-time``
   events (absolute simulated times, refused when past) and ``post``\\ s take
   effect, in that order.

Time then moves with :meth:`run` (until the posted tasks end), :meth:`advance`
(a while, tasks or not) or :meth:`run_mission` (``atlas run``: run, then fail
what is still running at the end; Ctrl-C halts the live tasks). The world's
skills and the program's virtual skills serve the sequencer side by side.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

from atlas_rap.errors import AtlasError, Problem, SourceError, SourceLocation
from atlas_rap.lang import ast, load
from atlas_rap.lang.loader import Program
from atlas_rap.layers.builders import build_system
from atlas_rap.layers.deliberation import Deliberation
from atlas_rap.layers.executive import Pace, Stop
from atlas_rap.layers.layer import LayerStack
from atlas_rap.layers.system import DEFAULT_WORLD, NamedWorld, RunOptions, System, WorldChoice, choose_world
from atlas_rap.logic import Compound, Relation, Term
from atlas_rap.sequencer import Sequencer, Task, Trace
from atlas_rap.sequencer.checks import check_program
from atlas_rap.sequencer.introspect import waiting_for
from atlas_rap.sequencer.task import SUCCEEDED
from atlas_rap.skillbus.skill_link import CombinedSkills
from atlas_rap.skills.manager import SkillManager
from atlas_rap.skills.virtual import VirtualSkills, skill_names

if TYPE_CHECKING:  # downward only
    from atlas_rap.maps.grid import OccupancyGrid
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.sim.world import World
    from atlas_rap.skillbus.remote import RemoteSkills

__all__ = ["DEFAULT_TIME_LIMIT", "DEFAULT_WORLD", "Loaded", "MissionEngine", "PLAN_TASK", "RunEnd", "RunOptions",
           "RunResult"]

DEFAULT_TIME_LIMIT = 3600.0
"""Simulated seconds a mission may run before its remaining tasks fail (``--until``)."""

PLAN_TASK = "carry-out-plan-{n}"
"""The RAP that a top-level ``(plan GOAL ...)`` of a mission becomes: one plan step."""

_PLANNING_FORMS = (ast.Operator, ast.Agents, ast.RelationDef, ast.Initial, ast.Goals, ast.Deadline)


class RunEnd(str, Enum):
    """How a run stopped. A ``str`` (its value is what traces, JSON and messages have always said)."""

    DONE = "done"
    """Every posted task ended."""
    STALLED = "stalled"
    """Nothing more could happen: no timer is due and no event can arrive."""
    TIME_LIMIT = "time-limit"
    """The simulated time limit (``--until``) came."""
    STOPPED = "stopped"
    """The caller's ``stop()`` said so (the REPL's Ctrl-C between commands)."""
    INTERRUPTED = "interrupted"
    """Ctrl-C during the run; the live tasks were halted."""
    ERROR = "error"
    """A memory rule broke; the run's notes say how."""

    __str__ = str.__str__
    __format__ = str.__format__


@dataclass
class RunResult:
    """How a run ended: the posted tasks (with their outcomes), the time, and why it stopped (:class:`RunEnd`)."""

    tasks: list[Task]
    time: float
    ended_by: RunEnd = RunEnd.DONE
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when every posted task succeeded."""
        return bool(self.tasks) and all(task.status == SUCCEEDED for task in self.tasks)


@dataclass
class Loaded:
    """What loading one program did: the names it defined, the tasks it posted, its warnings."""

    names: list[str] = field(default_factory=list)
    posted: list[Task] = field(default_factory=list)
    warnings: list[Problem] = field(default_factory=list)


class MissionEngine:
    """Programs loaded into one running :class:`~atlas_rap.layers.system.System` (world or none, skills,
    sequencer), and its time moved.

    ``options`` are what the run is asked for (:class:`RunOptions`); the
    System is built when the first program chooses the world
    (:meth:`ensure_system` builds the options' world before any program).
    ``trace`` receives every event (a new one by default).
    """

    def __init__(self, options: RunOptions | None = None, *, trace: Trace | None = None) -> None:
        self.options = options if options is not None else RunOptions()
        self.trace = trace if trace is not None else Trace()
        self.virtual = VirtualSkills()
        self.system: System | None = None
        self.started = False
        self.warnings: list[Problem] = []
        self.definitions: dict[tuple[str, str, int], ast.TopLevel] = {}
        self.planning: list[ast.TopLevel] = []
        self.lines: dict[str, list[str]] = {}
        self.files: set[str] = set()
        self.plans_made = 0
        self.worker_planning = False

    # -- the running system ----------------------------------------------------

    def ensure_system(self) -> System:
        """The System; when no program has chosen the world yet, the options' world is built now."""
        if self.system is None:
            self._build(WorldChoice(choose_world(self.options, None)))
        assert self.system is not None
        return self.system

    @property
    def sequencer(self) -> Sequencer:
        """The sequencer (the System must be built: :meth:`ensure_system`)."""
        return self._system.sequencer

    @property
    def built(self) -> bool:
        """True once the world (or none) is chosen and the System exists."""
        return self.system is not None

    @property
    def _system(self) -> System:
        if self.system is None:
            raise AtlasError("the run has no world yet: load a program or call ensure_system() first")
        return self.system

    @property
    def world(self) -> World | NamedWorld | None:
        """The world the robot is in (None: no world, or not built yet)."""
        return self.system.world if self.system is not None else None

    @property
    def world_file(self) -> Path | None:
        """The file of the world simulated here (None: no world, or the hosts')."""
        return self.system.world_file if self.system is not None else None

    @property
    def simulation(self) -> Simulation | None:
        """The simulated world in this process (None without one)."""
        return self.system.simulation if self.system is not None else None

    @property
    def manager(self) -> SkillManager | None:
        """The stock skills' manager in this process (None without a world here)."""
        return self.system.manager if self.system is not None else None

    @property
    def skills(self) -> CombinedSkills | VirtualSkills:
        """The one skill link the sequencer uses."""
        return self._system.skills

    @property
    def remote(self) -> RemoteSkills | None:
        """The skill hosts' skills, with ``--connect`` (None otherwise)."""
        return self.system.remote if self.system is not None else None

    @property
    def stack(self) -> LayerStack | None:
        """The ATLAS layers (None without a world here)."""
        return self.system.stack if self.system is not None else None

    @property
    def deliberation(self) -> Deliberation | None:
        """The planner beside the sequencer (None before the System is built)."""
        return self.system.deliberation if self.system is not None else None

    @property
    def seed(self) -> int:
        """The run's seed."""
        return self.options.seed

    def take_fault(self) -> str | None:
        """Why memory rules stopped the run, if they did since the last call (then forgotten)."""
        if self.system is None:
            return None
        seq = self.system.sequencer
        fault, seq.fault = seq.fault, None
        return fault

    @property
    def world_name(self) -> str:
        """The running world, as people name it (``none`` for virtual skills only)."""
        return self.ensure_system().world_name

    def start(self) -> None:
        """Start the world once: the prior map (places, doors) goes into memory."""
        system = self.ensure_system()
        if self.started:
            return
        self.started = True
        seq = system.sequencer
        if system.remote is not None:  # the skill hosts' worlds: their prior maps, then (map prior)
            facts = system.remote.prior_facts()
            seq.change([("assert", fact) for fact in facts if fact.functor != "map"], "world")
            seq.change([("assert", fact) for fact in facts if fact.functor == "map"], "world")
        elif system.believed is not None:
            from atlas_rap.sim.prior import prior_facts

            seq.change([("assert", fact) for fact in prior_facts(system.believed)], "world")
            if self.options.prior_map:
                seq.change([("assert", Compound("map", ("prior",)))], "world")

    def _build(self, choice: WorldChoice) -> None:
        """Build the System in the world ``choice`` names; in a world (here or the hosts'), load the
        layer-switching rules."""
        self.system = build_system(self.options, choice, self.trace, self.virtual, self.planning_problem,
                                   worker=self.worker_planning)
        if self.system.world is not None:
            self._load_layer_rules()

    def plan_in_worker(self, worker: bool = True) -> None:
        """Plan on a worker thread (the REPL on a terminal, ``--realtime``) or in simulated time
        (the default: the planner's latency charged by a rule, so runs are reproducible)."""
        self.worker_planning = worker
        if self.system is not None:
            self.system.deliberation.worker = worker or self.options.realtime

    def _load_layer_rules(self) -> None:
        """The switching rules and their settings (``layer_rules``), before any program."""
        program = load(self.options.rules_file)
        self._check(program, False)
        self._define(program)
        self._act(program)

    @property
    def grid(self) -> OccupancyGrid | None:
        """The occupancy grid Layer IV has built (None when it does not map)."""
        return self.system.grid if self.system is not None else None

    def save_map(self, path: str | Path) -> Path:
        """Write the grid Layer IV built (``--map-out``), as ``atlas run --map-in`` and ``atlas map`` read it."""
        grid = self.grid
        if grid is None:
            raise AtlasError("this run built no map: give --no-prior-map or --map-in to map while driving")
        return grid.save_npz(path)

    def _choose_world(self, program: Program) -> None:
        """Step 1 of :meth:`load`: the program's ``(world ...)`` chooses, or must match, the world."""
        forms = program.of_type(ast.WorldDecl)
        form = forms[-1] if forms else None
        if self.options.world is not None or form is None:
            self.ensure_system()
            return
        chosen = choose_world(self.options, form)
        if self.system is None:
            self._build(WorldChoice(chosen, form, program.source_line(form.loc)))
        elif not self._is_running(chosen):
            raise SourceError(Problem(
                f"this session runs {'with no world' if self.world is None else 'in ' + self.world.name}; "
                f"this file names the world '{form.world}'", form.loc, program.source_line(form.loc),
                f"start a session in that world (atlas repl --world {form.world}), or remove the (world ...) form"))

    def _is_running(self, chosen: str) -> bool:
        system = self._system
        if system.remote is not None:
            return chosen != "none" and system.world is not None and Path(chosen).stem == system.world.name
        if chosen == "none" or system.world is None:
            return chosen == "none" and system.world is None
        from atlas_rap.sim.world import world_path

        try:
            return world_path(chosen).resolve() == system.world_file
        except AtlasError:
            return False

    # -- loading programs ---------------------------------------------------------

    def load_file(self, path: str | Path, *, require_post: bool = False) -> Loaded:
        """Load a mission or RAP file (and what it includes); see :meth:`load`."""
        return self.load(load(path), require_post=require_post)

    def reload(self, path: str | Path) -> Loaded:
        """Load a file again for its definitions only: RAPs, rules, virtual skills and
        relations replace the old ones by name. Posts, initial memory, ``at-time``
        and ``plan`` forms are ignored: reloading changes what the robot knows how
        to do, not what it is doing. On an error nothing changes."""
        return self.load(load(path), definitions_only=True)

    def load(self, program: Program, *, require_post: bool = False, definitions_only: bool = False) -> Loaded:
        """Load one program in one pass (the six steps of the module docstring).

        ``require_post``: a program that posts nothing is an error (``atlas
        run``). Raises :class:`SourceError` with every problem; then nothing
        of the program has taken effect.
        """
        self._choose_world(program)
        loaded = Loaded()
        if program.of_type(ast.PlanRequest) and not definitions_only:
            program = self._carry_out_plans(program)
        loaded.warnings = self._check(program, require_post and not definitions_only)
        self.warnings += loaded.warnings
        loaded.names = self._define(program)
        self.start()
        if not definitions_only:
            loaded.posted = self._act(program)
        return loaded

    def _check(self, program: Program, require_post: bool) -> list[Problem]:
        """Step 3: the sequencer's load-time checks of ``program`` beside what is defined; the warnings."""
        seq = self.sequencer
        new_skills = program.of_type(ast.VirtualSkillDef)
        skills = {name: set(arities) for name, arities in self.skills.skills().items()}
        for name, arities in skill_names(new_skills).items():
            skills[name] = skills.get(name, set()) | arities
        produces = self.skills.produces() | VirtualSkills(new_skills).produces()
        produces |= {fact.functor for fact in seq.memory}
        redefined = {_definition_key(form) for form in program.forms}
        earlier = tuple(form for key, form in self.definitions.items() if key not in redefined)
        combined = dataclasses.replace(program, forms=earlier + program.forms, lines={**self.lines, **program.lines})
        mine = {source.path for source in program.files} | {program.root}
        problems = [p for p in check_program(combined, skills, produces, require_post=require_post)
                    if p.location.file in mine or p.location.file not in self.files]
        for event in program.of_type(ast.AtTime):
            if event.time < seq.now():
                problems.append(Problem(f"at-time {event.time:g} is in the past (the time is {seq.now():g} s)",
                                        event.loc, program.source_line(event.loc),
                                        "at-time takes an absolute simulated time; give a later one"))
        if any(problem.severity == "error" for problem in problems):
            raise SourceError(sorted(problems, key=lambda p: p.severity != "error"))
        return problems

    def _define(self, program: Program) -> list[str]:
        """Step 4: the program's definitions take effect; the names defined."""
        seq = self.sequencer
        self.lines.update(program.lines)
        self.files |= {source.path for source in program.files} | {program.root}
        new_skills = program.of_type(ast.VirtualSkillDef)
        if new_skills:
            self.virtual.define(new_skills)
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
            self.definitions = {key: form for key, form in self.definitions.items()
                                if key[:2] != ("RelationDef", name)}
        for form in program.forms:
            key = _definition_key(form)
            if key is not None:
                self.definitions.pop(key, None)
                self.definitions[key] = form
        self.planning = [form for form in self.planning if not _replaced(form, program)]
        self.planning += [form for form in program.forms if isinstance(form, _PLANNING_FORMS)]
        return [rap.name for rap in raps] + [form.name for form in rules] + [skill.name for skill in new_skills]

    def _act(self, program: Program) -> list[Task]:
        """Step 6: initial memory, at-time events and posts, in that order; the tasks posted.
        The planner's ``(initial ...)`` facts are what the robot believes too: they go into
        memory with the program's ``initial-memory``, each once."""
        seq = self.sequencer
        believed = tuple(f for f in dict.fromkeys(f for form in program.of_type(ast.Initial) for f in form.facts)
                         if f not in seq.memory)
        batches = [("initial", believed)] + [("initial-memory", form.facts)
                                             for form in program.of_type(ast.InitialMemory)]
        for source, facts in batches:
            if facts:
                seq.change([("assert", fact) for fact in facts], source)
            fault = self.take_fault()
            if fault is not None:
                raise AtlasError(f"{program.root}: the {source} facts broke a memory rule: {fault}")
        for event in program.of_type(ast.AtTime):
            changes = [(op.kind, op.fact) for op in event.actions]
            seq.timers.at(event.time, lambda changes=changes, t=event.time: seq.change(changes, f"at-time {t:g}"))
        return [seq.post(post.task, post.priority, post.deadline) for post in program.of_type(ast.Post)]

    # -- planning ----------------------------------------------------------------------

    def planning_problem(self, goals: tuple[Term, ...], lost: frozenset[str] = frozenset(),
                         loc: SourceLocation | None = None, program: Program | None = None,
                         facts: tuple[Compound, ...] = ()):
        """The planning problem for ``goals`` from memory now and ``facts``, with the operators,
        agents and relations loaded so far (and those of ``program``, being loaded), without
        the ``lost`` agents. One memory: the ``initial`` facts of the programs loaded are in
        it (:meth:`_act`), beside the prior map and what skills and RAPs asserted since, and
        the planner starts from memory alone."""
        from atlas_rap.planner.problem import problem_from_program

        forms = [form for form in self.planning if program is None or not _replaced(form, program)]
        if program is not None:
            forms += [form for form in program.forms if isinstance(form, _PLANNING_FORMS)]
        lines = {**self.lines, **(program.lines if program is not None else {})}
        problem_program = Program(root=program.root if program is not None else "<plan>", files=(),
                                  forms=tuple(forms), lines=lines)
        base = problem_from_program(problem_program, name=problem_program.root)
        if lost:
            base = dataclasses.replace(base, controlled=tuple(a for a in base.controlled if a not in lost))
        return base.asked(goals, tuple(self.sequencer.memory) + facts, loc)  # initial facts are in memory (_act)

    def _carry_out_plans(self, program: Program) -> Program:
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
                raise_problems(self.planning_problem(request.goals, frozenset(), request.loc, program, facts))
            except SourceError as exc:
                problems += exc.problems
                continue
            self.plans_made += 1
            name = PLAN_TASK.format(n=self.plans_made)
            rap = ast.RapDef(head=Compound(name, ()), loc=request.loc, retries=1,  # the plan step repairs itself
                             methods=(ast.Method(body=ast.TaskNet(nets=(request,), loc=request.loc),
                                                 loc=request.loc),))
            replaced[id(request)] = [rap, ast.Post(task=Compound(name, ()), loc=request.loc)]
        if problems:
            raise SourceError(problems)
        forms = tuple(new for form in program.forms for new in replaced.get(id(form), [form]))
        return dataclasses.replace(program, forms=forms)

    # -- time ---------------------------------------------------------------------------

    def now(self) -> float:
        """The simulated time, in seconds."""
        return self.sequencer.now()

    def run(self, until: float = DEFAULT_TIME_LIMIT, *, pace: Pace | None = None, stop: Stop | None = None) -> RunEnd:
        """Run until every posted task has ended; how it stopped. Tasks still running are left running."""
        self.start()
        ended = self._system.driver.run(until, pace, stop)
        return RunEnd.ERROR if self.sequencer.fault is not None else RunEnd(ended)

    def advance(self, seconds: float, *, pace: Pace | None = None, stop: Stop | None = None) -> None:
        """Let ``seconds`` of simulated time pass (world, skills, timers), tasks or not."""
        self.start()
        self._system.driver.advance(seconds, pace, stop)

    def run_mission(self, until: float = DEFAULT_TIME_LIMIT, *, pace: Pace | None = None) -> RunResult:
        """``atlas run``: run until the posted tasks end, then fail the tasks still running,
        saying what they waited for. Ctrl-C halts the live tasks (their skills disabled)."""
        try:
            ended = self.run(until, pace=pace)
        except KeyboardInterrupt:
            self.halt_live("the run was interrupted")
            ended = RunEnd.INTERRUPTED
        return self.finish(ended, until)

    def finish(self, ended_by: RunEnd | str, until: float = DEFAULT_TIME_LIMIT) -> RunResult:
        """The result of a run that ended by ``ended_by``; tasks still live fail, saying why."""
        seq = self.sequencer
        fault = self.take_fault()
        result = RunResult(list(seq.roots), seq.now(), RunEnd(ended_by), [fault] if fault else [])
        for task in seq.live_roots():
            waits = waiting_for(task)
            waiting = f"; it was waiting for {', '.join(waits)}" if waits else ""
            if ended_by == "stalled":
                why = f"nothing more can happen (no timer is due and no event can arrive){waiting}"
            else:
                why = f"still running at the time limit of {until:g} s{waiting}"
            seq.cancel(task, why)
        return result

    def halt_live(self, why: str) -> list[Task]:
        """Halt every live posted task (and disable every skill they enabled); the tasks halted."""
        seq = self.sequencer
        live = seq.live_roots()
        for task in live:
            seq.halt(task, why)
        return live


def _definition_key(form: ast.TopLevel) -> tuple[str, str, int] | None:
    """What a definition replaces: RAPs and virtual skills by name and arity, rules by name."""
    if isinstance(form, (ast.RapDef, ast.VirtualSkillDef)):
        return (type(form).__name__, form.name, len(form.head.args))
    if isinstance(form, ast.MemoryRuleDef):
        return ("MemoryRuleDef", form.name, 0)
    if isinstance(form, ast.RelationDef):  # each clause its own entry; _define drops a redefined relation's
        return ("RelationDef", form.name, id(form))
    return None


def _replaced(form: ast.TopLevel, program: Program) -> bool:
    """An earlier planning form that ``program`` replaces: an operator, or a relation's
    clauses, of the same name."""
    kind = type(form)
    return kind in (ast.Operator, ast.RelationDef) and any(
        type(new) is kind and new.name == form.name for new in program.forms)

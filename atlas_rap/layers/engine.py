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
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from atlas_rap.errors import AtlasError, Problem, SourceError, SourceLocation
from atlas_rap.lang import ast, load
from atlas_rap.lang.loader import Program
from atlas_rap.layers.clock import Clock, WallClock, wall_clock_pacer
from atlas_rap.layers.deliberation import Deliberation
from atlas_rap.layers.executive import Driver, Executive, Pace, Rates, Stop, VirtualExecutive
from atlas_rap.layers.layer import LAYER_NAMES, LayerStack
from atlas_rap.layers.monitoring import MonitoringLayer
from atlas_rap.layers.operational import OperationalLayer
from atlas_rap.layers.strategic import StrategicLayer
from atlas_rap.layers.tactical import TacticalLayer
from atlas_rap.logic import Compound, Relation, Term
from atlas_rap.sequencer import Sequencer, Task, Trace
from atlas_rap.sequencer.checks import check_program
from atlas_rap.sequencer.introspect import waiting_for
from atlas_rap.sequencer.task import SUCCEEDED
from atlas_rap.shipped import shipped_root
from atlas_rap.skillbus.remote import BusSettings
from atlas_rap.skillbus.skill_link import CombinedSkills
from atlas_rap.skills.beliefs import GRID, TOPOLOGY
from atlas_rap.skills.virtual import VirtualSkills, skill_names

DEFAULT_WORLD = "lab-corridor-office"
"""The world of an ``atlas run`` mission that names none: the seed's lab, corridor and office."""

DEFAULT_TIME_LIMIT = 3600.0
"""Simulated seconds a mission may run before its remaining tasks fail (``--until``)."""

PLAN_TASK = "carry-out-plan-{n}"
"""The RAP that a top-level ``(plan GOAL ...)`` of a mission becomes: one plan step."""

_PLANNING_FORMS = (ast.Operator, ast.Agents, ast.RelationDef, ast.Initial, ast.Goals, ast.Deadline)


@dataclass
class RunResult:
    """How a run ended: the posted tasks (with their outcomes), the time, and why it stopped.

    ``ended_by``: ``done`` (every posted task ended), ``stalled`` (nothing more
    could happen), ``time-limit``, ``interrupted`` (Ctrl-C) or ``error`` (a
    memory rule broke; ``notes`` says how).
    """

    tasks: list[Task]
    time: float
    ended_by: str = "done"
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
    """One running system (world or none, skills, sequencer) that programs are loaded into.

    ``world``: the world flag (a shipped world's name, a world file, or
    ``none``), which overrides the programs' ``(world ...)`` forms;
    ``default_world`` is used when neither says (``atlas run``: the lab,
    ``atlas repl``: none). ``topology`` is a topological map file for
    ``navigate-to``; ``mapping`` makes Layer IV map the world even with a
    prior map (``atlas map build``). ``prior_map`` False (``--no-prior-map``)
    gives the robot only the names and points of the places: Layer IV maps
    while it drives, from ``map_in`` (an ``occupancy.npz``) if given.
    ``layers`` are the layers enabled; ``layer_rules`` the file of switching
    rules (default: the shipped ``rap_library/layers.rap``); ``realtime``
    paces simulated time to the wall clock. ``bus`` (a
    :class:`~atlas_rap.skillbus.remote.BusSettings`: endpoints, robots, tokens)
    uses the robots' skill hosts on the skill bus instead of building
    the world here (``layers.remote``; what runs where: ``layers.skill_host``).
    """

    def __init__(self, world: str | None = None, *, default_world: str = DEFAULT_WORLD, seed: int = 0,
                 trace: Trace | None = None, topology: str | None = None, mapping: bool = False,
                 rates: Rates = Rates(), prior_map: bool = True, map_in: str | Path | None = None,
                 layers: Iterable[str] = LAYER_NAMES, layer_rules: str | Path | None = None,
                 realtime: bool = False, bus: BusSettings | None = None) -> None:
        self.world_flag = world
        self.bus = bus
        self.remote: Any = None  # the skill bus's RemoteSkills, with --connect
        self.prior_map = prior_map
        self.map_in = map_in
        self.enabled_layers = tuple(layers)
        self.layer_rules = Path(layer_rules) if layer_rules is not None else shipped_root("rap_library") / "layers.rap"
        self.realtime = realtime
        self.stack: LayerStack | None = None
        self.default_world = default_world
        self.seed = seed
        self.trace = trace if trace is not None else Trace()
        self.topology = topology
        self.mapping = mapping
        self.rates = rates
        self.world: Any = None
        self.world_file: Path | None = None
        self.simulation: Any = None
        self.manager: Any = None
        self.virtual = VirtualSkills()
        self.skills: Any = None
        self._sequencer: Sequencer | None = None
        self.driver: Driver | None = None
        self.started = False
        self.warnings: list[Problem] = []
        self.definitions: dict[tuple[str, str, int], ast.TopLevel] = {}
        self.planning: list[ast.TopLevel] = []
        self.lines: dict[str, list[str]] = {}
        self.files: set[str] = set()
        self.plans_made = 0
        self.deliberation: Deliberation | None = None
        self.worker_planning = False

    # -- the running system ----------------------------------------------------

    @property
    def sequencer(self) -> Sequencer:
        """The sequencer; asking for it before any program chose a world builds the default one."""
        if self._sequencer is None:
            self._build(self.world_flag or self.default_world)
        return self._sequencer  # type: ignore[return-value]

    @property
    def built(self) -> bool:
        """True once the world (or none) is chosen and the sequencer exists."""
        return self._sequencer is not None

    def take_fault(self) -> str | None:
        """Why memory rules stopped the run, if they did since the last call (then forgotten)."""
        if self._sequencer is None:
            return None
        fault, self._sequencer.fault = self._sequencer.fault, None
        return fault

    @property
    def world_name(self) -> str:
        """The running world, as people name it (``none`` for virtual skills only)."""
        if not self.built:
            self._build(self.world_flag or self.default_world)
        return self.world.name if self.world is not None else "none"

    def start(self) -> None:
        """Start the world once: the prior map (places, doors) goes into memory."""
        seq = self.sequencer
        if self.started:
            return
        self.started = True
        if self.remote is not None:  # the skill hosts' worlds: their prior maps, then (map prior)
            facts = self.remote.prior_facts()
            seq.change([("assert", fact) for fact in facts if fact.functor != "map"], "world")
            seq.change([("assert", fact) for fact in facts if fact.functor == "map"], "world")
        elif self.world is not None:
            from atlas_rap.sim.prior import prior_facts

            seq.change([("assert", fact) for fact in prior_facts(self.stack.world)], "world")
            if self.prior_map:
                seq.change([("assert", Compound("map", ("prior",)))], "world")

    def _build(self, chosen: str, form: ast.WorldDecl | None = None, line: str | None = None) -> None:
        """Make the world (unless ``none``), its skills beside the virtual ones, and the sequencer."""
        if self.bus is not None:
            from atlas_rap.layers.remote import build_remote

            build_remote(self, chosen, form, line)
            return
        if chosen == "none":
            if self.topology is not None:
                raise AtlasError("--map needs a world; this run has none (--world none)")
            self.skills = self.virtual
            self._sequencer = Sequencer(skills=self.skills, trace=self.trace)
            self._deliberate()
            self.driver = VirtualExecutive(self._sequencer, pace=wall_clock_pacer() if self.realtime else None)
            return
        from atlas_rap.sim.physics import Simulation
        from atlas_rap.sim.world import load_world, world_path
        from atlas_rap.skills.stock import stock_manager

        try:
            self.world_file = world_path(chosen).resolve()
            self.world = load_world(chosen)
        except SourceError:
            raise
        except AtlasError as exc:
            if form is None:
                raise
            raise _located(exc, form, line) from None
        self.simulation = Simulation(self.world, seed=self.seed, dt=1.0 / self.rates.physics)
        believed = self.world if self.prior_map else self.world.without_map()
        self.manager = stock_manager(believed, self.simulation, self.simulation.rng)
        if self.topology is not None:
            from atlas_rap.maps.topology import Topology

            self.manager.context.beliefs[TOPOLOGY] = Topology.from_json(self.topology)
        self.skills = CombinedSkills(self.manager, self.virtual)
        self._sequencer = Sequencer(skills=self.skills, trace=self.trace)
        self._deliberate()
        self.stack = self._layer_stack(believed)
        clock = (WallClock if self.realtime else Clock)(self.rates.physics)
        self.driver = Executive(self.simulation, self.manager, self._sequencer, self.rates, stack=self.stack,
                                clock=clock)
        self._load_layer_rules()

    def _deliberate(self) -> None:
        """The planner beside the sequencer: in simulated time, or on a worker in real time."""
        self.deliberation = Deliberation(self.planning_problem, self._sequencer.timers,
                                         worker=self.realtime or self.worker_planning)
        self._sequencer.deliberator = self.deliberation

    def plan_in_worker(self, worker: bool = True) -> None:
        """Plan on a worker thread (the REPL on a terminal, ``--realtime``) or in simulated time
        (the default: the planner's latency charged by a rule, so runs are reproducible)."""
        self.worker_planning = worker
        if self.deliberation is not None:
            self.deliberation.worker = worker or self.realtime

    def _layer_stack(self, believed: Any) -> LayerStack:
        """The four layers over the robot's beliefs; Layer IV only when there is a map to build."""
        stack = LayerStack(self._sequencer, self.manager.context.beliefs, believed, enabled=self.enabled_layers,
                           prior_map=self.prior_map)
        stack.rules_source = str(self.layer_rules)
        stack.add(MonitoringLayer(stack))
        stack.add(OperationalLayer(stack))
        stack.add(TacticalLayer(stack))
        if self.mapping or not self.prior_map or self.map_in is not None:
            stack.add(StrategicLayer(stack, self._map_in(believed) if self.map_in is not None else None))
        if not stack.active():
            raise AtlasError(f"--layers {','.join(self.enabled_layers)}: Layer IV maps, so it runs only when the "
                             f"robot maps (--no-prior-map or --map-in); enable I, II or III as well")
        return stack

    def _map_in(self, world: Any):
        """The grid of ``--map-in``, checked: a grid file, and one that covers the world."""
        from atlas_rap.maps.grid import OccupancyGrid

        try:
            grid = OccupancyGrid.load_npz(self.map_in)
        except (OSError, KeyError, ValueError) as exc:
            raise AtlasError(f"{self.map_in}: not an occupancy grid written by atlas run --map-out or "
                             f"atlas map build ({exc})") from None
        xmin, ymin, xmax, ymax = world.bounds
        frame = grid.frame
        inset = frame.resolution / 2
        corners = [frame.world_to_cell(x, y) for x in (xmin + inset, xmax - inset) for y in (ymin + inset, ymax - inset)]
        if not all(frame.contains_cell(row, col) for row, col in corners):
            raise AtlasError(f"{self.map_in}: this grid does not cover world {world.name} "
                             f"(x {xmin:g}..{xmax:g}, y {ymin:g}..{ymax:g}); was it built in another world?")
        return grid

    def _load_layer_rules(self) -> None:
        """The switching rules and their settings (``layer_rules``), before any program."""
        program = load(self.layer_rules)
        self._check(program, False)
        self._define(program)
        self._act(program)

    @property
    def grid(self):
        """The occupancy grid Layer IV has built (None when it does not map)."""
        return self.manager.context.beliefs.get(GRID) if self.manager is not None else None

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
        if self.world_flag is not None or form is None:
            self.sequencer
            return
        chosen = _world_choice(form)
        if self._sequencer is None:
            self._build(chosen, form, program.source_line(form.loc))
        elif not self._is_running(chosen):
            raise SourceError(Problem(
                f"this session runs {'with no world' if self.world is None else 'in ' + self.world.name}; "
                f"this file names the world '{form.world}'", form.loc, program.source_line(form.loc),
                f"start a session in that world (atlas repl --world {form.world}), or remove the (world ...) form"))

    def _is_running(self, chosen: str) -> bool:
        if self.remote is not None:
            return chosen != "none" and Path(chosen).stem == self.world.name
        if chosen == "none" or self.world is None:
            return chosen == "none" and self.world is None
        from atlas_rap.sim.world import world_path

        try:
            return world_path(chosen).resolve() == self.world_file
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

    def run(self, until: float = DEFAULT_TIME_LIMIT, *, pace: Pace | None = None, stop: Stop | None = None) -> str:
        """Run until every posted task has ended; how it stopped (see :class:`RunResult`,
        and ``stopped`` when ``stop()`` said so). Tasks still running are left running."""
        self.start()
        ended = self.driver.run(until, pace, stop)  # type: ignore[union-attr]
        return "error" if self.sequencer.fault is not None else ended

    def advance(self, seconds: float, *, pace: Pace | None = None, stop: Stop | None = None) -> None:
        """Let ``seconds`` of simulated time pass (world, skills, timers), tasks or not."""
        self.start()
        self.driver.advance(seconds, pace, stop)  # type: ignore[union-attr]

    def run_mission(self, until: float = DEFAULT_TIME_LIMIT, *, pace: Pace | None = None) -> RunResult:
        """``atlas run``: run until the posted tasks end, then fail the tasks still running,
        saying what they waited for. Ctrl-C halts the live tasks (their skills disabled)."""
        try:
            ended = self.run(until, pace=pace)
        except KeyboardInterrupt:
            self.halt_live("the run was interrupted")
            ended = "interrupted"
        return self.finish(ended, until)

    def finish(self, ended_by: str, until: float = DEFAULT_TIME_LIMIT) -> RunResult:
        """The result of a run that ended by ``ended_by``; tasks still live fail, saying why."""
        seq = self.sequencer
        fault = self.take_fault()
        result = RunResult(list(seq.roots), seq.now(), ended_by, [fault] if fault else [])
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


def _world_choice(form: ast.WorldDecl) -> str:
    """The world a ``(world ...)`` form names; a path is relative to the file it is written in."""
    world = form.world
    if ("/" in world or world.endswith((".yaml", ".yml"))) and not form.loc.file.startswith("<"):
        return str(Path(form.loc.file).resolve().parent / world)
    return world


def _located(exc: AtlasError, form: ast.WorldDecl, line: str | None) -> SourceError:
    """An error about the world a form names, as a problem located at the form."""
    first, *rest = str(exc).split("\n")
    hint = "; ".join(text.strip() for text in rest) or None
    return SourceError(Problem(first, form.loc, line, hint))


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

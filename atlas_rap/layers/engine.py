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

The engine is the orchestration only: the System it runs is built by
:mod:`atlas_rap.layers.builders` from :class:`~atlas_rap.layers.system.RunOptions`,
steps 2-4 and 6 are the functions of :mod:`atlas_rap.layers.library` over the
System and the :class:`~atlas_rap.layers.library.Library` of what is defined,
and time moves by the functions of :mod:`atlas_rap.layers.running`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from atlas_rap.errors import AtlasError, Problem, RunError, SourceLocation, WorldFileError
from atlas_rap.lang import ast, load
from atlas_rap.lang.loader import Program
from atlas_rap.layers.builders import build_system
from atlas_rap.layers.deliberation import Deliberation
from atlas_rap.layers.executive import Pace, Stop
import atlas_rap.layers.running as running
from atlas_rap.layers.layer import LayerStack
from atlas_rap.layers.library import Library, act, carry_out_plans, check, define, planning_problem
from atlas_rap.layers.running import DEFAULT_TIME_LIMIT, RunEnd, RunResult
from atlas_rap.layers.system import NamedWorld, RunOptions, System, WorldChoice, choose_world
from atlas_rap.logic import Compound, Term
from atlas_rap.sequencer import Sequencer, Task, Trace
from atlas_rap.skillbus.skill_link import CombinedSkills
from atlas_rap.skills.manager import SkillManager
from atlas_rap.skills.virtual import VirtualSkills

if TYPE_CHECKING:  # downward only
    from atlas_rap.maps.grid import OccupancyGrid
    from atlas_rap.planner.problem import PlanningProblem
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.sim.world import World
    from atlas_rap.skillbus.remote import RemoteSkills

__all__ = ["Loaded", "MissionEngine"]

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
        self.library = Library()
        self.started = False
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
            raise RunError("the run has no world yet: load a program or call ensure_system() first")
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
        return running.take_fault(self.system) if self.system is not None else None

    @property
    def world_name(self) -> str:
        """The running world, as people name it (``none`` for virtual skills only; the System must
        be built: :meth:`ensure_system`)."""
        return self._system.world_name

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
            self.system.deliberation.worker = self.options.plans_on_worker(worker)

    def _load_layer_rules(self) -> None:
        """The switching rules and their settings (``layer_rules``), before any program."""
        program = load(self.options.rules_file)
        check(self._system, self.library, program, require_post=False)
        define(self._system, self.library, program)
        act(self._system, program)

    @property
    def grid(self) -> OccupancyGrid | None:
        """The occupancy grid Layer IV has built (None when it does not map)."""
        return self.system.grid if self.system is not None else None

    def save_map(self, path: str | Path) -> Path:
        """Write the grid Layer IV built (``--map-out``), as ``atlas run --map-in`` and ``atlas map`` read it."""
        grid = self.grid
        if grid is None:
            raise RunError("this run built no map: give --no-prior-map or --map-in to map while driving")
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
            raise WorldFileError(Problem(
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
            program = carry_out_plans(self._system, self.library, program)
        loaded.warnings = check(self._system, self.library, program, require_post and not definitions_only)
        self.library.warnings += loaded.warnings
        loaded.names = define(self._system, self.library, program)
        self.start()
        if not definitions_only:
            loaded.posted = act(self._system, program)
        return loaded

    def planning_problem(self, goals: tuple[Term, ...], lost: frozenset[str] = frozenset(),
                         loc: SourceLocation | None = None, program: Program | None = None,
                         facts: tuple[Compound, ...] = ()) -> PlanningProblem:
        """The planning problem for ``goals`` now (:func:`atlas_rap.layers.library.planning_problem`)."""
        return planning_problem(self._system, self.library, goals, lost, loc, program, facts)

    # -- time ---------------------------------------------------------------------------

    def now(self) -> float:
        """The simulated time, in seconds."""
        return self.sequencer.now()

    def run(self, until: float = DEFAULT_TIME_LIMIT, *, pace: Pace | None = None, stop: Stop | None = None) -> RunEnd:
        """Start the world if it is not yet, and run until every posted task has ended (:func:`running.run`)."""
        self.start()
        return running.run(self._system, until, pace=pace, stop=stop)

    def advance(self, seconds: float, *, pace: Pace | None = None, stop: Stop | None = None) -> None:
        """Start the world if it is not yet, and let ``seconds`` of simulated time pass."""
        self.start()
        running.advance(self._system, seconds, pace=pace, stop=stop)

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
        """The result of a run that ended by ``ended_by`` (:func:`running.finish`)."""
        return running.finish(self._system, ended_by, until)

    def halt_live(self, why: str) -> list[Task]:
        """Halt every live posted task (and disable every skill they enabled); the tasks halted."""
        return running.halt_live(self._system, why)

"""The run as a typed System: what a run is asked for (:class:`RunOptions`) and what it is made of (:class:`System`).

One straight pipeline from options to a running robot::

    options = RunOptions(world="lab-corridor-office", seed=3)   # cli/ builds it once
    chosen = choose_world(options, form)                          # pure: builds nothing
    system = build_system(options, chosen, trace, virtual, problem_for)   # layers.builders

Every field of a :class:`System` is typed, so a run can be followed
statically from ``cli/`` into the sequencer, the skills and the sim. Three
builders make one (:mod:`atlas_rap.layers.builders`: a world simulated
here, no world, or the robots' skill hosts over the bus); the mission
engine (:mod:`atlas_rap.layers.engine`) loads programs into it and moves its
time.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from atlas_rap.errors import AtlasError, Problem, WorldFileError
from atlas_rap.layers.deliberation import Deliberation, ProblemFor
from atlas_rap.layers.executive import Driver, Rates
from atlas_rap.layers.layer import LAYER_NAMES, LayerStack
from atlas_rap.lang import ast
from atlas_rap.sequencer import Sequencer, Trace
from atlas_rap.shipped import shipped_root
from atlas_rap.skillbus.remote import BusSettings
from atlas_rap.skillbus.skill_link import CombinedSkills
from atlas_rap.skills.manager import SkillManager
from atlas_rap.skills.robot import Robot
from atlas_rap.skills.virtual import VirtualSkills

if TYPE_CHECKING:  # downward only: the sim, the maps and the bus are imported when they are used
    from atlas_rap.maps.grid import OccupancyGrid
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.sim.world import World
    from atlas_rap.skillbus.remote import RemoteSkills

__all__ = ["DEFAULT_WORLD", "NamedWorld", "RunOptions", "System", "WorldChoice", "choose_world", "located",
           "planning_beside", "world_of"]

DEFAULT_WORLD = "lab-corridor-office"
"""The world of an ``atlas run`` mission that names none: the seed's lab, corridor and office."""


@dataclass(frozen=True)
class RunOptions:
    """What a run is asked for; ``cli/`` builds it once from the command line.

    - ``world``: the world flag (a shipped world's name, a world file, or
      ``none``); it overrides the programs' ``(world ...)`` forms.
      ``default_world`` is used when neither says (``atlas run``: the lab,
      ``atlas repl``: none).
    - ``seed``: every random choice of the run; ``rates``: the executive's periods.
    - ``topology``: a topological map file for ``navigate-to`` (``--map``).
    - ``mapping``: Layer IV maps the world even with a prior map (``atlas map build``).
    - ``prior_map`` False (``--no-prior-map``): the robot knows only the names
      and points of the places; Layer IV maps while it drives, from
      ``map_in`` (an occupancy ``.npz``) if given; ``map_out`` is where the
      caller writes the grid built.
    - ``layers``: the layers enabled; ``layer_rules``: the file of switching
      rules (None: the shipped ``rap_library/layers.rap``).
    - ``realtime``: pace simulated time to the wall clock.
    - ``errand``: the places an errand visits in turn (the experiment's ``("office", "lab")``):
      Layer IV then measures the map's quality over the fixed area that errand needs
      (:func:`~atlas_rap.maps.errand_area.errand_area`) instead of the explored region.
    - ``localisation``: how the robot knows where it is (``--localisation``): ``mcl``, Monte
      Carlo localisation on its prior map (without one, the odometry corrected against the map
      being built), or ``odometry``, dead reckoning alone (:mod:`atlas_rap.skills.localising`).
    - ``bus``: the skill hosts to use instead of a world here (``--connect``,
      ``--robot``, tokens: :class:`~atlas_rap.skillbus.remote.BusSettings`).
    """

    world: str | None = None
    default_world: str = DEFAULT_WORLD
    seed: int = 0
    rates: Rates = Rates()
    topology: str | None = None
    mapping: bool = False
    prior_map: bool = True
    map_in: str | Path | None = None
    map_out: str | Path | None = None
    layers: tuple[str, ...] = LAYER_NAMES
    layer_rules: str | Path | None = None
    realtime: bool = False
    bus: BusSettings | None = None
    localisation: str = "mcl"
    errand: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "layers", tuple(self.layers))  # any iterable of layer names
        object.__setattr__(self, "errand", tuple(self.errand))

    @property
    def rules_file(self) -> Path:
        """The layer-switching rules to load before any program."""
        return Path(self.layer_rules) if self.layer_rules is not None else shipped_root("rap_library") / "layers.rap"

    def plans_on_worker(self, asked: bool) -> bool:
        """Whether the planner runs on a worker thread: when ``asked`` (the REPL on a terminal), and
        always in a run paced to the wall clock; else in simulated time, so runs are reproducible."""
        return asked or self.realtime

    @property
    def maps_while_driving(self) -> bool:
        """Whether Layer IV builds a grid in this run."""
        return self.mapping or not self.prior_map or self.map_in is not None


@dataclass(frozen=True)
class NamedWorld:
    """A world known only by name: the one a skill host runs, as the sequencer's side knows it."""

    name: str


@dataclass
class System:
    """One running system, wired: every part a run is made of, typed.

    ``world`` is the world the robot is in (None: no world; a
    :class:`NamedWorld` over the bus), ``believed`` what the robot believes
    of it (without its map under ``--no-prior-map``), ``world_file`` its file.
    ``robot`` is the body the skills drive (the simulation in this process;
    None with no world or over the bus, where the hosts own the bodies).
    ``skills`` is the one skill link the sequencer uses: the stock skills'
    ``manager`` (or the hosts' ``remote`` skills) beside the ``virtual`` ones.
    ``stack`` is the four ATLAS layers (None without a world here),
    ``driver`` what moves time, ``deliberation`` the planner beside the
    sequencer, ``trace`` where every event goes.
    """

    options: RunOptions
    trace: Trace
    virtual: VirtualSkills
    skills: CombinedSkills | VirtualSkills
    sequencer: Sequencer
    deliberation: Deliberation
    driver: Driver
    world: World | NamedWorld | None = None
    believed: World | None = None
    world_file: Path | None = None
    simulation: Simulation | None = None
    robot: Robot | None = None
    manager: SkillManager | None = None
    remote: RemoteSkills | None = None
    stack: LayerStack | None = None

    @property
    def world_name(self) -> str:
        """The running world, as people name it (``none`` for virtual skills only)."""
        return self.world.name if self.world is not None else "none"

    @property
    def grid(self) -> OccupancyGrid | None:
        """The occupancy grid Layer IV has built (None when it does not map)."""
        from atlas_rap.skills.beliefs import GRID

        return self.manager.context.beliefs.get(GRID) if self.manager is not None else None


@dataclass(frozen=True)
class WorldChoice:
    """The world a run is built in (``name``: a shipped world, a world file or ``none``), and the
    ``(world ...)`` form that chose it with its source ``line`` (None when the options did), so an
    error in that world is located at the form."""

    name: str
    form: ast.WorldDecl | None = None
    line: str | None = None


def choose_world(options: RunOptions, form: ast.WorldDecl | None) -> str:
    """The world a run uses, given the last ``(world ...)`` form of its first program (or None).

    Pure: it builds nothing. ``--world`` overrides every form; a path in a
    form is relative to the file it is written in.
    """
    if options.world is not None or form is None:
        return options.world or options.default_world
    return world_of(form)


def world_of(form: ast.WorldDecl) -> str:
    """The world a ``(world ...)`` form names; a path is relative to the file it is written in."""
    world = form.world
    if ("/" in world or world.endswith((".yaml", ".yml"))) and not form.loc.file.startswith("<"):
        return str(Path(form.loc.file).resolve().parent / world)
    return world


def located(exc: AtlasError, form: ast.WorldDecl, line: str | None) -> WorldFileError:
    """An error about the world a form names, as a problem located at the form."""
    first, *rest = str(exc).split("\n")
    hint = "; ".join(text.strip() for text in rest) or None
    return WorldFileError(Problem(first, form.loc, line, hint))


def planning_beside(sequencer: Sequencer, problem_for: ProblemFor, options: RunOptions, worker: bool) -> Deliberation:
    """The planner beside ``sequencer``: on a worker thread or in simulated time
    (:meth:`RunOptions.plans_on_worker`)."""
    deliberation = Deliberation(problem_for, sequencer.timers, worker=options.plans_on_worker(worker))
    sequencer.deliberator = deliberation
    return deliberation

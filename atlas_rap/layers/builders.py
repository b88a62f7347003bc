"""The three ways a run is built: a world simulated here, no world, or the robots' skill hosts over the bus.

:func:`build_system` picks the builder from :data:`BUILDERS` by what the
run is asked for (:func:`backend_for`):

- ``simulated``: a world file in this process: the pymunk body, the stock
  skills on it beside the program's virtual ones, the four layers over the
  robot's beliefs and the multirate executive;
- ``virtual``: no world (``--world none``): virtual skills and timers only;
- ``remote``: the robots' skill hosts over the skill bus (``--connect``;
  :func:`atlas_rap.layers.remote.build_remote`), driven in lock step.

Each returns a whole :class:`~atlas_rap.layers.system.System`; none reaches
into another object. A new backend (a real robot's driver, say) is one more
function of the :class:`Builder` shape in the registry.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from atlas_rap.errors import AtlasError, MapError, RunError, SourceError
from atlas_rap.layers.clock import Clock, WallClock, wall_clock_pacer
from atlas_rap.layers.deliberation import ProblemFor
from atlas_rap.layers.executive import Executive, Rates, VirtualExecutive
from atlas_rap.layers.layer import LayerStack
from atlas_rap.layers.monitoring import MonitoringLayer
from atlas_rap.layers.operational import OperationalLayer
from atlas_rap.layers.remote import build_remote
from atlas_rap.layers.strategic import GRID_RESOLUTION, StrategicLayer
from atlas_rap.layers.system import RunOptions, System, WorldChoice, located, planning_beside
from atlas_rap.layers.tactical import TacticalLayer
from atlas_rap.sequencer import Sequencer, Trace
from atlas_rap.skillbus.skill_link import CombinedSkills
from atlas_rap.skills.beliefs import LOCALISATION, TOPOLOGY
from atlas_rap.skills.manager import SkillManager
from atlas_rap.skills.virtual import VirtualSkills

if TYPE_CHECKING:  # downward only: the sim and the maps are imported when a world is built
    import numpy as np

    from atlas_rap.maps.grid import OccupancyGrid
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.sim.world import World

__all__ = ["BUILDERS", "Builder", "backend_for", "build_remote", "build_simulated", "build_system", "build_virtual",
           "simulated_robot"]


class Builder(Protocol):
    """Builds the :class:`System` of a run in the world ``choice`` names: the shape every backend shares.

    ``problem_for`` makes the planning problem of a plan step (from the
    engine's operators and memory); ``worker`` plans on a worker thread.
    """

    def __call__(self, options: RunOptions, choice: WorldChoice, trace: Trace, virtual: VirtualSkills,
                 problem_for: ProblemFor, worker: bool) -> System: ...


def backend_for(options: RunOptions, chosen: str) -> str:
    """Which of :data:`BUILDERS` builds the run: the skill hosts, no world, or a world here."""
    if options.bus is not None:
        return "remote"
    return "virtual" if chosen == "none" else "simulated"


def build_system(options: RunOptions, choice: WorldChoice, trace: Trace, virtual: VirtualSkills,
                 problem_for: ProblemFor, *, worker: bool = False) -> System:
    """Build the System of a run in the world ``choice`` names, with the backend :func:`backend_for` picks."""
    return BUILDERS[backend_for(options, choice.name)](options, choice, trace, virtual, problem_for, worker)


def build_virtual(options: RunOptions, choice: WorldChoice, trace: Trace, virtual: VirtualSkills,
                  problem_for: ProblemFor, worker: bool) -> System:
    """No world: the program's virtual skills and the timers (``--world none``)."""
    if options.topology is not None:
        raise RunError("--map needs a world; this run has none (--world none)")
    sequencer = Sequencer(skills=virtual, trace=trace)
    deliberation = planning_beside(sequencer, problem_for, options, worker)
    driver = VirtualExecutive(sequencer, pace=wall_clock_pacer() if options.realtime else None)
    return System(options, trace, virtual, virtual, sequencer, deliberation, driver)


def build_simulated(options: RunOptions, choice: WorldChoice, trace: Trace, virtual: VirtualSkills,
                    problem_for: ProblemFor, worker: bool) -> System:
    """A world in this process: the simulated body, the stock skills, the layers and the executive.
    An error in the world a program names is located at its ``(world ...)`` form."""
    from atlas_rap.sim.world import load_world, world_path

    try:
        world_file = world_path(choice.name).resolve()
        world = load_world(choice.name)
    except SourceError:
        raise
    except AtlasError as exc:
        if choice.form is None:
            raise
        raise located(exc, choice.form, choice.line) from None
    believed = world if options.prior_map else world.without_map()
    simulation, manager = simulated_robot(world, believed, options.seed, options.rates)
    manager.context.beliefs[LOCALISATION] = options.localisation
    if options.topology is not None:
        from atlas_rap.maps.topology import Topology

        manager.context.beliefs[TOPOLOGY] = Topology.from_json(options.topology)
    skills = CombinedSkills(manager, virtual)
    sequencer = Sequencer(skills=skills, trace=trace)
    deliberation = planning_beside(sequencer, problem_for, options, worker)
    stack = layer_stack(options, sequencer, manager, believed, world)
    clock = (WallClock if options.realtime else Clock)(options.rates.physics)
    driver = Executive(simulation, manager, sequencer, options.rates, stack=stack, clock=clock)
    return System(options, trace, virtual, skills, sequencer, deliberation, driver, world=world, believed=believed,
                  world_file=world_file, simulation=simulation, robot=simulation, manager=manager, stack=stack)


def simulated_robot(world: World, believed: World, seed: int, rates: Rates) -> tuple[Simulation, SkillManager]:
    """The simulated body in ``world`` and the stock skills on it, which know ``believed`` of the world
    (``atlas run`` here, and each session of ``atlas skills serve``)."""
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.skills.stock import stock_manager

    simulation = Simulation(world, seed=seed, dt=1.0 / rates.physics)
    return simulation, stock_manager(believed, simulation, simulation.rng)


def layer_stack(options: RunOptions, sequencer: Sequencer, manager: SkillManager, believed: World,
                world: World) -> LayerStack:
    """The four layers over the robot's beliefs; Layer IV only when there is a map to build. ``world``
    (the true one) only draws the area of ``options.errand`` Layer IV measures the map over."""
    stack = LayerStack(sequencer, manager.context.beliefs, believed, enabled=options.layers,
                       prior_map=options.prior_map)
    stack.rules_source = str(options.rules_file)
    stack.add(MonitoringLayer(stack))
    stack.add(OperationalLayer(stack))
    stack.add(TacticalLayer(stack))
    if options.maps_while_driving:
        grid = map_in(options.map_in, believed) if options.map_in is not None else None
        stack.add(StrategicLayer(stack, grid, area=errand_area_of(options, world, grid)))
    if not stack.active():
        raise RunError(f"--layers {','.join(options.layers)}: Layer IV maps, so it runs only when the "
                       f"robot maps (--no-prior-map or --map-in); enable I, II or III as well")
    return stack


def errand_area_of(options: RunOptions, world: World, grid: OccupancyGrid | None) -> np.ndarray | None:
    """The mask of the area ``options.errand`` needs, on the grid's frame (None: no errand given)."""
    if not options.errand:
        return None
    from atlas_rap.maps.errand_area import errand_area
    from atlas_rap.maps.frame import GridFrame

    frame = grid.frame if grid is not None else GridFrame.covering(world.bounds, GRID_RESOLUTION)  # Layer IV's new grid's
    try:
        return errand_area(world, frame, options.errand)
    except ValueError as exc:
        raise RunError(f"the errand's area: {exc}") from None


def map_in(path: str | Path, world: World) -> OccupancyGrid:
    """The grid of ``--map-in``, checked: a grid file, and one that covers the world."""
    from atlas_rap.maps.grid import OccupancyGrid

    try:
        grid = OccupancyGrid.load_npz(path)
    except (OSError, KeyError, ValueError) as exc:
        raise MapError(f"{path}: not an occupancy grid written by atlas run --map-out or "
                       f"atlas map build ({exc})") from None
    xmin, ymin, xmax, ymax = world.bounds
    frame = grid.frame
    inset = frame.resolution / 2
    corners = [frame.world_to_cell(x, y) for x in (xmin + inset, xmax - inset) for y in (ymin + inset, ymax - inset)]
    if not all(frame.contains_cell(row, col) for row, col in corners):
        raise MapError(f"{path}: this grid does not cover world {world.name} "
                       f"(x {xmin:g}..{xmax:g}, y {ymin:g}..{ymax:g}); was it built in another world?")
    return grid


BUILDERS: dict[str, Builder] = {"simulated": build_simulated, "virtual": build_virtual, "remote": build_remote}
"""The backends, by :func:`backend_for`'s name."""

"""Layer II, Operational: action execution and monitoring on the stochastic SDT (seed Table 1).

The RAP sequencer runs in Layer II's slot, at the operational rate (the
executive steps it), so RAPs live here: ``(navigate-to office)`` is a
Layer II action whichever layer plans the way.

When Layer II drives, the route is planned once on the best map the robot
has, and followed; ``navigate-to`` monitors the progress along it (no
progress for its patience: it fails, and the RAP recovers). The map is,
in order:

1. the topological map (Layer III's, built from sonar, or ``atlas run
   --map``): the most probable short route along the SDT, then pulled
   taut on the known free cells of the grid (it keeps the SDT route's way
   through the building and its clearance, and loses the skeleton's detours);
   a route the grid shows blocked (the topology is older than the grid) is
   not taken;
2. the prior map's places and doors (a run with a prior map);
3. the occupancy grid, on its known free cells only (the unknown is not
   passable for Layer II: it does not explore).

What Layer III found blocked is left out of every route: the doors, on the
prior map; the points, on a grid (where the obstacle is on the map too).
"""

from __future__ import annotations

from atlas_rap.layers.layer import Layer, LayerStack
from atlas_rap.model import Point
from atlas_rap.skills.beliefs import GRID, TOPOLOGY, PlannedRoute
from atlas_rap.skills.routes import PriorMapRoutes, TopologyRoutes


class OperationalLayer(Layer):
    """Layer II; see the module docstring."""

    name = "II"
    plans = True
    period = 0.1

    def route(self, goal: str, start: Point, closed: set[str]) -> PlannedRoute | str:
        return route_on_maps(self.stack, goal, start, closed, self.name)


def route_on_maps(stack: LayerStack, goal: str, start: Point, closed: set[str], by: str) -> PlannedRoute | str:
    """A route on the best map the robot has (see the module docstring), avoiding ``stack.blocks``."""
    world = stack.world
    topology = stack.beliefs.get(TOPOLOGY)
    if topology is not None:
        source = TopologyRoutes(world, topology, by)  # the blocks are on the grid the topology is made from
        if stack.prior_map:
            source.avoid = list(stack.blocks)
        answer = source.route(goal, start, closed)
        if isinstance(answer, PlannedRoute):
            if stack.beliefs.get(GRID) is None:
                return answer
            planner = stack.grid_planner(unknown_passable=False)
            along = planner.plan_along(start, world.places[goal].point, answer.waypoints)
            if along is not None:
                return PlannedRoute(along.waypoints, answer.doors, by)
            taut = planner.pull_taut(answer.waypoints)
            if not planner.blocked(taut):
                return PlannedRoute(taut.waypoints, answer.doors, by)
        elif stack.prior_map:
            return answer
    if stack.prior_map:
        source = PriorMapRoutes(world, by)
        source.avoid = set(stack.blocked_doors)
        return source.route(goal, start, closed)
    grid = stack.beliefs.get(GRID)
    if grid is None:
        return f"Layer {by} has no map to plan a route to {goal} on"
    path = stack.grid_planner(unknown_passable=False).plan(start, world.places[goal].point)
    if path is None:
        return f"no route to {goal} on the known part of the map"
    return PlannedRoute(path.waypoints, {}, by)


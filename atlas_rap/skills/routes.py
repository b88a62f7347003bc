"""Routes over the prior map: places joined by doors, as waypoints the robot can drive.

The world's places and doors form a graph (a place is a node, a door an
edge between its two places). :func:`plan_route` finds the shortest route
(Dijkstra on waypoint distances, plus ``DOOR_COST`` a door) from where the robot is to a place,
leaving out the doors believed closed, and returns the waypoints: for each
door, a point in front of it on this side, its centre and a point past it,
then the place's point. This is the seed's Layer III in its simplest form;
the topological maps built from sonar replace the prior map later.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

from atlas_rap.model import Door, Point, World
from atlas_rap.skills.beliefs import PlannedRoute

DOOR_CLEARANCE = 0.7
DOOR_COST = 2.0
"""Metres a route is charged for each door it passes: doorways are slow and may be closed."""


@dataclass(frozen=True, slots=True)
class Route:
    """A way to a place: the places passed, the doors used and the waypoints to drive."""

    places: tuple[str, ...]
    doors: tuple[str, ...]
    waypoints: tuple[Point, ...]

    @property
    def length(self) -> float:
        return sum(math.dist(a, b) for a, b in zip(self.waypoints, self.waypoints[1:]))


def where_is(world: World, x: float, y: float) -> str | None:
    """The place the point is in, or else the place whose point is nearest."""
    place = world.place_at(x, y)
    if place is not None or not world.places:
        return place
    return min(world.places.values(), key=lambda p: math.dist(p.point, (x, y))).name


def plan_route(world: World, start: Point, goal: str, closed: frozenset[str] | set[str] = frozenset()) -> Route | None:
    """The shortest route from ``start`` to the place ``goal`` avoiding ``closed`` doors, or None."""
    origin = where_is(world, *start)
    if origin is None or goal not in world.places:
        return None
    best: dict[str, float] = {origin: 0.0}
    queue: list[tuple[float, int, str, Point, tuple[str, ...], tuple[str, ...], tuple[Point, ...]]] = [
        (0.0, 0, origin, start, (origin,), (), ())]
    order = 1
    while queue:
        cost, _, place, here, places, doors, points = heapq.heappop(queue)
        if place == goal:
            final = world.places[goal].point
            return Route(places, doors, points + (final,))
        if cost > best.get(place, math.inf):
            continue
        for door in world.doors.values():
            if door.name in closed or place not in door.between:
                continue
            other = door.between[1] if door.between[0] == place else door.between[0]
            through = door_waypoints(world, door, place, other)
            step = DOOR_COST + math.dist(here, through[0]) + sum(math.dist(a, b) for a, b in zip(through, through[1:]))
            if other == goal:
                step += math.dist(through[-1], world.places[goal].point)
            if cost + step < best.get(other, math.inf):
                best[other] = cost + step
                heapq.heappush(queue, (cost + step, order, other, through[-1], places + (other,),
                                       doors + (door.name,), points + through))
                order += 1
    return None


def door_waypoints(world: World, door: Door, from_place: str, to_place: str) -> tuple[Point, ...]:
    """In front of the door on ``from_place``'s side, its centre, and past it on ``to_place``'s side."""
    if door.segment is None:
        return (door.center,)
    a, b = door.side_points(DOOR_CLEARANCE)
    source = world.places[from_place]
    if source.contains(*b) and not source.contains(*a):
        a, b = b, a
    elif not source.contains(*a) and math.dist(b, source.point) < math.dist(a, source.point):
        a, b = b, a
    return a, door.center, b


def door_positions(world: World, route: Route) -> dict[str, int]:
    """For each door of ``route``, the index of the last waypoint before passing it."""
    positions, index, here = {}, 0, route.places[0]
    for door_name, there in zip(route.doors, route.places[1:]):
        positions[door_name] = index
        index += len(door_waypoints(world, world.doors[door_name], here, there))
        here = there
    return positions


class PriorMapRoutes:
    """A :class:`~atlas_rap.skills.beliefs.RouteSource` on the prior map: places joined by doors.

    ``avoid`` are doors the robot found blocked by an obstacle (Layer III):
    left out as if closed. The prior map has no geometry to go round
    anything else by.
    """

    def __init__(self, world: World, by: str = "prior map") -> None:
        self.world = world
        self.by = by
        self.revision = 0
        self.avoid: set[str] = set()

    def route(self, goal: str, start: Point, closed: set[str]):
        world = self.world
        blocked = set(self.avoid)
        route = plan_route(world, start, goal, set(closed) | blocked)
        if route is None:
            here = where_is(world, *start)
            known = f" (doors seen closed: {', '.join(sorted(closed))})" if closed else ""
            cut = f" (blocked: {', '.join(sorted(blocked))})" if blocked else ""
            return f"no route from {here} to {goal}{known}{cut}"
        return PlannedRoute(route.waypoints, door_positions(world, route), self.by)


class TopologyRoutes:
    """A :class:`~atlas_rap.skills.beliefs.RouteSource` on a topological map (Layer III's, or ``--map``)."""

    def __init__(self, world: World, topology, by: str = "topology") -> None:
        self.world = world
        self.topology = topology
        self.by = by
        self.revision = 0
        self.avoid: list[Point] = []

    def route(self, goal: str, start: Point, closed: set[str]):
        world = self.world
        avoid = [world.doors[door].center for door in sorted(closed) if door in world.doors] + list(self.avoid)
        found = self.topology.route(start, world.places[goal].point, avoid=avoid)
        if found is None:
            known = f" (doors seen closed: {', '.join(sorted(closed))})" if closed else ""
            return f"no route on the topological map from {where_is(world, *start)} to {goal}{known}"
        waypoints = tuple((float(x), float(y)) for x, y in found.waypoints)
        doors = {}
        for door in world.doors.values():
            if door.segment is None:
                continue
            gaps = [_distance_to_segment(door.center, a, b) for a, b in zip(waypoints, waypoints[1:])]
            if gaps and min(gaps) < 0.5:
                doors[door.name] = gaps.index(min(gaps))
        return PlannedRoute(waypoints, doors, self.by)


def _distance_to_segment(p: Point, a: Point, b: Point) -> float:
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / length2))
    return math.hypot(p[0] - ax - t * dx, p[1] - ay - t * dy)

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

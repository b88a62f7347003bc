"""Going to named places: the navigate-to and open-door skills.

``(navigate-to PLACE)`` plans a route over the prior map (places and
doors, ``skills.routes``), leaving out the doors the robot has seen closed,
and follows its waypoints around obstacles. When a door on its way is seen
closed (the door monitor's belief), or it makes no progress, it stops,
asserts ``(blocked robot WHAT)`` and fails with the reason, so that the
``go-to`` RAP can recover: open the door, or navigate again, which plans
another way round. ``(open-door DOOR)`` drives up to a door that the robot
can open (``openable`` in the world) and opens it.

With a topological map built from sonar (``atlas map build``, then
``atlas run --map DIR/topology.json``), navigate-to plans on that graph
instead (ATLAS Layer III): the most probable short route along the
skeleton, leaving out edges through doors seen closed.
"""

from __future__ import annotations

import math

import numpy as np
from typing import Any, Mapping

from atlas_rap.logic import Compound, Var
from atlas_rap.skills.motion import FollowRoute, _Driving
from atlas_rap.skills.routes import door_waypoints, plan_route, where_is

CLOSED_DOORS = "closed-doors"
"""The belief (a set of door names) the door monitor keeps and the route planner avoids."""

TOPOLOGY = "topology"
"""The belief holding a topological map built from sonar (``atlas run --map``); routes are planned on it when set."""


class NavigateTo(FollowRoute):
    """``(navigate-to PLACE)``: drive to a named place by a route through open doors."""

    name = "navigate-to"
    params = ("place",)
    events = ("blocked",)

    def enable(self, args: tuple[Any, ...]) -> None:
        _Driving.enable(self, args)
        context = self.context
        context.retract_matching(Compound("blocked", ("robot", Var("what"))))
        self.goal = str(args[0])
        self.waypoints, self.index, self.door_at = [], 0, {}
        self.failure: str | None = None
        world = context.world
        if self.goal not in world.places:
            self.failure = f"there is no place named {self.goal} in world {world.name}"
            return
        x, y, _ = context.robot.odometry
        closed = context.beliefs.get(CLOSED_DOORS, set())
        topology = context.beliefs.get(TOPOLOGY)
        if topology is not None:
            self._route_on_topology(topology, (x, y), closed)
            return
        route = plan_route(world, (x, y), self.goal, closed)
        if route is None:
            here = where_is(world, x, y)
            known = f" (doors seen closed: {', '.join(sorted(closed))})" if closed else ""
            self.failure = f"no route from {here} to {self.goal}{known}"
            return
        self.route = route
        self.waypoints = list(route.waypoints)
        self.door_at = self._door_positions(route)

    def _route_on_topology(self, topology, start: tuple[float, float], closed: set[str]) -> None:
        """Plan on the topological map built from sonar, leaving out edges through doors seen closed."""
        world = self.context.world
        avoid = [world.doors[door].center for door in sorted(closed)]
        route = topology.route(start, world.places[self.goal].point, avoid=avoid)
        if route is None:
            known = f" (doors seen closed: {', '.join(sorted(closed))})" if closed else ""
            self.failure = f"no route on the topological map from {where_is(world, *start)} to {self.goal}{known}"
            return
        self.waypoints = [(float(x), float(y)) for x, y in route.waypoints]
        self.door_at = {}
        for door in world.doors.values():
            if door.segment is None:
                continue
            gaps = [_distance_to_segment(door.center, a, b) for a, b in zip(self.waypoints, self.waypoints[1:])]
            if gaps and min(gaps) < 0.5:
                self.door_at[door.name] = int(np.argmin(gaps))

    def _door_positions(self, route) -> dict[str, int]:
        """For each door of the route, the index of the last waypoint before passing it."""
        positions, index, here = {}, 0, route.places[0]
        for door_name, there in zip(route.doors, route.places[1:]):
            door = self.context.world.doors[door_name]
            positions[door_name] = index
            index += len(door_waypoints(self.context.world, door, here, there))
            here = there
        return positions

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        if self.failure is not None:
            self.context.assert_fact(Compound("blocked", ("robot", "no-route")))
            self.context.finish(self, ":fail", self.failure)
            return {"command": (0.0, 0.0)}
        pose = inputs["pose"]
        if pose is None:
            return {}
        closed = self.context.beliefs.get(CLOSED_DOORS, set())
        for door, position in self.door_at.items():
            if door in closed and self.index <= position + 1:
                self.context.assert_fact(Compound("blocked", ("robot", door)))
                self.context.finish(self, ":fail", f"door {door} on the way to {self.goal} is closed")
                return {"command": (0.0, 0.0)}
        return self.follow(pose, inputs["sonar"])


class OpenDoor(_Driving):
    """``(open-door DOOR)``: drive up to a door the robot can open, press, and wait until it is open."""

    name = "open-door"
    params = ("door",)
    events = ("door-open",)
    press_time = 1.5

    def enable(self, args: tuple[Any, ...]) -> None:
        super().enable(args)
        self.door = self.context.world.doors.get(str(args[0]))
        self.pressed_at: float | None = None

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        context, door = self.context, self.door
        if door is None:
            context.finish(self, ":fail", f"there is no door named {self.args[0]}")
            return {}
        if not door.openable:
            context.finish(self, ":fail", f"door {door.name} cannot be opened by the robot")
            return {}
        pose = inputs["pose"]
        if pose is None:
            return {}
        if self.pressed_at is None:
            a, b = door.side_points(0.6)
            front = min((a, b), key=lambda p: math.dist(p, pose[:2]))
            out, arrived = self.drive_to(pose, front, inputs["sonar"], final=True)
            if not arrived:
                if self.progress.stuck(math.dist(pose[:2], front), context.now()):
                    return self.give_up(f"could not reach door {door.name}")
                return out
            self.pressed_at = context.now()
        if context.now() - self.pressed_at >= self.press_time:
            context.robot.set_door(door.name, True)
            context.beliefs.setdefault(CLOSED_DOORS, set()).discard(door.name)
            context.retract_fact(Compound("door-closed", (door.name,)))
            context.assert_fact(Compound("door-open", (door.name,)))
            context.finish(self)
        return {"command": (0.0, 0.0)}


def _distance_to_segment(p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / length2))
    return math.hypot(p[0] - ax - t * dx, p[1] - ay - t * dy)

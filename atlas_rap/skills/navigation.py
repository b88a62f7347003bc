"""Going to named places: the navigate-to and open-door skills.

``(navigate-to PLACE)`` plans a route over the prior map (places and
doors, ``skills.routes``), leaving out the doors the robot has seen closed,
and follows its waypoints around obstacles. When a door on its way is seen
closed (the door monitor's belief), or it makes no progress, it stops,
asserts ``(blocked robot WHAT)`` and fails with the reason, so that the
``go-to`` RAP can recover: open the door, or navigate again, which plans
another way round. ``(open-door DOOR)`` drives up to a door that the robot
can open (``openable`` in the world) and opens it.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from atlas_rap.logic import Compound, Var
from atlas_rap.skills.motion import FollowRoute, _Driving
from atlas_rap.skills.routes import door_waypoints, plan_route, where_is

CLOSED_DOORS = "closed-doors"
"""The belief (a set of door names) the door monitor keeps and the route planner avoids."""


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
        route = plan_route(world, (x, y), self.goal, closed)
        if route is None:
            here = where_is(world, x, y)
            known = f" (doors seen closed: {', '.join(sorted(closed))})" if closed else ""
            self.failure = f"no route from {here} to {self.goal}{known}"
            return
        self.route = route
        self.waypoints = list(route.waypoints)
        self.door_at = self._door_positions(route)

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

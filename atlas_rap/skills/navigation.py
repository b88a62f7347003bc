"""Going to named places: the navigate-to and open-door skills.

``(navigate-to PLACE)`` asks a *route source* for a route and follows its
waypoints around obstacles. The source is the belief
:data:`~atlas_rap.skills.beliefs.ROUTES`: in a run it is the ATLAS layer
stack, which asks whichever layer is primary (the prior map's places and
doors, the topology built from sonar, or the occupancy grid); alone (a unit
test of the skill), it is the prior map, or the topological map of ``atlas
run --map``. When the source has a better route (its ``revision`` grows: a
re-plan on a newer grid, a re-route round a block), navigate-to takes it.
When a door on its way is seen closed (the door monitor's belief), or it
makes no progress, it stops, asserts ``(blocked robot WHAT)`` and fails with
the reason, so that the ``go-to`` RAP can recover: open the door, or
navigate again, which plans another way round. ``(open-door DOOR)`` drives
up to a door that the robot can open (``openable`` in the world) and opens it.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from atlas_rap.logic import Compound, Var
from atlas_rap.skills.beliefs import CLOSED_DOORS, GOAL, POSE, ROUTE, ROUTES, TOPOLOGY, FollowedRoute, Goal, PlannedRoute
from atlas_rap.skills.catalog import registered
from atlas_rap.skills.motion import FollowRoute, _Driving
from atlas_rap.skills.routes import PriorMapRoutes, TopologyRoutes


@registered("navigate-to")
class NavigateTo(FollowRoute):
    """``(navigate-to PLACE)``: drive to a named place by the route its route source gives."""

    def enable(self, args: tuple[Any, ...]) -> None:
        _Driving.enable(self, args)
        context = self.context
        context.retract_matching(Compound("blocked", ("robot", Var("what"))))
        self.goal = str(args[0])
        self.waypoints, self.index, self.door_at = [], 0, {}
        self.failure: str | None = None
        self.revision: int | None = None
        world = context.world
        if self.goal not in world.places:
            self.failure = f"there is no place named {self.goal} in world {world.name}"
            return
        context.beliefs[GOAL] = Goal(self.goal, world.places[self.goal].point)
        self.source = context.beliefs.get(ROUTES) or self._own_source()
        self._plan()

    def _own_source(self):
        """Without the layers: the topological map of ``--map`` if there is one, else the prior map."""
        topology = self.context.beliefs.get(TOPOLOGY)
        source = TopologyRoutes(self.context.world, topology) if topology is not None else PriorMapRoutes(
            self.context.world)
        self.context.beliefs[ROUTES] = source
        return source

    def _plan(self) -> None:
        """Ask the route source for a route from here; take it, or keep the reason there is none."""
        context = self.context
        x, y, _ = context.beliefs[POSE]
        self.revision = self.source.revision
        answer = self.source.route(self.goal, (x, y), context.beliefs.get(CLOSED_DOORS) or set())
        if not isinstance(answer, PlannedRoute):
            self.failure = str(answer)
            return
        self.waypoints, self.index, self.door_at = list(answer.waypoints), 0, dict(answer.doors)
        context.beliefs[ROUTE] = FollowedRoute(self.goal, answer.waypoints, 0, answer.by, dict(answer.doors))
        self.progress.reset(context.now())

    def disable(self) -> None:
        self.context.beliefs.pop(GOAL)
        self.context.beliefs.pop(ROUTE)

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        if self.failure is None and self.revision is not None and self.source.revision != self.revision:
            self._plan()
        if self.failure is not None:
            self.context.assert_fact(Compound("blocked", ("robot", "no-route")))
            self.context.finish(self, ":fail", self.failure)
            return {"command": (0.0, 0.0)}
        pose = inputs["pose"]
        if pose is None:
            return {}
        closed = self.context.beliefs.get(CLOSED_DOORS) or set()
        for door, position in self.door_at.items():
            if door in closed and self.index <= position + 1:
                self.context.assert_fact(Compound("blocked", ("robot", door)))
                self.context.finish(self, ":fail", f"door {door} on the way to {self.goal} is closed")
                return {"command": (0.0, 0.0)}
        out = self.follow(pose, inputs["sonar"])
        followed = self.context.beliefs.get(ROUTE)
        if followed is not None:
            followed.index = self.index
        return out


@registered("open-door")
class OpenDoor(_Driving):
    """``(open-door DOOR)``: drive up to a door the robot can open, press, and wait until it is open."""

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


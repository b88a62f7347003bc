"""``creep``: a motion skill that drives the simulated robot straight ahead, slowly, for a distance.

``(creep DISTANCE SPEED)`` drives forward at ``SPEED`` m/s (at most the
robot's top speed) until it has gone ``DISTANCE`` metres from where it was
enabled, then finishes ``:succeed``. When the sonar sees something closer
than :data:`CLEARANCE` ahead it stops, posts ``(blocked robot creep)`` and
finishes ``:fail`` saying why. Like the stock motion skills it writes
``command`` = (v, omega), which the safety reflex and the wheels take.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from atlas_rap.logic import Compound
from atlas_rap.skills import Skill

CLEARANCE = 0.35
"""Metres of free space ahead (from the robot's rim) the robot keeps."""

AHEAD = math.radians(20)
"""The sonar beams within this angle of the robot's heading look ahead."""


class Creep(Skill):
    """Drive straight ahead ``distance`` metres at ``speed``; stop and fail before a wall."""

    name = "creep"
    params = ("distance: number", "speed: number")
    events = ("blocked",)
    rate = 20.0
    inputs = ("pose", "sonar")
    outputs = ("command",)

    def enable(self, args: tuple[Any, ...]) -> None:
        super().enable(args)
        distance, speed = (float(arg) for arg in args)
        world = self.context.world
        top = world.robot.max_speed if world is not None else 0.5
        self.distance, self.speed = distance, max(0.0, min(speed, top))
        self.start: tuple[float, float] | None = None

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        pose, sonar = inputs["pose"], inputs["sonar"]
        if pose is None or sonar is None:
            return {}
        if self.start is None:
            self.start = (pose[0], pose[1])
        if math.dist(self.start, (pose[0], pose[1])) >= self.distance:
            self.context.finish(self)
            return {"command": (0.0, 0.0)}
        ranges, angles = sonar
        ahead = [r for r, a in zip(ranges, angles) if abs(math.remainder(a, math.tau)) < AHEAD]
        if ahead and min(ahead) < CLEARANCE:
            self.context.assert_fact(Compound("blocked", ("robot", "creep")))
            self.context.finish(self, ":fail", f"something {min(ahead):.2f} m ahead")
            return {"command": (0.0, 0.0)}
        return {"command": (self.speed, 0.0)}

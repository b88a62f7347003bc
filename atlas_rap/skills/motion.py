"""Motion skills that RAPs enable: move-to, follow-route, turn-to, spin, wander, wall-follow, stop.

Each writes ``command`` = (v, ω) for the safety reflex and the wheels, and
finishes with ``(done (SKILL ARG ...) :succeed)`` when it has got where it
was told, or ``:fail`` with a reason, after asserting ``(blocked robot
SKILL)``, when it makes no progress for ``patience`` seconds (an obstacle
it cannot get round). Spin, wander and wall-follow never finish on their own
(``look-around``, in :mod:`atlas_rap.skills.camera`, turns once and finishes).
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from atlas_rap.logic import Compound
from atlas_rap.skills.avoidance import angle_difference, angle_wrap, steer
from atlas_rap.skills.beliefs import HOLD, SPEED_LIMIT
from atlas_rap.skills.catalog import registered
from atlas_rap.skills.skill import Skill

ARRIVED = 0.2  # metres from a final goal that count as there
PASSED = 0.35  # metres from an intermediate waypoint that count as passed


class Progress:
    """Notices when the robot stops getting closer to its goal."""

    def __init__(self, patience: float = 8.0, gain: float = 0.15) -> None:
        self.patience = patience
        self.gain = gain
        self.best = math.inf
        self.since = 0.0

    def reset(self, now: float) -> None:
        self.best = math.inf
        self.since = now

    def stuck(self, distance: float, now: float) -> bool:
        """True when ``distance`` has not improved by ``gain`` for ``patience`` seconds."""
        if distance < self.best - self.gain:
            self.best = distance
            self.since = now
        return now - self.since > self.patience


class _Driving(Skill):
    """A motion skill: knows the robot's limits and how to give up."""

    inputs = ("pose", "sonar")
    outputs = ("command",)

    def init(self, context) -> None:
        super().init(context)
        robot = context.world.robot if context.world is not None else None
        self.max_speed = robot.max_speed if robot is not None else 0.5
        self.max_turn = robot.max_turn_rate if robot is not None else 1.5
        self.progress = Progress()

    def enable(self, args: tuple[Any, ...]) -> None:
        super().enable(args)
        self.progress.reset(self.context.now())

    def give_up(self, why: str) -> dict[str, Any]:
        self.context.assert_fact(Compound("blocked", ("robot", self.name)))
        self.context.finish(self, ":fail", why)
        return {"command": (0.0, 0.0)}

    def drive_to(self, pose, goal, sonar, final: bool) -> tuple[dict[str, Any], bool]:
        """Steer toward ``goal``; (outputs, arrived)."""
        distance = math.dist(pose[:2], goal)
        if distance < (ARRIVED if final else PASSED):
            return {"command": (0.0, 0.0)}, True
        limit = self.context.beliefs.get(SPEED_LIMIT)
        speed = self.max_speed if limit is None else self.max_speed * limit
        v, omega = steer(pose, goal, sonar, max_speed=speed, max_turn=self.max_turn,
                         arrive_radius=0.8 if final else 0.3)
        return {"command": (v, omega)}, False


@registered("follow-route")
class FollowRoute(_Driving):
    """``(follow-route ((X1 Y1) (X2 Y2) ...))``: pass each waypoint in turn, stop at the last."""

    def enable(self, args: tuple[Any, ...]) -> None:
        super().enable(args)
        self.waypoints = [(float(p[0]), float(p[1])) for p in args[0]]
        self.index = 0

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        pose = inputs["pose"]
        if pose is None or not self.waypoints:
            return {}
        return self.follow(pose, inputs["sonar"])

    def follow(self, pose, sonar) -> dict[str, Any]:
        """Drive along ``self.waypoints``; finish at the last one. While Layer I holds the
        robot, no progress is expected."""
        if HOLD in self.context.beliefs:
            self.progress.reset(self.context.now())
        goal = self.waypoints[self.index]
        final = self.index == len(self.waypoints) - 1
        out, arrived = self.drive_to(pose, goal, sonar, final)
        if arrived:
            if final:
                self.context.finish(self)
                return out
            self.index += 1
            self.progress.reset(self.context.now())
            return self.drive_to(pose, self.waypoints[self.index], sonar,
                                 self.index == len(self.waypoints) - 1)[0]
        if self.progress.stuck(math.dist(pose[:2], goal), self.context.now()):
            which = f"waypoint {self.index + 1} " if len(self.waypoints) > 1 else ""
            return self.give_up(f"no progress toward {which}({goal[0]:g}, {goal[1]:g}) "
                                f"for {self.progress.patience:g} s")
        return out


@registered("move-to")
class MoveTo(FollowRoute):
    """``(move-to X Y)``: go to the point (X, Y) around obstacles (a route of one waypoint)."""

    def enable(self, args: tuple[Any, ...]) -> None:
        _Driving.enable(self, args)
        self.waypoints = [(float(args[0]), float(args[1]))]
        self.index = 0


@registered("turn-to")
class TurnTo(Skill):
    """``(turn-to HEADING-DEGREES)``: turn on the spot to face a heading."""

    inputs = ("pose",)
    outputs = ("command",)

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        pose = inputs["pose"]
        if pose is None:
            return {}
        error = angle_difference(math.radians(float(self.args[0])), pose[2])
        if abs(error) < math.radians(3):
            self.context.finish(self)
            return {"command": (0.0, 0.0)}
        turn = self.context.world.robot.max_turn_rate if self.context.world is not None else 1.5
        return {"command": (0.0, max(-turn, min(turn, 2.0 * error)))}


@registered("spin")
class Spin(Skill):
    """``(spin)``: turn on the spot, counter-clockwise at half the top turn rate, until disabled (nav2's
    Spin recovery): a lost robot's sonar sweeps the room around it, and the localiser sees the whole
    of it instead of one side."""

    outputs = ("command",)

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        turn = self.context.world.robot.max_turn_rate if self.context.world is not None else 1.5
        return {"command": (0.0, 0.5 * turn)}


@registered("stop")
class Stop(Skill):
    """``(stop)``: command zero velocity, and finish once the command is out."""

    outputs = ("command",)

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        self.context.finish(self)
        return {"command": (0.0, 0.0)}


@registered("wander")
class Wander(Skill):
    """``(wander)``: drive ahead, turning away from echoes, with a random drift (never finishes)."""

    inputs = ("sonar",)
    outputs = ("command",)

    def enable(self, args: tuple[Any, ...]) -> None:
        super().enable(args)
        self.drift = 0.0

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        sonar = inputs["sonar"]
        if sonar is None:
            return {}
        ranges, angles = sonar
        rng = self.context.rng
        self.drift = 0.9 * self.drift + 0.1 * (float(rng.normal(0.0, 0.6)) if rng is not None else 0.0)
        heading = math.atan2(float(np.sum(np.sin(angles) * ranges)), float(np.sum(np.cos(angles) * ranges)))
        speed = self.context.world.robot.max_speed * 0.6 if self.context.world is not None else 0.3
        return {"command": (speed, 1.5 * heading + self.drift)}


@registered("wall-follow")
class WallFollow(Skill):
    """``(wall-follow SIDE)``: keep a wall at ``distance`` on the left or right (never finishes)."""

    inputs = ("sonar",)
    outputs = ("command",)
    distance = 0.5

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        sonar = inputs["sonar"]
        if sonar is None:
            return {}
        ranges, angles = sonar
        sign = 1.0 if str(self.args[0]) == "left" else -1.0
        side = np.abs(angle_wrap(angles - sign * math.pi / 2)) < math.radians(30)
        ahead = np.abs(angle_wrap(angles)) < math.radians(25)
        side_range = float(ranges[side].min()) if side.any() else self.distance
        ahead_range = float(ranges[ahead].min()) if ahead.any() else math.inf
        turn = sign * 1.5 * (side_range - self.distance)
        if ahead_range < 0.6:
            turn = -sign * 1.2
        speed = self.context.world.robot.max_speed * 0.5 if self.context.world is not None else 0.25
        return {"command": (speed if ahead_range > 0.3 else 0.0, turn)}

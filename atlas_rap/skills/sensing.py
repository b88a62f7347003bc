"""Sensor and actuator skills: the robot's body as skills (always on).

They connect the skill network to the robot: ``sonar`` (the ring's ranges
and their body-frame angles), ``bump`` (the bumper),
and the ``drive`` actuator, which sends the final velocity command
(``safe-command``, after the safety reflex) to the wheels and stops the
robot when no skill commands it. The ``pose`` comes from the localiser
(:mod:`atlas_rap.skills.localising`), from the odometry and the sonar.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from atlas_rap.skills.beliefs import BUMP, SONAR
from atlas_rap.skills.catalog import registered
from atlas_rap.skills.skill import Skill


@registered("sonar-ring")
class SonarSensor(Skill):
    """The sonar ring at its own rate: ``sonar`` = (ranges, angles), ranges from the robot's rim."""

    outputs = ("sonar",)

    def init(self, context) -> None:
        super().init(context)
        self.rate = float(context.world.sonar.rate) if context.world is not None else self.rate
        self.angles = np.asarray(context.robot.sonar_angles, dtype=float)

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        reading = (self.context.robot.sonar(), self.angles)
        self.context.beliefs[SONAR] = reading
        return {"sonar": reading}


@registered("bumper")
class Bumper(Skill):
    """The bumper: ``bump`` = the body-frame angle of a contact this period, or None; a contact is
    also the :data:`~atlas_rap.skills.beliefs.BUMP` belief, (time, angle), for the layers' map."""

    outputs = ("bump",)

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        robot = self.context.robot
        angle = robot.bump_angle if robot.bumped else None
        if angle is not None:
            self.context.beliefs[BUMP] = (self.context.now(), float(angle))
        return {"bump": angle}


@registered("drive")
class Drive(Skill):
    """The wheels: sends ``safe-command`` (v, ω) to the robot; no command means stop."""

    inputs = ("safe-command",)

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        command = inputs["safe-command"]
        v, omega = command if command is not None else (0.0, 0.0)
        self.context.robot.command(v, omega)
        return {}

"""The safety reflex: always on, between every motion skill and the wheels.

Gat's Alfred (seed 004) had reflexes below the sequencer that keep the
robot safe whatever the higher layers ask: slow down near obstacles, stop
before a collision, back off after a bump. This skill reads the motion
skills' ``command`` and the sonar and bumper, and writes ``safe-command``
for the ``drive`` actuator. It does not plan: a motion skill that keeps
pushing into an obstacle gets zero forward speed and notices it is blocked.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from atlas_rap.skills.beliefs import HOLD, REFLEXES
from atlas_rap.skills.catalog import registered
from atlas_rap.skills.skill import Skill

FRONT_HALF_ANGLE = math.radians(50)


@registered("safety-reflex")
class SafetyReflex(Skill):
    """``command`` + ``sonar`` + ``bump`` → ``safe-command``.

    Forward speed scales down linearly from ``slow_range`` to ``stop_range``
    (sonar range from the robot's rim, in the front sector); after a bump
    the robot reverses for ``backoff_time`` seconds, turning away. While
    Layer I holds the robot (the :data:`~atlas_rap.skills.beliefs.HOLD`
    belief) it stands still; with Layer I not enabled the reflex is off.
    """

    inputs = ("command", "sonar", "bump")
    outputs = ("safe-command",)

    slow_range = 0.6
    stop_range = 0.12
    backoff_time = 0.6
    backoff_speed = 0.12

    def init(self, context) -> None:
        super().init(context)
        self.backing_off_until = -1.0
        self.backoff_turn = 0.0
        self.front: np.ndarray | None = None

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        beliefs = self.context.beliefs
        if beliefs.get(REFLEXES) is False:  # Layer I is not enabled: the command goes to the wheels as it is
            return {"safe-command": inputs["command"]}
        now = self.context.now()
        bump = inputs["bump"]
        if bump is not None and math.cos(bump) > 0 and now >= self.backing_off_until:
            self.backing_off_until = now + self.backoff_time
            self.backoff_turn = -0.8 if math.sin(bump) > 0 else 0.8
        if now < self.backing_off_until:
            return {"safe-command": (-self.backoff_speed, self.backoff_turn)}
        command = inputs["command"]
        if command is None:
            return {"safe-command": None}
        if HOLD in beliefs:  # Layer I is primary: stop until the way is clear
            return {"safe-command": (0.0, 0.0)}
        v, omega = command
        sonar = inputs["sonar"]
        if sonar is not None and v > 0:
            ranges, angles = sonar
            if self.front is None or len(self.front) != len(angles):
                self.front = np.cos(angles) > math.cos(FRONT_HALF_ANGLE)
            nearest = float(ranges[self.front].min()) if self.front.any() else math.inf
            scale = (nearest - self.stop_range) / (self.slow_range - self.stop_range)
            v *= min(1.0, max(0.0, scale))
        return {"safe-command": (v, omega)}

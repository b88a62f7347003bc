"""``light-sensor``: a simulated light sensor, an always-on skill that posts a fact.

A sensor is a skill that is always on: it runs at its rate from the start of
a run and posts facts to RAP memory when what it senses changes. This one
reads the robot's pose (the localiser's ``pose`` output) and measures the
light of the world's place named ``lamp``: ``1 / (1 + d**2)`` at ``d`` metres
from the lamp's point. It posts ``(light robot bright)`` when the level
reaches :data:`BRIGHT` and ``(light robot dark)`` when it falls below it
(retracting the other). In a world with no ``lamp`` it senses nothing.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from atlas_rap.logic import Compound
from atlas_rap.skills import Skill

BRIGHT = 0.5
"""The light level from which the robot is in the light: within 1 m of the lamp."""


def light_level(position: tuple[float, float], lamp: tuple[float, float]) -> float:
    """The light at ``position`` from a lamp at ``lamp``: 1 at the lamp, falling with the square of the distance."""
    return 1.0 / (1.0 + math.dist(position, lamp) ** 2)


class LightSensor(Skill):
    """Posts ``(light robot bright)`` / ``(light robot dark)`` as the robot comes near the lamp or leaves it."""

    # The skill's declaration, the one place atlas reads it from (atlas skills list, atlas check, the bus):
    name = "light-sensor"
    events = ("light",)
    rate = 5.0
    always_on = True
    inputs = ("pose",)

    def init(self, context) -> None:
        super().init(context)
        world = context.world
        lamp = world.places.get("lamp") if world is not None else None
        self.lamp = lamp.point if lamp is not None else None
        self.state: str | None = None

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        pose = inputs["pose"]
        if self.lamp is None or pose is None:
            return {}
        state = "bright" if light_level((pose[0], pose[1]), self.lamp) >= BRIGHT else "dark"
        if state != self.state:
            if self.state is not None:
                self.context.retract_fact(Compound("light", ("robot", self.state)))
            self.context.assert_fact(Compound("light", ("robot", state)))
            self.state = state
        return {}

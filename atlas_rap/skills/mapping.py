"""Mapping skills: the robot builds its occupancy grid from the sonar as it goes (seed §3.2).

:class:`MapBuilder` is always on: at 10 Hz it fuses the latest sonar ring
into an :class:`~atlas_rap.maps.grid.OccupancyGrid` covering the world's
bounds, at the pose the robot believes it has (odometry). The grid and the
poses it was built from are beliefs, shared with the skills and layers that
reason about space (``context.beliefs["grid"]`` and
``context.beliefs["poses"]``), e.g. to make an
:class:`~atlas_rap.maps.inference.InferenceGrid` or the abstract maps.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.model import SonarConfig
from atlas_rap.skills.skill import Skill


class MapBuilder(Skill):
    """Fuses each new sonar ring into ``beliefs["grid"]`` at the believed pose; ``beliefs["poses"]`` lists the poses.

    A ring is fused once: when the sonar has not produced a new reading
    since the last tick (the same array), the tick does nothing. Without a
    pose or a reading yet, it waits.
    """

    name = "map-builder"
    inputs = ("pose", "sonar")
    always_on = True
    rate = 10.0
    resolution = 0.05  # metres per cell of the grid built

    def init(self, context) -> None:
        super().init(context)
        world = context.world
        if world is None:
            raise ValueError("map-builder needs a world (for its bounds and sonar settings)")
        self.config: SonarConfig = world.sonar
        robot = getattr(context, "robot", None)
        self.robot_radius = float(getattr(robot, "radius", world.robot.radius))
        self.grid = OccupancyGrid.covering(world.bounds, self.resolution)
        self.poses: list[tuple[float, float, float]] = []
        context.beliefs["grid"] = self.grid
        context.beliefs["poses"] = self.poses
        self._last_reading: Any = None

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        pose, sonar = inputs.get("pose"), inputs.get("sonar")
        if pose is None or sonar is None:
            return {}
        ranges, angles = sonar
        if ranges is self._last_reading:
            return {}
        self._last_reading = ranges
        x, y, heading = (float(v) for v in pose)
        self.grid.update_sonar(x, y, heading, ranges, angles, self.robot_radius, self.config)
        self.poses.append((x, y, heading))
        return {}

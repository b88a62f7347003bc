"""The static shapes of the simulated world and what each collides with.

A wall or a door leaf is two shapes: a segment of radius :data:`WALL_RADIUS`
that the robot collides with, and a zero-thickness copy on its centre line
that only the sonar sees (so readings measure the world's true geometry; see
:mod:`atlas_rap.sim.sonar`). Boxes and people are obstacles: exact shapes
both collided with and seen. :class:`~atlas_rap.sim.physics.Simulation`,
:mod:`~atlas_rap.sim.doors` and :mod:`~atlas_rap.sim.disturbances` build
their shapes from these.
"""

from __future__ import annotations

import pymunk

from atlas_rap.sim.sonar import ECHO_CATEGORY, OBSTACLE_CATEGORY, ROBOT_CATEGORY, SENSOR_CATEGORY, WALL_CATEGORY

__all__ = ["COLLISION_SLOP", "ECHO_ONLY_FILTER", "OBSTACLE_FILTER", "WALL_FILTER", "WALL_FRICTION", "WALL_RADIUS",
           "wall_shapes"]

WALL_RADIUS = 0.02  # m: collision thickness either side of a wall's centre line
WALL_FRICTION = 0.5
COLLISION_SLOP = 0.002  # m of overlap the solver allows before pushing apart

WALL_FILTER = pymunk.ShapeFilter(categories=WALL_CATEGORY, mask=ROBOT_CATEGORY)
ECHO_ONLY_FILTER = pymunk.ShapeFilter(categories=ECHO_CATEGORY, mask=SENSOR_CATEGORY)
OBSTACLE_FILTER = pymunk.ShapeFilter(categories=OBSTACLE_CATEGORY, mask=ROBOT_CATEGORY | SENSOR_CATEGORY)


def wall_shapes(space: pymunk.Space, a, b) -> tuple[pymunk.Shape, pymunk.Shape]:
    """The collision segment and the sonar's zero-thickness copy of a wall from ``a`` to ``b``
    (on ``space``'s static body, not added to it)."""
    a, b = (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))
    solid = pymunk.Segment(space.static_body, a, b, WALL_RADIUS)
    solid.filter = WALL_FILTER
    solid.friction = WALL_FRICTION
    solid.elasticity = 0.0
    echo = pymunk.Segment(space.static_body, a, b, 0.0)
    echo.filter = ECHO_ONLY_FILTER
    return solid, echo

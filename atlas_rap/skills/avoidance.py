"""Steering toward a goal around obstacles seen by the sonar: a vector field.

The goal pulls with a unit vector; every sonar echo closer than
``influence`` pushes away with a strength growing as ``1/r − 1/influence``
(Khatib's potential field, on the sonar ring as Borenstein's VFF did). The
sum gives the heading; the turn rate is proportional to the heading error
and the forward speed falls with it, so the robot turns on the spot when
the way ahead is wrong. Local minima are left to the route: the navigation
skill gives waypoints through doorways, and a motion skill that makes no
progress reports that it is blocked.
"""

from __future__ import annotations

import math

import numpy as np

REPULSION_GAIN = 0.25
TURN_GAIN = 2.0


def steer(pose: tuple[float, float, float], goal: tuple[float, float],
          sonar: tuple[np.ndarray, np.ndarray] | None, *, max_speed: float, max_turn: float,
          influence: float = 0.7, arrive_radius: float = 0.8) -> tuple[float, float]:
    """The (v, ω) command that takes the robot at ``pose`` toward ``goal`` around echoes."""
    x, y, heading = pose
    dx, dy = goal[0] - x, goal[1] - y
    distance = math.hypot(dx, dy)
    bearing = math.atan2(dy, dx) - heading
    fx, fy = math.cos(bearing), math.sin(bearing)
    if sonar is not None:
        ranges, angles = sonar
        close = ranges < min(influence, distance)
        if close.any():
            r = np.maximum(ranges[close], 0.02)
            push = REPULSION_GAIN * (1.0 / r - 1.0 / influence)
            fx -= float(np.dot(push, np.cos(angles[close])))
            fy -= float(np.dot(push, np.sin(angles[close])))
    error = math.atan2(fy, fx)
    omega = max(-max_turn, min(max_turn, TURN_GAIN * error))
    v = max_speed * max(0.0, math.cos(error)) ** 2 * min(1.0, distance / arrive_radius + 0.2)
    return v, omega


def angle_difference(a: float, b: float) -> float:
    """a − b wrapped to (−π, π]."""
    return math.atan2(math.sin(a - b), math.cos(a - b))


def angle_wrap(angles: np.ndarray) -> np.ndarray:
    """Angles wrapped to (−π, π], elementwise."""
    return np.arctan2(np.sin(angles), np.cos(angles))

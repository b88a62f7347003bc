"""Finding a lost robot again: the whole map searched for the pose where its last rings fit best.

A particle filter recovers from a kidnap by scattering random particles and
waiting for one to land near the truth (AMCL's recovery). On a building
with a 16-sonar ring that rarely works: a few thousand particles leave next
to none near the robot, and one ring fits many places (every corridor looks
like itself 5 m further on), so the filter settles on a wrong place as
confidently as on the right one.

This is the other way, the correlative search of scan matching (Olson,
"Real-time correlative scan matching", 2009) over the whole map: every
pose on a coarse grid of the free space (:data:`STEP` metres,
:data:`HEADING_STEP` radians) is scored by *several* rings at once, taken
as the robot turned or drove (each placed at its own pose relative to the
latest by the odometry, which is good over a few metres). One turn on the
spot gives 16 beams per ring at many bearings, a 360-degree picture of the
room that one ring is not, and the sum of their log-likelihoods singles
out the room and the pose in it. The best :data:`KEEP` poses seed the
particle filter again, which then tracks as before.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from atlas_rap.maps.localisation import ParticleFilter, Pose, between

__all__ = ["HEADING_STEP", "KEEP", "MAX_RINGS", "STEP", "best_poses", "candidate_poses"]

STEP = 0.25
"""Metres between the candidate positions."""
HEADING_STEP = math.radians(10.0)
"""Radians between the candidate headings."""
MAX_RINGS = 8
"""The most rings scored (evenly spread over those given): more cost more and add little."""
KEEP = 20
"""How many of the best candidates are returned."""


def candidate_poses(pf: ParticleFilter, clearance: float, step: float = STEP,
                    heading_step: float = HEADING_STEP) -> np.ndarray:
    """Poses (m x 3) on a grid of ``step`` metres over the map's cells at least ``clearance`` metres
    from every obstacle (where the robot's body fits), at every ``heading_step`` of heading."""
    field = pf.field
    frame = field.frame
    every = max(1, int(round(step / frame.resolution)))
    fits = field.distance >= clearance
    rows, cols = np.nonzero(fits[::every, ::every])
    x, y = frame.cell_to_world(rows * every, cols * every)
    headings = np.arange(-math.pi, math.pi, heading_step)
    xy = np.column_stack([np.atleast_1d(x), np.atleast_1d(y)])
    return np.column_stack([np.repeat(xy, len(headings), axis=0), np.tile(headings, len(xy))])


def best_poses(pf: ParticleFilter, rings: Sequence[tuple[Pose, np.ndarray, np.ndarray]], latest: Pose,
               clearance: float, keep: int = KEEP) -> tuple[np.ndarray, np.ndarray]:
    """The ``keep`` candidate poses (k x 3) where ``rings`` fit best, and their summed log-likelihoods
    (best first). Each ring is ``(odometry pose when taken, ranges, body-frame angles)``; ``latest``
    is the odometry pose now, the pose the candidates are for."""
    if len(rings) > MAX_RINGS:
        rings = [rings[int(i)] for i in np.linspace(0, len(rings) - 1, MAX_RINGS)]
    candidates = candidate_poses(pf, clearance)
    score = np.zeros(len(candidates))
    for odometry, ranges, angles in rings:
        score += pf.log_likelihood(_moved(candidates, between(latest, odometry)), ranges, angles)
    order = np.argsort(-score)[:keep]
    return candidates[order], score[order]


def _moved(poses: np.ndarray, delta: Pose) -> np.ndarray:
    """Every pose of ``poses`` moved by ``delta`` in its own frame."""
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    return np.column_stack([poses[:, 0] + delta[0] * c - delta[1] * s, poses[:, 1] + delta[0] * s + delta[1] * c,
                            poses[:, 2] + delta[2]])

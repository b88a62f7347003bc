"""How far the robot's pose belief was from the truth: the evaluation of localisation in simulation.

The localiser (:mod:`atlas_rap.skills.localising`) keeps the estimated
poses it gave, every period, in the :data:`~atlas_rap.skills.beliefs.POSE_TRACK`
belief; the simulator keeps the true path. This module sets one beside the
other. It is evaluation, so it may read the true pose: no skill, layer or
RAP does. :func:`covariance_ellipse` is the belief's own word on its error
(the ellipse the pictures and the Foxglove recording draw).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from atlas_rap.maps.localisation import wrap
from atlas_rap.skills.beliefs import POSE_TRACK

__all__ = ["PoseErrors", "covariance_ellipse", "pose_errors", "track_errors"]


@dataclass(frozen=True)
class PoseErrors:
    """The belief's position error (m) against the true pose, over a run: its root mean square, its
    worst, and at the end; the worst heading error (degrees); and how many poses were compared."""

    rmse: float
    worst: float
    final: float
    worst_heading_deg: float
    samples: int

    def line(self) -> str:
        """The one line ``atlas run`` prints."""
        return (f"pose error: {self.final:.2f} m at the end, RMSE {self.rmse:.2f} m, worst {self.worst:.2f} m "
                f"(heading worst {self.worst_heading_deg:.0f}°) over {self.samples} estimates")


def track_errors(track: Sequence[tuple[float, float, float, float]],
                 truth: Sequence[tuple[float, float, float, float]]) -> PoseErrors | None:
    """Each estimate (t, x, y, heading) of ``track`` against the true pose at its time, interpolated in
    ``truth`` (the simulator's path, same form); None when there is nothing to compare."""
    if not len(track) or len(truth) < 2:
        return None
    est, true = np.asarray(track, dtype=float), np.asarray(truth, dtype=float)
    x = np.interp(est[:, 0], true[:, 0], true[:, 1])
    y = np.interp(est[:, 0], true[:, 0], true[:, 2])
    heading = np.interp(est[:, 0], true[:, 0], np.unwrap(true[:, 3]))
    error = np.hypot(est[:, 1] - x, est[:, 2] - y)
    turn = np.abs(wrap(est[:, 3] - heading))
    return PoseErrors(float(np.sqrt(np.mean(error ** 2))), float(error.max()), float(error[-1]),
                      math.degrees(float(turn.max())), len(est))


def pose_errors(system) -> PoseErrors | None:
    """The pose errors of a simulated run (a :class:`~atlas_rap.layers.system.System`); None when
    nothing was estimated (no simulation here, or odometry without noise)."""
    if system is None or system.simulation is None or system.manager is None:
        return None
    track = system.manager.context.beliefs.get(POSE_TRACK)
    return track_errors(track, system.simulation.path) if track else None


def covariance_ellipse(covariance, sigmas: float = 2.0) -> tuple[float, float, float]:
    """The ``sigmas``-sigma ellipse of a pose covariance's x-y block (3 x 3, or 2 x 2): its full
    ``(width, height, angle)``, in metres and degrees counter-clockwise from x to the width's axis
    (the larger), as matplotlib's ``Ellipse`` takes them.

    >>> covariance_ellipse([[0.04, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.1]])
    (0.8, 0.4, 0.0)
    """
    block = np.asarray(covariance, dtype=float)[:2, :2]
    block = (block + block.T) / 2  # a covariance is symmetric; rounding may have left it not quite
    values, vectors = np.linalg.eigh(block)  # ascending
    small, large = (math.sqrt(max(0.0, float(v))) for v in values)
    angle = math.degrees(math.atan2(vectors[1, 1], vectors[0, 1]))  # the larger eigenvalue's axis
    return 2 * sigmas * large, 2 * sigmas * small, round(angle, 9) % 180.0  # (rounded: -1e-15 is 0, not 180)

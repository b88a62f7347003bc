"""How far the robot's pose belief was from the truth: the evaluation of localisation in simulation.

The localiser (:mod:`atlas_rap.skills.localising`) keeps the estimated
poses it gave, every period, in the :data:`~atlas_rap.skills.beliefs.POSE_TRACK`
belief; the simulator keeps the true path. This module sets one beside the
other. It is evaluation, so it may read the true pose: no skill, layer or
RAP does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from atlas_rap.skills.beliefs import POSE_TRACK

__all__ = ["PoseErrors", "pose_errors", "track_errors"]


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
    turn = np.abs((est[:, 3] - heading + math.pi) % (2 * math.pi) - math.pi)
    return PoseErrors(float(np.sqrt(np.mean(error ** 2))), float(error.max()), float(error[-1]),
                      math.degrees(float(turn.max())), len(est))


def pose_errors(system) -> PoseErrors | None:
    """The pose errors of a simulated run (a :class:`~atlas_rap.layers.system.System`); None when
    nothing was estimated (no simulation here, or odometry without noise)."""
    if system is None or system.simulation is None or system.manager is None:
        return None
    track = system.manager.context.beliefs.get(POSE_TRACK)
    return track_errors(track, system.simulation.path) if track else None

"""Layer IV's exploring in the runs after the first (:mod:`atlas_rap.layers.strategic`, "explores"):
whether a run explores, and the robot's way to the spot it goes to look from.

While the map of an errand's area has never been good enough, a run on it goes by the
reachable spot from which the sonar would learn most of what the survey is unsure of
(:func:`~atlas_rap.maps.viewpoints.best_viewpoint`). The spot is forgotten once the robot
has passed it, or once the robot has come no nearer to it for a while: a spot the planner
reaches but the robot cannot (Layer I holding it at a corner, say) is given up, as
explore_lite gives up a frontier after its ``progress_timeout``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from atlas_rap.model import Point

__all__ = ["GIVEN_UP", "PASSED", "VIEWPOINT_PATIENCE", "VIEWPOINT_PROGRESS", "VIEWPOINT_REACHED",
           "ViewpointWatch", "explores_this_run"]

VIEWPOINT_REACHED = 0.5
"""Metres from its viewpoint within which the robot has passed it."""

VIEWPOINT_PATIENCE = 30.0
"""Seconds the robot may come no nearer to its viewpoint before it gives the viewpoint up
(explore_lite's ``progress_timeout``, whose default this is)."""

VIEWPOINT_PROGRESS = 0.1
"""Metres nearer to the viewpoint that count as progress: more than the believed pose's jitter."""

PASSED, GIVEN_UP = "passed", "given up"
"""What :meth:`ViewpointWatch.follow` says of a viewpoint the robot is done with."""


def explores_this_run(quality: float, earlier: list[float], threshold: float, hysteresis: float, *,
                      when_stalled: bool = False) -> bool:
    """Whether a run that maps an errand's area on a carried map explores, from the map quality
    it begins with and those the earlier runs began with.

    By default, while the map is under the threshold and never reached it in an earlier run (a
    map that slipped under it, a block Layer III put on it say, is mapped on the way, with no
    detour). ``when_stalled``: only once the errand's way taken again has stopped paying
    (the run before added less than the hysteresis), while the map is under the threshold and
    never reached it."""
    maturing = quality < threshold and max(earlier, default=0.0) < threshold
    if not when_stalled:
        return maturing
    return maturing and bool(earlier) and quality - earlier[-1] < hysteresis


@dataclass
class ViewpointWatch:
    """How near the robot has come to the viewpoint it is on its way to, and when it last came nearer."""

    viewpoint: Point | None = None
    nearest: float = math.inf
    nearer_at: float = 0.0

    def follow(self, viewpoint: Point, position: Point, now: float) -> str | None:
        """The robot at ``position`` at time ``now`` on its way to ``viewpoint``: :data:`PASSED`
        within :data:`VIEWPOINT_REACHED` of it, :data:`GIVEN_UP` after :data:`VIEWPOINT_PATIENCE`
        seconds without coming :data:`VIEWPOINT_PROGRESS` nearer, else None (still on its way)."""
        distance = math.dist(position, viewpoint)
        if viewpoint != self.viewpoint or distance < self.nearest - VIEWPOINT_PROGRESS:
            self.viewpoint, self.nearest, self.nearer_at = viewpoint, distance, now
        if distance <= VIEWPOINT_REACHED:
            return PASSED
        if now - self.nearer_at > VIEWPOINT_PATIENCE:
            return GIVEN_UP
        return None

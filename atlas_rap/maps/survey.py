"""The survey: how sure the map is, from sonar rings read far enough apart to be independent.

The recursive Bayesian update (:meth:`~atlas_rap.maps.grid.OccupancyGrid.update_sonar`)
assumes that each reading is independent evidence. A ring read ten times a
second from nearly where the last one was sees the same surfaces at the same
angles. Fused in full, every ring makes a cell surer by repetition alone: one
pass settles what it sees, and a robot standing still grows sure of the wall
in front of it. That is what driving wants (a door jamb the robot has
stopped at firms up at once; nav2's costmaps mark every scan), and it is not
how well the map is known.

So Layer IV keeps two grids of the same rings:

- **the grid** it drives, plans and localises on, every ring fused;
- **the survey** (``OccupancyGrid.survey``), which fuses a ring only once the
  robot has moved ``distance`` metres or turned ``turn`` radians since the
  last ring the survey fused (:class:`RingSpacing`). These are slam_toolbox's
  ``minimum_travel_distance`` and ``minimum_travel_heading``, 0.5 m and
  0.5 rad by default there and here (:data:`SURVEY_SPACING`; the layer
  rules' ``map-update-distance`` and ``map-update-turn`` change them; gmapping's
  ``linearUpdate`` and ``angularUpdate`` are 1.0 m and 0.5 rad).

The map quality the layer rules compare with their threshold (1 - mean
entropy) is measured on the survey, and Layer IV explores where the survey is
unsure. A map seen once is then only as sure as one look makes it, and it
firms up as later runs see the same area again (seed §5.2: "as the robot
repeatedly explores the same area, the overall quality of the map
increases"). docs/how-to/layers.md, "The survey", measures it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["SURVEY_SPACING", "RingSpacing"]

SURVEY_SPACING = 0.5
"""Metres moved, and radians turned, after which a ring counts again: slam_toolbox's defaults, and
Layer IV's unless the layer rules set ``map-update-distance`` and ``map-update-turn``."""


@dataclass
class RingSpacing:
    """Which rings the survey fuses: one read ``distance`` metres or ``turn`` radians (either)
    from the last it fused, and the first. Both 0: every ring."""

    distance: float
    turn: float
    last: tuple[float, float, float] | None = None  # the pose of the last ring fused

    def counts(self, pose: tuple[float, float, float]) -> bool:
        """Whether the ring read at ``pose`` (x, y, heading) is fused; if so, it becomes the last."""
        last = self.last
        if last is not None and (self.distance > 0.0 or self.turn > 0.0):
            moved = self.distance > 0.0 and math.dist(last[:2], pose[:2]) >= self.distance
            turned = self.turn > 0.0 and abs(math.remainder(pose[2] - last[2], math.tau)) >= self.turn
            if not (moved or turned):
                return False
        self.last = pose
        return True

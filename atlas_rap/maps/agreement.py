"""How well a map built from sonar agrees with the true map: the figure by which mapping is judged.

A built grid (:class:`~atlas_rap.maps.grid.OccupancyGrid`) labels the cells
the robot saw as occupied (P > 0.65) or free (P < 0.35), as a ROS map does.
Against the true walls (segments, drawn into the grid's own frame):

- an **occupied** cell agrees when a true wall is within ``tolerance``
  metres of it (a sonar's range noise and its 15-degree cone blur a wall
  by about a cell either side);
- a **free** cell agrees when no true wall is within half a cell of it.

The agreement is the share of labelled cells that agree; cells left
unknown (never seen, or seen both ways) are not counted, so the figure says
how right the map is where it says anything. A map smeared by a drifting
pose has walls where there are none and free space across real walls:
both count against it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import ndimage

from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.maps.localisation import wall_mask
from atlas_rap.model import Segment

__all__ = ["MapAgreement", "map_agreement"]


@dataclass(frozen=True)
class MapAgreement:
    """The labelled cells of a built map against the truth: how many were labelled occupied and free,
    and how many of each agree; :attr:`share` is the agreement over both."""

    occupied: int
    free: int
    occupied_agree: int
    free_agree: int

    @property
    def share(self) -> float:
        """Agreeing cells over labelled cells (0 when nothing is labelled)."""
        labelled = self.occupied + self.free
        return (self.occupied_agree + self.free_agree) / labelled if labelled else 0.0


def map_agreement(grid: OccupancyGrid, walls: Sequence[Segment], tolerance: float = 0.1,
                  occupied: float = 0.65, free: float = 0.35) -> MapAgreement:
    """The agreement of ``grid`` with the true ``walls`` (see the module docstring)."""
    frame = grid.frame
    truth = wall_mask(tuple(walls), frame, thickness=frame.resolution)
    distance = ndimage.distance_transform_edt(~truth) * frame.resolution if truth.any() \
        else np.full(frame.shape, np.inf)
    seen = grid.updated
    p = grid.probabilities()
    said_occupied, said_free = seen & (p > occupied), seen & (p < free)
    return MapAgreement(int(said_occupied.sum()), int(said_free.sum()),
                        int((said_occupied & (distance <= tolerance)).sum()),
                        int((said_free & (distance > frame.resolution / 2)).sum()))

"""The area an errand needs: a fixed region of interest for measuring the quality of a map.

The seed's experiment (000 §5.2) measures "the overall quality of the global
OG" run after run; the map is "evaluated both in terms of its extent and its
quality". A region that grows with exploration (the explored part of the
map, :func:`atlas_rap.maps.inference.explored_region`) makes that measure
flat: each new stretch of map is as good as the last. So the experiment
measures over a region fixed before the first run, the area the errand
needs:

- the free space within ``margin`` metres (1.0 m) of the shortest routes of
  the errand on the true map (from the robot's start through each stop in
  turn), the way any good route goes;
- the free space of every room (place region) those routes pass through:
  the robot sees them as it passes and they hold the route's alternatives;
- the walls that bound that free space (``wall_band`` metres into them, 0.1
  m): the structure Layer III's skeleton and Layer II's clearance are made
  from, and what takes several passes of a sonar to settle.

It is the experimenter's outline of the area of operation, drawn once from
the true building, as an operator gives a robot the extent of its map. The
robot is given the mask only, never the walls.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import ndimage
from skimage.draw import line, polygon

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.gridpath import GridPlanner, world_occupancy
from atlas_rap.model import World

__all__ = ["ERRAND_MARGIN", "WALL_BAND", "errand_area"]

ERRAND_MARGIN = 1.0
"""Metres either side of the errand's shortest routes whose free space the area takes in."""

WALL_BAND = 0.1
"""Metres into the walls bounding the area's free space that the area takes in."""


def errand_area(world: World, frame: GridFrame, stops: Sequence[str], *, margin: float = ERRAND_MARGIN,
                wall_band: float = WALL_BAND) -> np.ndarray:
    """The area (a boolean mask on ``frame``) of the errand from the robot's start through the places
    ``stops`` in turn; see the module docstring. A ``ValueError`` names a stop the world lacks, a
    frame that is not the world's at its resolution, or a stop the robot cannot reach."""
    missing = [stop for stop in stops if stop not in world.places]
    if missing:
        raise ValueError(f"world {world.name} has no place named {', '.join(missing)}")
    truth, truth_frame = world_occupancy(world, frame.resolution)
    if truth_frame != frame:
        raise ValueError(f"the errand's area is drawn on world {world.name}'s own frame at "
                         f"{frame.resolution} m, not on {frame}")
    walls = truth > 0.5
    labels, _ = ndimage.label(~walls)  # 4-connected: a diagonal wall of cells does not leak
    start = world.robot.start[:2]
    inside = labels == labels[frame.world_to_cell(*start)]  # the building's free space, as the robot can reach it
    route = np.zeros(frame.shape, dtype=bool)
    planner = GridPlanner(truth, frame, world.robot.radius, resolution=frame.resolution, clearance_cost=0.0)
    points = [start, *(world.places[stop].point for stop in stops)]
    for a, b in zip(points, points[1:]):
        path = planner.plan(a, b)
        if path is None:
            raise ValueError(f"in world {world.name} the robot cannot get from {a} to {b}")
        for p, q in zip(path.waypoints, path.waypoints[1:]):
            rr, cc = line(*frame.world_to_cell(*p), *frame.world_to_cell(*q))
            route[rr, cc] = True
    near = ndimage.distance_transform_edt(~route) * frame.resolution <= margin
    rooms = np.zeros(frame.shape, dtype=bool)
    for place in world.places.values():
        if place.region is None:
            continue
        room = _polygon_mask(frame, place.region)
        if (room & route).any():
            rooms |= room
    area = inside & (near | rooms)
    band = max(1, round(wall_band / frame.resolution))
    return area | (ndimage.binary_dilation(area, iterations=band) & ndimage.binary_dilation(walls))


def _polygon_mask(frame: GridFrame, points: Sequence[tuple[float, float]]) -> np.ndarray:
    """The cells whose centres lie in the polygon ``points`` (world coordinates)."""
    rows, cols = frame.world_to_cell(np.array([p[0] for p in points]), np.array([p[1] for p in points]))
    mask = np.zeros(frame.shape, dtype=bool)
    rr, cc = polygon(np.asarray(rows, dtype=float), np.asarray(cols, dtype=float), frame.shape)
    mask[rr, cc] = True
    return mask

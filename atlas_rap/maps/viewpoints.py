"""Where to look next: the reachable spot from which the sonar would learn most of an area.

Layer IV explores while it maps (seed 000 §5.2: the robot "had to explore
its surroundings while trying to find a path to the goal", the map
"constantly evaluated, both in terms of its extent and its quality"). A path
straight to the goal sees the same cells run after run and leaves the rest
of the area it was given (:mod:`atlas_rap.maps.errand_area`) as unsure as
it was: the corridor's far ends, a room's corners. So in the runs after
the first (:mod:`atlas_rap.layers.strategic`, "explores"), on its way Layer
IV calls at a *viewpoint*, the choice of information-driven exploration
(frontier exploration weighed by expected information gain, as in
González-Baños and Latombe's next-best-view and ROS's ``explore_lite``):

- the candidates are the cells inside the area that the robot can reach
  from where it is and that the map holds free (P(occupied) under 0.35, the
  free label of ROS's map_server): a spot the robot has only glimpsed may
  hold what it cannot see from afar, such as a crate;
- a spot's **gain** is the entropy (bits, :meth:`OccupancyGrid.entropy`) of
  the area's cells the sonar could see from there, times the cell area:
  square metres of the area the map is unsure of, as if each of them were
  wholly unknown. What it could see is found by ray casting
  (:func:`visible_gain`): straight rays out to ``radius`` metres, each
  stopped by the first cell the map holds occupied, so a spot beside a wall
  does not count the room behind it. Ray casting every candidate would cost
  too much, so the :data:`CANDIDATES` most promising spots are cast, by the
  unsure area within ``radius`` of them walls or not
  (:func:`information_gain`, one convolution for the whole grid);
- the viewpoint is the candidate of greatest gain, when that gain is at
  least ``min_gain`` square metres; else there is nothing worth the detour.

As the robot passes a viewpoint its rings firm the cells round it up, so the
next leg's viewpoint is elsewhere. What stays unsure round a viewpoint once
visited is what the sonar cannot settle from there (the corridor's end
behind a crate), so the next viewpoint of the run is at least ``radius``
from the ones before.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.signal import fftconvolve

from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.maps.gridpath import GridPlanner
from atlas_rap.model import Point

__all__ = ["VIEW_RADIUS", "MIN_GAIN", "information_gain", "visible_gain", "best_viewpoint"]

VIEW_RADIUS = 2.5
"""Metres round a viewpoint whose cells count towards its gain: half the sonar's 5 m range,
where its readings are surest."""

MIN_GAIN = 1.0
"""Square metres of unsure area a viewpoint must offer for the robot to go out of its way."""

CANDIDATES = 24
"""Spots whose view is ray-traced (:func:`visible_gain`), the most promising by :func:`information_gain`."""

CANDIDATE_SPACING = 0.5
"""Metres at least between the spots ray-traced, so that they are not all round one corner."""

RAYS = 180
"""Rays cast from a spot to see what it sees: 2 degrees apart, so a cell (5 cm) apart 1.4 m out and
under two cells apart at 2.5 m."""

FREE = 0.35
"""P(occupied) under which a cell is free enough to stand on (the free label of ROS's map_server)."""

OCCUPIED = 0.6
"""P(occupied) above which a cell stops a ray (the planners' obstacle threshold)."""


def information_gain(grid: OccupancyGrid, area: np.ndarray, radius: float = VIEW_RADIUS) -> np.ndarray:
    """Each cell's gain (module docstring) on ``grid``'s frame: the entropy of the ``area``
    (a boolean mask) within ``radius`` metres, in square metres."""
    res = grid.frame.resolution
    reach = int(math.ceil(radius / res))
    rows, cols = np.ogrid[-reach:reach + 1, -reach:reach + 1]
    disc = (rows ** 2 + cols ** 2 <= (radius / res) ** 2).astype(np.float32)
    unsure = np.where(area, grid.entropy(), np.float32(0.0))
    return np.clip(fftconvolve(unsure, disc, mode="same"), 0.0, None) * res * res


def visible_gain(grid: OccupancyGrid, area: np.ndarray, points: np.ndarray, radius: float = VIEW_RADIUS,
                 rays: int = RAYS) -> np.ndarray:
    """The gain of each of ``points`` ((N, 2) world x, y) counting only the cells the sonar could
    reach from there: along ``rays`` straight rays out to ``radius`` metres, each stopped by the
    first cell the grid believes occupied (P > 0.6; that cell counts, the ones behind it do not).
    Square metres, as :func:`information_gain`."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    frame = grid.frame
    res = frame.resolution
    unsure = np.where(area, grid.entropy(), np.float32(0.0))
    occupied = grid.probabilities() > OCCUPIED
    angles = np.linspace(0.0, 2.0 * math.pi, rays, endpoint=False)
    steps = np.arange(0.0, radius + 1e-9, res / 2.0)
    dx = np.cos(angles)[:, None] * steps[None, :]
    dy = np.sin(angles)[:, None] * steps[None, :]
    rows, cols = frame.world_to_cell(points[:, 0, None, None] + dx, points[:, 1, None, None] + dy)
    rows, cols = np.asarray(rows), np.asarray(cols)
    height, width = frame.shape
    on = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
    rows, cols = np.where(on, rows, 0), np.where(on, cols, 0)
    wall = occupied[rows, cols] & on
    behind = np.zeros_like(wall)
    behind[..., 1:] = np.logical_or.accumulate(wall, axis=-1)[..., :-1]  # past the first occupied cell
    seen = on & ~behind
    gains = np.empty(len(points))
    for i in range(len(points)):
        cells = np.unique(rows[i][seen[i]] * width + cols[i][seen[i]])
        gains[i] = float(unsure.ravel()[cells].sum(dtype=np.float64)) * res * res
    return gains


def best_viewpoint(grid: OccupancyGrid, area: np.ndarray, planner: GridPlanner, start: Point, *,
                   radius: float = VIEW_RADIUS, min_gain: float = MIN_GAIN,
                   looked_from: Sequence[Point] = ()) -> tuple[Point, float] | None:
    """The viewpoint (world x, y) and its gain in square metres, for a robot at ``start`` planning
    with ``planner`` on ``grid``; None when no reachable spot of the area offers ``min_gain``.
    Spots within ``radius`` of one in ``looked_from`` (viewpoints already visited) are not
    candidates: what stayed unsure round them is what the sonar cannot settle from there (behind
    a crate, in a corner it cannot see into)."""
    costs = planner.costs_from(start)
    if costs is None:
        return None
    frame = planner.frame  # the planning frame: its cells are the candidates
    rows, cols = np.nonzero(np.isfinite(costs) & ~planner.unknown & ~planner.impassable)
    if not len(rows):
        return None
    xs, ys = frame.cell_to_world(rows, cols)
    fine_rows, fine_cols = (np.asarray(v) for v in grid.frame.world_to_cell(xs, ys))
    height, width = grid.frame.shape
    on = (fine_rows >= 0) & (fine_rows < height) & (fine_cols >= 0) & (fine_cols < width)
    fine_rows, fine_cols, xs, ys = fine_rows[on], fine_cols[on], np.asarray(xs)[on], np.asarray(ys)[on]
    inside = area[fine_rows, fine_cols] & (grid.probabilities()[fine_rows, fine_cols] < FREE)
    for x, y in looked_from:
        inside &= np.hypot(xs - x, ys - y) >= radius
    if not inside.any():
        return None
    xs, ys = xs[inside], ys[inside]
    near = information_gain(grid, area, radius)[fine_rows[inside], fine_cols[inside]]
    picked: list[int] = []
    for i in np.argsort(-near, kind="stable"):  # the most promising spots, CANDIDATE_SPACING apart
        if near[i] < min_gain or len(picked) == CANDIDATES:
            break
        if all(math.hypot(xs[i] - xs[j], ys[i] - ys[j]) >= CANDIDATE_SPACING for j in picked):
            picked.append(int(i))
    if not picked:
        return None
    gain = visible_gain(grid, area, np.column_stack([xs[picked], ys[picked]]), radius)
    best = int(np.argmax(gain))
    if gain[best] < min_gain:
        return None
    return (float(xs[picked[best]]), float(ys[picked[best]])), float(gain[best])

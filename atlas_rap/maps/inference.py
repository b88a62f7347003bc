"""Inference grids (seed §3.3): occupancy plus what the robot can reach and what it can observe.

An :class:`InferenceGrid` attaches two binary properties to the cells of an
:class:`~atlas_rap.maps.grid.OccupancyGrid` (seed Fig. 5):

* **reachable** — cells the robot's centre can get to from where it is:
  the empty cells (P(occ) < 0.5) plus the robot's own disc (it is standing
  there, so that is empty), eroded by the robot's radius (so the robot's
  whole body fits), then flood-filled (4-connected, so a diagonal gap between
  two cells never counts as a way through) from the robot's cell.
* **observable** — cells within sensor range and in line of sight of some
  pose the robot has been at: rays are cast from each pose (``poses``,
  thinned to one every ``pose_spacing`` metres) out to ``robot_radius +
  sensor_range`` (half a cell apart along each ray, rays at most 0.7 cell
  apart at the far end) and stop at the first cell whose MAP state is
  occupied (P(occ) > ``occupied``, 0.5 by default: the seed's §4.1 MAP
  labelling), which is itself observable. Unknown cells (never updated, p =
  0.5) do not block: a ray runs through them as far as the sensor reaches.

Their union is the :attr:`InferenceGrid.region_of_interest`: the map's
:meth:`InferenceGrid.quality` (1 - mean entropy, seed §5) is measured over it,
so cells the robot can never see (behind walls, outside the building) do not
cap the metric.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from functools import cached_property

import numpy as np
from scipy import ndimage

from atlas_rap.maps.grid import OccupancyGrid

__all__ = ["InferenceGrid", "doubt_unseen_walls", "explored_quality", "explored_region"]


def _disk(radius_cells: int) -> np.ndarray:
    span = np.arange(-radius_cells, radius_cells + 1)
    return (span[:, None] ** 2 + span[None, :] ** 2) <= radius_cells ** 2


class InferenceGrid:
    """Occupancy, reachability and observability over one grid; see the module docstring.

    ``robot_xy`` is where the robot is now; ``poses`` ((x, y) or (x, y,
    heading) each) where it has been (default: only ``robot_xy``; the
    robot's position is always included). ``sensor_range`` is measured from
    the robot's rim, as the sonar's ``max_range``. ``occupied`` is the
    probability above which a cell blocks the line of sight.
    """

    def __init__(self, grid: OccupancyGrid, robot_xy: Sequence[float], robot_radius: float, sensor_range: float,
                 poses: Iterable[Sequence[float]] | None = None, *, occupied: float = 0.5,
                 pose_spacing: float = 0.25) -> None:
        self.grid = grid
        self.frame = grid.frame
        self.robot_xy = (float(robot_xy[0]), float(robot_xy[1]))
        self.robot_radius = float(robot_radius)
        self.sensor_range = float(sensor_range)
        self.occupied_threshold = float(occupied)
        self.pose_spacing = float(pose_spacing)
        points = [(float(p[0]), float(p[1])) for p in (poses or ())]
        self.poses = points + [self.robot_xy]
        self.occupancy = grid.probabilities()

    # -- reachability ------------------------------------------------------------------

    @cached_property
    def reachable(self) -> np.ndarray:
        """Boolean (height, width): cells the robot's centre can reach from where it is now."""
        frame = self.frame
        res = frame.resolution
        radius_cells = round(self.robot_radius / res)
        free = self.occupancy < 0.5
        row, col = frame.world_to_cell(*self.robot_xy)
        if not frame.contains_cell(row, col):
            return np.zeros(frame.shape, dtype=bool)
        disk = _disk(radius_cells)
        body = np.zeros(frame.shape, dtype=bool)
        body[row, col] = True
        body = ndimage.binary_dilation(body, structure=disk)
        space = ndimage.binary_erosion(free | body, structure=disk, border_value=0)
        space[row, col] = True  # the robot is where it is, even if the map is a little off
        labels, _ = ndimage.label(space)
        return labels == labels[row, col]

    # -- observability -----------------------------------------------------------------

    def _thinned_poses(self) -> list[tuple[float, float]]:
        """The poses, one every ``pose_spacing`` metres along the path (the last one always)."""
        kept: list[tuple[float, float]] = []
        for point in self.poses:
            if not kept or math.dist(point, kept[-1]) >= self.pose_spacing:
                kept.append(point)
        if kept[-1] != self.poses[-1]:
            kept.append(self.poses[-1])
        return kept

    @cached_property
    def observable(self) -> np.ndarray:
        """Boolean (height, width): cells in range and in line of sight of some pose."""
        frame = self.frame
        res = frame.resolution
        h, w = frame.shape
        reach = self.robot_radius + self.sensor_range
        blocked = self.occupancy > self.occupied_threshold
        seen = np.zeros(h * w, dtype=bool)
        step = res / 2
        samples = np.arange(1, math.ceil(reach / step) + 1) * step  # distances along a ray
        rays = max(8, math.ceil(2 * math.pi * reach / (0.7 * res)))
        theta = np.arange(rays) * (2 * math.pi / rays)
        ox, oy, yaw = frame.origin
        cos, sin = np.cos(theta - yaw), np.sin(theta - yaw)
        # ray sample offsets in cells along the grid's axes (x: columns, y: up, i.e. rows counted from the bottom)
        dx = cos[:, None] * samples[None, :] / res
        dy = sin[:, None] * samples[None, :] / res
        flat_blocked = blocked.ravel()
        index = np.arange(samples.size)
        for x, y in self._thinned_poses():
            r0, c0 = frame.world_to_cell(x, y)
            if not frame.contains_cell(r0, c0):
                continue
            lx, ly = x - ox, y - oy  # the pose in cells along the grid's axes, as GridFrame.world_to_cell
            gx = (math.cos(yaw) * lx + math.sin(yaw) * ly) / res
            gy = (-math.sin(yaw) * lx + math.cos(yaw) * ly) / res
            cols = np.floor(gx + dx).astype(np.int64)
            rows = h - 1 - np.floor(gy + dy).astype(np.int64)
            inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
            flat = np.where(inside, rows * w + cols, 0)
            stop = ~inside | flat_blocked[flat]
            # a ray sees up to and including its first blocked sample; off the map it sees nothing more
            first = np.where(stop.any(axis=1), stop.argmax(axis=1), samples.size)
            visible = (index[None, :] <= first[:, None]) & inside
            seen[flat[visible]] = True
            seen[r0 * w + c0] = True
        return seen.reshape(h, w)

    # -- the metric --------------------------------------------------------------------

    @property
    def region_of_interest(self) -> np.ndarray:
        """Cells that matter for the map's quality: reachable or observable."""
        return self.reachable | self.observable

    def quality(self) -> float:
        """1 - mean binary entropy (bits) of the cells in :attr:`region_of_interest`."""
        return self.grid.quality(self.region_of_interest)

    def __repr__(self) -> str:
        return (f"<InferenceGrid {self.frame.height}x{self.frame.width}: {int(self.reachable.sum())} reachable, "
                f"{int(self.observable.sum())} observable>")


def explored_region(grid: OccupancyGrid, frontier: float = 0.5, goals: Iterable[Sequence[float]] = (),
                    goal_radius: float = 1.5) -> np.ndarray:
    """The region of interest of a robot with no prior map: what it has explored, and where it is going.

    The cells believed free, and every cell within ``frontier`` metres of them
    that can be reached without passing a cell believed occupied: the walls that
    bound them, and a band of the unknown beyond the frontier; and the discs of
    ``goal_radius`` round the ``goals`` (the places the robot has been sent to).
    Cheap (one masked dilation), for measuring quality while driving.

    The band and the discs make the quality grow with the map's *extent* (seed
    §5: the map is evaluated "both in terms of its extent and its quality"):
    while the robot explores, the unknown beyond the frontier and round a goal
    not reached yet (entropy 1) weigh the quality down, so one room seen many
    times does not pass for a good map; behind a wall nothing counts, as the
    robot cannot see there.
    """
    frame = grid.frame
    region = np.zeros(frame.shape, dtype=bool)
    steps = max(1, round(frontier / grid.resolution))
    updated = grid.updated
    rows = np.flatnonzero(updated.any(axis=1))
    if rows.size:  # the work is done on the box round what has been seen, not on the whole grid
        cols = np.flatnonzero(updated.any(axis=0))
        r0, r1 = max(rows[0] - steps - 1, 0), min(rows[-1] + steps + 2, frame.height)
        c0, c1 = max(cols[0] - steps - 1, 0), min(cols[-1] + steps + 2, frame.width)
        log_odds, seen = grid.log_odds[r0:r1, c0:c1], updated[r0:r1, c0:c1]
        free = seen & (log_odds < 0)
        open_cells = ~(seen & (log_odds > 0))
        band = ndimage.binary_dilation(free, iterations=steps, mask=open_cells) if free.any() else free
        region[r0:r1, c0:c1] = band | ndimage.binary_dilation(band) & ~open_cells
    for x, y in goals:
        found = frame.disc(x, y, goal_radius)
        if found is not None:
            region[found[0]] |= found[1]
    return region


def explored_quality(grid: OccupancyGrid, frontier: float = 0.5, goals: Iterable[Sequence[float]] = ()) -> float:
    """1 - mean entropy over :func:`explored_region`: the map quality the ATLAS layers switch on."""
    return grid.quality(explored_region(grid, frontier, goals))


def doubt_unseen_walls(grid: OccupancyGrid, robot_xy: Sequence[float], robot_radius: float,
                       sensor_range: float) -> int:
    """Doubt the walls the robot remembers round it but cannot see from where it is.

    The cells within sensor reach (``robot_radius + sensor_range``) of ``robot_xy``
    that ``grid`` believes occupied and that are not
    :attr:`InferenceGrid.observable` from there (behind other walls, or behind an
    obstacle) become doubtful (:meth:`~atlas_rap.maps.grid.OccupancyGrid.doubt_walls`):
    unknown to a planner until the sonar sees them again. The walls the robot
    sees keep what the grid knows of them. For a robot whose every known way
    has been cut (seed §5.2, Layer IV remaps): a way may have opened where it
    cannot look. The cells doubted.
    """
    seen = InferenceGrid(grid, robot_xy, robot_radius, sensor_range).observable
    return grid.doubt_walls(float(robot_xy[0]), float(robot_xy[1]), robot_radius + sensor_range, keep=seen)

"""Paths on an occupancy grid for ATLAS's strategic layer: where to drive between two points of a map.

The topology (:mod:`atlas_rap.maps.topology`) says which places and doors a
route goes through; this module says the metric way there on the grid the
robot has mapped so far: a short list of world (x, y) waypoints the motion
skills can drive leg by leg. Minimum-cost paths come from scikit-image's
``skimage.graph.MCP_Geometric`` (8-connected, a move's cost is its length
times the mean of its two cells' costs); nothing here searches a graph by
hand. The choices:

* **Planning resolution** (0.1 m by default). The grid ``p_occ`` (NaN =
  unknown; or any value where ``known`` is False) is downsampled by the
  whole factor ``k = round(resolution / frame.resolution)`` (at least 1),
  conservatively: a planning cell is as occupied as its most occupied known
  fine cell, and unknown only if all its fine cells are unknown. The grid is
  padded at the top and the right to a multiple of ``k`` (the padding is
  unknown), so the planning frame keeps the grid's origin and yaw.
* **Impassable** cells: those with P(occ) > ``occupied``, dilated by a disc
  -- every cell whose centre is within ``robot_radius`` + half a planning
  cell of an occupied cell's centre (``scipy.ndimage.distance_transform_edt``
  in cells): a robot centred there would reach into the occupied cell.
  Cells outside the grid are impassable (MCP never leaves the array); the
  grid's edge is not a wall otherwise.
* **Costs** per metre of travel: 1 on known free cells, ``unknown_cost``
  (2.5) on unknown ones -- optimistic planning: the unknown is passable, at a
  price, so a route through mapped corridors wins unless the unknown saves a
  lot -- plus ``clearance_cost * (1 - d / clearance)`` on passable cells
  closer than ``clearance`` (0.35 m) to an impassable cell (``d`` from the
  distance transform of the passable cells, in metres), so paths keep off
  walls and go through the middle of doorways.
* **Tracks the robot drove** (``tracks``, polylines of world points in the
  order driven) are passable whatever the grid says: the planning cells on
  the straight legs between their points are taken out of the impassable
  ones; so are the cells of ``driven`` (a mask on the grid's frame, such as
  :attr:`~atlas_rap.maps.grid.OccupancyGrid.driven`), a planning cell
  wherever any of its cells is.
  The robot's body was there, so a path along its centre line fits; a
  sonar map can still close a doorway behind the robot (the arcs of echoes
  off its jambs) or narrow it under the robot's width plus inflation.
* **Start and goal** on an impassable cell are moved to the nearest passable
  cell's centre (the feature transform of ``distance_transform_edt``) if it
  is within :data:`SNAP_DISTANCE` (0.6 m); otherwise there is no path. The
  waypoints begin and end at the points used.
* **Simplification by string-pulling.** The MCP traceback (one point per
  cell) is pulled taut greedily: from each kept point jump to the farthest
  later point of the traceback whose straight segment is clear. *Clear*
  means the segment, sampled every half planning cell (vectorised over all
  candidates at once), meets no cell that **costs more than the costliest
  cell of the traceback section it replaces** (impassable cells cost inf).
  So a shortcut never crosses an obstacle, a section through known free
  cells is not cut short through the unknown, and a shortcut keeps at least
  the wall clearance the optimal path had (e.g. in a doorway).
* The cost array, the MCP object and the snapping transform are computed
  once per :class:`GridPlanner`; :meth:`GridPlanner.plan` only runs
  ``find_costs`` from start to goal and the traceback. Everything is
  deterministic.

:func:`world_occupancy` rasterises a :class:`~atlas_rap.model.World`'s true
map (walls and closed doors); :func:`shortest_route_length` is the
reference length of the shortest route on it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import ndimage
from skimage.draw import line
from skimage.graph import MCP_Geometric

from atlas_rap.maps.frame import GridFrame
from atlas_rap.model import World

if TYPE_CHECKING:
    from atlas_rap.maps.grid import OccupancyGrid

__all__ = ["SNAP_DISTANCE", "GridPath", "GridPlanner", "plan_path", "shortest_route_length", "world_occupancy"]

SNAP_DISTANCE = 0.6
"""Metres a start or goal on an impassable cell may be moved to reach a passable one."""

Point = tuple[float, float]


@dataclass(frozen=True)
class GridPath:
    """A planned path: world (x, y) waypoints from start to goal, its length and share through the unknown."""

    waypoints: tuple[Point, ...]
    length: float
    unknown_share: float


def _downsample(p_occ: np.ndarray, known: np.ndarray, frame: GridFrame,
                resolution: float) -> tuple[np.ndarray, np.ndarray, GridFrame]:
    """(worst known P(occ) per planning cell, -inf where none; unknown mask; planning frame)."""
    k = max(1, round(resolution / frame.resolution))
    worst = np.where(known, p_occ, -np.inf)
    if k == 1:
        return worst, ~known, frame
    height, width = frame.shape
    hc, wc = -(-height // k), -(-width // k)
    top = hc * k - height  # padding rows go on top, columns on the right: the origin stays put
    padded = np.full((hc * k, wc * k), -np.inf)
    padded[top:, :width] = worst
    seen = np.zeros((hc * k, wc * k), dtype=bool)
    seen[top:, :width] = known
    worst = padded.reshape(hc, k, wc, k).max(axis=(1, 3))
    unknown = ~seen.reshape(hc, k, wc, k).any(axis=(1, 3))
    return worst, unknown, GridFrame(hc, wc, frame.resolution * k, frame.origin)


class GridPlanner:
    """Plans on one occupancy grid at a planning resolution (default 0.1 m).

    ``frame`` (the planning frame), ``costs`` (per metre, inf where
    impassable), ``impassable`` and ``unknown`` describe the planning grid.
    """

    def __init__(self, p_occ: np.ndarray, frame: GridFrame, robot_radius: float, *,
                 known: np.ndarray | None = None, resolution: float = 0.1, occupied: float = 0.6,
                 unknown_cost: float = 2.5, clearance: float = 0.35, clearance_cost: float = 2.0,
                 tracks: Sequence[Sequence[Point]] = (), driven: np.ndarray | None = None) -> None:
        p = np.asarray(p_occ, dtype=np.float64)
        if p.shape != frame.shape:
            raise ValueError(f"p_occ has shape {p.shape}, but the frame is {frame.height} x {frame.width}")
        seen = ~np.isnan(p)
        if known is not None:
            known = np.asarray(known, dtype=bool)
            if known.shape != frame.shape:
                raise ValueError(f"known has shape {known.shape}, but the frame is {frame.height} x {frame.width}")
            seen &= known
        worst, unknown, self.frame = _downsample(p, seen, frame, resolution)
        res = self.frame.resolution
        obstacle = worst > occupied
        if obstacle.any():
            impassable = ndimage.distance_transform_edt(~obstacle) <= robot_radius / res + 0.5
        else:
            impassable = np.zeros(obstacle.shape, dtype=bool)
        for track in tracks:
            impassable &= ~self._cells_along(track)
        if driven is not None:
            driven = np.asarray(driven, dtype=bool)
            if driven.shape != frame.shape:
                raise ValueError(f"driven has shape {driven.shape}, but the frame is {frame.height} x {frame.width}")
            impassable &= _downsample(np.zeros(frame.shape), driven, frame, resolution)[1]  # no cell driven
        costs = np.where(unknown, float(unknown_cost), 1.0)
        if impassable.any() and clearance > 0 and clearance_cost > 0:
            d = ndimage.distance_transform_edt(~impassable) * res
            costs += clearance_cost * np.clip(1.0 - d / clearance, 0.0, None)
        costs[impassable] = np.inf
        self.costs = costs
        self.impassable = impassable
        self.unknown = unknown
        self._mcp = MCP_Geometric(costs, fully_connected=True)
        self._nearest: np.ndarray | None = None  # feature transform to the nearest passable cell, made when needed

    def _cells_along(self, track: Sequence[Point]) -> np.ndarray:
        """The planning cells on the straight legs between the points of ``track`` (a mask)."""
        xy = np.asarray(track, dtype=float).reshape(-1, 2)
        rows, cols = (np.asarray(v) for v in self.frame.world_to_cell(xy[:, 0], xy[:, 1]))
        height, width = self.frame.shape
        mask = np.zeros((height, width), dtype=bool)
        for r0, c0, r1, c1 in zip(rows, cols, rows[1:], cols[1:]):
            rr, cc = line(int(r0), int(c0), int(r1), int(c1))
            on = (rr >= 0) & (rr < height) & (cc >= 0) & (cc < width)
            mask[rr[on], cc[on]] = True
        if len(rows) == 1 and 0 <= rows[0] < height and 0 <= cols[0] < width:
            mask[rows[0], cols[0]] = True
        return mask

    @classmethod
    def from_grid(cls, grid: OccupancyGrid, robot_radius: float, **settings: Any) -> GridPlanner:
        """A planner on an :class:`~atlas_rap.maps.grid.OccupancyGrid` (its cells ever updated are the known ones)."""
        return cls(grid.probabilities(), grid.frame, robot_radius, known=grid.updated, **settings)

    # -- geometry in planning cells ---------------------------------------------------

    def _fractional(self, x: Any, y: Any) -> tuple[np.ndarray, np.ndarray]:
        """Fractional (row, col) of world points: cell centres at whole numbers (cf. ``frame.cell_to_world``)."""
        f = self.frame
        ox, oy, yaw = f.origin
        dx, dy = np.asarray(x, dtype=float) - ox, np.asarray(y, dtype=float) - oy
        cos, sin = math.cos(yaw), math.sin(yaw)
        lx, ly = cos * dx + sin * dy, -sin * dx + cos * dy
        return f.height - 0.5 - ly / f.resolution, lx / f.resolution - 0.5

    def _cells(self, rf: np.ndarray, cf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The cells containing fractional positions (the same cell as ``frame.world_to_cell``)."""
        return np.ceil(rf - 0.5).astype(np.int64), np.floor(cf + 0.5).astype(np.int64)

    def _along(self, values: np.ndarray, a: np.ndarray, b: np.ndarray,
               outside: float) -> tuple[np.ndarray, np.ndarray]:
        """``values`` sampled every half cell along segments a[i] -> b[i] (fractional cells, (N, 2) each).

        Returns the samples (both ends included) and each segment's first
        sample's index, ready for ``np.ufunc.reduceat``; ``outside`` for
        samples off the grid.
        """
        a = np.broadcast_to(a, b.shape)
        delta = b - a
        pieces = np.maximum(1, np.ceil(2.0 * np.hypot(delta[:, 0], delta[:, 1]))).astype(np.int64)
        counts = pieces + 1
        starts = np.zeros(len(counts), dtype=np.int64)
        np.cumsum(counts[:-1], out=starts[1:])
        seg = np.repeat(np.arange(len(counts)), counts)
        t = (np.arange(int(counts.sum())) - starts[seg]) / pieces[seg]
        rows, cols = self._cells(a[seg, 0] + t * delta[seg, 0], a[seg, 1] + t * delta[seg, 1])
        height, width = self.frame.shape
        inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
        sampled = np.where(inside, values[np.where(inside, rows, 0), np.where(inside, cols, 0)], outside)
        return sampled, starts

    def _snap(self, point: Point) -> tuple[np.ndarray, tuple[int, int], Point] | None:
        """Fractional position, cell and world (x, y) of ``point``, moved to the nearest passable cell if need be."""
        rf, cf = self._fractional(*point)
        r, c = self._cells(rf, cf)
        r, c = int(r), int(c)
        height, width = self.frame.shape
        if 0 <= r < height and 0 <= c < width and not self.impassable[r, c]:
            return np.array([float(rf), float(cf)]), (r, c), (float(point[0]), float(point[1]))
        if self.impassable.all():
            return None
        if self._nearest is None:
            self._nearest = ndimage.distance_transform_edt(self.impassable, return_distances=False,
                                                           return_indices=True)
        nr, nc = (int(v) for v in self._nearest[:, min(max(r, 0), height - 1), min(max(c, 0), width - 1)])
        x, y = self.frame.cell_to_world(nr, nc)
        if math.dist((x, y), point) > SNAP_DISTANCE:
            return None
        return np.array([float(nr), float(nc)]), (nr, nc), (x, y)

    def _pull(self, points: np.ndarray) -> list[int]:
        """Indices of the traceback points kept by string-pulling (see the module docstring)."""
        cost = self.costs[tuple(self._cells(points[:, 0], points[:, 1]))]
        keep = [0]
        i, last = 0, len(points) - 1
        while i < last:
            section = np.maximum.accumulate(cost[i:])[1:]  # costliest cell of points i..j, j = i+1..last
            sampled, starts = self._along(self.costs, points[i], points[i + 1:], np.inf)
            worst = np.maximum.reduceat(sampled, starts)
            ok = np.flatnonzero((worst <= section) & np.isfinite(worst))  # never through an impassable cell
            i = i + 1 + int(ok[-1]) if len(ok) else i + 1
            keep.append(i)
        return keep

    def _legs(self, waypoints: tuple[Point, ...]) -> tuple[np.ndarray, np.ndarray]:
        xy = np.asarray(waypoints, dtype=float).reshape(-1, 2)
        rf, cf = self._fractional(xy[:, 0], xy[:, 1])
        cells = np.column_stack([rf, cf])
        return cells[:-1], cells[1:]

    # -- planning ---------------------------------------------------------------------

    def plan(self, start: Point, goal: Point) -> GridPath | None:
        """The path from ``start`` to ``goal`` (world x, y), or None when there is none (see the module docstring)."""
        snapped_start, snapped_goal = self._snap(start), self._snap(goal)
        if snapped_start is None or snapped_goal is None:
            return None
        (a, start_cell, first), (b, goal_cell, final) = snapped_start, snapped_goal
        cumulative, _ = self._mcp.find_costs([start_cell], [goal_cell])
        if not math.isfinite(cumulative[goal_cell]):
            return None
        trace = np.asarray(self._mcp.traceback(goal_cell), dtype=float).reshape(-1, 2)
        points = np.vstack([a, trace[1:-1], b])  # the traceback's end cells replaced by the points themselves
        kept = points[self._pull(points)]
        xs, ys = self.frame.cell_to_world(kept[1:-1, 0], kept[1:-1, 1])
        waypoints = (first, *zip(np.asarray(xs, dtype=float).tolist(), np.asarray(ys, dtype=float).tolist()), final)
        legs = np.hypot(*np.diff(np.asarray(waypoints), axis=0).T)
        length = float(legs.sum())
        sampled, starts = self._along(self.unknown.astype(float), kept[:-1], kept[1:], 1.0)
        fraction = np.add.reduceat(sampled, starts) / np.diff(np.append(starts, len(sampled)))
        share = float((fraction * legs).sum() / length) if length > 0 else float(fraction[0])
        return GridPath(waypoints, length, share)

    def costs_from(self, start: Point) -> np.ndarray | None:
        """The cost of the cheapest path from ``start`` to every planning cell (inf where none),
        or None when ``start`` is nowhere near a passable cell."""
        snapped = self._snap(start)
        if snapped is None:
            return None
        cumulative, _ = self._mcp.find_costs([snapped[1]])
        return cumulative

    def plan_along(self, start: Point, goal: Point, polyline: tuple[Point, ...] | list[Point],
                   width: float = 1.5) -> GridPath | None:
        """The cheapest path from ``start`` to ``goal`` that keeps within ``width`` metres of
        ``polyline`` (a route on the topology): the route's way through the map, the grid's
        geometry. None when there is none inside that corridor."""
        xy = np.asarray(polyline, dtype=float).reshape(-1, 2)
        rf, cf = self._fractional(xy[:, 0], xy[:, 1])
        cells = np.column_stack([rf, cf])
        if len(cells) == 1:
            cells = np.vstack([cells, cells])
        on_route = np.zeros(self.costs.shape, dtype=bool)
        sampled_rows, sampled_cols = [], []
        for a, b in zip(cells[:-1], cells[1:]):
            pieces = max(1, math.ceil(2.0 * math.dist(a, b)))
            t = np.arange(pieces + 1) / pieces
            rows, cols = self._cells(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
            sampled_rows.append(rows)
            sampled_cols.append(cols)
        rows, cols = np.concatenate(sampled_rows), np.concatenate(sampled_cols)
        inside = (rows >= 0) & (rows < self.frame.height) & (cols >= 0) & (cols < self.frame.width)
        on_route[rows[inside], cols[inside]] = True
        corridor = ndimage.distance_transform_edt(~on_route) * self.frame.resolution <= width
        narrowed = GridPlanner.__new__(GridPlanner)
        narrowed.__dict__.update(self.__dict__)
        narrowed.costs = np.where(corridor, self.costs, np.inf)
        narrowed._mcp = MCP_Geometric(narrowed.costs, fully_connected=True)
        return narrowed.plan(start, goal)

    def pull_taut(self, waypoints: tuple[Point, ...] | list[Point]) -> GridPath:
        """A polyline (a route on the topology, say) pulled taut on this grid by the same
        string-pulling as :meth:`plan`: it keeps the polyline's way through the map (its
        homotopy) and its worst clearance, and loses the detours of a skeleton route."""
        xy = np.asarray(waypoints, dtype=float).reshape(-1, 2)
        rf, cf = self._fractional(xy[:, 0], xy[:, 1])
        cells = np.column_stack([rf, cf])
        dense = [cells[:1]]
        for a, b in zip(cells[:-1], cells[1:]):
            pieces = max(1, math.ceil(2.0 * math.dist(a, b)))
            t = (np.arange(1, pieces + 1) / pieces)[:, None]
            dense.append(a + t * (b - a))
        points = np.vstack(dense)
        kept = points[self._pull(points)]
        xs, ys = self.frame.cell_to_world(kept[1:-1, 0], kept[1:-1, 1])
        first, final = (float(xy[0, 0]), float(xy[0, 1])), (float(xy[-1, 0]), float(xy[-1, 1]))
        middle = zip(np.asarray(xs, dtype=float).tolist(), np.asarray(ys, dtype=float).tolist())
        taut = (first, *middle, final) if len(xy) > 1 else (first,)
        legs = np.hypot(*np.diff(np.asarray(taut), axis=0).T) if len(taut) > 1 else np.zeros(1)
        sampled, starts = self._along(self.unknown.astype(float), kept[:-1], kept[1:], 1.0) if len(kept) > 1 \
            else (np.zeros(1), np.zeros(1, dtype=np.int64))
        fraction = np.add.reduceat(sampled, starts) / np.diff(np.append(starts, len(sampled)))
        length = float(legs.sum())
        share = float((fraction * legs).sum() / length) if length > 0 else 0.0
        return GridPath(taut, length, share)

    def blocked(self, path: GridPath) -> bool:
        """Whether a leg of ``path`` now crosses an impassable cell of this planner's grid (or leaves it)."""
        if not path.waypoints:
            return False
        a, b = self._legs(path.waypoints if len(path.waypoints) > 1 else path.waypoints * 2)
        sampled, _ = self._along(self.impassable, a, b, True)
        return bool(sampled.any())


def plan_path(p_occ: np.ndarray, frame: GridFrame, start: Point, goal: Point, robot_radius: float,
              **settings: Any) -> GridPath | None:
    """One-shot :meth:`GridPlanner.plan` (``settings`` are :class:`GridPlanner`'s keyword arguments)."""
    return GridPlanner(p_occ, frame, robot_radius, **settings).plan(start, goal)


# -- the true map ----------------------------------------------------------------------

def world_occupancy(world: World, resolution: float = 0.05) -> tuple[np.ndarray, GridFrame]:
    """The world's true map over ``world.bounds``: walls and closed doors rasterised as 1.0, the rest 0.0."""
    frame = GridFrame.covering(world.bounds, resolution)
    p_occ = np.zeros(frame.shape, dtype=np.float64)
    segments = list(world.walls)
    segments += [door.segment for door in world.doors.values() if door.segment is not None and not door.open]
    for segment in segments:
        rr, cc = line(*frame.world_to_cell(*segment.a), *frame.world_to_cell(*segment.b))
        inside = (rr >= 0) & (rr < frame.height) & (cc >= 0) & (cc < frame.width)
        p_occ[rr[inside], cc[inside]] = 1.0
    return p_occ, frame


def shortest_route_length(world: World, start: Point, goal: Point, resolution: float = 0.05) -> float:
    """Length (metres) of the shortest route for the robot on the true map; ``math.inf`` when there is none.

    MCP_Geometric with cost 1 on every cell the robot's disc fits in (the
    impassable cells of :class:`GridPlanner` at the map's own resolution,
    no unknown, no clearance penalty), then string-pulled: on uniform costs
    the rule is pure line of sight, so the route is pulled taut rather than
    measured along the 8-connected traceback (which is up to 8% longer).
    """
    p_occ, frame = world_occupancy(world, resolution)
    planner = GridPlanner(p_occ, frame, world.robot.radius, resolution=resolution, clearance_cost=0.0)
    path = planner.plan(start, goal)
    return math.inf if path is None else path.length

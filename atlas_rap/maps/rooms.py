"""Places that are rooms: room segmentation of an occupancy grid, on drawn maps and on maps built from sonar.

The places of a map are its rooms and corridors. They are found in the
spirit of the room-segmentation literature (Thrun's critical points on the
Voronoi skeleton, 1998; the region merging of ipa_room_segmentation's
Voronoi method, Bormann et al. 2016), with every setting in metres
(:class:`RoomSettings`) and one implementation for drawn maps and for maps
built from sonar:

1. **Where a robot can be.** The space the robot's centre can reach (its
   configuration space: free cells with a clearance over its radius, and,
   on a map built from sonar, only those the robot could reach from where
   it drove, ``reachable``). Regions are grown in it, so a gap the robot
   cannot pass (between furniture and a wall, a hole left in a wall by the
   sonar) never joins two places, and free cells the robot could never
   reach make no place.
2. **Door candidates** (:func:`door_candidates`): critical points of the
   skeleton, where the clearance along a skeleton path dips to a local
   minimum, at most ``door_ratio`` times the clearance reached on both
   sides, and the free gap there is as wide as a door of the building
   (``door_width``).
3. **Doorways** (:func:`doorway`): the critical line through the point, from
   its nearest obstacle cell to the nearest one on the other side, must be
   a gap *in a wall*: a thin wall goes on, in line with the gap, beyond
   one of its ends (``jamb_length`` of occupied cells), and a wall or a
   corner is at the other, which a gap between a desk and a wall does not
   do; the line must be nearly straight through the point (the two
   obstacles on opposite sides). On a map that draws its walls as unknown
   (soft grey walls read in trinary mode), every cell that is not free
   counts as wall.
4. **Regions**: the configuration space cut along the doorways is labelled
   (4-connected). A doorway whose two sides are joined anyway (round a
   table, through another gap) is no door, and does not count. Every
   other free cell is given to the region it touches, grown from all
   regions at once.
5. **Merging** (:func:`merge_regions`), by size, shape and shared border as
   ipa_room_segmentation does: a region smaller than ``min_room_area``
   joins the neighbour it shares the longest border with; a region that
   shares more than ``open_border`` of its perimeter with one neighbour is
   not a room of its own and joins it.

:func:`segment_rooms` runs the whole of it and returns the label image (0
off the places, 1..N in raster order of their first cell).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

__all__ = ["Doorway", "RoomSettings", "door_candidates", "doorway", "merge_regions", "region_borders",
           "segment_rooms"]


@dataclass(frozen=True, slots=True)
class RoomSettings:
    """What a door and a room are in the buildings mapped; lengths in metres, areas in m².

    - ``door_width``: the free width of a doorway, (narrowest, widest). Office
      and laboratory doors are 0.7-1.3 m; the range is a little wider for
      maps whose walls the sonar drew thick or thin.
    - ``door_ratio``: a door's clearance is at most this times the clearance
      reached on both sides of it along the skeleton (a door is a narrowing).
    - ``jamb_length``: how far the wall must go on in line with a doorway,
      beyond each of its ends, to make the gap a gap in a wall.
    - ``jamb_fill``: the fraction of those cells that must be occupied
      (unknown cells do not count: the outside of a building is not a wall).
    - ``wall_thickness``: walls are at most this thick; what is thicker
      (a desk, a cabinet) is furniture, and a gap beside it is no door.
    - ``min_room_area``: regions smaller than this join a neighbour.
    - ``open_border``: a region sharing more than this fraction of its
      perimeter with one neighbour joins it (it is part of that room).
    """

    door_width: tuple[float, float] = (0.55, 1.6)
    door_ratio: float = 0.9
    jamb_length: float = 0.3
    jamb_fill: float = 0.6
    wall_thickness: float = 0.35
    min_room_area: float = 2.0
    open_border: float = 0.3


@dataclass(frozen=True, slots=True)
class Doorway:
    """A door found in the map: its critical point and the line across it (cells, row and col), its width (m)."""

    point: tuple[int, int]
    a: tuple[int, int]
    b: tuple[int, int]
    width: float


def door_candidates(paths: Sequence[np.ndarray], dt: np.ndarray, resolution: float,
                    settings: RoomSettings = RoomSettings()) -> list[list[tuple[int, int]]]:
    """Where doors may be on the skeleton ``paths`` (ordered (n, 2) cells each): one list per dip, best first.

    A dip is a run of a path where the clearance ``dt`` (metres) is at most
    ``door_ratio`` times the highest clearance reached on both sides and
    the free gap (about twice the clearance) is within ``door_width``. Its
    points: the middle of its narrowest stretch, then the middles of its
    other local minima, narrowest first (a door next to a narrowing made
    by furniture is only a minimum of its own within the same dip).
    """
    lo, hi = settings.door_width
    found: list[list[tuple[int, int]]] = []
    for cells in paths:
        if len(cells) < 3:
            continue
        profile = dt[cells[:, 0], cells[:, 1]]
        left = np.maximum.accumulate(profile)
        right = np.maximum.accumulate(profile[::-1])[::-1]
        side = np.minimum(left, right)
        width = 2 * profile + resolution
        dip = (profile <= settings.door_ratio * side) & (width >= lo) & (width <= hi)
        if not dip.any():
            continue
        edges = np.diff(np.concatenate([[0], dip.view(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            points = [a + i for i in _minima(profile[a:b])]
            found.append([(int(cells[i, 0]), int(cells[i, 1])) for i in points])
    return found


def _minima(run: np.ndarray) -> list[int]:
    """The middles of the flat stretches of ``run`` lower than their neighbours, narrowest first."""
    change = np.flatnonzero(np.diff(run)) + 1
    starts = np.concatenate([[0], change])
    stops = np.concatenate([change, [run.size]])
    values = run[starts]
    lower_left = np.concatenate([[True], values[1:] < values[:-1]])
    lower_right = np.concatenate([values[:-1] < values[1:], [True]])
    keep = np.flatnonzero(lower_left & lower_right)
    keep = keep[np.argsort(values[keep], kind="stable")]
    return [int((starts[k] + stops[k] - 1) // 2) for k in keep]


def doorway(point: tuple[int, int], free: np.ndarray, occupied: np.ndarray, dt_cells: float, resolution: float,
            settings: RoomSettings = RoomSettings()) -> Doorway | None:
    """The doorway at a door candidate, or None when the gap there is not a gap in a wall.

    ``free`` and ``occupied`` are masks (a cell may be neither: unknown);
    ``dt_cells`` the clearance at ``point`` in cells. See the module
    docstring, step 3: a thin wall going on in line beyond one end and a
    wall or a corner at the other.
    """
    r, c = point
    height, width = free.shape
    k = int(math.ceil(dt_cells)) + 2
    r0, r1, c0, c1 = max(0, r - k), min(height, r + k + 1), max(0, c - k), min(width, c + k + 1)
    rows, cols = np.nonzero(~free[r0:r1, c0:c1])
    if rows.size == 0:
        return None
    dr, dc = rows + (r0 - r), cols + (c0 - c)
    dist = np.hypot(dr, dc)
    i = int(np.argmin(dist))
    ar, ac = dr[i], dc[i]
    opposite = dr * ar + dc * ac < 0
    if not opposite.any():
        return None
    cos = (dr * ar + dc * ac) / np.maximum(dist * dist[i], 1e-9)
    score = np.where(opposite & (cos < -0.7), dist, np.inf)  # across the point: within ~45 degrees of straight
    j = int(np.argmin(score))
    if not np.isfinite(score[j]):
        return None
    a = (r + int(ar), c + int(ac))
    b = (r + int(dr[j]), c + int(dc[j]))
    span = math.hypot(a[0] - b[0], a[1] - b[1])
    gap = (span - 1) * resolution
    lo, hi = settings.door_width
    if not lo <= gap <= hi:
        return None
    u = ((a[0] - b[0]) / span, (a[1] - b[1]) / span)
    steps = max(2, int(round(settings.jamb_length / resolution)))
    thick = max(1, int(round(settings.wall_thickness / resolution)))
    jambs = [_jamb(end, direction, occupied, steps, thick, settings.jamb_fill)
             for end, direction in ((a, u), (b, (-u[0], -u[1])))]
    if not (jambs[0] == "wall" and jambs[1] != "" or jambs[1] == "wall" and jambs[0] != ""):
        return None
    return Doorway((r, c), a, b, gap)


def _jamb(end: tuple[int, int], direction: tuple[float, float], occupied: np.ndarray, steps: int, thick: int,
          fill: float) -> str:
    """What the obstacle at one end of a doorway is.

    ``"wall"``: a wall goes on beyond the end, in line with the doorway
    (``direction`` points away from the gap), and it is thin: somewhere
    along the first ``steps`` cells, across the line, it is at most
    ``thick`` cells deep (a wall met at a T or a corner just past the jamb
    is thick only there). ``"across"``: something runs across the line at
    the end (a wall the doorway meets at a corner, or furniture). ``""``:
    neither. A door is a gap with a wall at one end at least and a wall or
    a corner at the other; a gap between a desk and a wall has neither end
    a thin wall in line with it.

    Steps count a cell on the line or either next to it across the line, so
    a wall drawn one cell thick and a little askew, or seen by the sonar
    with small holes, still goes on.
    """
    ur, uc = direction
    nr, nc = -uc, ur
    t = np.arange(1, steps + 1, dtype=float)[:, None]
    band = np.array([-1.0, 0.0, 1.0])[None, :]
    line = _sample(occupied, end[0] + ur * t + nr * band, end[1] + uc * t + nc * band)
    if line.any(axis=1).mean() >= fill and line[:, 1].any():
        deep = np.arange(1, thick + 2, dtype=float)[None, :]
        depth = 1 + sum(_first_false(_sample(occupied, end[0] + ur * t + sign * nr * deep,
                                             end[1] + uc * t + sign * nc * deep)) for sign in (1.0, -1.0))
        if depth[line[:, 1]].min() <= thick:
            return "wall"
    for sign in (1.0, -1.0):
        run = _sample(occupied, end[0] + sign * nr * t + ur * band, end[1] + sign * nc * t + uc * band)
        if run.any(axis=1).mean() >= fill:
            return "across"
    return ""


def _sample(occupied: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``occupied`` at the nearest cells of (rows, cols), False off the grid."""
    height, width = occupied.shape
    rr, cc = np.rint(rows).astype(np.int64), np.rint(cols).astype(np.int64)
    inside = (rr >= 0) & (rr < height) & (cc >= 0) & (cc < width)
    out = np.zeros(rr.shape, dtype=bool)
    out[inside] = occupied[rr[inside], cc[inside]]
    return out


def _first_false(rows: np.ndarray) -> np.ndarray:
    """For each row of a boolean array, how many True come before its first False."""
    return np.where(rows.all(axis=1), rows.shape[1], rows.argmin(axis=1))


def _line_cells(a: tuple[int, int], b: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    from skimage.draw import line

    return line(a[0], a[1], b[0], b[1])


def _side_cells(door: Doorway, cspace: np.ndarray, cut: np.ndarray, reach: int) -> tuple[tuple[int, int] | None, ...]:
    """A cell of the configuration space on each side of a doorway (None where there is none near)."""
    height, width = cspace.shape
    (ar, ac), (br, bc) = door.a, door.b
    span = max(math.hypot(ar - br, ac - bc), 1e-9)
    nr, nc = -(ac - bc) / span, (ar - br) / span  # the doorway's normal
    mr, mc = (ar + br) / 2, (ac + bc) / 2
    found = []
    for sign in (1.0, -1.0):
        cell = None
        for t in range(1, reach + 1):
            rr, cc = int(round(mr + sign * nr * t)), int(round(mc + sign * nc * t))
            if 0 <= rr < height and 0 <= cc < width and cspace[rr, cc] and not cut[rr, cc]:
                cell = (rr, cc)
                break
        found.append(cell)
    return tuple(found)


def region_borders(labels: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Areas (cells), perimeters (4-neighbour boundary pairs, walls included) and shared borders of regions.

    ``shared[i, j]`` counts the 4-neighbour cell pairs with one cell in
    region i and the other in j (0 is off the places, i.e. walls and
    unknown). Label ``count`` is the highest label. Vectorised: one
    bincount over the pairs of each direction.
    """
    n = count + 1
    area = np.bincount(labels.ravel(), minlength=n)
    shared = np.zeros((n, n), dtype=np.int64)
    for a, b in ((labels[:, :-1], labels[:, 1:]), (labels[:-1, :], labels[1:, :])):
        differ = a != b
        pa, pb = a[differ].astype(np.int64), b[differ].astype(np.int64)
        pairs = np.bincount(pa * n + pb, minlength=n * n).reshape(n, n)
        shared += pairs + pairs.T
    perimeter = shared.sum(axis=1)
    return area, perimeter, shared


def merge_regions(labels: np.ndarray, resolution: float, settings: RoomSettings = RoomSettings()) -> np.ndarray:
    """Merge regions that are not rooms of their own (module docstring, step 5); labels renumbered 1..N."""
    count = int(labels.max()) if labels.size else 0
    if count <= 1:
        return labels
    area, perimeter, shared = region_borders(labels, count)
    area = area.astype(float) * resolution * resolution
    perimeter = perimeter.astype(float)
    shared = shared.astype(float)
    shared[0, :] = shared[:, 0] = 0  # walls are not a neighbour to merge with
    parent = np.arange(count + 1)
    alive = np.zeros(count + 1, dtype=bool)
    alive[1:] = area[1:] > 0
    changed = True
    while changed:
        changed = False
        for i in sorted(np.flatnonzero(alive), key=lambda k: area[k]):
            if not alive[i]:
                continue
            border = shared[i]
            j = int(np.argmax(border))
            if border[j] <= 0:
                continue
            small = area[i] < settings.min_room_area
            open_ = perimeter[i] > 0 and border[j] > settings.open_border * perimeter[i]
            if not (small or open_):
                continue
            # i joins j: its area, its borders (less the border between them), its perimeter
            area[j] += area[i]
            perimeter[j] += perimeter[i] - 2 * border[j]
            shared[j] += shared[i]
            shared[:, j] += shared[:, i]
            shared[j, j] = 0
            shared[i] = 0
            shared[:, i] = 0
            alive[i] = False
            parent[i] = j
            changed = True
    for i in range(count + 1):  # flatten the merges
        root = i
        while parent[root] != root:
            root = parent[root]
        parent[i] = root
    lut = np.zeros(count + 1, dtype=np.int32)
    roots = np.flatnonzero(alive)
    lut[roots] = np.arange(1, roots.size + 1, dtype=np.int32)
    return lut[parent][labels]


def segment_rooms(free: np.ndarray, occupied: np.ndarray, dt: np.ndarray, resolution: float,
                  paths: Sequence[np.ndarray], *, robot_radius: float = 0.2, reachable: np.ndarray | None = None,
                  settings: RoomSettings = RoomSettings()) -> tuple[np.ndarray, list[Doorway]]:
    """The places of a map as a label image (0 off the places), and the doorways between them.

    ``free`` and ``occupied`` are masks of the grid (unknown cells are
    neither), ``dt`` the distance transform of ``free`` in metres,
    ``paths`` the skeleton as ordered (n, 2) cells (the topology's edges),
    ``reachable`` the cells a robot that mapped the space could reach (None:
    every free cell). See the module docstring for the steps.
    """
    free = np.asarray(free, dtype=bool)
    occupied = _walls(free, np.asarray(occupied, dtype=bool))
    cspace = dt > robot_radius
    if reachable is not None:
        cspace &= reachable
    doors: list[Doorway] = []
    for points in door_candidates(paths, dt, resolution, settings):
        for r, c in points:  # the first point of a dip that is a doorway is the dip's door
            if not cspace[r, c]:
                continue
            door = doorway((r, c), free, occupied, dt[r, c] / resolution, resolution, settings)
            if door is not None:
                doors.append(door)
                break
    cut = np.zeros_like(free)
    for door in doors:
        rr, cc = _line_cells(door.a, door.b)
        cut[rr, cc] = True
    labels, count = ndimage.label(cspace & ~cut)
    if count:  # regions too small to hold the robot turning round are not places
        sizes = np.bincount(labels.ravel(), minlength=count + 1)
        keep = sizes >= max(4, int((2 * robot_radius / resolution) ** 2))
        keep[0] = False
        lut = np.zeros(count + 1, dtype=np.int32)
        lut[keep] = np.arange(1, int(keep.sum()) + 1, dtype=np.int32)
        labels = lut[labels]
    reach = int(math.ceil(settings.door_width[1] / resolution))
    separating = []
    for door in doors:
        one, two = _side_cells(door, cspace, cut, reach)
        if one is not None and two is not None and labels[one] and labels[two] and labels[one] != labels[two]:
            separating.append(door)
    _grow(labels, free & (labels == 0))
    labels = merge_regions(labels, resolution, settings)
    return _raster_order(labels), separating


def _walls(free: np.ndarray, occupied: np.ndarray) -> np.ndarray:
    """What the doorway tests take for walls: the occupied cells, or, on a map that draws its walls
    as unknown (less than half of the cells bounding the free space occupied, as on maps whose soft
    grey walls read as unknown), every cell that is not free."""
    boundary = np.zeros_like(free)
    boundary[1:, :] |= free[:-1, :]
    boundary[:-1, :] |= free[1:, :]
    boundary[:, 1:] |= free[:, :-1]
    boundary[:, :-1] |= free[:, 1:]
    boundary &= ~free
    seen = int(boundary.sum())
    if seen and int(occupied[boundary].sum()) < seen / 2:
        return ~free
    return occupied


def _grow(labels: np.ndarray, todo_mask: np.ndarray) -> None:
    """Give the cells of ``todo_mask`` to the labels they touch, one 4-connected ring at a time, from all at once."""
    height, width = labels.shape
    todo = np.flatnonzero(todo_mask.ravel())
    flat = labels.ravel()
    rows, cols = np.divmod(todo, width)
    while todo.size:
        best = np.zeros(todo.size, dtype=labels.dtype)
        for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
            r, c = rows + dr, cols + dc
            inside = (r >= 0) & (r < height) & (c >= 0) & (c < width)
            values = np.where(inside, flat[np.where(inside, r * width + c, 0)], 0)
            np.maximum(best, values, out=best)
        grown = best > 0
        if not grown.any():
            break
        flat[todo[grown]] = best[grown]
        todo, rows, cols = todo[~grown], rows[~grown], cols[~grown]


def _raster_order(labels: np.ndarray) -> np.ndarray:
    """Labels renumbered 1..N in raster order of each region's first cell."""
    flat = labels.ravel()
    ids, first = np.unique(flat, return_index=True)
    keep = ids > 0
    ids, first = ids[keep], first[keep]
    lut = np.zeros(int(flat.max()) + 1 if flat.size else 1, dtype=np.int32)
    lut[ids[np.argsort(first)]] = np.arange(1, ids.size + 1, dtype=np.int32)
    return lut[labels]

"""Places that are rooms: room segmentation of an occupancy grid, on drawn maps and on maps built from sonar.

The places of a map are its rooms and corridors. They are found by two
methods of the room-segmentation literature, one after the other, with
every setting in metres (:class:`RoomSettings`) and one implementation for
drawn maps, robots' scans and maps built from sonar:

1. **Where a robot can be.** The space the robot's centre can reach (its
   configuration space: free cells with a clearance over its radius, and,
   on a map built from sonar, only those the robot could reach from where
   it drove, ``reachable``). Regions are grown in it, so a gap the robot
   cannot pass (between furniture and a wall, a hole left in a wall by the
   sonar) never joins two places, and free cells the robot could never
   reach make no place.
2. **Doors in walls** (Thrun's critical points on the Voronoi skeleton,
   1998; ipa_room_segmentation's Voronoi method, Bormann et al. 2016).
   Candidates (:func:`door_candidates`): where the clearance along a
   skeleton path dips to a local minimum, at most ``door_ratio`` times the
   clearance reached on both sides, and the gap there is as wide as a door
   (``door_width``). Doorways (:func:`doorways`): the critical line through
   the point, from its nearest obstacle to the nearest one on the other
   side, is a gap *in a wall*: a thin wall goes on, in line with the gap,
   beyond one of its ends (``jamb_length``), and a wall or a corner is at
   the other, which a gap between a desk and a wall does not do. On a map
   that draws its walls as unknown, every cell that is not free is wall.
   The configuration space cut along the doorways is labelled; a doorway
   whose two sides are joined anyway is no door.
3. **Narrowings between room-sized spaces** (the morphological and distance
   methods of ipa_room_segmentation, as one tree: :func:`narrowing_cores`).
   Within each region, the space where the clearance is above each level
   from half the narrowest door to half the widest falls apart as the level
   passes the half-width of each narrowing. Where a region holds two
   pieces of at least ``core_area``, each with a clearance well above the
   narrowing's (``door_ratio``), the narrowing between them is a door: the
   region is divided among its pieces by a watershed of the clearance, so
   the boundary runs through the narrowing.
4. **Merging** (:func:`merge_regions`, as ipa_room_segmentation does). The
   other free cells go to the region they touch; then a region with no
   piece of step 3 (a nook, the gap behind a row of chairs) or smaller
   than ``min_room_area`` joins the neighbour it shares the longest border
   with, and one sharing more than ``open_border`` of its perimeter with a
   neighbour joins it.

**Why both.** Step 2 reads the walls: on drawn plans it holds where a door
is as wide as its corridor, and it ignores a gap beside a desk; but it
needs walls that are drawn, thin and straight, so a scan's unknown, ragged
or cluttered walls, or walls thicker than ``wall_thickness``, hide its
doors. Step 3 needs no wall at all (wall thickness, jambs, a door at a
wall's end, walls read as unknown: none of it matters), but it cannot tell
a room from a corridor no wider than its door, and a table can leave two
room-sized halves. Each alone, and both, measured on 2026-12-04
(``benchmarks/bench_places.py``; generated plans ``tests/floorplans.py``,
seeds 0-49, hard and scanned like SLAM, rooms with a place of IoU >= 0.5,
clean / furnished; the real building g4s_y2, 15 rooms):

===========================  =============  =============  =====================
method                       hard plans     SLAM-like      g4s_y2 (rooms, prec.)
===========================  =============  =============  =====================
doors in walls (step 2)      0.981 / 0.943  0.461 / 0.420  4 / 15, 0.64
narrowings (step 3) alone    0.973 / 0.838  0.905 / 0.761  10 / 15 at best, 0.79
both                         0.993 / 0.959  0.950 / 0.895  9 / 15, 0.88
===========================  =============  =============  =====================

(Step 3 alone was a prototype: the tree on the whole free space, grown by
watershed, with the merging of step 4.) What still fails on g4s_y2: the
corridor, which meets the long hall beside it through openings as wide as
itself, so pieces of it go to the hall's parts, and rooms whose clutter
leaves two room-sized halves. Telling those apart needs the building's
wall lines (ROSE², Luperto et al. 2022), which this module does not read.

:func:`segment_rooms` runs the whole of it and returns the label image (0
off the places, 1..N: the regions of step 2 in raster order of their first
cell the robot's centre can reach, then the parts step 3 cut them into).

Over 25 KB on purpose: one algorithm in four steps, with the measurements that justify its
settings kept beside it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

__all__ = ["Doorway", "RoomSettings", "door_candidates", "doorways", "merge_regions", "region_borders",
           "segment_rooms"]


@dataclass(frozen=True, slots=True)
class RoomSettings:
    """What a door and a room are in the buildings mapped; lengths in metres, areas in m².

    - ``door_width``: the free width of a doorway, (narrowest, widest). Office
      and laboratory doors are 0.7-1.3 m, double doors up to 1.6 m; the
      range is a little wider for maps whose walls the sonar drew thick or
      thin. (Wider, and corridor cross-sections start to pass for doors.)
    - ``door_ratio``: a door's clearance is at most this times the clearance
      reached on both sides of it along the skeleton (a door is a narrowing);
      in step 3, at most this times the clearance of each space it divides
      (a corridor pinched a little by a cabinet is not cut).
    - ``jamb_length``: how far the wall must go on in line with a doorway,
      beyond each of its ends, to make the gap a gap in a wall.
    - ``jamb_fill``: the fraction of those cells that must be occupied
      (an unknown cell counts where it touches the free space, a stretch of
      wall the scan did not see; deeper unknown, the outside of a building,
      does not).
    - ``wall_thickness``: walls are at most this thick; what is thicker
      (a desk, a cabinet) is furniture, and a gap beside it is no door.
    - ``min_room_area``: regions smaller than this join a neighbour.
    - ``open_border``: a region sharing more than this fraction of its
      perimeter with one neighbour joins it (it is part of that room).
    - ``core_area``: a narrowing no wider than a door splits a region when
      the space beyond it on each side still holds this much room for the
      robot's centre at the narrowing's clearance (step 3: a room's core;
      a nook behind a desk, or a corner between chairs, has less).
    """

    door_width: tuple[float, float] = (0.55, 1.7)
    door_ratio: float = 0.9
    jamb_length: float = 0.3
    jamb_fill: float = 0.6
    wall_thickness: float = 0.45
    min_room_area: float = 2.0
    open_border: float = 0.3
    core_area: float = 2.0


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
    Vectorised over all the paths at once.
    """
    paths = [cells for cells in paths if len(cells) >= 3]
    if not paths:
        return []
    cells = np.concatenate(paths)
    sizes = np.array([len(c) for c in paths])
    path = np.repeat(np.arange(len(paths)), sizes)
    profile = dt[cells[:, 0], cells[:, 1]].astype(np.float64)
    # running maxima that start again at each path: each path rides on a base above the previous ones
    base = path * (float(profile.max()) + 1.0)
    left = np.maximum.accumulate(profile + base) - base
    right = (np.maximum.accumulate((profile - base)[::-1]) + base[::-1])[::-1]
    lo, hi = settings.door_width
    width = 2 * profile + resolution
    dip = (profile <= settings.door_ratio * np.minimum(left, right)) & (width >= lo) & (width <= hi)
    if not dip.any():
        return []
    # dips: runs of ``dip`` within one path
    new_run = dip & np.concatenate([[True], ~dip[:-1] | (path[1:] != path[:-1])])
    run = np.cumsum(new_run) - 1
    # flat stretches of equal clearance within a run, and which of them are lower than both neighbours
    idx = np.flatnonzero(dip)
    r, v = run[idx], profile[idx]
    starts = np.flatnonzero(np.concatenate([[True], (r[1:] != r[:-1]) | (v[1:] != v[:-1])]))
    stops = np.concatenate([starts[1:], [idx.size]])
    sr, sv = r[starts], v[starts]
    lower_left = np.concatenate([[True], (sr[1:] != sr[:-1]) | (sv[1:] < sv[:-1])])
    lower_right = np.concatenate([(sr[:-1] != sr[1:]) | (sv[:-1] < sv[1:]), [True]])
    keep = np.flatnonzero(lower_left & lower_right)
    keep = keep[np.lexsort((sv[keep], sr[keep]))]  # by dip, narrowest first
    middle = idx[(starts[keep] + stops[keep] - 1) // 2]
    found: list[list[tuple[int, int]]] = []
    last = -1
    for dip_id, (row, col) in zip(sr[keep].tolist(), cells[middle].tolist()):
        if dip_id != last:
            found.append([])
            last = dip_id
        found[-1].append((row, col))
    return found


def doorways(points: np.ndarray, nearest: np.ndarray, walls: np.ndarray, resolution: float,
             settings: RoomSettings = RoomSettings()) -> list[Doorway | None]:
    """The doorway at each door candidate (``points``, (N, 2) cells), or None where the gap is no door.

    ``nearest`` is the nearest obstacle cell of every cell ((2, H, W) rows
    and columns: the feature transform the distance transform was computed
    with), ``walls`` the cells that count as wall. See the module docstring,
    step 2: the critical line runs from the point's nearest obstacle to the
    nearest obstacle on the other side (within 45 degrees of straight
    across), its free width is a door's, a thin wall goes on in line beyond
    one end and a wall or a corner is at the other. Vectorised over all the
    candidates of a map at once.
    """
    points = np.asarray(points, dtype=np.int64).reshape(-1, 2)
    if not len(points):
        return []
    height, width = walls.shape
    a = nearest[:, points[:, 0], points[:, 1]].T.astype(np.int64)
    to_a = (a - points).astype(float)
    # the other side: the nearest obstacle of points past the candidate, away from ``a`` (the first that
    # lies across the candidate from ``a``, within 45 degrees of straight, and is the closest of those)
    b = np.zeros_like(a)
    best = np.full(len(points), np.inf)
    for k in (0.5, 0.75, 1.0):
        beyond = np.rint(points - k * to_a).astype(np.int64)
        beyond[:, 0] = np.clip(beyond[:, 0], 0, height - 1)
        beyond[:, 1] = np.clip(beyond[:, 1], 0, width - 1)
        other = nearest[:, beyond[:, 0], beyond[:, 1]].T.astype(np.int64)
        to_b = (other - points).astype(float)
        reach = np.hypot(*to_b.T)
        across = (to_a * to_b).sum(axis=1) < -0.7 * np.maximum(np.hypot(*to_a.T) * reach, 1e-9)
        better = across & (reach < best)
        b[better], best[better] = other[better], reach[better]
    straight = np.isfinite(best)
    span = np.hypot(*(a - b).T.astype(float))
    gap = (span - 1) * resolution
    lo, hi = settings.door_width
    ok = straight & (gap >= lo) & (gap <= hi)
    u = (a - b) / np.maximum(span, 1e-9)[:, None]
    steps = max(2, int(round(settings.jamb_length / resolution)))
    # a wall thicker than the grid is as thick as the grid: the bound keeps the samples' arrays small
    thick = max(1, min(int(round(min(settings.wall_thickness / resolution, 1e9))), max(height, width)))
    jamb_a = _jambs(a, u, walls, steps, thick, settings.jamb_fill)
    jamb_b = _jambs(b, -u, walls, steps, thick, settings.jamb_fill)
    ok &= ((jamb_a == _WALL) & (jamb_b != _NONE)) | ((jamb_b == _WALL) & (jamb_a != _NONE))
    return [Doorway((int(p[0]), int(p[1])), (int(x[0]), int(x[1])), (int(y[0]), int(y[1])), float(g)) if good
            else None for p, x, y, g, good in zip(points, a, b, gap, ok)]


_NONE, _ACROSS, _WALL = 0, 1, 2


def _jambs(ends: np.ndarray, directions: np.ndarray, walls: np.ndarray, steps: int, thick: int,
           fill: float) -> np.ndarray:
    """What the obstacle at each end of a doorway is: ``_WALL``, ``_ACROSS`` or ``_NONE``.

    ``_WALL``: a wall goes on beyond the end, in line with the doorway
    (``directions`` point away from the gap), and it is thin: somewhere
    along the first ``steps`` cells, across the line, it is at most
    ``thick`` cells deep (a wall met at a T or a corner just past the jamb
    is thick only there). ``_ACROSS``: something runs across the line at
    the end (a wall the doorway meets at a corner, or furniture). A door is
    a gap with a wall at one end at least and a wall or a corner at the
    other; a gap between a desk and a wall has neither end a thin wall in
    line with it. Steps count a cell on the line or either next to it
    across the line, so a wall drawn one cell thick and a little askew, or
    seen by the sonar with small holes, still goes on.
    """
    n = len(ends)
    u = directions.astype(float)
    normal = np.stack([-u[:, 1], u[:, 0]], axis=1)
    t = np.arange(1, steps + 1, dtype=float)
    band = np.array([-1.0, 0.0, 1.0])

    def sample(origin: np.ndarray, along: np.ndarray, across: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        # walls at origin + along * t + across * offset: (n, steps, len(offsets))
        pts = origin[:, None, None, :] + along[:, None, None, :] * t[None, :, None, None] \
            + across[:, None, None, :] * offsets[None, None, :, None]
        return _sample(walls, pts[..., 0], pts[..., 1])

    origin = ends.astype(float)
    line = sample(origin, u, normal, band)
    in_line = line.any(axis=2).mean(axis=1) >= fill
    deep = np.arange(1, thick + 2, dtype=float)
    thinnest = np.full(n, thick + 1)
    for i, offset in enumerate(band):  # how deep across the wall is, from each wall cell met along the band
        start = origin + normal * offset
        depth = 1 + _first_false(sample(start, u, normal, deep)) + _first_false(sample(start, u, -normal, deep))
        thinnest = np.minimum(thinnest, np.where(line[:, :, i], depth, thick + 1).min(axis=1))
    kind = np.full(n, _NONE, dtype=np.int8)
    across = (sample(origin, normal, u, band).any(axis=2).mean(axis=1) >= fill) | \
        (sample(origin, -normal, u, band).any(axis=2).mean(axis=1) >= fill)
    kind[across] = _ACROSS
    kind[in_line & (thinnest <= thick)] = _WALL
    return kind


def _sample(walls: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``walls`` at the nearest cells of (rows, cols), False off the grid."""
    height, width = walls.shape
    rr, cc = np.rint(rows).astype(np.int64), np.rint(cols).astype(np.int64)
    inside = (rr >= 0) & (rr < height) & (cc >= 0) & (cc < width)
    out = np.zeros(rr.shape, dtype=bool)
    out[inside] = walls[rr[inside], cc[inside]]
    return out


def _first_false(rows: np.ndarray) -> np.ndarray:
    """Along the last axis of a boolean array, how many True come before the first False."""
    return np.where(rows.all(axis=-1), rows.shape[-1], rows.argmin(axis=-1))


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


def narrowing_cores(clearance: np.ndarray, levels: Sequence[float], cell_area: float,
                    core_area: float, ratio: float = 1.0) -> np.ndarray:
    """The cores of the regions that narrowings split ``clearance`` into: a label image (0 elsewhere).

    The morphological and distance methods of room segmentation (Bormann
    et al. 2016) in one tree: the space where the clearance is above each
    of ``levels`` (metres, rising) falls apart as the level passes the
    half-width of each narrowing. A region is split where, at some level,
    it holds two or more pieces of at least ``core_area`` (m², each cell
    ``cell_area``) whose highest clearance is at least the level over
    ``ratio`` (the narrowing is markedly narrower than the spaces it
    divides): each piece is then split again the same way. A region
    that never splits is one core, taken at the level it was found. Small
    pieces (a corner between chairs, a nook behind a desk) never split a
    region. Vectorised per level (one ``ndimage.label`` each); the tree
    walk is over the pieces, not the cells.
    """
    labels, parents, big = [], [], []
    flat = clearance.ravel()
    above = np.flatnonzero(flat > levels[0]) if len(levels) else np.zeros(0, dtype=np.int64)
    below: np.ndarray | None = None
    for level in levels:
        still = flat[above] > level
        above = above[still]
        lab, count = ndimage.label(clearance > level, output=np.int64)
        at = lab.ravel()[above]
        area = np.bincount(at, minlength=count + 1) * cell_area
        parent = np.zeros(count + 1, dtype=np.int64)
        if below is not None:
            parent[at] = below[still]
        below = at
        labels.append((above, at))
        parents.append(parent)
        peak = np.zeros(count + 1)
        np.maximum.at(peak, at, flat[above])
        significant = (area >= core_area) & (ratio * peak >= level)
        significant[0] = False
        big.append(np.flatnonzero(significant))
    chosen: list[tuple[int, int]] = []

    def ancestor(level: int, nodes: np.ndarray, above: int) -> np.ndarray:
        for k in range(level, above, -1):
            nodes = parents[k][nodes]
        return nodes

    stack = [(0, int(node)) for node in big[0][::-1]] if len(levels) else []
    while stack:
        level, node = stack.pop()
        for deeper in range(level + 1, len(levels)):
            kids = big[deeper][ancestor(deeper, big[deeper], level) == node]
            if len(kids) >= 2:
                stack.extend((deeper, int(kid)) for kid in kids[::-1])
                break
            if not len(kids):
                chosen.append((level, node))
                break
        else:
            chosen.append((level, node))
    cores = np.zeros(clearance.size, dtype=np.int32)
    for level in sorted({level for level, _ in chosen}):
        lut = np.zeros(len(parents[level]), dtype=np.int32)
        for number, (at, node) in enumerate(chosen, start=1):
            if at == level:
                lut[node] = number
        where, label = labels[level]
        painted = lut[label]
        cores[where[painted > 0]] = painted[painted > 0]
    return cores.reshape(clearance.shape)


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


def merge_regions(labels: np.ndarray, resolution: float, settings: RoomSettings = RoomSettings(), *,
                  join: np.ndarray | None = None) -> np.ndarray:
    """Merge regions that are not rooms of their own (module docstring, step 4); labels renumbered 1..N.

    ``join`` (one flag per label, 0..max) marks regions that join their
    neighbour whatever their size and shape (those without a room's core).
    """
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
            small = area[i] < settings.min_room_area or (join is not None and bool(join[i]))
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
    # Number the places by their first member: labels from ``ndimage.label`` are in raster order.
    first = np.full(count + 1, count + 1, dtype=np.int64)
    np.minimum.at(first, parent, np.arange(count + 1))
    roots = np.flatnonzero(alive)
    lut = np.zeros(count + 1, dtype=np.int32)
    lut[roots[np.argsort(first[roots], kind="stable")]] = np.arange(1, roots.size + 1, dtype=np.int32)
    return lut[parent][labels]


def segment_rooms(free: np.ndarray, occupied: np.ndarray, dt: np.ndarray, nearest: np.ndarray, resolution: float,
                  paths: Sequence[np.ndarray], *, robot_radius: float = 0.2, reachable: np.ndarray | None = None,
                  settings: RoomSettings = RoomSettings()) -> tuple[np.ndarray, list[Doorway]]:
    """The places of a map as a label image (0 off the places), and the doorways between them.

    ``free`` and ``occupied`` are masks of the grid (unknown cells are
    neither), ``dt`` the distance transform of ``free`` in metres and
    ``nearest`` its feature transform (the nearest non-free cell of each
    cell, :func:`atlas_rap.maps.sdt.distance_transform` with ``nearest``),
    ``paths`` the skeleton as ordered (n, 2) cells (the topology's edges),
    ``reachable`` the cells a robot that mapped the space could reach (None:
    every free cell). See the module docstring for the steps.
    """
    free = np.asarray(free, dtype=bool)
    occupied = _walls(free, np.asarray(occupied, dtype=bool))
    cspace = dt > robot_radius
    if reachable is not None:
        cspace &= reachable
    dips = door_candidates(paths, dt, resolution, settings)
    flat = np.array([point for points in dips for point in points], dtype=np.int64).reshape(-1, 2)
    found = iter(doorways(flat, nearest, occupied, resolution, settings))
    doors: list[Doorway] = []
    for points in dips:  # the first point of a dip that is a doorway (in the robot's space) is its door
        door = None
        for (r, c), candidate in zip(points, found):
            if door is None and candidate is not None and cspace[r, c]:
                door = candidate
        if door is not None:
            doors.append(door)
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
    labels, coreless = _split_at_narrowings(labels, dt, resolution, settings)
    _grow(labels, free & (labels == 0), nearest, robot_radius / resolution)
    return merge_regions(labels, resolution, settings, join=coreless), separating


NARROWING_STEP = 0.1
"""Metres between the clearance levels at which :func:`narrowing_cores` looks for splits."""


def _split_at_narrowings(labels: np.ndarray, dt: np.ndarray, resolution: float,
                         settings: RoomSettings) -> tuple[np.ndarray, np.ndarray]:
    """Split the regions that narrowings no wider than a door cut into cores (step 3); which have none.

    The cores (:func:`narrowing_cores`, on blocks of 2 x 2 cells: their
    least clearance ``dt``, and none where a cell of the block is in no
    region, so a doorway's cut line stays closed) are looked for at the
    clearances of the doors (half of ``door_width``). A region holding two
    or more is divided among them by a watershed of the blocks' clearance,
    so each boundary runs through the narrowing; the other regions keep
    their labels, and the parts of a split region take labels after them,
    in the order of their cores. The cells of a split region that no
    part's blocks cover (within a cell or two of its edges) are left 0 for
    :func:`_grow`. Returns the labels and, per label, whether the region
    holds no core (it then joins a neighbour, :func:`merge_regions`).
    """
    # Regions never touch (cut lines and walls lie between them): a block with a cell in no region gets no
    # clearance, and every other block lies wholly in one region, whose label is the block's least.
    block_labels = _least_of_2x2(labels)
    blocks = np.where(block_labels > 0, _least_of_2x2(dt), 0.0)
    lo, hi = (w / 2 for w in settings.door_width)
    levels = np.linspace(lo, hi, max(2, int(math.ceil((hi - lo) / NARROWING_STEP)) + 1))
    small = narrowing_cores(blocks, levels, 4 * resolution * resolution, settings.core_area, settings.door_ratio)
    count = int(labels.max()) if labels.size else 0
    rows, cols = np.nonzero(small)
    region_of = np.zeros(int(small.max()) + 1 if small.size else 1, dtype=np.int64)
    region_of[small[rows, cols]] = block_labels[rows, cols]
    per_region = np.bincount(region_of[1:], minlength=count + 1)
    split = per_region >= 2
    split[0] = False
    coreless = np.zeros(count + region_of.size, dtype=bool)
    coreless[1:count + 1] = per_region[1:] == 0
    if not split.any():
        return labels, coreless[:count + 1]
    from skimage.segmentation import watershed

    inside = split[block_labels] & (blocks > 0)
    parts = watershed(-blocks, np.where(inside, small, 0), mask=inside)
    keep = np.arange(count + 1, dtype=labels.dtype)
    keep[split] = 0
    out = keep[labels]
    parts[parts > 0] += count
    for dr in (0, 1):  # each cell of a block that a part covers takes the part
        for dc in (0, 1):
            view = out[dr::2, dc::2]
            block = parts[:view.shape[0], :view.shape[1]]
            np.copyto(view, block, where=block > 0)
    return out, coreless


def _least_of_2x2(values: np.ndarray) -> np.ndarray:
    """The least value of each block of 2 x 2 cells (an odd last row or column is padded with 0)."""
    padded = np.pad(values, ((0, values.shape[0] % 2), (0, values.shape[1] % 2)))
    return np.minimum(np.minimum(padded[::2, ::2], padded[1::2, ::2]),
                      np.minimum(padded[::2, 1::2], padded[1::2, 1::2]))


def _walls(free: np.ndarray, occupied: np.ndarray) -> np.ndarray:
    """What the doorway tests take for walls: the occupied cells and the unknown cells touching the
    free space (a stretch of wall a scan did not see), or, on a map that draws its walls as unknown
    (less than half of the cells bounding the free space occupied, as on maps whose soft grey walls
    read as unknown), every cell that is not free."""
    boundary = np.zeros_like(free)
    boundary[1:, :] |= free[:-1, :]
    boundary[:-1, :] |= free[1:, :]
    boundary[:, 1:] |= free[:, :-1]
    boundary[:, :-1] |= free[:, 1:]
    boundary &= ~free
    seen = int(boundary.sum())
    if seen and int(occupied[boundary].sum()) < seen / 2:
        return ~free
    return occupied | boundary


def _grow(labels: np.ndarray, todo_mask: np.ndarray, nearest: np.ndarray, radius_cells: float) -> None:
    """Give the free cells of ``todo_mask`` (near the walls, where the robot's centre cannot be) to regions.

    A cell takes the region the robot's centre reaches by stepping straight
    away from the cell's nearest obstacle (one vectorised look-up); the few
    cells that leaves (in corners) take the labels they touch, one
    4-connected ring at a time, from all the regions at once.
    """
    height, width = labels.shape
    flat = labels.ravel()
    rows, cols = (axis.astype(np.int32) for axis in np.nonzero(todo_mask))
    away_r = (rows - nearest[0][rows, cols]).astype(np.float32)
    away_c = (cols - nearest[1][rows, cols]).astype(np.float32)
    gap = np.maximum(np.hypot(away_r, away_c), np.float32(1e-6))
    step = (np.float32(radius_cells + 1.5) - gap) / gap
    tr = np.clip(np.rint(rows + away_r * step), 0, height - 1).astype(np.int64)
    tc = np.clip(np.rint(cols + away_c * step), 0, width - 1).astype(np.int64)
    found = flat[tr * width + tc]
    hit = found > 0
    todo = rows.astype(np.int64) * width + cols
    flat[todo[hit]] = found[hit]
    miss = ~hit
    todo, rows, cols = todo[miss], rows[miss].astype(np.int64), cols[miss].astype(np.int64)
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

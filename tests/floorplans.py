"""A test bed with ground truth: procedural floor plans, the rooms of the shipped worlds, and a scorer.

Issue 13, part 2 (issue 25: real buildings' walls, doors, wings and SLAM
scans). Three things, importable by tests and benchmarks alike
(``from floorplans import generate_plan, score``):

- :func:`generate_plan` draws a building from a seed: an occupancy grid
  (0 free, 1 occupied, NaN unknown outside the outer wall) and its rooms as
  a label image, with names, doors and (optionally) furniture; ``hard``
  plans are messier and come in more layouts, ``slam`` plans are hard
  plans as a robot's scan shows them (see below).
  :func:`write_plan` saves it as a ROS map plus the ground truth.
- :func:`world_rooms` rasterises a shipped world's named regions, so the
  worlds are ground truth too.
- :func:`score` compares a place labelling (e.g. ``abstract(...).places``)
  with ground-truth rooms: recall, precision, rooms with a place of their
  own, merged and split rooms.

**What a room is.** The ground truth is what a floor plan would name: the
connected pieces of free space once every door is closed. Door gaps
themselves (the cells inside the wall's thickness) are 0 in ``rooms``, as
are walls, outside and furniture. The corridor network is one room (a
building calls it "the corridor"): it is not split at its junctions or where
its width changes, only by a door across it (a fire door in front of a
dead-end branch), behind which the branch is a room of its own
(``corridor-2``). An open-plan area is one room, however large or L-shaped.

**How a plan is built** (all in whole cells of ``resolution`` metres; the
ranges below are checked on the images by ``tests/test_floorplans.py``):

1. the building: a rectangle, by default 24-40 m by 14-26 m (portrait or
   landscape), one inner wall thickness and one outer wall thickness per
   plan, both 0.1-0.25 m;
2. corridors 1.2-3 m wide along the long side: one "spine" and branches
   (layouts ``T``, ``L``, ``comb``: branches off one side or both,
   ``cross``: branches through the spine) or two spines joined by branches
   (``grid``, buildings deep enough); every branch reaches the outer wall or
   another spine; dead-end branches sometimes get a fire door;
3. the blocks between corridors are split into rooms (:func:`_subdivide`:
   rooms of a target area drawn per room cut one by one off the ends of a
   block, so that most keep a corridor frontage, and blocks deeper than 8 m
   sometimes cut into two rows; rooms 4-60 m², sides >= 2 m, long side
   mostly within 2.5 times the short), sometimes two neighbours are
   merged into an L-shaped (or larger rectangular) open-plan area of
   30-60 m², and sometimes a corner block is left out, which makes the
   outline L- or U-shaped (the outside is unknown there too);
4. doors 0.7-1.3 m wide, at least 0.15 m from the wall's ends: every room
   is connected (a spanning tree from the corridors, 85 % onto a corridor
   when it touches one, else onto a connected neighbour), then a few extra
   doors; a room has 1-3 doors;
5. with ``furniture``: desks, tables, shelves, cabinets and pillars
   (0.4-2 m rectangles) against walls, free-standing (>= 1 m from the walls)
   or leaving a sliver of 0.3-0.9 m to a wall; never within 1 m in front of
   a door (0.3 m either side of it), never overlapping, and each room's
   space for a robot of radius 0.2 m stays one piece that reaches all its
   doors (checked as each piece is placed; a piece that fails is left out).
   Furniture draws from its own random stream, so the same seed gives the
   same building with and without it.

A plan is redrawn (deterministically, from the same stream) until it has
10-40 rooms when the size is the default.

**Hard plans** (``hard=True``) are made to look like real drawn plans and
robots' maps; the room rule is unchanged (the free pieces with the doors
closed). At the default size three in five are the same building as the
plain plan of the seed (the same labels, names and doors between the same
rooms, and a few more doors); two in five (:data:`WING_SHARE`, drawn from
their own "wings" stream) are instead a **building of wings**
(:data:`WING_LAYOUTS`), the walls drawn as in step 1 and doors as in
step 4:

- ``double-loaded`` (two in five of them): one straight corridor 1.5-2.5 m
  wide from end wall to end wall, 24-44 m long, with a row of rooms 3-5 m
  wide and 3.5-5 m deep on each side;
- ``L-shaped`` and ``U-shaped`` (three in ten each): such a wing with one
  arm (L) or two (U) at its ends, each arm a double-loaded corridor of its
  own reaching 8-18 m beyond the main wing (rooms 3-5 m by 3.5-5 m on both
  sides) that starts from the main corridor, so the corridors are one
  network (the main corridor runs on to the outer wall past an arm; an arm
  may get a fire door). The outside fills the rest of the bounding box
  (the court of a U is 8-16 m wide; an L's main wing runs 12-26 m past
  its arm), so the outline is an L or a U.

A building of wings has 10-40 rooms, and three times in ten two neighbours
make one open-plan area. Then, in order, each from the plan's own "hard"
random stream:

6. walls of their own thickness: the plan draws the most its inner walls
   may be and the most its outer walls may be (each 0.1-0.4 m), then every
   side of every room and corridor rectangle moves into its wall, or back
   from it, by a few cells drawn for that side, so an inner wall is
   0.05 m (1 cell at 0.05 m) to that most, 0.05-0.4 m over the plans (the
   two sides facing across it drew apart, so a wall steps where the rooms
   along it change), and an outer wall likewise (the outline stays where it
   was): 1-8 cells at 0.05 m;
7. doors redrawn in the same walls, anywhere along them: flush against an
   end of the wall (0 m from the corner) a third of the time, 0.6 m wide one
   time in ten, 1.3-1.6 m (double doors) one in five, else 0.7-1.2 m, and
   0.3 m at least from any other door (flush in both walls of one corner,
   a post stays); then a room with a door onto a corridor gets a second
   door in the same wall one time in five (:data:`SECOND_DOOR_ODDS`; while
   it has fewer than 3 doors and the wall has room, drawn as the others);
8. furniture (``furniture``; as above, in the new rooms), then the whole
   building turned about its centre: one plan in five not at all, the
   others by an angle drawn uniformly in +-30 degrees (``rotation``), by
   nearest-neighbour sampling of every image at once (ground truth, doors,
   furniture). Walls of 2 cells or more stay closed; where a wall of 1 cell
   comes out with two rooms, or a room and the outside, touching (even
   diagonally), the cell of the room with the smaller label becomes wall
   (or door gap, in a doorway between the two), so 1-cell walls stay 1
   cell thick except there, where they are 2. Room bits the sampling cut
   off become wall, and the furniture next to any pocket of robot space
   the turn made (a sliver sampled a cell narrower) is taken out, so the
   robot space stays one piece (as checked at 0.05 m);
9. map noise: 4-12 occupied specks of 1-2 cells in open space (0.6 m
   from anything occupied, 1 m from door gaps and each other: ``specks``,
   ``rooms`` 0 there) and 8-24 single cells missing from the walls' faces
   (``holes``: free, taken into the room whose face it was, with no other
   room, door gap or unknown cell among their 8 neighbours, so no hole
   joins two rooms and none is one a robot could pass; walls of 1 cell
   have none).

In a turned plan a door's and a piece of furniture's ``box`` is the
bounding box of its cells; :meth:`FloorPlan.door_cells` and
:meth:`FloorPlan.furniture_cells` give the cells.

**SLAM plans** (``slam=True``, which implies ``hard``) are the hard plan
of the seed as a robot's SLAM scan shows it, each step from the plan's
own "slam" random stream (so the hard plan is the same with it or without):

10. ragged walls: along 5-15 % of the rooms' edges, in runs of 0.2-1 m,
    the wall's face moves out a cell (room cells become wall), and along
    5-15 % of the walls' faces it moves in a cell (wall cells become the
    room's, only where no other room, door gap or unknown is within 2
    cells, so a wall never opens); none within 0.3 m of a door gap or 1 m
    of furniture or specks;
11. unexplored patches: discs 0.2-1 m across (:data:`SLAM_PATCH`), about
    one for every two or three rooms, centred in nooks (room cells with
    mostly walls, furniture or unknown within 0.3 m: the corners of rooms
    and the spaces behind furniture) at least the radius + 0.5 m from door
    gaps; the room's, walls' and furniture's cells in the disc become
    unknown (``unexplored``: their bounding boxes);
12. unseen walls: 20-50 % of the wall faces (the wall cells next to a
    room; :data:`SLAM_UNSEEN_SHARE`) read unknown, in runs of 0.5-3 m along
    them (:data:`SLAM_UNSEEN_RUN`), half the runs through the wall's whole
    thickness (so a room may border the unknown outside);
13. anti-aliased edges: 10-30 % of the wall-face cells still occupied read
    0.55-0.9 (:data:`SLAM_ANTIALIAS`);
14. speckle: single cells in the rooms, 0.05-0.2 a square metre of floor,
    each 0.6 m at least from anything not free, from door gaps and from
    each other; a quarter of them grey (0.25-0.75), the others occupied.

``rooms`` drops every cell that is no longer free (occupancy 0), and bits
of a room cut off from it become wall. The invariants stay: each room one
piece, no two rooms touching even diagonally (unknown, grey or occupied
cells between them), the free cells that are in no room the door gaps, the
image's border unknown, and the robot space one piece reaching every room
(each step that changes the free space is undone, per patch or as a whole
for the ragged walls, if it would break that). The unknown is no longer
only the outside: it may border free cells, inside the building too.

**Cluttered corridors** (``clutter_corridors=True``, with or without
``hard`` and ``furniture``, from their own stream): benches, printers,
lockers and plants against the corridors' walls (as for rooms: backed by a
wall along their whole side, clear of doors, the corridor's robot space one
piece reaching its doors), each leaving at least 1 m of free floor in
front of it across the corridor.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from atlas_rap.maps.frame import GridFrame

__all__ = [
    "CORRIDOR_CLEAR", "CORRIDOR_WIDTH", "DOOR_WIDTH", "FURNITURE_SIDE", "HARD_DOOR_WIDTH", "HARD_OUTER_THICKNESS",
    "HARD_ROTATION", "HARD_WALL_THICKNESS", "OPEN_PLAN_AREA", "ROBOT_RADIUS", "ROOMS_PER_PLAN",
    "ROOM_AREA", "SECOND_DOOR_ODDS", "SLAM_ANTIALIAS", "SLAM_PATCH", "SLAM_UNSEEN_RUN", "SLAM_UNSEEN_SHARE",
    "SLIVER", "WALL_THICKNESS", "WING_CORRIDOR_WIDTH", "WING_LAYOUTS", "WING_ROOM_DEPTH", "WING_ROOM_WIDTH",
    "WING_SHARE", "Door", "FloorPlan", "Furniture", "Score", "best_places", "built_world_scores", "generate_plan",
    "read_truth", "robot_space", "score", "world_room_names", "world_rooms", "write_plan",
]

Rect = tuple[int, int, int, int]
"""(row0, row1, col0, col1) of a block of cells, half-open."""

ROOM_AREA = (4.0, 60.0)
"""m² of a room (corridors excepted)."""
OPEN_PLAN_AREA = (30.0, 60.0)
DOOR_WIDTH = (0.7, 1.3)
CORRIDOR_WIDTH = (1.2, 3.0)
WALL_THICKNESS = (0.1, 0.25)
FURNITURE_SIDE = (0.4, 2.0)
SLIVER = (0.3, 0.9)
"""The gap some furniture leaves to a wall: too narrow to be a room, wide enough to fool a door detector."""
ROBOT_RADIUS = 0.2
ROOMS_PER_PLAN = (10, 40)
HARD_WALL_THICKNESS = (0.05, 0.4)
"""Inner walls of a ``hard`` plan, each its own (outer walls: :data:`HARD_OUTER_THICKNESS`): 1-8 cells at 0.05 m."""
HARD_OUTER_THICKNESS = (0.05, 0.4)
HARD_DOOR_WIDTH = (0.6, 1.6)
HARD_ROTATION = 30.0
"""Degrees either way a ``hard`` plan's building is turned (when it is turned at all)."""
SECOND_DOOR_ODDS = 0.2
"""The share of a ``hard`` plan's rooms with a door onto a corridor that get a second door onto it."""
WING_LAYOUTS = ("double-loaded", "L-shaped", "U-shaped")
"""Buildings of wings (double-loaded corridors) that ``hard`` plans draw :data:`WING_SHARE` of the time."""
WING_SHARE = 0.4
WING_CORRIDOR_WIDTH = (1.5, 2.5)
WING_ROOM_WIDTH = (3.0, 5.0)
"""Metres along the corridor of a wing's room (as drawn: a ``hard`` plan's walls then move its sides)."""
WING_ROOM_DEPTH = (3.5, 5.0)
SLAM_UNSEEN_SHARE = (0.2, 0.5)
"""The share of a ``slam`` plan's wall faces that read unknown, in runs of :data:`SLAM_UNSEEN_RUN` metres."""
SLAM_UNSEEN_RUN = (0.5, 3.0)
SLAM_PATCH = (0.2, 1.0)
"""Metres across an unexplored (unknown) patch of a ``slam`` plan, in a room's corner or behind furniture."""
SLAM_ANTIALIAS = (0.55, 0.9)
"""Occupancy of a ``slam`` plan's anti-aliased wall-face cells."""
CORRIDOR_CLEAR = 1.0
"""Metres of corridor that ``clutter_corridors`` furniture leaves free across it."""
DEFAULT_SIZE = ((24.0, 40.0), (14.0, 26.0))
"""(long side, short side) ranges in metres of a building of the default size."""
MIN_SIZE = (12.0, 10.0)
MARGIN = 1.0
"""Metres of unknown around the building."""

_MIN_SIDE = 2.0  # shortest side of a room
_MIN_BAND = 3.5  # depth of the rooms between two corridors, or a corridor and the outer wall
_MIN_BLOCK = 4.0  # width of the rooms between two branches
_DOOR_END = 0.15  # a door keeps this much wall at each end of the wall it is in
_DOOR_ZONE = (1.0, 0.3)  # furniture keeps this far in front of a door, and this far either side of it
_DOOR_APART = 0.3  # a hard plan's doors keep this far from each other
_ATTEMPTS = 30


# -- the plan ------------------------------------------------------------------------------

@dataclass(frozen=True)
class Door:
    """A gap in a wall between two rooms.

    ``center`` (x, y) in metres and ``width`` in metres (along the wall);
    ``rooms`` the two labels it joins (smaller first); ``box`` the gap's
    cells (row0, row1, col0, col1), the wall's thickness one way and the
    width the other; ``wall`` is ``"horizontal"`` or ``"vertical"``, the
    direction of the wall it is in; ``corner``: flush against an end of
    the wall (a hard plan's corner door).
    """

    center: tuple[float, float]
    width: float
    rooms: tuple[int, int]
    box: Rect
    wall: str
    corner: bool = False


@dataclass(frozen=True)
class Furniture:
    """An occupied rectangle in a room: ``kind`` (desk, table, shelf, cabinet, pillar), where it stands.

    ``placement`` is ``wall`` (against a wall), ``sliver`` (``gap`` metres
    from the wall on its ``side``: top, bottom, left or right of the room as
    seen in the image) or ``free`` (at least 1 m from every wall).
    """

    kind: str
    box: Rect
    room: int
    placement: str
    side: str = ""
    gap: float = 0.0


@dataclass(frozen=True, eq=False)
class FloorPlan:
    """A generated building: its occupancy grid and its ground-truth rooms, on one :class:`GridFrame`.

    ``occupancy`` (float32): 0 free, 1 occupied (walls, furniture), NaN
    unknown (outside the outer wall). ``rooms`` (int32): 0 not a room
    (walls, door gaps, outside, furniture), 1..N a room, ``room_names[i]``
    and ``room_kinds[i]`` (corridor, storage, office, lab, meeting-room,
    open-plan) naming label i + 1; corridors come first. Both arrays are
    read-only and have row 0 at the top (``frame`` places them).

    A ``hard`` plan (see the module docstring) may be a building of wings
    (``layout`` one of :data:`WING_LAYOUTS`) and may be turned by
    ``rotation`` degrees (counter-clockwise); its doors' and furniture's
    ``box`` are then the bounding boxes of their cells in the image (a
    door's cells are the free cells with ``rooms == 0``) and ``wall`` is the
    wall's direction before the turn; ``furniture_mask`` holds the
    furniture's cells then (see :meth:`furniture_cells`). ``specks`` are
    the 1-2 cell boxes of clutter noise (occupied, ``rooms`` 0), ``holes``
    the wall cells left out (free, in the room whose wall they were in).

    A ``slam`` plan is a hard plan as a robot's scan shows it: its
    ``occupancy`` also has grey cells (between 0 and 1: anti-aliased wall
    faces and speckle) and unknown cells inside the building (stretches of
    wall, and the ``unexplored`` patches, given by their bounding boxes),
    and ``rooms`` only the cells still free; ``specks`` and ``holes`` are
    those the scan left as they were. Furniture cells may read unknown.
    """

    occupancy: np.ndarray
    rooms: np.ndarray
    room_names: tuple[str, ...]
    room_kinds: tuple[str, ...]
    frame: GridFrame
    doors: tuple[Door, ...]
    furniture: tuple[Furniture, ...] = ()
    seed: int = 0
    layout: str = ""
    hard: bool = False
    rotation: float = 0.0
    specks: tuple[Rect, ...] = ()
    holes: tuple[tuple[int, int], ...] = ()
    furniture_mask: np.ndarray | None = None
    slam: bool = False
    unexplored: tuple[Rect, ...] = ()

    @property
    def n_rooms(self) -> int:
        return len(self.room_names)

    def door_cells(self) -> np.ndarray:
        """The door gaps' cells: free, in no room."""
        return (self.occupancy == 0) & (self.rooms == 0)

    def furniture_cells(self) -> np.ndarray:
        """The furniture's cells (its boxes, unless the plan was turned: ``furniture_mask``)."""
        if self.furniture_mask is not None:
            return self.furniture_mask
        mask = np.zeros(self.rooms.shape, dtype=bool)
        for item in self.furniture:
            r0, r1, c0, c1 = item.box
            mask[r0:r1, c0:c1] = True
        return mask

    @property
    def free(self) -> np.ndarray:
        """Cells that are free (occupancy 0)."""
        return self.occupancy == 0

    @property
    def corridors(self) -> tuple[int, ...]:
        """Labels of the corridor rooms."""
        return tuple(i + 1 for i, kind in enumerate(self.room_kinds) if kind == "corridor")

    def room_areas(self) -> np.ndarray:
        """Area in m² of each room, index i for label i + 1 (furniture excluded)."""
        counts = np.bincount(self.rooms.ravel(), minlength=self.n_rooms + 1)[1:]
        return counts * self.frame.resolution ** 2

    def label(self, name: str) -> int:
        """The label of the room called ``name``."""
        return self.room_names.index(name) + 1

    def doors_of(self, label: int) -> tuple[Door, ...]:
        return tuple(d for d in self.doors if label in d.rooms)


# -- units ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Units:
    """Metres to whole cells, and draws of a whole number of cells within a range of metres."""

    res: float

    def cells(self, metres: float) -> int:
        return max(1, round(metres / self.res))

    def span(self, lo: float, hi: float) -> tuple[int, int]:
        """The fewest and most cells whose length is within [lo, hi] metres (at least 1 cell)."""
        return max(1, math.ceil(lo / self.res - 1e-9)), max(1, math.floor(hi / self.res + 1e-9))

    def draw(self, rng: np.random.Generator, lo: float, hi: float) -> int:
        a, b = self.span(lo, hi)
        return int(rng.integers(a, max(a, b) + 1))

    def area(self, rect: Rect) -> float:
        return (rect[1] - rect[0]) * (rect[3] - rect[2]) * self.res ** 2


# -- the building, in "canonical" cells: the inner area's top-left is (0, 0), spines run along columns

@dataclass
class _Space:
    """A room or a corridor being drawn: the rectangles carved for it (``connectors`` carve, never get doors)."""

    kind: str
    rects: list[Rect]
    connectors: list[Rect] = field(default_factory=list)
    block: int = -1
    doors: int = 0


@dataclass
class _Draft:
    height: int
    width: int
    wall: int
    outer: int
    layout: str
    pieces: list[Rect]
    fire_walls: list[Rect]  # walls across corridors, each with a fire door
    blocks: list[Rect]
    spaces: list[_Space] = field(default_factory=list)
    doors: list[tuple[int, int, Rect, str]] = field(default_factory=list)  # space a, space b, gap, wall
    corners: set[Rect] = field(default_factory=set)  # the gaps of doors flush against an end of their wall
    drawn: list[tuple[list[Rect], list[Rect]]] | None = None  # each space's (rects, connectors) before a hard
    # plan's walls moved: the outline, the labels' order and the rooms' kinds go by them (None: as they are)


def _split_length(rng: np.random.Generator, total: int, parts: int, minimum: int,
                  maximum: int | None = None) -> list[int] | None:
    """``parts`` whole numbers >= ``minimum`` (and <= ``maximum``) adding up to ``total``, otherwise random;
    None if impossible. What a part draws above ``maximum`` goes to the parts with the most room left."""
    slack = total - parts * minimum
    if slack < 0 or (maximum is not None and total > parts * maximum):
        return None
    weights = rng.uniform(0.6, 1.4, parts)
    extra = np.floor(slack * weights / weights.sum()).astype(int)
    extra[int(rng.integers(parts))] += slack - int(extra.sum())
    if maximum is not None:
        room = maximum - minimum
        over = int(np.maximum(extra - room, 0).sum())
        extra = np.minimum(extra, room)
        while over:
            i = int(np.argmin(extra))
            extra[i] += 1
            over -= 1
    return [minimum + int(e) for e in extra]


def _spaced(rng: np.random.Generator, length: int, widths: list[int], gap: int) -> list[int]:
    """Start columns of strips of ``widths`` with at least ``gap`` between them and from both ends."""
    while widths:
        parts = _split_length(rng, length - sum(widths), len(widths) + 1, gap)
        if parts is not None:
            starts, x = [], 0
            for w, p in zip(widths, parts):
                x += p
                starts.append(x)
                x += w
            return starts
        widths = widths[:-1]
    return []


def _corridor_width(rng: np.random.Generator, u: _Units) -> int:
    """Mostly 1.5-2.4 m; one in five anywhere in 1.2-3 m."""
    return u.draw(rng, *CORRIDOR_WIDTH) if rng.random() < 0.2 else u.draw(rng, 1.5, 2.4)


def _fitting_width(u: _Units, width: int, height: int, wall: int) -> int:
    """A spine's width, narrowed (to no less than 1.2 m) to leave 3.5 m of rooms on either side."""
    room = height - 2 * wall - 2 * u.cells(_MIN_BAND)
    if room < u.span(*CORRIDOR_WIDTH)[0]:
        raise ValueError(f"the building is too shallow ({height * u.res:.1f} m inside) for a corridor and rooms")
    return min(width, room)


def _choose_layout(rng: np.random.Generator, u: _Units, height: int, width: int) -> str:
    if height * u.res >= 19.0 and rng.random() < 0.6:
        return "grid"
    if width * u.res < 22.0:
        return str(rng.choice(["T", "L"]))
    return str(rng.choice(["T", "L", "comb", "cross"], p=[0.3, 0.2, 0.3, 0.2]))


def _spine_layout(rng: np.random.Generator, u: _Units, draft: _Draft) -> None:
    """Spines across the whole width, branches across the bands between them and the outer wall."""
    h, w, t = draft.height, draft.width, draft.wall
    n_spines = 2 if draft.layout == "grid" else 1
    spine_w = [_corridor_width(rng, u) for _ in range(n_spines)]
    depths = _split_length(rng, h - sum(spine_w) - 2 * t * n_spines, n_spines + 1, u.cells(_MIN_BAND))
    if depths is None:
        n_spines, draft.layout = 1, "T"
        spine_w = [_fitting_width(u, spine_w[0], h, t)]
        depths = _split_length(rng, h - spine_w[0] - 2 * t, 2, u.cells(_MIN_BAND))
        assert depths is not None
    bands, spines, row = [], [], 0
    for i, depth in enumerate(depths):
        bands.append((row, row + depth))
        row += depth
        if i < n_spines:
            spines.append((row + t, row + t + spine_w[i]))
            row += 2 * t + spine_w[i]
    n_bands = len(bands)
    count = {"T": 1, "comb": int(rng.integers(2, 4)), "cross": int(rng.integers(1, 3)),
             "grid": int(rng.integers(1, 4))}[draft.layout]
    widths = [u.draw(rng, 1.2, 2.4) for _ in range(count)]
    starts = _spaced(rng, w, widths, u.cells(_MIN_BLOCK) + 2 * t)
    spans = []
    for i in range(len(starts)):
        if draft.layout == "cross":
            spans.append((0, n_bands - 1))
        elif draft.layout == "grid":
            first = 1 if i == 0 else int(rng.integers(0, n_bands))
            spans.append((int(rng.integers(0, first + 1)) if i == 0 else first,
                          int(rng.integers(first, n_bands)) if i == 0 else first))
        else:
            side = int(rng.integers(0, 2)) * (n_bands - 1)
            spans.append((side, side))
    draft.pieces = [(r0, r1, 0, w) for r0, r1 in spines]
    for v, vw, (j, k) in zip(starts, widths, spans):
        r0 = spines[j - 1][1] if j > 0 else 0
        r1 = spines[k][0] if k < n_bands - 1 else h
        draft.pieces.append((r0, r1, v, v + vw))
    for b, (r0, r1) in enumerate(bands):
        c = 0
        for v, vw, (j, k) in sorted(zip(starts, widths, spans)):
            if j <= b <= k:
                draft.blocks.append((r0, r1, c, v - t))
                c = v + vw + t
        draft.blocks.append((r0, r1, c, w))


def _l_layout(rng: np.random.Generator, u: _Units, draft: _Draft) -> None:
    """A corridor from one end wall that turns and runs to a side wall: three blocks around it."""
    h, w, t = draft.height, draft.width, draft.wall
    sw, vw = _fitting_width(u, _corridor_width(rng, u), h, t), _corridor_width(rng, u)
    depths = _split_length(rng, h - sw - 2 * t, 2, u.cells(_MIN_BAND))
    assert depths is not None
    h0 = depths[0] + t
    block = u.cells(_MIN_BLOCK)
    lo, hi = block + t, w - vw - t - block
    if hi < lo:  # too short for the turn and the rooms around it
        draft.layout = "T"
        _spine_layout(rng, u, draft)
        return
    start = min(max(lo, int(0.45 * w)), hi)
    v = int(rng.integers(start, max(start, min(hi, int(0.8 * w))) + 1))
    draft.pieces = [(h0, h0 + sw, 0, v + vw), (h0, h, v, v + vw)]
    draft.blocks = [(0, h0 - t, 0, w), (h0 + sw + t, h, 0, v - t), (h0, h, v + vw + t, w)]


def _dead_ends(draft: _Draft, u: _Units) -> list[tuple[int, Rect]]:
    """Walls that could close a dead-end corridor arm with a fire door: (piece, the wall's cells).

    An arm is a piece's stretch between the outer wall and the nearest piece
    that crosses or meets it; the fire wall stands 1-2 m from that junction
    and leaves at least 3 m of corridor behind it.
    """
    t, out = draft.wall, []
    near, far = u.cells(1.0), u.cells(3.0)
    for i, (r0, r1, c0, c1) in enumerate(draft.pieces):
        along_cols = (c1 - c0) > (r1 - r0)
        others = [p for j, p in enumerate(draft.pieces) if j != i and _touch(p, draft.pieces[i])]
        if along_cols:
            lo_end = min((p[2] for p in others), default=None)
            hi_end = max((p[3] for p in others), default=None)
            if lo_end is not None and c0 == 0 and lo_end - near - t >= far:
                out.append((i, (r0, r1, lo_end - near - t, lo_end - near)))
            if hi_end is not None and c1 == draft.width and draft.width - (hi_end + near + t) >= far:
                out.append((i, (r0, r1, hi_end + near, hi_end + near + t)))
        else:
            lo_end = min((p[0] for p in others), default=None)
            hi_end = max((p[1] for p in others), default=None)
            if lo_end is not None and r0 == 0 and lo_end - near - t >= far:
                out.append((i, (lo_end - near - t, lo_end - near, c0, c1)))
            if hi_end is not None and r1 == draft.height and draft.height - (hi_end + near + t) >= far:
                out.append((i, (hi_end + near, hi_end + near + t, c0, c1)))
    return out


def _touch(a: Rect, b: Rect) -> bool:
    """Whether two rectangles overlap or share an edge (their cells are 4-connected)."""
    rows = a[0] <= b[1] and b[0] <= a[1]
    cols = a[2] <= b[3] and b[2] <= a[3]
    overlap_rows = a[0] < b[1] and b[0] < a[1]
    overlap_cols = a[2] < b[3] and b[2] < a[3]
    return (rows and overlap_cols) or (cols and overlap_rows)


def _add_fire_doors(rng: np.random.Generator, u: _Units, draft: _Draft) -> None:
    """Cut 0-2 dead-end arms off with a wall across them (the door in it comes with the other doors)."""
    candidates = _dead_ends(draft, u)
    count = min(len(candidates), int(rng.choice([0, 1, 2], p=[0.6, 0.3, 0.1])))
    for k in sorted(rng.choice(len(candidates), size=count, replace=False).tolist(), reverse=True):
        _, wall = candidates[k]
        index = next(j for j, p in enumerate(draft.pieces) if _inside(wall, p))
        r0, r1, c0, c1 = draft.pieces[index]
        if wall[0] == r0 and wall[1] == r1:
            a, b = (r0, r1, c0, wall[2]), (r0, r1, wall[3], c1)
        else:
            a, b = (r0, wall[0], c0, c1), (wall[1], r1, c0, c1)
        draft.pieces[index] = a
        draft.pieces.append(b)
        draft.fire_walls.append(wall)


def _inside(inner: Rect, outer: Rect) -> bool:
    return outer[0] <= inner[0] and inner[1] <= outer[1] and outer[2] <= inner[2] and inner[3] <= outer[3]


def _room_target(rng: np.random.Generator) -> float:
    """The area (m²) a room is split down to: small rooms, offices, large rooms and halls."""
    kind = rng.choice(4, p=[0.2, 0.45, 0.25, 0.1])
    return float(rng.uniform(*((6.0, 14.0), (14.0, 30.0), (30.0, 45.0), (45.0, 60.0))[kind]))


def _subdivide(rng: np.random.Generator, u: _Units, block: Rect, wall: int, scale: float,
               deep_axis: int) -> list[Rect]:
    """Rooms of a block by binary space partition, each split down to its own target area (times ``scale``).

    A piece is a room when its area is at most the target and its sides are
    within 2.5 : 1, or when it cannot be split with both halves at least
    2 m wide; it is always split above 60 m² when it can be. Cuts run
    across the corridor wall (``deep_axis`` is the axis away from the
    corridor: 0 rows, 1 columns), so that rooms keep a corridor frontage,
    each cutting one room of about its target area (but no narrower than
    its depth / 2.5) off one end of the piece -- halving instead would
    overshoot the targets into strips -- except that a piece deeper than
    8 m is cut along it, near its middle, half the time (rooms behind
    rooms, reached through them) and a piece much deeper than wide always is.
    """
    side = u.cells(_MIN_SIDE)
    leaves, todo = [], [block]
    while todo:
        rect = todo.pop()
        h, w = rect[1] - rect[0], rect[3] - rect[2]
        area, aspect = u.area(rect), max(h, w) / min(h, w)
        can = [h >= 2 * side + wall, w >= 2 * side + wall]
        target = min(_room_target(rng) * scale, ROOM_AREA[1])
        if not any(can) or (area <= target and aspect <= 2.5):
            leaves.append(rect)
            continue
        depth, front = (h, w)[deep_axis], (h, w)[1 - deep_axis]
        deep = (depth * u.res > 8.0 and rng.random() < 0.5) or depth > 2.5 * front
        narrowest = max(side, math.ceil(depth / 2.5))  # rooms no thinner than that, across the frontage
        if not deep and front < 2 * narrowest + wall:
            if area <= ROOM_AREA[1]:  # cannot be cut into two well-shaped rooms: one larger room
                leaves.append(rect)
                continue
            deep = True
        axis = deep_axis if deep else 1 - deep_axis
        if not can[axis]:
            axis, narrowest = 1 - axis, side
        length = (h, w)[axis]
        if axis == deep_axis:  # two rows of rooms, roughly halfway
            lo, hi = max(side, int(0.35 * length)), min(length - side - wall, int(0.65 * length))
            cut = int(rng.integers(lo, hi + 1)) if lo <= hi else (length - wall) // 2
        else:  # one room of about the target's area off one end
            size = target / ((h, w)[1 - axis] * u.res) / u.res * rng.uniform(0.85, 1.15)
            cut = min(max(round(size), narrowest), length - wall - narrowest)
            if rng.random() < 0.5:
                cut = length - wall - cut
        start = rect[2 * axis]
        if axis == 0:
            todo += [(rect[0], start + cut, rect[2], rect[3]), (start + cut + wall, rect[1], rect[2], rect[3])]
        else:
            todo += [(rect[0], rect[1], rect[2], start + cut), (rect[0], rect[1], start + cut + wall, rect[3])]
    return leaves


def _deep_axis(block: Rect, pieces: list[Rect], wall: int) -> int:
    """The axis away from the block's longest corridor wall: 0 (rows) for a corridor above or below it."""
    best, axis = 0, 0
    for piece in pieces:
        shared = _shared_wall(block, piece, wall)
        if shared is not None and shared[2] - shared[1] > best:
            best, axis = shared[2] - shared[1], 0 if shared[0] == "horizontal" else 1
    return axis


def _shared_wall(a: Rect, b: Rect, t: int) -> tuple[str, int, int, int, int] | None:
    """Where rectangles a and b face each other across a wall ``t`` cells thick.

    (wall, lo, hi, w0, w1): the wall is ``vertical`` (cells [lo, hi) of rows,
    [w0, w1) of columns) or ``horizontal`` (rows [w0, w1), columns [lo, hi)).
    """
    for wall, (a0, a1, b0, b1), (along_a, along_b) in (
            ("vertical", (a[2], a[3], b[2], b[3]), ((a[0], a[1]), (b[0], b[1]))),
            ("horizontal", (a[0], a[1], b[0], b[1]), ((a[2], a[3]), (b[2], b[3])))):
        if a1 + t == b0 or b1 + t == a0:
            lo, hi = max(along_a[0], along_b[0]), min(along_a[1], along_b[1])
            w0 = a1 if a1 + t == b0 else b1
            return (wall, lo, hi, w0, w0 + t) if hi > lo else None
    return None


def _walls_between(x: _Space, y: _Space, t: int) -> list[tuple[str, int, int, int, int]]:
    found = (_shared_wall(a, b, t) for a in x.rects for b in y.rects)
    return [s for s in found if s is not None]


def _door_in(rng: np.random.Generator, u: _Units, wall: tuple[str, int, int, int, int]) -> Rect | None:
    """A gap 0.7-1.3 m wide somewhere along ``wall``, 0.15 m from its ends; None if the wall is too short."""
    kind, lo, hi, w0, w1 = wall
    end = u.cells(_DOOR_END)
    wmin, wmax = u.span(*DOOR_WIDTH)
    wmax = min(wmax, hi - lo - 2 * end)
    if wmax < wmin:
        return None
    width = int(rng.integers(wmin, wmax + 1))
    d0 = int(rng.integers(lo + end, hi - end - width + 1))
    return (d0, d0 + width, w0, w1) if kind == "vertical" else (w0, w1, d0, d0 + width)


def _corridor_spaces(draft: _Draft) -> list[_Space]:
    """The pieces grouped into corridors: pieces that overlap or touch are one corridor."""
    group = list(range(len(draft.pieces)))

    def root(i: int) -> int:
        while group[i] != i:
            i = group[i]
        return i

    for i, a in enumerate(draft.pieces):
        for j in range(i):
            if _touch(a, draft.pieces[j]):
                group[root(i)] = root(j)
    roots = sorted({root(i) for i in range(len(draft.pieces))})
    return [_Space("corridor", [p for i, p in enumerate(draft.pieces) if root(i) == r]) for r in roots]


def _merge_open_plan(rng: np.random.Generator, u: _Units, draft: _Draft, rooms: list[_Space]) -> None:
    """Join two neighbours of a block into one open-plan area of 30-60 m² (L-shaped when they differ)."""
    t, pairs = draft.wall, []
    for i, a in enumerate(rooms):
        for j in range(i):
            b = rooms[j]
            if a.block != b.block:
                continue
            wall = _shared_wall(a.rects[0], b.rects[0], t)
            if wall is None or (wall[2] - wall[1]) * u.res < 2.0:
                continue
            connector = _wall_rect(wall)
            area = u.area(a.rects[0]) + u.area(b.rects[0]) + u.area(connector)
            if OPEN_PLAN_AREA[0] <= area <= OPEN_PLAN_AREA[1]:
                pairs.append((i, j, connector))
    if not pairs:
        return
    i, j, connector = pairs[int(rng.integers(len(pairs)))]
    rooms[j].rects += rooms[i].rects
    rooms[j].connectors.append(connector)
    rooms[j].kind = "open-plan"
    del rooms[i]


def _wall_rect(wall: tuple[str, int, int, int, int]) -> Rect:
    kind, lo, hi, w0, w1 = wall
    return (lo, hi, w0, w1) if kind == "vertical" else (w0, w1, lo, hi)


def _drop_corner_block(rng: np.random.Generator, draft: _Draft, rooms: list[_Space]) -> list[_Space]:
    """Sometimes leave out a block in a corner of the building (while 10 rooms remain): an L or U outline."""
    if len(draft.blocks) < 3 or rng.random() >= 0.3:
        return rooms
    h, w = draft.height, draft.width
    corners = [b for b, (r0, r1, c0, c1) in enumerate(draft.blocks)
               if (r0 == 0) + (r1 == h) == 1 and (c0 == 0) + (c1 == w) == 1]
    if not corners:
        return rooms
    drop = corners[int(rng.integers(len(corners)))]
    kept = [r for r in rooms if r.block != drop]
    return kept if len(kept) >= ROOMS_PER_PLAN[0] else rooms


def _connect(rng: np.random.Generator, u: _Units, draft: _Draft) -> bool:
    """Doors: fire doors, then a spanning tree from the corridors, then a few more; False if a room is stuck."""
    spaces, t = draft.spaces, draft.wall
    corridor_of = {}
    for s, space in enumerate(spaces):
        for rect in space.rects if space.kind == "corridor" else ():
            corridor_of[rect] = s
    for fire_wall in draft.fire_walls:
        pa, pb = (p for p in draft.pieces if _touch(p, fire_wall))
        wall = _shared_wall(pa, pb, t)
        assert wall is not None and _wall_rect(wall) == fire_wall
        gap = _door_in(rng, u, wall)
        assert gap is not None, "a corridor too narrow for a door"
        draft.doors.append((corridor_of[pa], corridor_of[pb], gap, wall[0]))
    walls = {(i, j): _walls_between(spaces[i], spaces[j], t)
             for i in range(len(spaces)) for j in range(len(spaces))
             if i != j and "corridor" != spaces[i].kind}
    joined: set[tuple[int, int]] = set()

    def add(i: int, j: int) -> bool:
        options = walls.get((i, j), [])
        for k in rng.permutation(len(options)):
            gap = _door_in(rng, u, options[int(k)])
            if gap is not None:
                draft.doors.append((i, j, gap, options[int(k)][0]))
                spaces[i].doors += 1
                spaces[j].doors += 1
                joined.update({(i, j), (j, i)})
                return True
        return False

    def has_room(j: int) -> bool:
        return spaces[j].kind == "corridor" or spaces[j].doors < 3

    connected = {s for s, space in enumerate(spaces) if space.kind == "corridor"}
    todo = [s for s in range(len(spaces)) if s not in connected]
    while todo:
        progress = False
        for s in [todo[int(k)] for k in rng.permutation(len(todo))]:
            options = [j for j in connected if walls.get((s, j)) and has_room(j)]
            corridors = [j for j in options if spaces[j].kind == "corridor"]
            others = [j for j in options if spaces[j].kind != "corridor"]
            pick = corridors if corridors and (not others or rng.random() < 0.85) else others
            for j in [pick[int(k)] for k in rng.permutation(len(pick))]:
                if add(s, j):
                    connected.add(s)
                    todo.remove(s)
                    progress = True
                    break
        if not progress:
            return False
    for s in range(len(spaces)):
        if spaces[s].kind == "corridor" or spaces[s].doors >= 3:
            continue
        chance = 0.5 if u.area(spaces[s].rects[0]) >= 25.0 else 0.25
        if rng.random() < chance:
            options = [j for j in range(len(spaces)) if walls.get((s, j)) and (s, j) not in joined and has_room(j)]
            if options:
                add(s, options[int(rng.integers(len(options)))])
    return True


def _draw_building(rng: np.random.Generator, u: _Units, size: tuple[float, float] | None,
                   scale: float) -> tuple[_Draft, bool]:
    """A building in canonical cells (spines along the columns) and whether to show it transposed."""
    if size is None:
        long = rng.uniform(*DEFAULT_SIZE[0])
        short = rng.uniform(DEFAULT_SIZE[1][0], min(DEFAULT_SIZE[1][1], long))
        transposed = bool(rng.random() < 0.4)
    else:
        width, height = (float(v) for v in size)
        long, short, transposed = max(width, height), min(width, height), height > width
    wall = u.draw(rng, WALL_THICKNESS[0], 0.2)
    outer = u.draw(rng, max(WALL_THICKNESS[0], wall * u.res), WALL_THICKNESS[1])
    height, width = u.cells(short) - 2 * outer, u.cells(long) - 2 * outer
    layout = _choose_layout(rng, u, height, width)
    draft = _Draft(height, width, wall, outer, layout, [], [], [])
    (_l_layout if layout == "L" else _spine_layout)(rng, u, draft)
    _add_fire_doors(rng, u, draft)
    rooms = [_Space("room", [leaf], block=b) for b, block in enumerate(draft.blocks)
             for leaf in _subdivide(rng, u, block, wall, scale, _deep_axis(block, draft.pieces, wall))]
    rooms = _drop_corner_block(rng, draft, rooms)
    if rng.random() < 0.6 or not any(u.area(r.rects[0]) >= OPEN_PLAN_AREA[0] for r in rooms):
        _merge_open_plan(rng, u, draft, rooms)
    draft.spaces = _corridor_spaces(draft) + rooms
    return draft, transposed


# -- buildings of wings: double-loaded corridors, alone or joined into an L or a U ---------------

def _wing_section(rng: np.random.Generator, u: _Units) -> tuple[int, int, int]:
    """A wing's cross-section in cells: the depth of the rooms on one side, the corridor's width, the other side's."""
    return u.draw(rng, *WING_ROOM_DEPTH), u.draw(rng, *WING_CORRIDOR_WIDTH), u.draw(rng, *WING_ROOM_DEPTH)


def _row_of_rooms(rng: np.random.Generator, u: _Units, band: Rect, along_cols: bool, wall: int) -> list[Rect]:
    """The rooms of a band beside a corridor: 3-5 m wide each along it (``along_cols``: the band's columns),
    side by side with a wall between (wider when no number of rooms of 3-5 m fills the band)."""
    r0, r1, c0, c1 = band
    length = (c1 - c0) if along_cols else (r1 - r0)
    narrow, wide = u.span(*WING_ROOM_WIDTH)
    fewest = math.ceil((length + wall) / (wide + wall))
    most = (length + wall) // (narrow + wall)
    fits = fewest <= most
    parts = int(rng.integers(fewest, most + 1)) if fits else max(most, 1)
    widths = _split_length(rng, length - (parts - 1) * wall, parts, min(narrow, length), wide if fits else None)
    assert widths is not None
    rooms, x = [], c0 if along_cols else r0
    for width in widths:
        rooms.append((r0, r1, x, x + width) if along_cols else (x, x + width, c0, c1))
        x += width + wall
    return rooms


def _wings_layout(rng: np.random.Generator, u: _Units, layout: str, wall: int) -> tuple[int, int, list[Rect],
                                                                                        list[Rect]]:
    """A building of wings in canonical cells: (height, width, corridor pieces, bands of rooms).

    The main wing runs along the columns at the top: rooms, corridor, rooms.
    An ``L-shaped`` building adds an arm down the left, a ``U-shaped`` one
    down the right too: each arm is a double-loaded corridor that starts
    from the main corridor (which runs on to the outer wall past it), its
    outer rooms below the main corridor's end and its inner rooms below
    the main wing's inner rooms; the outside fills the rest (a court between
    the arms of a U).
    """
    t = wall
    top, cw, bottom = _wing_section(rng, u)
    depth = top + cw + bottom + 2 * t
    arms = WING_LAYOUTS.index(layout)
    sections = [_wing_section(rng, u) for _ in range(arms)]  # (outer rooms, corridor, inner rooms)
    reach = [outer + corridor + inner + 2 * t for outer, corridor, inner in sections]
    if arms == 0:
        height, width = depth, u.draw(rng, 24.0, 44.0)
    else:
        height = depth + u.draw(rng, 8.0, 18.0)
        width = sum(reach) + (u.draw(rng, 8.0, 16.0) if arms == 2 else u.draw(rng, 12.0, 26.0))
    a = top + t  # the main corridor's first row
    pieces = [(a, a + cw, 0, width)]
    bands = [(0, top, 0, width)]
    inner_lo, inner_hi = 0, width  # the main wing's inner rooms, between the arms
    for k, (outer, corridor, inner) in enumerate(sections):
        if k == 0:  # the left arm
            c = outer + t
            pieces.append((a + cw, height, c, c + corridor))
            bands += [(a + cw + t, height, 0, outer), (depth + t, height, c + corridor + t, reach[0])]
            inner_lo = c + corridor + t
        else:  # the right arm, mirrored
            c = width - outer - t - corridor
            pieces.append((a + cw, height, c, c + corridor))
            bands += [(a + cw + t, height, width - outer, width), (depth + t, height, width - reach[1], c - t)]
            inner_hi = c - t
    bands.append((a + cw + t, depth, inner_lo, inner_hi))
    return height, width, pieces, bands


def _draw_wings(rng: np.random.Generator, u: _Units) -> tuple[_Draft, bool]:
    """A building of wings (:data:`WING_LAYOUTS`, see :func:`_wings_layout`) and whether to show it transposed.

    Walls are drawn as for :func:`_draw_building`; rooms 3-5 m wide and
    3.5-5 m deep line both sides of each corridor; the arms of an L or a U
    may get a fire door (:func:`_add_fire_doors`), and three times in ten
    two neighbours join into an open-plan area.
    """
    layout = WING_LAYOUTS[int(rng.choice(len(WING_LAYOUTS), p=[0.4, 0.3, 0.3]))]
    wall = u.draw(rng, WALL_THICKNESS[0], 0.2)
    outer = u.draw(rng, max(WALL_THICKNESS[0], wall * u.res), WALL_THICKNESS[1])
    height, width, pieces, bands = _wings_layout(rng, u, layout, wall)
    draft = _Draft(height, width, wall, outer, layout, pieces, [], bands)
    _add_fire_doors(rng, u, draft)
    rooms = [_Space("room", [rect], block=b) for b, band in enumerate(bands)
             for rect in _row_of_rooms(rng, u, band, band[3] - band[2] > band[1] - band[0], wall)]
    if rng.random() < 0.3:
        _merge_open_plan(rng, u, draft, rooms)
    draft.spaces = _corridor_spaces(draft) + rooms
    return draft, bool(rng.random() < 0.5)


def _building(rng: np.random.Generator, u: _Units, size: tuple[float, float] | None, seed: int,
              wings: bool) -> tuple[_Draft, bool]:
    """A connected building (redrawn until it has 10-40 rooms at the default size) and whether it is transposed."""
    scale = 1.0
    for _ in range(_ATTEMPTS):
        draft, transposed = _draw_wings(rng, u) if wings else _draw_building(rng, u, size, scale)
        if not _connect(rng, u, draft):
            continue
        n = len(draft.spaces)
        if size is None and not ROOMS_PER_PLAN[0] <= n <= ROOMS_PER_PLAN[1]:
            scale *= 1.2 if n > ROOMS_PER_PLAN[1] else 1 / 1.2
            continue
        return draft, transposed
    raise RuntimeError(f"no floor plan for seed {seed} after {_ATTEMPTS} attempts")  # pragma: no cover


# -- from canonical cells to the image ------------------------------------------------------

@dataclass(frozen=True)
class _Placement:
    """Where canonical cells go in the image: an offset (margin + outer wall), flips, a transpose."""

    offset: int
    shape: tuple[int, int]  # canonical image shape
    flip_rows: bool
    flip_cols: bool
    transpose: bool

    def rect(self, rect: Rect) -> Rect:
        r0, r1, c0, c1 = (v + self.offset for v in rect)
        if self.flip_rows:
            r0, r1 = self.shape[0] - r1, self.shape[0] - r0
        if self.flip_cols:
            c0, c1 = self.shape[1] - c1, self.shape[1] - c0
        return (c0, c1, r0, r1) if self.transpose else (r0, r1, c0, c1)

    def wall(self, wall: str) -> str:
        if not self.transpose:
            return wall
        return "horizontal" if wall == "vertical" else "vertical"

    @property
    def image_shape(self) -> tuple[int, int]:
        return (self.shape[1], self.shape[0]) if self.transpose else self.shape


def _kind_of(rng: np.random.Generator, space: _Space, area: float) -> str:
    if space.kind in ("corridor", "open-plan"):
        return space.kind
    if area < 8.0:
        return "storage"
    if area < 16.0:
        return "office"
    if area < OPEN_PLAN_AREA[0]:
        return str(rng.choice(["lab", "meeting-room", "office"]))
    return str(rng.choice(["open-plan", "lab"]))


def _names(kinds: list[str]) -> list[str]:
    """``corridor`` when there is one, else ``corridor-1``...; ``office-1``, ``office-2``... per kind."""
    total = {k: kinds.count(k) for k in kinds}
    seen: dict[str, int] = {}
    names = []
    for kind in kinds:
        seen[kind] = seen.get(kind, 0) + 1
        names.append(kind if kind == "corridor" and total[kind] == 1 else f"{kind}-{seen[kind]}")
    return names


def _render(rng: np.random.Generator, u: _Units, draft: _Draft, transposed: bool, seed: int,
            rects_out: dict[int, list[Rect]] | None = None) -> FloorPlan:
    """Carve the rooms and doors into a walled footprint, number the rooms, place the image in the world.

    ``rects_out`` (if given) receives each label's rectangles in the image.
    """
    margin = u.cells(MARGIN)
    offset = margin + draft.outer
    canon = (draft.height + 2 * offset, draft.width + 2 * offset)
    place = _Placement(offset, canon, bool(rng.random() < 0.5), bool(rng.random() < 0.5), transposed)
    shape = place.image_shape
    spaces = [([place.rect(r) for r in s.rects], [place.rect(r) for r in s.connectors]) for s in draft.spaces]
    # The spaces as drawn: what labels, names and the outline go by (a hard plan's walls moved since).
    base = spaces if draft.drawn is None else [
        ([place.rect(r) for r in rects], [place.rect(r) for r in connectors]) for rects, connectors in draft.drawn]
    # Corridors first, then rooms from the top left, as one reads a plan.
    corridors = [s for s, space in enumerate(draft.spaces) if space.kind == "corridor"]
    others = [s for s, space in enumerate(draft.spaces) if space.kind != "corridor"]
    key = [min((r[0], r[2]) for r in rects) for rects, _ in base]
    order = sorted(corridors, key=lambda s: key[s]) + sorted(others, key=lambda s: key[s])
    label_of = {s: i + 1 for i, s in enumerate(order)}
    rooms = np.zeros(shape, dtype=np.int32)
    footprint = np.zeros(shape, dtype=bool)
    o = draft.outer
    for s, (rects, connectors) in enumerate(spaces):
        for r0, r1, c0, c1 in rects + connectors:
            rooms[r0:r1, c0:c1] = label_of[s]
    drawn = rooms if draft.drawn is None else np.zeros(shape, dtype=np.int32)
    for s, (rects, connectors) in enumerate(base):
        for r0, r1, c0, c1 in rects + connectors:
            drawn[r0:r1, c0:c1] = label_of[s]
            footprint[r0 - o:r1 + o, c0 - o:c1 + o] = True
    if rects_out is not None:
        rects_out.update({label_of[s]: rects for s, (rects, _) in enumerate(spaces)})
    free = rooms > 0
    doors = []
    frame = GridFrame(shape[0], shape[1], u.res, (-margin * u.res, -margin * u.res, 0.0))
    for a, b, gap, wall in draft.doors:
        r0, r1, c0, c1 = box = place.rect(gap)
        free[r0:r1, c0:c1] = True
        x, y = frame.cell_to_world((r0 + r1 - 1) / 2, (c0 + c1 - 1) / 2)
        wall = place.wall(wall)
        width = (c1 - c0 if wall == "horizontal" else r1 - r0) * u.res
        la, lb = sorted((label_of[a], label_of[b]))
        doors.append(Door((round(x, 6), round(y, 6)), round(width, 6), (la, lb), box, wall, gap in draft.corners))
    occupancy = np.where(footprint, np.where(free, 0.0, 1.0), np.nan).astype(np.float32)
    areas = np.bincount(drawn.ravel(), minlength=len(order) + 1) * u.res ** 2
    kinds = [_kind_of(rng, draft.spaces[s], float(areas[label_of[s]])) for s in order]
    doors.sort(key=lambda d: (d.rooms, d.box))
    return FloorPlan(_frozen(occupancy), _frozen(rooms), tuple(_names(kinds)), tuple(kinds), frame,
                     tuple(doors), (), seed, draft.layout)


def _frozen(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


# -- furniture ------------------------------------------------------------------------------

_PIECES: dict[str, tuple[tuple[float, float], tuple[float, float] | None, tuple[str, ...], tuple[float, ...]]] = {
    # kind: (long side, short side (None: square), placements, their odds)
    "desk": ((1.2, 1.8), (0.6, 0.8), ("wall", "free", "sliver"), (0.5, 0.3, 0.2)),
    "table": ((0.8, 2.0), (0.8, 1.2), ("free", "sliver", "wall"), (0.6, 0.3, 0.1)),
    "shelf": ((0.8, 2.0), (0.4, 0.5), ("wall", "sliver"), (0.6, 0.4)),
    "cabinet": ((0.4, 1.0), (0.4, 0.6), ("wall", "sliver"), (0.7, 0.3)),
    "pillar": ((0.4, 0.6), None, ("free", "sliver"), (0.7, 0.3)),
}
_PIECE_ODDS = {"desk": 0.3, "table": 0.2, "shelf": 0.2, "cabinet": 0.2, "pillar": 0.1}
_SIDES = ("top", "bottom", "left", "right")


def robot_space(free: np.ndarray, resolution: float, radius: float = ROBOT_RADIUS) -> np.ndarray:
    """Cells where a disc robot of ``radius`` fits: free, their centre ``radius`` from every non-free cell's edge.

    The cell's distance to the nearest non-free cell centre, less half a cell
    (that cell's edge), is at least ``radius`` -- the rule of
    :meth:`atlas_rap.maps.rosmap.RosMap.free_points_near`. The border of the
    array counts as not free.
    """
    padded = np.pad(np.asarray(free, dtype=bool), 1, constant_values=False)
    dt = ndimage.distance_transform_edt(padded)[1:-1, 1:-1]
    return dt * resolution - resolution / 2 >= radius


def _door_zone(door: Door, u: _Units, shape: tuple[int, int]) -> Rect:
    """The cells in front of a door (both sides) that furniture keeps clear."""
    deep, aside = u.cells(_DOOR_ZONE[0]), u.cells(_DOOR_ZONE[1])
    r0, r1, c0, c1 = door.box
    if door.wall == "horizontal":
        r0, r1, c0, c1 = r0 - deep, r1 + deep, c0 - aside, c1 + aside
    else:
        r0, r1, c0, c1 = r0 - aside, r1 + aside, c0 - deep, c1 + deep
    return (max(r0, 0), min(r1, shape[0]), max(c0, 0), min(c1, shape[1]))


def _room_rects(rooms: np.ndarray, label: int) -> list[Rect]:
    """The room's cells as rectangles: its bounding box when it is a rectangle, else its maximal row bands."""
    rows, cols = np.nonzero(rooms == label)
    box = (int(rows.min()), int(rows.max()) + 1, int(cols.min()), int(cols.max()) + 1)
    if rows.size == (box[1] - box[0]) * (box[3] - box[2]):
        return [box]
    mask = rooms[box[0]:box[1], box[2]:box[3]] == label
    bands: list[Rect] = []
    start, spans = box[0], None
    for r in range(box[0], box[1] + 1):
        here = None
        if r < box[1]:
            cs = np.flatnonzero(mask[r - box[0]])
            here = (int(cs.min()) + box[2], int(cs.max()) + 1 + box[2])
        if here != spans:
            if spans is not None:
                bands.append((start, r, spans[0], spans[1]))
            start, spans = r, here
    return [b for b in bands if b[1] - b[0] >= 2]


def _draw_piece(rng: np.random.Generator, u: _Units, rect: Rect) -> tuple[str, Rect, str, str, int] | None:
    """(kind, box, placement, side, gap cells) of a piece of furniture in ``rect``, or None if it does not fit."""
    kinds = list(_PIECE_ODDS)
    kind = kinds[int(rng.choice(len(kinds), p=list(_PIECE_ODDS.values())))]
    long, short, placements, odds = _PIECES[kind]
    a = u.draw(rng, *long)
    b = a if short is None else u.draw(rng, *short)
    placement = placements[int(rng.choice(len(placements), p=odds))]
    side = _SIDES[int(rng.integers(4))]
    # Against a wall the long side runs along it; free-standing either way.
    along_rows = side in ("left", "right")
    h, w = (a, b) if along_rows else (b, a)
    if placement == "free" and rng.random() < 0.5:
        h, w = w, h
    r0, r1, c0, c1 = rect
    gap = 0 if placement == "wall" else u.draw(rng, *SLIVER)
    if placement == "free":
        clear = u.cells(1.0)
        if r1 - r0 < h + 2 * clear or c1 - c0 < w + 2 * clear:
            return None
        top = int(rng.integers(r0 + clear, r1 - clear - h + 1))
        left = int(rng.integers(c0 + clear, c1 - clear - w + 1))
        return kind, (top, top + h, left, left + w), placement, "", 0
    if r1 - r0 < h + (gap if not along_rows else 0) or c1 - c0 < w + (gap if along_rows else 0):
        return None
    if along_rows:
        top = int(rng.integers(r0, r1 - h + 1))
        left = c0 + gap if side == "left" else c1 - gap - w
    else:
        left = int(rng.integers(c0, c1 - w + 1))
        top = r0 + gap if side == "top" else r1 - gap - h
    return kind, (top, top + h, left, left + w), placement, side, gap


def _furnish(rng: np.random.Generator, u: _Units, plan: FloorPlan) -> FloorPlan:
    """Put furniture in every room but the corridors (see the module docstring for the rules)."""
    rooms, occupancy = plan.rooms.copy(), plan.occupancy.copy()
    shape, items = rooms.shape, []
    zones = np.zeros(shape, dtype=bool)
    for door in plan.doors:
        r0, r1, c0, c1 = _door_zone(door, u, shape)
        zones[r0:r1, c0:c1] = True
    areas = plan.room_areas()
    for label in range(1, plan.n_rooms + 1):
        if plan.room_kinds[label - 1] == "corridor":
            continue
        rects = _room_rects(plan.rooms, label)
        weights = np.array([u.area(r) for r in rects])
        count = min(6, int(rng.poisson(areas[label - 1] / 8.0)))
        for _ in range(count):
            for _attempt in range(6):
                rect = rects[int(rng.choice(len(rects), p=weights / weights.sum()))]
                drawn = _draw_piece(rng, u, rect)
                if drawn is not None and _backed(drawn, plan) and _fits(drawn[1], label, rooms, zones, plan, u):
                    kind, (r0, r1, c0, c1), placement, side, gap = drawn
                    rooms[r0:r1, c0:c1] = 0
                    occupancy[r0:r1, c0:c1] = 1.0
                    items.append(Furniture(kind, (r0, r1, c0, c1), label, placement, side, round(gap * u.res, 6)))
                    break
    return FloorPlan(_frozen(occupancy), _frozen(rooms), plan.room_names, plan.room_kinds, plan.frame,
                     plan.doors, tuple(items), plan.seed, plan.layout)


def _backed(drawn: tuple[str, Rect, str, str, int], plan: FloorPlan) -> bool:
    """Whether a piece against a wall, or a sliver from one, has a wall along its whole side at that distance.

    (A room's rectangle may have an open side: one half of an L-shaped room.)
    """
    _, (r0, r1, c0, c1), placement, side, gap = drawn
    if placement == "free":
        return True
    height, width = plan.occupancy.shape
    if side == "top" and r0 - gap - 1 >= 0:
        beyond, between = plan.occupancy[r0 - gap - 1, c0:c1], plan.occupancy[r0 - gap:r0, c0:c1]
    elif side == "bottom" and r1 + gap < height:
        beyond, between = plan.occupancy[r1 + gap, c0:c1], plan.occupancy[r1:r1 + gap, c0:c1]
    elif side == "left" and c0 - gap - 1 >= 0:
        beyond, between = plan.occupancy[r0:r1, c0 - gap - 1], plan.occupancy[r0:r1, c0 - gap:c0]
    elif side == "right" and c1 + gap < width:
        beyond, between = plan.occupancy[r0:r1, c1 + gap], plan.occupancy[r0:r1, c1:c1 + gap]
    else:
        return False
    return bool((beyond == 1).all() and (between == 0).all())


def _fits(box: Rect, label: int, rooms: np.ndarray, zones: np.ndarray, plan: FloorPlan, u: _Units) -> bool:
    """Whether furniture at ``box`` stays on the room's free cells, 1 cell from other furniture and clear of doors,
    and leaves the room's robot space in one piece that reaches each of its doors."""
    r0, r1, c0, c1 = box
    g0, g1, h0, h1 = max(r0 - 1, 0), r1 + 1, max(c0 - 1, 0), c1 + 1
    if zones[r0:r1, c0:c1].any() or not (plan.rooms[r0:r1, c0:c1] == label).all():
        return False
    if ((plan.rooms[g0:g1, h0:h1] == label) & (rooms[g0:g1, h0:h1] != label)).any():  # other furniture
        return False
    rows, cols = np.nonzero(plan.rooms == label)
    pad = 2
    w0, w1 = max(int(rows.min()) - pad, 0), int(rows.max()) + 1 + pad
    v0, v1 = max(int(cols.min()) - pad, 0), int(cols.max()) + 1 + pad
    mask = rooms[w0:w1, v0:v1] == label
    mask[r0 - w0:r1 - w0, c0 - v0:c1 - v0] = False
    space = robot_space(mask, u.res)
    _, count = ndimage.label(space)
    if count != 1:
        return False
    for door in plan.doors_of(label):
        z0, z1, y0, y1 = _door_zone(door, u, rooms.shape)
        local = space[max(z0 - w0, 0):max(z1 - w0, 0), max(y0 - v0, 0):max(y1 - v0, 0)]
        if not local.any():
            return False
    return True


# -- hard plans: walls of their own thickness, doors anywhere, a turn, map noise -------------------

def _facing(a: Rect, b: Rect) -> tuple[str, int, int, int, int] | None:
    """Where rectangles a and b face each other across a gap of any width (:func:`_shared_wall`'s tuple)."""
    for wall, (a0, a1, b0, b1), (along_a, along_b) in (
            ("vertical", (a[2], a[3], b[2], b[3]), ((a[0], a[1]), (b[0], b[1]))),
            ("horizontal", (a[0], a[1], b[0], b[1]), ((a[2], a[3]), (b[2], b[3])))):
        if a1 < b0 or b1 < a0:
            lo, hi = max(along_a[0], along_b[0]), min(along_a[1], along_b[1])
            w0, w1 = (a1, b0) if a1 < b0 else (b1, a0)
            return (wall, lo, hi, w0, w1) if hi > lo else None
    return None


def _beside(rect: Rect, gap: Rect, kind: str) -> bool:
    """Whether ``rect`` is one of the two rectangles a door ``gap`` in a ``kind`` wall opens into."""
    if kind == "vertical":
        return (rect[3] == gap[2] or rect[2] == gap[3]) and rect[0] <= gap[0] and gap[1] <= rect[1]
    return (rect[1] == gap[0] or rect[0] == gap[1]) and rect[2] <= gap[2] and gap[3] <= rect[3]


def _hard_door_width(rng: np.random.Generator, u: _Units) -> int:
    """A narrow door (0.6 m) one time in ten, a double door (1.3-1.6 m) one in five, else 0.7-1.2 m."""
    kind = rng.choice(3, p=[0.1, 0.7, 0.2])
    if kind == 0:
        return u.cells(HARD_DOOR_WIDTH[0])
    return u.draw(rng, 0.7, 1.2) if kind == 1 else u.draw(rng, 1.3, HARD_DOOR_WIDTH[1])


def _vary_walls(rng: np.random.Generator, u: _Units, draft: _Draft) -> None:
    """Give each wall its own thickness and redraw the doors (width, anywhere along the wall).

    The plan draws the most its inner walls may be, and the most its outer
    walls may be, each 0.1-0.4 m (2-8 cells at 0.05 m); then every side of
    every rectangle moves into its wall (or back from it) by a few cells
    drawn for that side (:func:`_move_sides`), so an inner wall ends up
    0.05 m (one cell) to the plan's most thick, the two sides facing
    across it drawing independently (a wall along a row of rooms steps
    from room to room), and an outer wall likewise (the building's outline
    stays: ``drawn`` keeps the draft's rectangles). Then the open-plan
    connectors are redrawn across their new wall and the doors redrawn
    (:func:`_redraw_doors`).
    """
    t, o = draft.wall, draft.outer
    wmin, wmax = u.span(*HARD_WALL_THICKNESS)
    omax = u.span(*HARD_OUTER_THICKNESS)[1]
    wmax = int(rng.integers(min(wmin + 1, wmax), wmax + 1))
    omax = int(rng.integers(min(wmin + 1, omax), omax + 1))
    # A wall's two faces are a top (left) side and a bottom (right) side: between them they move t - wmax to
    # t - wmin cells (the latter, bottom and right, taking the odd cell), so any wall can be wmin to wmax thick.
    first_lo, first_hi = (t - wmax) // 2, max(0, (t - wmin) // 2)
    inner = [(first_lo, first_hi), (t - wmax - first_lo, max(0, t - wmin - first_hi))]
    spaces = draft.spaces
    pairs = []
    for a, b, gap, kind in draft.doors:
        ia = next(i for i, r in enumerate(spaces[a].rects) if _beside(r, gap, kind))
        ib = next(i for i, r in enumerate(spaces[b].rects) if _beside(r, gap, kind))
        pairs.append((ia, ib))
    draft.drawn = [(list(space.rects), list(space.connectors)) for space in spaces]
    _move_sides(rng, draft, inner, (o - omax, o - wmin))
    boxes = [(s, r) for s, space in enumerate(spaces) for r in space.rects]
    for i, (s, a) in enumerate(boxes):  # the rooms stay apart, by a wall of a cell at least
        for q, b in boxes[:i]:
            gap = max(b[0] - a[1], a[0] - b[1], b[2] - a[3], a[2] - b[3])
            assert q == s or gap >= wmin, (a, b)
    for space in spaces:
        if space.connectors:
            wall = _facing(space.rects[0], space.rects[1])
            assert wall is not None
            space.connectors = [_wall_rect(wall)]
    _redraw_doors(rng, u, draft, pairs)


def _move_sides(rng: np.random.Generator, draft: _Draft, inner: list[tuple[int, int]],
                outer: tuple[int, int]) -> None:
    """Move every side of every rectangle of every space outwards by cells drawn in its range (negative: back).

    A side with another space within a wall's thickness of it (or a bit
    past its ends) is an inner side and draws from ``inner`` (top and left
    sides from the first range, bottom and right from the second), else an
    outer side, from ``outer``; the sides across an open-plan connector
    are inner sides. A side never moves back from a rectangle of its own
    space it touches (a branch from its spine).
    """
    t, o = draft.wall, draft.outer
    h, w = draft.height, draft.width
    owner = np.zeros((h, w), dtype=np.int32)
    for s, space in enumerate(draft.spaces):
        for r0, r1, c0, c1 in space.rects:
            owner[max(r0, 0):r1, max(c0, 0):c1] = s + 1
    for space in draft.spaces:  # an open-plan connector is a wall between two rectangles: their sides are inner
        for r0, r1, c0, c1 in space.connectors:
            owner[max(r0, 0):r1, max(c0, 0):c1] = -1
    d, e = max(t, o) + 1, t + 1  # how far beyond a side, and past its ends, a neighbour makes it an inner side
    for s, space in enumerate(draft.spaces):
        grown = []
        for r0, r1, c0, c1 in space.rects:
            moves: list[int] = []
            for strip in ((r0 - d, r0, c0 - e, c1 + e), (r1, r1 + d, c0 - e, c1 + e),
                          (r0 - e, r1 + e, c0 - d, c0), (r0 - e, r1 + e, c1, c1 + d)):
                a0, a1, b0, b1 = strip
                near = owner[max(a0, 0):max(a1, 0), max(b0, 0):max(b1, 0)]
                first = (owner[max(r0 - 1, 0):max(r0, 0), c0:c1], owner[r1:r1 + 1, c0:c1],
                         owner[r0:r1, max(c0 - 1, 0):max(c0, 0)], owner[r0:r1, c1:c1 + 1])[len(moves)]
                lo, hi = inner[len(moves) % 2] if ((near != 0) & (near != s + 1)).any() else outer
                if (first == s + 1).any():
                    lo = max(lo, 0)
                moves.append(int(rng.integers(lo, max(lo, hi) + 1)))
            grown.append((r0 - moves[0], r1 + moves[1], c0 - moves[2], c1 + moves[3]))
        space.rects = grown


def _redraw_doors(rng: np.random.Generator, u: _Units, draft: _Draft, pairs: list[tuple[int, int]]) -> None:
    """Each door redrawn in the wall between the same two rectangles (``pairs``), then some second doors.

    A door's width comes from :func:`_hard_door_width` (at most the wall's
    length) and its place from :func:`_place_door`. Then a room with a door
    onto a corridor gets a second door in the same wall one time in five
    (:data:`SECOND_DOOR_ODDS`) when it has fewer than three doors and the
    wall has room for it.
    """
    spaces, doors = draft.spaces, []
    walls = []
    for (a, b, _, kind), (ia, ib) in zip(draft.doors, pairs):
        wall = _facing(spaces[a].rects[ia], spaces[b].rects[ib])
        assert wall is not None and wall[0] == kind
        gap = _place_door(rng, u, draft, wall, doors, strict=False)
        assert gap is not None
        doors.append((a, b, gap, kind))
        walls.append(wall)
    count = np.bincount(np.array([(a, b) for a, b, _, _ in doors]).ravel(), minlength=len(spaces))
    seen = set()
    for (a, b, _, kind), wall in list(zip(doors, walls)):
        if (spaces[a].kind == "corridor") == (spaces[b].kind == "corridor"):  # two rooms, or two corridors
            continue
        room = b if spaces[a].kind == "corridor" else a
        if room in seen:
            continue
        seen.add(room)
        if rng.random() < SECOND_DOOR_ODDS and count[room] < 3:
            gap = _place_door(rng, u, draft, wall, doors, strict=True)
            if gap is not None:
                doors.append((a, b, gap, kind))
                count[room] += 1
    draft.doors = doors


def _place_door(rng: np.random.Generator, u: _Units, draft: _Draft, wall: tuple[str, int, int, int, int],
                doors: list[tuple[int, int, Rect, str]], strict: bool) -> Rect | None:
    """A door gap in ``wall`` (a :func:`_facing` tuple) 0.3 m at least from ``doors``.

    Flush against one end of the wall a third of the time (added to
    ``draft.corners``), else anywhere; when no place keeps 0.3 m from the
    other doors (two doors flush in one corner would meet: the corner keeps
    a post) the last place tried, or None when ``strict``.
    """
    kind, lo, hi, w0, w1 = wall
    width = min(_hard_door_width(rng, u), hi - lo)
    if rng.random() < 1 / 3:
        starts = [lo if rng.random() < 0.5 else hi - width]
    else:
        starts = [int(rng.integers(lo, hi - width + 1))]
    starts += rng.permutation(np.arange(lo, hi - width + 1)).tolist()
    apart = u.cells(_DOOR_APART)
    for d0 in starts:
        gap = (d0, d0 + width, w0, w1) if kind == "vertical" else (w0, w1, d0, d0 + width)
        if all(max(g[0] - gap[1], gap[0] - g[1], g[2] - gap[3], gap[2] - g[3]) >= apart for _, _, g, _ in doors):
            break
    else:
        if strict:
            return None
    if d0 in (lo, hi - width):
        draft.corners.add(gap)
    return gap


_CORRIDOR_PIECES: dict[str, tuple[tuple[float, float], tuple[float, float] | None, float]] = {
    # kind: (length along the wall, depth (None: square), odds)
    "bench": ((1.2, 2.0), (0.4, 0.5), 0.35),
    "printer": ((0.5, 0.8), (0.5, 0.7), 0.25),
    "locker": ((0.8, 1.6), (0.4, 0.6), 0.25),
    "plant": ((0.4, 0.5), None, 0.15),
}


def _clutter(rng: np.random.Generator, u: _Units, plan: FloorPlan, rects: dict[int, list[Rect]]) -> FloorPlan:
    """Benches, printers, lockers and plants against the corridors' walls (``clutter_corridors``).

    The rules of :func:`_furnish` (clear of doors, backed by a wall along
    its whole side, the corridor's robot space one piece that reaches all
    its doors), and every piece leaves at least :data:`CORRIDOR_CLEAR`
    of free cells in front of it, across the corridor.
    """
    rooms, occupancy = plan.rooms.copy(), plan.occupancy.copy()
    shape, items = rooms.shape, list(plan.furniture)
    zones = np.zeros(shape, dtype=bool)
    for door in plan.doors:
        r0, r1, c0, c1 = _door_zone(door, u, shape)
        zones[r0:r1, c0:c1] = True
    kinds = list(_CORRIDOR_PIECES)
    odds = np.array([v[2] for v in _CORRIDOR_PIECES.values()])
    clear = u.cells(CORRIDOR_CLEAR)
    areas = plan.room_areas()
    for label in plan.corridors:
        boxes = rects[label]
        weights = np.array([u.area(r) for r in boxes])
        for _ in range(min(10, int(rng.poisson(areas[label - 1] / 12.0)))):
            for _attempt in range(8):
                r0, r1, c0, c1 = boxes[int(rng.choice(len(boxes), p=weights / weights.sum()))]
                kind = kinds[int(rng.choice(len(kinds), p=odds / odds.sum()))]
                long, deep, _ = _CORRIDOR_PIECES[kind]
                a = u.draw(rng, *long)
                b = a if deep is None else u.draw(rng, *deep)
                side = _SIDES[int(rng.integers(4))]
                if side in ("left", "right"):
                    if r1 - r0 < a or c1 - c0 < b + clear:
                        continue
                    top = int(rng.integers(r0, r1 - a + 1))
                    left = c0 if side == "left" else c1 - b
                    box = (top, top + a, left, left + b)
                    ahead = occupancy[top:top + a, left + b:left + b + clear] if side == "left" else \
                        occupancy[top:top + a, max(left - clear, 0):left]
                else:
                    if c1 - c0 < a or r1 - r0 < b + clear:
                        continue
                    left = int(rng.integers(c0, c1 - a + 1))
                    top = r0 if side == "top" else r1 - b
                    box = (top, top + b, left, left + a)
                    ahead = occupancy[top + b:top + b + clear, left:left + a] if side == "top" else \
                        occupancy[max(top - clear, 0):top, left:left + a]
                drawn = (kind, box, "wall", side, 0)
                if ahead.shape[0] * ahead.shape[1] and (ahead == 0).all() and _backed(drawn, plan) \
                        and _fits(box, label, rooms, zones, plan, u):
                    b0, b1, b2, b3 = box
                    rooms[b0:b1, b2:b3] = 0
                    occupancy[b0:b1, b2:b3] = 1.0
                    items.append(Furniture(kind, box, label, "wall", side, 0.0))
                    break
    return _replace(plan, occupancy=_frozen(occupancy), rooms=_frozen(rooms), furniture=tuple(items))


def _replace(plan: FloorPlan, **changes: Any) -> FloorPlan:
    import dataclasses

    return dataclasses.replace(plan, **changes)


def _part(occ: np.ndarray, rooms: np.ndarray, doors: np.ndarray, door_list: tuple[Door, ...]) -> None:
    """Part (in place) the rooms that touch, even diagonally, and the free cells that touch the outside.

    Of two cells of different rooms side by side (or corner to corner) the
    one of the smaller label leaves its room: it becomes part of the door
    gap when it is next to the gap of a door between those two rooms
    (``doors``: a door's number + 1 per cell), else wall; a free cell (of
    a room or a door gap) next to the outside (unknown) becomes wall. One
    pass parts them all (the cells of the larger label stay, so a 1-cell
    wall thickens to 2 cells only there).
    """
    nan = np.isnan(occ)
    top = ndimage.maximum_filter(rooms, size=3, mode="constant")
    clash = (rooms > 0) & (top > rooms)
    outside = (occ == 0) & ndimage.maximum_filter(nan, size=3, mode="constant")
    if not (clash.any() or outside.any()):
        return
    near = ndimage.maximum_filter(doors, size=3, mode="constant")
    pair_lo = np.array([0] + [d.rooms[0] for d in door_list])
    pair_hi = np.array([0] + [d.rooms[1] for d in door_list])
    gap = clash & ~outside & (near > 0) & (pair_lo[near] == rooms) & (pair_hi[near] == top)
    wall = (clash | outside) & ~gap
    occ[gap], rooms[gap], doors[gap] = 0.0, 0, near[gap]
    occ[wall], rooms[wall], doors[wall] = 1.0, 0, 0


def _rotate(plan: FloorPlan, degrees: float, u: _Units) -> FloorPlan:
    """The plan with its building turned ``degrees`` counter-clockwise about its centre, nearest neighbour.

    Each cell of the new image takes everything (occupancy, room, door,
    furniture) from the cell of the old one its centre falls in, so walls
    stay at least as thick (across) as they were and, being 2 cells or
    more, closed. A wall of 1 cell may come out with rooms touching across
    it (even diagonally), or a room touching the outside: there a cell is
    thickened (:func:`_part`), so such a wall is 2 cells thick only where
    it needs to be. Bits of a room that the sampling cut off from it
    (touching it only diagonally) become wall, or part of the furniture
    they touch (:func:`_cut_off_bits`), and furniture that walls in a
    pocket of robot space goes (:func:`_unpocket`).
    """
    occ0, rooms0 = plan.occupancy, plan.rooms
    doors0 = np.zeros(rooms0.shape, dtype=np.int32)
    for i, door in enumerate(plan.doors):
        r0, r1, c0, c1 = door.box
        doors0[r0:r1, c0:c1] = i + 1
    furn0 = np.zeros(rooms0.shape, dtype=np.int32)
    for i, item in enumerate(plan.furniture):
        r0, r1, c0, c1 = item.box
        furn0[r0:r1, c0:c1] = i + 1
    rows, cols = np.nonzero(~np.isnan(occ0))
    cy, cx = (rows.min() + rows.max() + 1) / 2, (cols.min() + cols.max() + 1) / 2
    cos, sin = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    corners = np.array([(x - cx, y - cy) for x in (cols.min(), cols.max() + 1) for y in (rows.min(), rows.max() + 1)])
    xr, yr = cos * corners[:, 0] + sin * corners[:, 1], -sin * corners[:, 0] + cos * corners[:, 1]
    margin = u.cells(MARGIN)
    height = math.ceil(yr.max() - yr.min() - 1e-9) + 2 * margin
    width = math.ceil(xr.max() - xr.min() - 1e-9) + 2 * margin
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float64)
    dx, dy = xx + 0.5 - margin + xr.min(), yy + 0.5 - margin + yr.min()
    src_c = np.floor(cos * dx - sin * dy + cx).astype(np.int64)
    src_r = np.floor(sin * dx + cos * dy + cy).astype(np.int64)
    inside = (src_r >= 0) & (src_r < occ0.shape[0]) & (src_c >= 0) & (src_c < occ0.shape[1])
    src_r, src_c = np.where(inside, src_r, 0), np.where(inside, src_c, 0)
    occ = np.where(inside, occ0[src_r, src_c], np.float32(np.nan)).astype(np.float32)
    rooms = np.where(inside, rooms0[src_r, src_c], 0).astype(np.int32)
    doors = np.where(inside, doors0[src_r, src_c], 0)
    furn = np.where(inside, furn0[src_r, src_c], 0)
    kept = [True] * len(plan.furniture)
    while True:  # touching rooms, cut-off bits of rooms and pockets of robot space, until none is left to do
        _part(occ, rooms, doors, plan.doors)
        _cut_off_bits(occ, rooms, furn, plan.n_rooms)
        gone = _unpocket(occ, rooms, furn, plan.furniture, kept, u)
        if not gone:
            break
    frame = GridFrame(height, width, u.res, (-margin * u.res, -margin * u.res, 0.0))
    door_boxes, furn_boxes = _boxes(doors, len(plan.doors)), _boxes(furn, len(plan.furniture))
    new_doors = []
    for i, door in enumerate(plan.doors):
        box = door_boxes[i]
        assert box is not None, f"door {door} lost in the turn"
        rr, cc = _cells_of(doors, i + 1, box)
        x, y = frame.cell_to_world(rr.mean(), cc.mean())
        new_doors.append(Door((round(x, 6), round(y, 6)), door.width, door.rooms, box, door.wall, door.corner))
    items = [Furniture(f.kind, furn_boxes[i], f.room, f.placement, f.side, f.gap)
             for i, f in enumerate(plan.furniture) if kept[i] and furn_boxes[i] is not None]
    return _replace(plan, occupancy=_frozen(occ), rooms=_frozen(rooms), frame=frame, doors=tuple(new_doors),
                    furniture=tuple(items), rotation=float(degrees), furniture_mask=_frozen(furn > 0))


def _boxes(numbers: np.ndarray, count: int) -> list[Rect | None]:
    """The bounding box of the cells of each number 1..count in ``numbers`` (index i for i + 1; None: no cell)."""
    found = ndimage.find_objects(numbers, max_label=count)
    return [None if b is None else (b[0].start, b[0].stop, b[1].start, b[1].stop) for b in found]


def _cells_of(numbers: np.ndarray, number: int, box: Rect) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) of the cells of ``number`` in ``numbers``, all inside ``box``."""
    rr, cc = np.nonzero(numbers[box[0]:box[1], box[2]:box[3]] == number)
    return rr + box[0], cc + box[2]


def _cut_off_bits(occ: np.ndarray, rooms: np.ndarray, furn: np.ndarray, n_rooms: int) -> None:
    """Make (in place) the bits of a room cut off from its largest piece occupied: part of the furniture
    they touch (``furn``, a piece's number + 1), else of the wall."""
    pieces, count = ndimage.label(rooms > 0)
    if count <= n_rooms:
        return
    sizes = np.bincount(pieces.ravel(), minlength=count + 1)
    sizes[0] = 0
    labels = np.zeros(count + 1, dtype=np.int64)
    labels[pieces.ravel()] = rooms.ravel()
    keep = np.zeros(count + 1, dtype=bool)
    for label in range(1, n_rooms + 1):
        mine = np.flatnonzero(labels == label)
        mine = mine[mine > 0]
        if mine.size:
            keep[mine[np.argmax(sizes[mine])]] = True
    keep[0] = True
    cut = ~keep[pieces]
    occ[cut], rooms[cut] = 1.0, 0
    furn[cut] = ndimage.grey_dilation(furn, size=(3, 3))[cut]


def _unpocket(occ: np.ndarray, rooms: np.ndarray, furn: np.ndarray, items: tuple[Furniture, ...],
              kept: list[bool], u: _Units) -> bool:
    """Take out (in place) the furniture nearest each pocket of robot space the turn made; whether any went.

    A sliver a robot just fits into may come out of the sampling a cell
    narrower in places, leaving bits of robot space it cannot reach; the
    piece of furniture nearest each such pocket goes (its cells become its
    room's again, ``kept[i]`` False), until the robot space is one piece
    (or no furniture stands next to the pockets left).
    """
    took = False
    while items:
        pieces, count = ndimage.label(robot_space(occ == 0, u.res))
        if count <= 1:
            break
        sizes = np.bincount(pieces.ravel())
        sizes[0] = 0
        main = int(np.argmax(sizes))
        present = [i for i in range(len(items)) if kept[i]]
        if not present:
            break
        boxes = _boxes(furn, len(items))
        present = [i for i in present if boxes[i] is not None]
        cells = {i: _cells_of(furn, i + 1, boxes[i]) for i in present}
        dist = ndimage.distance_transform_edt((pieces == 0) | (pieces == main), return_indices=False)
        pockets = np.zeros(count + 1, dtype=bool)
        pockets[1:] = True
        pockets[main] = False
        near = ndimage.distance_transform_edt(~pockets[pieces], return_indices=True)[1]
        owner = pieces[near[0], near[1]]  # the pocket nearest each cell
        chosen = set()
        reach = ROBOT_RADIUS / u.res + 2.0  # a piece this close to a pocket is what walls it in
        for k in np.flatnonzero(pockets):
            gaps = {j: float(np.where(owner[cells[j]] == k, dist[cells[j]], np.inf).min(initial=np.inf))
                    for j in present}
            i = min(present, key=gaps.__getitem__)
            if gaps[i] <= reach:
                chosen.add(i)
        if not chosen:  # pockets no furniture makes (a doorway at a coarse resolution) stay
            break
        for i in chosen:
            kept[i] = False
            occ[cells[i]], rooms[cells[i]], furn[cells[i]] = 0.0, items[i].room, 0
        took = True
    return took


def _random_cell(ok: np.ndarray, rng: np.random.Generator) -> tuple[int, int] | None:
    """A cell where ``ok`` is True, drawn uniformly with ``rng`` (row, col); None when there is none."""
    cells = np.flatnonzero(ok)
    if not cells.size:
        return None
    r, c = divmod(int(cells[int(rng.integers(cells.size))]), ok.shape[1])
    return r, c


def _add_noise(rng: np.random.Generator, u: _Units, plan: FloorPlan) -> FloorPlan:
    """A few occupied specks in free space and a few cells missing from the walls, as in a robot's map.

    Specks (4-12, of 1 or 2 cells) stand at least 0.6 m from anything
    occupied or unknown, 1 m from a door gap and 1 m from each other; a
    robot passes around them and through every door as before. Holes (8-24
    single cells, never touching each other) are wall cells on a room's
    face, with only that room, walls and furniture around them (no door,
    other room or unknown cell among their 8 neighbours): the room takes
    them in, so no hole joins two rooms, or lets a robot through a wall.
    """
    occ, rooms = plan.occupancy.copy(), plan.rooms.copy()
    free = occ == 0
    gaps = free & (rooms == 0)
    furn = plan.furniture_cells()
    clearance = ndimage.distance_transform_edt(free) * u.res
    to_gap = ndimage.distance_transform_edt(~gaps) * u.res
    ok = (rooms > 0) & (clearance >= 0.6) & (to_gap >= 1.0)
    space = u.cells(1.0)
    specks = []
    for _ in range(int(rng.integers(4, 13))):
        cell = _random_cell(ok, rng)
        if cell is None:
            break
        r, c = cell
        box = (r, r + 1, c, c + 1)
        if rng.random() < 0.5:
            box = (r, r + 1, c, c + 2) if rng.random() < 0.5 else (r, r + 2, c, c + 1)
            if not ok[box[0]:box[1], box[2]:box[3]].all():
                box = (r, r + 1, c, c + 1)
        occ[box[0]:box[1], box[2]:box[3]], rooms[box[0]:box[1], box[2]:box[3]] = 1.0, 0
        ok[max(r - space, 0):r + space + 1, max(c - space, 0):c + space + 1] = False
        specks.append(box)
    wall = (occ == 1) & ~furn
    for box in specks:
        wall[box[0]:box[1], box[2]:box[3]] = False
    big = np.iinfo(np.int32).max
    top = ndimage.maximum_filter(rooms, size=3, mode="constant")
    low = ndimage.minimum_filter(np.where(rooms > 0, rooms, big), size=3, mode="constant", cval=big)
    bad = ndimage.maximum_filter((gaps | np.isnan(occ)).astype(np.uint8), size=3, mode="constant", cval=1) > 0
    face = ndimage.binary_dilation(rooms > 0)
    ok = wall & face & (top > 0) & (top == low) & ~bad
    holes = []
    for _ in range(int(rng.integers(8, 25))):
        cell = _random_cell(ok, rng)
        if cell is None:
            break
        r, c = cell
        occ[r, c], rooms[r, c] = 0.0, top[r, c]
        ok[max(r - 2, 0):r + 3, max(c - 2, 0):c + 3] = False
        holes.append((r, c))
    return _replace(plan, occupancy=_frozen(occ), rooms=_frozen(rooms), specks=tuple(specks),
                    holes=tuple(sorted(holes)))


# -- slam plans: a robot's scan of a hard plan ---------------------------------------------------

@dataclass
class _Scan:
    """The images a SLAM scan changes (copies, changed in place) and what it leaves alone.

    ``others`` are the occupied cells that are not walls (furniture, specks);
    ``gaps`` the door gaps, ``to_gap`` each cell's distance (metres) to one.
    """

    occ: np.ndarray
    rooms: np.ndarray
    gaps: np.ndarray
    others: np.ndarray
    u: _Units
    to_gap: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.to_gap = ndimage.distance_transform_edt(~self.gaps) * self.u.res

    @property
    def walls(self) -> np.ndarray:
        """The wall cells still occupied (1)."""
        return (self.occ == 1) & ~self.others

    def faces(self, connectivity: int) -> np.ndarray:
        """Wall cells next to a room cell (``connectivity`` 1: side by side; 2: corners too)."""
        structure = ndimage.generate_binary_structure(2, connectivity)
        return self.walls & ndimage.binary_dilation(self.rooms > 0, structure)

    def near(self, mask: np.ndarray, metres: float) -> np.ndarray:
        """Cells within ``metres`` of a ``mask`` cell."""
        if not mask.any():
            return np.zeros(mask.shape, dtype=bool)
        return ndimage.distance_transform_edt(~mask) * self.u.res <= metres

    def robot(self) -> tuple[np.ndarray, int, set[int]]:
        """The robot space, its number of pieces and the rooms it reaches."""
        space = robot_space(self.occ == 0, self.u.res)
        return space, ndimage.label(space)[1], set(np.unique(self.rooms[space]).tolist()) - {0}


def _scan(rng: np.random.Generator, u: _Units, plan: FloorPlan) -> FloorPlan:
    """The hard ``plan`` as a robot's SLAM scan would show it (``slam``; see the module docstring).

    In order: ragged walls (:func:`_ragged_walls`), unexplored patches
    (:func:`_unexplored`), wall faces that read unknown
    (:func:`_unseen_walls`) or grey (:func:`_antialias`), speckle
    (:func:`_speckle`). None opens a wall or lets two rooms touch; each
    keeps the robot space in as many pieces as it was, reaching every room
    it reached. ``rooms`` loses the cells that are no longer free, and a
    bit of a room cut off from it becomes wall.
    """
    others = plan.furniture_cells().copy()
    for r0, r1, c0, c1 in plan.specks:
        others[r0:r1, c0:c1] = True
    scan = _Scan(np.array(plan.occupancy), np.array(plan.rooms), plan.door_cells(), others, u)
    robot = _ragged_walls(rng, scan)
    patches = _unexplored(rng, scan, plan.n_rooms, robot)
    _unseen_walls(rng, scan)
    _antialias(rng, scan)
    _speckle(rng, scan)
    scan.rooms[scan.occ != 0] = 0
    _cut_off_bits(scan.occ, scan.rooms, np.zeros(scan.rooms.shape, dtype=np.int32), plan.n_rooms)
    holes = tuple(h for h in plan.holes if scan.rooms[h] > 0)
    specks = tuple(b for b in plan.specks if (scan.occ[b[0]:b[1], b[2]:b[3]] == 1).all())
    return _replace(plan, occupancy=_frozen(scan.occ), rooms=_frozen(scan.rooms), slam=True,
                    unexplored=tuple(patches), holes=holes, specks=specks)


def _shuffled(rng: np.random.Generator, mask: np.ndarray) -> Iterator[tuple[int, int]]:
    """The ``mask`` cells (row, col) in an order drawn with ``rng`` (one permutation, drawn first)."""
    rows, cols = np.nonzero(mask)
    order = rng.permutation(rows.size)
    return ((int(rows[i]), int(cols[i])) for i in order)


def _runs(rng: np.random.Generator, u: _Units, cells: np.ndarray, owner: np.ndarray, share: float,
          length: tuple[float, float], behind: np.ndarray | None = None) -> np.ndarray:
    """Runs along ``cells`` (a face) that cover ``share`` of them (the last run may take a few more).

    A run starts from a cell drawn from those not yet taken and takes the
    cells of the same room's face (``owner``) within a square of a drawn
    ``length`` (metres) about it that are 8-connected to it there; with
    ``behind`` (the walls), half the runs also take the ``behind`` cells
    connected to them in the square (the rest of the wall's thickness).
    """
    taken = np.zeros(cells.shape, dtype=bool)
    goal, count = share * int(cells.sum()), 0
    eight = np.ones((3, 3), dtype=bool)
    for r, c in _shuffled(rng, cells):
        if count >= goal:
            break
        if taken[r, c]:
            continue
        half = max(1, round(rng.uniform(*length) / u.res / 2))
        window = (slice(max(r - half, 0), r + half + 1), slice(max(c - half, 0), c + half + 1))
        at = (r - window[0].start, c - window[1].start)
        pieces, _ = ndimage.label(cells[window] & (owner[window] == owner[r, c]), eight)
        run = pieces == pieces[at]
        if behind is not None and rng.random() < 0.5:
            pieces, _ = ndimage.label(run | behind[window], eight)
            run = pieces == pieces[at]
        count += int((run & cells[window] & ~taken[window]).sum())
        taken[window] |= run
    return taken


def _ragged_walls(rng: np.random.Generator, scan: _Scan) -> tuple[np.ndarray, int, set[int]]:
    """Move the faces of the walls by a cell, here and there, in runs of 0.2-1 m along them.

    Out (into the room: its cells become wall) along 5-15 % of the rooms'
    edges, and in along 5-15 % of the walls' faces (the wall's cells become
    the room's, where no other room, door gap or unknown cell is within 2
    cells: the wall keeps a cell at least, and rooms stay 2 cells apart).
    Not within 0.3 m of a door gap, nor within 1 m of furniture or a speck
    (slivers a robot just fits into). If the robot space would fall into
    more pieces, or miss a room, the walls stay as they were. Returns
    :meth:`_Scan.robot` of the walls as they end up.
    """
    occ, rooms, u = scan.occ, scan.rooms, scan.u
    keep_off = (scan.to_gap <= 0.3) | scan.near(scan.others, 1.0)
    cross = ndimage.generate_binary_structure(2, 1)
    edge = (rooms > 0) & ndimage.binary_dilation(scan.walls, cross) & ~keep_off
    big = np.iinfo(np.int32).max
    top = ndimage.maximum_filter(rooms, size=5, mode="constant")
    low = ndimage.minimum_filter(np.where(rooms > 0, rooms, big), size=5, mode="constant", cval=big)
    bad = ndimage.maximum_filter((scan.gaps | np.isnan(occ)).astype(np.uint8), size=5, mode="constant", cval=1) > 0
    face = scan.faces(1) & (top > 0) & (top == low) & ~bad & ~keep_off
    robot = scan.robot()
    saved = occ.copy(), rooms.copy()
    out = _runs(rng, u, edge, rooms, rng.uniform(0.05, 0.15), (0.2, 1.0))
    into = _runs(rng, u, face, top, rng.uniform(0.05, 0.15), (0.2, 1.0))
    occ[out], rooms[out] = 1.0, 0
    occ[into], rooms[into] = 0.0, top[into]
    moved = scan.robot()
    if moved[1] <= robot[1] and moved[2] == robot[2]:
        return moved
    occ[...], rooms[...] = saved
    return robot


def _unexplored(rng: np.random.Generator, scan: _Scan, n_rooms: int,
                robot: tuple[np.ndarray, int, set[int]]) -> list[Rect]:
    """Unknown patches 0.2-1 m across (discs) in nooks: the corners of rooms and the spaces behind furniture.

    A nook is a room cell with mostly walls, furniture or unknown within
    0.3 m of it, 1 m at least from a door gap (and the patch's radius +
    0.5 m). A patch takes in the cells of its room, the walls and the
    furniture in its disc, and is kept only if the room stays one piece and
    the robot space keeps its pieces and still reaches the room. About one
    patch for every two to three rooms; their bounding boxes are returned.
    ``robot`` is :meth:`_Scan.robot` as the scan stands.
    """
    occ, rooms, u = scan.occ, scan.rooms, scan.u
    k = u.cells(0.3)
    closed = ndimage.uniform_filter((rooms == 0).astype(np.float32), size=2 * k + 1, mode="constant", cval=1.0)
    to_gap = scan.to_gap
    nooks = (rooms > 0) & (closed >= 0.55) & (to_gap >= 1.0)
    space, pieces = robot[0].copy(), robot[1]
    reach = ROBOT_RADIUS / u.res + 0.5
    boxes = ndimage.find_objects(rooms)
    patches: list[Rect] = []
    wanted = int(rng.integers(n_rooms // 3, n_rooms // 2 + 2))
    for r, c in _shuffled(rng, nooks):
        if len(patches) >= wanted:
            break
        radius = rng.uniform(*SLAM_PATCH) / 2 / u.res
        if not nooks[r, c] or to_gap[r, c] < radius * u.res + 0.5:
            continue
        label, n = int(rooms[r, c]), math.ceil(radius) + math.ceil(reach)
        win = (slice(max(r - n, 0), r + n + 1), slice(max(c - n, 0), c + n + 1))
        yy, xx = np.ogrid[win[0], win[1]]
        disc = ((yy - r) ** 2 + (xx - c) ** 2 <= radius ** 2) & ((rooms[win] == label) | (occ[win] == 1))
        lost = disc & (occ[win] == 0)
        before = occ[win].copy(), rooms[win].copy(), space[win].copy()
        occ[win][disc], rooms[win][disc] = np.nan, 0
        space[win] &= ndimage.distance_transform_edt(~lost) >= reach
        rs, cs = boxes[label - 1]
        mine = rooms[rs, cs] == label
        if ndimage.label(mine)[1] == 1 and space[rs, cs][mine].any() and ndimage.label(space)[1] <= pieces:
            rr, cc = np.nonzero(disc)
            patches.append((int(rr.min()) + win[0].start, int(rr.max()) + 1 + win[0].start,
                            int(cc.min()) + win[1].start, int(cc.max()) + 1 + win[1].start))
            nooks[win] = False
        else:
            occ[win], rooms[win], space[win] = before
    return patches


def _unseen_walls(rng: np.random.Generator, scan: _Scan) -> None:
    """20-50 % of the wall faces (wall cells next to a room, corners too) read unknown, in runs of 0.5-3 m
    along them; half the runs through the wall's whole thickness (so a room may border the unknown outside)."""
    face = scan.faces(2)
    owner = ndimage.maximum_filter(scan.rooms, size=3, mode="constant")  # the room whose face it is (one of them)
    unseen = _runs(rng, scan.u, face, owner, rng.uniform(*SLAM_UNSEEN_SHARE), SLAM_UNSEEN_RUN, scan.walls)
    scan.occ[unseen] = np.nan


def _antialias(rng: np.random.Generator, scan: _Scan) -> None:
    """10-30 % of the wall-face cells still occupied read 0.55-0.9 (:data:`SLAM_ANTIALIAS`), as a scan's edges."""
    face = scan.faces(2)
    grey = face & (rng.random(face.shape) < rng.uniform(0.1, 0.3))
    scan.occ[grey] = rng.uniform(*SLAM_ANTIALIAS, size=int(grey.sum())).astype(np.float32)


def _speckle(rng: np.random.Generator, scan: _Scan) -> None:
    """Single cells of clutter in the rooms, 0.05-0.2 a square metre of floor; a quarter of them grey (0.25-0.75).

    Each at least 0.6 m from anything not free, from each other and from
    door gaps, so that a robot passes around every one.
    """
    occ, rooms, u = scan.occ, scan.rooms, scan.u
    clear = ndimage.distance_transform_edt(occ == 0) * u.res
    ok = (rooms > 0) & (clear >= 0.6) & (scan.to_gap > 0.6)
    wanted = round(float((rooms > 0).sum()) * u.res ** 2 * rng.uniform(0.05, 0.2))
    space = u.cells(0.6)
    for r, c in _shuffled(rng, ok):
        if not wanted:
            break
        if not ok[r, c]:
            continue
        occ[r, c] = 1.0 if rng.random() >= 0.25 else rng.uniform(0.25, 0.75)
        rooms[r, c] = 0
        ok[max(r - space, 0):r + space + 1, max(c - space, 0):c + space + 1] = False
        wanted -= 1


# -- the generator ---------------------------------------------------------------------------

def generate_plan(seed: int, *, furniture: bool = False, hard: bool = False, clutter_corridors: bool = False,
                  resolution: float = 0.05, size: tuple[float, float] | None = None,
                  slam: bool = False) -> FloorPlan:
    """A floor plan drawn from ``seed``: the same seed, resolution, size and options always give the same plan.

    ``size`` is the building's (width, height) in metres (its outer wall's
    box; at least 12 x 10 m); by default each seed draws one, 24-40 m by
    14-26 m, and the plan is redrawn until it has 10-40 rooms. Around the
    building are 1 m of unknown cells; the frame puts the building's
    lower-left outer corner at world (0, 0). ``furniture`` adds clutter to
    the same building (see the module docstring).

    ``hard`` makes the building messier, as real drawn plans and robot
    maps are: walls of their own thickness (0.05-0.4 m), doors anywhere
    (often flush in a corner), narrow, double and second doors, the
    building turned up to 30 degrees (the lower-left corner of its
    bounding box at (0, 0)), specks and missing wall cells; at the default
    size two plans in five are buildings of wings instead of the plain
    plan's building (a double-loaded corridor, or wings of them joined
    into an L or a U: :data:`WING_LAYOUTS`). ``slam`` (which implies
    ``hard``) shows the hard plan as a robot's SLAM scan: ragged walls,
    speckle and grey cells, stretches of wall and patches of the rooms
    unknown, anti-aliased wall edges. ``clutter_corridors`` puts benches,
    printers, lockers and plants along the corridors' walls (with or
    without ``furniture`` in the rooms). Each draws from its own random
    stream, so a ``slam`` plan is the ``hard`` plan of its seed, scanned.
    """
    if not resolution > 0 or resolution > 0.2:
        raise ValueError(f"resolution must be in (0, 0.2] metres, not {resolution}")
    if size is not None and (max(size) < MIN_SIZE[0] or min(size) < MIN_SIZE[1]):
        raise ValueError(f"a building is at least {MIN_SIZE[0]:g} x {MIN_SIZE[1]:g} m, not {size}")
    u = _Units(float(resolution))
    hard = hard or slam
    # spawn(6)'s first four streams are spawn(4)'s, whose first two are spawn(2)'s: the plans of old stay.
    layout_rng, furniture_rng, hard_rng, clutter_rng, wings_rng, slam_rng = (
        np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(6))
    wings = hard and size is None and wings_rng.random() < WING_SHARE
    building_rng = wings_rng if wings else layout_rng
    draft, transposed = _building(building_rng, u, size, seed, wings)
    turn = 0.0
    if hard:  # the turn first: it stays the seed's whatever the walls and doors draw after it
        if hard_rng.random() >= 0.2:
            turn = round(float(hard_rng.uniform(-HARD_ROTATION, HARD_ROTATION)), 1)
        _vary_walls(hard_rng, u, draft)
    rects: dict[int, list[Rect]] = {}
    plan = _render(building_rng, u, draft, transposed, seed, rects)
    if furniture:
        plan = _furnish(furniture_rng, u, plan)
    if clutter_corridors:
        plan = _clutter(clutter_rng, u, plan, rects)
    if not hard:
        return plan
    plan = _replace(plan, hard=True)
    if turn:
        plan = _rotate(plan, turn, u)
    plan = _add_noise(hard_rng, u, plan)
    return _scan(slam_rng, u, plan) if slam else plan


# -- files -----------------------------------------------------------------------------------

def write_plan(plan: FloorPlan, folder: str | Path, name: str) -> Path:
    """Write ``name.yaml`` + ``name.pgm`` (the ROS map), ``name-rooms.png`` and ``name-rooms.json``; the YAML's path.

    The map is trinary (free 254, occupied 0, unknown 205), so
    :func:`atlas_rap.maps.rosmap.load_ros_map` and ``atlas map abstract
    folder/name.yaml`` read it back exactly; a ``slam`` plan's grey cells
    are written as their occupancy (``round(255 (1 - p))``), so a reader
    sees them through its thresholds (0.196 and 0.65: unknown between).
    ``name-rooms.png`` is the ``rooms`` label image as a 16-bit greyscale
    PNG (row 0 at the top, as the map); ``name-rooms.json`` names the
    labels and lists the doors and furniture (see :func:`read_truth`), for
    a hard plan its rotation, specks and holes, and for a slam plan its
    unexplored patches.
    """
    import imageio.v3 as iio

    from atlas_rap.maps.rosmap import FREE, OCCUPIED, UNKNOWN, write_ros_map

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    labels = np.select([plan.occupancy == 0, plan.occupancy == 1], [FREE, OCCUPIED], UNKNOWN).astype(np.int8)
    yaml = out / f"{name}.yaml"
    write_ros_map(yaml, plan.occupancy if plan.slam else labels, plan.frame.resolution, plan.frame.origin)
    if plan.n_rooms > np.iinfo(np.uint16).max:  # pragma: no cover - plans have at most 40 rooms
        raise ValueError("too many rooms for a 16-bit label image")
    iio.imwrite(out / f"{name}-rooms.png", plan.rooms.astype(np.uint16))
    truth = _truth_dict(plan, f"{name}-rooms.png", yaml.name)
    (out / f"{name}-rooms.json").write_text(json.dumps(truth, indent=1) + "\n", encoding="utf-8")
    return yaml


def _truth_dict(plan: FloorPlan, image: str, map_yaml: str) -> dict[str, Any]:
    areas = plan.room_areas()
    hard = {"hard": True, "rotation": plan.rotation, "specks": [list(b) for b in plan.specks],
            "holes": [list(c) for c in plan.holes]} if plan.hard else {}
    slam = {"slam": True, "unexplored": [list(b) for b in plan.unexplored]} if plan.slam else {}
    return hard | slam | {
        "seed": plan.seed, "layout": plan.layout, "map": map_yaml, "image": image,
        "shape": list(plan.rooms.shape), "resolution": plan.frame.resolution, "origin": list(plan.frame.origin),
        "rooms": [{"label": i + 1, "name": n, "kind": k, "area": round(float(a), 4)}
                  for i, (n, k, a) in enumerate(zip(plan.room_names, plan.room_kinds, areas))],
        "doors": [{"center": list(d.center), "width": d.width, "rooms": list(d.rooms),
                   "names": [plan.room_names[r - 1] for r in d.rooms], "box": list(d.box), "wall": d.wall}
                  | ({"corner": d.corner} if plan.hard else {}) for d in plan.doors],
        "furniture": [{"kind": f.kind, "room": f.room, "placement": f.placement, "side": f.side, "gap": f.gap,
                       "box": list(f.box)} for f in plan.furniture],
    }


def read_truth(folder: str | Path, name: str) -> tuple[np.ndarray, dict[str, Any]]:
    """The ground truth :func:`write_plan` wrote: (rooms as int32, the JSON's contents)."""
    import imageio.v3 as iio

    out = Path(folder)
    info = json.loads((out / f"{name}-rooms.json").read_text(encoding="utf-8"))
    rooms = np.asarray(iio.imread(out / info["image"])).astype(np.int32)
    return rooms, info


# -- the shipped worlds' rooms ----------------------------------------------------------------

def world_rooms(world: Any, frame: GridFrame, *, free: np.ndarray | None = None) -> np.ndarray:
    """The world's named places as a label image on ``frame``: label i + 1 for the i-th place in file order.

    ``world`` is an :class:`atlas_rap.model.World` or the name of a
    shipped world. A cell belongs to a place when its centre is inside the
    place's region (even-odd rule, as :meth:`Place.contains`), or within
    ``radius`` of its point for a place without a region; the walls are not
    consulted (they are segments, not cells), so pass ``free`` (e.g. a map's
    free cells) to set the cells that are not free to 0. Where regions
    overlap the first place in file order wins, as in
    :meth:`World.place_at`. The names are :func:`world_room_names`.
    """
    if isinstance(world, str):
        from atlas_rap.sim.world import load_world

        world = load_world(world)
    labels = np.zeros(frame.shape, dtype=np.int32)
    places = list(world.places.values())
    for i in range(len(places) - 1, -1, -1):
        rows, cols, inside = _place_cells(places[i], frame)
        labels[rows[inside], cols[inside]] = i + 1
    if free is not None:
        labels[~np.asarray(free, dtype=bool)] = 0
    return labels


def best_places(places: np.ndarray, rooms: np.ndarray) -> list[tuple[int, float]]:
    """For each room (label 1..max of ``rooms``): the place that covers most of it, and that place's IoU
    with the room (0 where no place covers it)."""
    found = []
    count = int(places.max()) + 1 if places.size else 1
    for room in range(1, int(rooms.max()) + 1 if rooms.size else 1):
        region = rooms == room
        counts = np.bincount(places[region], minlength=count)
        counts[0] = 0
        best = int(np.argmax(counts))
        union = region.sum() + ((places == best) & ~region).sum()
        found.append((best, float(counts[best] / union) if counts[best] else 0.0))
    return found


def built_world_scores(folder: str | Path, world: Any) -> dict[str, tuple[float, str]]:
    """Score the levels ``atlas map build`` wrote to ``folder`` against ``world``'s named regions: for each
    region, the IoU of the place covering most of it and the name that place took ("" for none)."""
    from atlas_rap.sim.world import load_world

    folder = Path(folder)
    with np.load(folder / "grid.npz") as data:
        places, frame = data["places"], GridFrame.from_array(data["frame"])
    topology = json.loads((folder / "topology.json").read_text(encoding="utf-8"))
    named = {int(label): name for label, name in topology["place_names"].items()}
    loaded = load_world(world) if isinstance(world, str) else world
    return {name: (iou, named.get(best, ""))
            for name, (best, iou) in zip(world_room_names(loaded), best_places(places, world_rooms(loaded, frame)))}


def world_room_names(world: Any) -> tuple[str, ...]:
    """The names of :func:`world_rooms`' labels: index i for label i + 1."""
    if isinstance(world, str):
        from atlas_rap.sim.world import load_world

        world = load_world(world)
    return tuple(world.places)


def _place_cells(place: Any, frame: GridFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rows, cols, inside) over the cells near a place: whether each cell's centre is in it."""
    if place.region is None:
        xs = np.array([place.point[0] - place.radius, place.point[0] + place.radius])
        ys = np.array([place.point[1] - place.radius, place.point[1] + place.radius])
    else:
        xs, ys = np.array([p[0] for p in place.region]), np.array([p[1] for p in place.region])
    if frame.origin[2] == 0.0:
        r_hi, c_lo = frame.world_to_cell(xs.min(), ys.min())
        r_lo, c_hi = frame.world_to_cell(xs.max(), ys.max())
        r0, r1 = max(r_lo - 1, 0), min(r_hi + 2, frame.height)
        c0, c1 = max(c_lo - 1, 0), min(c_hi + 2, frame.width)
    else:
        r0, r1, c0, c1 = 0, frame.height, 0, frame.width
    rows, cols = np.meshgrid(np.arange(r0, max(r0, r1)), np.arange(c0, max(c0, c1)), indexing="ij")
    x, y = frame.cell_to_world(rows, cols)
    x, y = np.broadcast_to(x, rows.shape), np.broadcast_to(y, rows.shape)
    if place.region is None:
        inside = np.hypot(x - place.point[0], y - place.point[1]) <= place.radius
    else:
        inside = _even_odd(place.region, x, y)
    return rows, cols, inside


def _even_odd(polygon: Any, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """:func:`atlas_rap.model._inside`, vectorised over the points."""
    inside = np.zeros(x.shape, dtype=bool)
    n = len(polygon)
    for i in range(n):
        (x1, y1), (x2, y2) = polygon[i], polygon[(i + 1) % n]
        if y1 == y2:
            continue
        crosses = ((y1 > y) != (y2 > y)) & (x < x1 + (y - y1) * (x2 - x1) / (y2 - y1))
        inside ^= crosses
    return inside


# -- the scorer -------------------------------------------------------------------------------

@dataclass(frozen=True)
class Score:
    """How well a place labelling matches ground-truth rooms (see :func:`score` for the definitions)."""

    n_rooms: int
    n_places: int
    mean_recall: float
    mean_precision: float
    pixel_precision: float
    owned_rooms: int
    owned_fraction: float
    merged_rooms: int
    merged_places: int
    split_rooms: int
    max_rooms_per_place: int
    places_off_rooms: int
    iou_threshold: float
    room_labels: tuple[int, ...]
    room_recall: tuple[float, ...]
    room_iou: tuple[float, ...]
    room_place: tuple[int, ...]
    place_labels: tuple[int, ...] = ()
    place_precision: tuple[float, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """Plain numbers, NaN as None (strict JSON); per room (recall, IoU, best place) and per place (precision)."""
        summary: dict[str, Any] = {k: _plain(getattr(self, k)) for k in (
            "n_rooms", "n_places", "mean_recall", "mean_precision", "pixel_precision", "owned_rooms",
            "owned_fraction", "merged_rooms", "merged_places", "split_rooms", "max_rooms_per_place",
            "places_off_rooms", "iou_threshold")}
        summary["rooms"] = {str(r): {"recall": _plain(rc), "iou": _plain(iou), "place": p}
                            for r, rc, iou, p in zip(self.room_labels, self.room_recall, self.room_iou,
                                                     self.room_place)}
        summary["places"] = {str(p): {"precision": _plain(v)}
                             for p, v in zip(self.place_labels, self.place_precision)}
        return summary


def _plain(value: Any) -> Any:
    """NaN (a mean of nothing, the precision of a place off the rooms) as None, for strict JSON."""
    return None if isinstance(value, float) and math.isnan(value) else value


def _compact(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the labels > 0 present, sorted; the image relabelled 1..k in that order, 0 staying 0), as int32.

    Counting (``np.bincount``, one pass) when the labels are small numbers;
    sorting (``np.unique``) when they are large and sparse.
    """
    flat = labels.ravel()
    top = int(flat.max()) if flat.size else 0
    if top <= 4 * flat.size + 1024:
        present = np.flatnonzero(np.bincount(flat, minlength=1))
        present = present[present > 0]
        lut = np.zeros(top + 1, dtype=np.int32)
        lut[present] = np.arange(1, present.size + 1, dtype=np.int32)
        return present, lut[labels]
    values, inverse = np.unique(flat, return_inverse=True)
    shift = 0 if values[0] == 0 else 1
    return values[1 - shift:], (inverse.reshape(labels.shape) + shift).astype(np.int32)


_DENSE_BINS = 2 ** 22
"""Pairs (room, place) up to which :func:`score` counts into a dense table (32 MB)."""


def _as_labels(values: np.ndarray, name: str) -> np.ndarray:
    array = np.asarray(values)
    if array.dtype == bool:
        return array.astype(np.int32)
    if not np.issubdtype(array.dtype, np.integer):
        raise ValueError(f"{name} must be an integer label image, not {array.dtype}")
    if array.size and array.min() < 0:
        raise ValueError(f"{name} has negative labels")
    return array


def score(places: np.ndarray, rooms: np.ndarray, *, iou_threshold: float = 0.5, hold: float = 0.5,
          split: float = 0.2, dense_bins: int = _DENSE_BINS) -> Score:
    """Compare a place labelling with ground-truth rooms, pixel by pixel (both integer images of one shape).

    ``places``: 0 = no place, 1..P places. ``rooms``: 0 = ignore (walls,
    door gaps, outside, furniture), 1..R rooms. Only pixels on rooms count:
    a place's pixels where ``rooms == 0`` are ignored (walls and furniture
    are in no room, so covering them is neither right nor wrong). With
    ``n(r, p)`` the pixels of room r in place p, ``|r|`` the room's pixels
    and ``|p|`` the place's pixels on rooms:

    - **recall** of room r: ``max_p n(r, p) / |r|`` (p > 0), the share of the
      room its best place covers; ``mean_recall`` over the rooms;
    - **precision** of place p (``place_precision``, NaN for a place off
      the rooms): ``max_r n(r, p) / |p|``, the share of the
      place inside its best room; ``mean_precision`` over the places with
      pixels on rooms, ``pixel_precision`` weighted by ``|p|`` (i.e.
      ``sum_p max_r n(r, p) / sum_p |p|``); places with no pixel on a room
      are ``places_off_rooms`` and count in neither;
    - a room **owns** a place when their IoU ``n / (|r| + |p| - n)`` is at
      least ``iou_threshold`` (above 0.5 a place can be owned by one room
      only, and a room own one place only); ``owned_fraction`` = owned / R;
    - a place **holds** a room when it covers more than ``hold`` (half) of
      it, so a room is held by at most one place (a ``hold`` below 0.5
      would let two places hold it and count it merged twice); a room is
      **merged** when the place holding it holds another room too
      (``merged_rooms``; the places holding two or more are
      ``merged_places``, the most rooms one place holds
      ``max_rooms_per_place``);
    - a room is **split** when two or more places each cover at least
      ``split`` (20 %) of it.

    ``n_rooms`` and ``n_places`` count the labels present (the places
    anywhere in the image). Means of nothing are NaN. One ``np.bincount`` of
    the joint labels does the counting: a 4000 x 4000 image takes ~0.3 s.
    Up to ``dense_bins`` (room, place) pairs it counts into a dense table,
    beyond that only the pairs that occur (the same figures either way).
    """
    p_img, r_img = _as_labels(places, "places"), _as_labels(rooms, "rooms")
    if p_img.shape != r_img.shape:
        raise ValueError(f"places {p_img.shape} and rooms {r_img.shape} differ in shape")
    room_ids, r_c = _compact(r_img)
    place_ids, p_c = _compact(p_img)
    nr, npl = room_ids.size, place_ids.size
    width = npl + 1
    if (nr + 1) * width <= dense_bins:
        codes = r_c.ravel() * np.int32(width) + p_c.ravel()
        counts = np.bincount(codes, minlength=(nr + 1) * width).reshape(nr + 1, width)
        rr, pp = np.nonzero(counts[1:])
        cc = counts[1:][rr, pp]
    else:  # too many labels for a table of every pair: count the pairs that occur
        codes = r_c.ravel().astype(np.int64) * width + p_c.ravel()
        pairs, cc = np.unique(codes[codes >= width], return_counts=True)
        rr, pp = np.divmod(pairs, width)
        rr -= 1
    room_size = np.bincount(rr, weights=cc, minlength=nr)
    on = pp > 0
    rr, pp, cc = rr[on], pp[on] - 1, cc[on].astype(np.float64)
    place_size = np.bincount(pp, weights=cc, minlength=npl)
    best_in_room = np.zeros(nr)
    np.maximum.at(best_in_room, rr, cc)
    best_in_place = np.zeros(npl)
    np.maximum.at(best_in_place, pp, cc)
    iou = cc / (room_size[rr] + place_size[pp] - cc)
    room_iou = np.zeros(nr)
    np.maximum.at(room_iou, rr, iou)
    room_place = np.zeros(nr, dtype=np.int64)
    best = cc == best_in_room[rr]
    room_place[rr[best]] = place_ids[pp[best]]
    held = cc > hold * room_size[rr]
    rooms_held = np.bincount(pp[held], minlength=npl)
    merged = int(np.count_nonzero(rooms_held[pp[held]] >= 2))
    big_parts = np.bincount(rr[cc >= split * room_size[rr]], minlength=nr)
    recall = best_in_room / np.maximum(room_size, 1)
    on_rooms = place_size > 0
    precision = np.where(on_rooms, best_in_place / np.maximum(place_size, 1), np.nan)
    owned = int(np.count_nonzero(room_iou >= iou_threshold))
    return Score(
        n_rooms=int(nr), n_places=int(npl),
        mean_recall=float(recall.mean()) if nr else math.nan,
        mean_precision=float(precision[on_rooms].mean()) if on_rooms.any() else math.nan,
        pixel_precision=float(best_in_place.sum() / place_size.sum()) if on_rooms.any() else math.nan,
        owned_rooms=owned, owned_fraction=owned / nr if nr else math.nan,
        merged_rooms=merged, merged_places=int(np.count_nonzero(rooms_held >= 2)),
        split_rooms=int(np.count_nonzero(big_parts >= 2)),
        max_rooms_per_place=int(rooms_held.max(initial=0)),
        places_off_rooms=int(np.count_nonzero(~on_rooms)), iou_threshold=float(iou_threshold),
        room_labels=tuple(int(r) for r in room_ids), room_recall=tuple(float(v) for v in recall),
        room_iou=tuple(float(v) for v in room_iou), room_place=tuple(int(v) for v in room_place),
        place_labels=tuple(int(p) for p in place_ids), place_precision=tuple(float(v) for v in precision))

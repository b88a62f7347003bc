"""Topological maps (seed §4.2, Fig. 11): the skeleton's crossings, junctions and ends as a graph, and routes on it.

:func:`build_topology` turns a traced skeleton (:func:`atlas_rap.maps.sdt.trace_skeleton`)
into a :class:`Topology`, a ``networkx.Graph``:

* **nodes** -- crossings (kind ``"X"``, four or more branches), T-junctions
  (``"T"``, three) and endpoints / enclosed places (``"L"``, one; also a
  lone node or a ring). Attributes: ``kind``, ``branches`` (skeleton
  branches met there), ``cell`` (row, col), ``xy`` (world x, y, metres),
  ``clearance`` (the DT there, metres), ``place`` (the place label it lies
  in, 0 if none).
* **edges** -- the skeleton between two nodes. Attributes: ``length``
  (metres along the skeleton), ``probability`` (that it is empty, see
  :mod:`atlas_rap.maps.sdt`), ``cost`` (= -log probability =
  sum over its cells of -log p_cell, weighted by arc length per robot
  diameter: the most probable route is the cheapest), ``cells`` (tuple of
  (row, col) from node ``head`` to the other end), ``support`` (each cell's
  probability that the robot's band there is empty, in the same order),
  ``head`` and ``places`` (the place labels it crosses, in order from ``head``).

The skeleton is simplified before it becomes a graph, repeatedly until
nothing changes: **spurs** (a branch ending in an endpoint) are cut when
they reach less than ``spur_ratio`` times the junction's clearance beyond
the junction's clearance circle (``length - (dt_junction - dt_tip)``: a
corner spur or a bump on a wall; a junction keeps at least one branch);
nodes left with two branches are dissolved into one edge; and **junctions
closer** than ``max(merge_cells, their smaller clearance)`` along the
skeleton merge into one (two T's a cell apart are a crossing). A ring
back to its own node (round a table) is a self-loop; of parallel edges
(both ways round a pillar) the graph keeps the cheapest, so a node's
``branches`` may exceed its degree.

Routes (:meth:`Topology.route`) join each end point to the nearest
skeleton cell in line of sight, search the graph (length + ``risk`` x cost)
and return the nodes passed and metric waypoints for the follow-route
skill. Topologies are saved as JSON (:meth:`Topology.to_json`, read back
equal by :meth:`Topology.from_json`) and GraphML (:meth:`Topology.to_graphml`).
:meth:`Topology.facts` gives ``place`` and ``connected`` facts for the RAP memory.

Over 25 KB on purpose: the topological map: building it, its places and routes, and its JSON
and GraphML forms, over one graph representation.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

from atlas_rap.errors import MapError, read_at_most
from atlas_rap.maps.frame import GridFrame
from atlas_rap.outputs import write_text
from atlas_rap.maps.rooms import RoomSettings, segment_rooms
from atlas_rap.maps.sdt import (
    SkeletonSegment,
    SkeletonTrace,
    cell_support,
    distance_transform,
    segment_costs,
)

__all__ = ["GraphRoute", "Topology", "build_topology", "RISK"]

FORMAT = "atlas-rap topology"
VERSION = 1
RISK = 10.0
"""Metres of detour a route accepts to avoid one unit of cost (-log P): a 50 % passage costs 6.9 m."""


# -- building --------------------------------------------------------------------------

class _Skeleton:
    """A small multigraph over the traced skeleton: pruned and merged in place, edges as pieces of segments."""

    def __init__(self, trace: SkeletonTrace, clearance: np.ndarray) -> None:
        self.trace = trace
        self.clearance = clearance  # of each node, in cells
        # edge id -> [u, v, pieces, length]; a piece is (segment, forward)
        self.edges: dict[int, list[Any]] = {}
        self.adj: dict[int, dict[int, None]] = {n: {} for n in range(len(trace.node_cells))}
        self.degrees: dict[int, int] = dict.fromkeys(self.adj, 0)  # branches met at each node (a ring counts 2)
        for e, (u, v, length) in enumerate(zip(trace.seg_u.tolist(), trace.seg_v.tolist(),
                                               trace.seg_length.tolist())):
            self._add(e, u, v, [(e, True)], length)
        self.next_id = len(trace.seg_u)

    def _add(self, e: int, u: int, v: int, pieces: list[tuple[int, bool]], length: float) -> None:
        self.edges[e] = [u, v, pieces, length]
        self.adj[u][e] = None
        self.adj[v][e] = None
        self.degrees[u] += 1
        self.degrees[v] += 1

    def _remove(self, e: int) -> None:
        u, v, _, _ = self.edges.pop(e)
        self.adj[u].pop(e, None)
        self.adj[v].pop(e, None)
        self.degrees[u] -= 1
        self.degrees[v] -= 1

    def degree(self, n: int) -> int:
        return self.degrees[n]

    def other(self, e: int, n: int) -> int:
        u, v = self.edges[e][0], self.edges[e][1]
        return v if u == n else u

    def pieces_from(self, e: int, n: int) -> list[tuple[int, bool]]:
        """The pieces of edge ``e`` oriented to start at node ``n``."""
        u, _, pieces, _ = self.edges[e]
        return list(pieces) if u == n else [(s, not f) for s, f in reversed(pieces)]

    def prune_spurs(self, ratio: float, min_cells: float) -> bool:
        changed = False
        for j in list(self.adj):
            if j not in self.adj or self.degree(j) < 3:
                continue
            spurs = []
            for e in self.adj[j]:
                leaf = self.other(e, j)
                if leaf != j and self.degree(leaf) == 1:
                    length = self.edges[e][3]
                    reach = length - (self.clearance[j] - self.clearance[leaf])
                    if reach < ratio * self.clearance[j] or length < min_cells:
                        spurs.append((reach, e, leaf))
            for _, e, leaf in sorted(spurs):
                if self.degree(j) < 2:
                    break  # a junction keeps its longest branch
                self._remove(e)
                del self.adj[leaf]
                changed = True
        return changed

    def dissolve(self) -> bool:
        """Join the two edges of every node with two branches into one edge."""
        changed = False
        for n in list(self.adj):
            ends = list(self.adj.get(n, ()))
            if len(ends) != 2 or any(self.edges[e][0] == self.edges[e][1] for e in ends):
                continue
            e1, e2 = ends
            a, b = self.other(e1, n), self.other(e2, n)
            pieces = [(s, not f) for s, f in reversed(self.pieces_from(e1, n))] + self.pieces_from(e2, n)
            length = self.edges[e1][3] + self.edges[e2][3]
            self._remove(e1)
            self._remove(e2)
            del self.adj[n]
            self._add(self.next_id, a, b, pieces, length)
            self.next_id += 1
            changed = True
        return changed

    def merge_junctions(self, min_cells: float) -> bool:
        changed = False
        for e in sorted(self.edges, key=lambda e: self.edges[e][3]):
            if e not in self.edges:
                continue
            u, v, _, length = self.edges[e]
            if u == v or self.degree(u) < 3 or self.degree(v) < 3:
                continue
            if length > max(min_cells, min(self.clearance[u], self.clearance[v])):
                continue
            keep, gone = (u, v) if self.clearance[u] >= self.clearance[v] else (v, u)
            bridge = self.pieces_from(e, keep)
            self._remove(e)
            for other in list(self.adj[gone]):
                w = self.other(other, gone)
                pieces = bridge + self.pieces_from(other, gone)
                total = length + self.edges[other][3]
                loop = w == gone
                self._remove(other)
                if loop:  # a loop on the merged node: keep ... gone -> gone becomes keep -> keep
                    pieces = pieces + [(s, not f) for s, f in reversed(bridge)]
                    total += length
                self._add(self.next_id, keep, keep if loop else w, pieces, total)
                self.next_id += 1
            del self.adj[gone]
            changed = True
        return changed

    def edge_cells(self, e: int) -> np.ndarray:
        parts = []
        for s, forward in self.edges[e][2]:
            cells = self.trace.cells(s)
            cells = cells if forward else cells[::-1]
            if parts and (parts[-1][-1] == cells[0]).all():
                cells = cells[1:]
            parts.append(cells)
        return np.concatenate(parts) if parts else np.zeros((0, 2), dtype=np.int64)


def build_topology(trace: SkeletonTrace, dt: np.ndarray, p_occ: np.ndarray, frame: GridFrame, *,
                   robot_radius: float = 0.2, spur_ratio: float = 1.0, merge_cells: float = 3.0,
                   free: np.ndarray | None = None, nearest: np.ndarray | None = None,
                   reachable: np.ndarray | None = None, rooms: RoomSettings = RoomSettings()) -> Topology:
    """The :class:`Topology` of a traced skeleton (see the module docstring for the simplification).

    ``dt`` is the distance transform in metres, ``p_occ`` the occupancy
    grid (for the edges' probabilities and the walls the places are cut
    along), ``free`` the free mask (for the places and for line-of-sight
    checks in routes; default ``dt > 0``), ``nearest`` the feature
    transform of ``free`` (:func:`atlas_rap.maps.sdt.distance_transform`;
    computed here when not given), ``reachable`` the cells a robot
    that mapped the space could reach (:func:`atlas_rap.maps.rooms.segment_rooms`),
    ``rooms`` what the building's doors and rooms are like.
    """
    res = frame.resolution
    free = dt > 0 if free is None else np.asarray(free, dtype=bool)
    node_cells = trace.node_cells
    clearance = dt[node_cells[:, 0], node_cells[:, 1]] / res if len(node_cells) else np.zeros(0)
    sk = _Skeleton(trace, clearance)
    changed = True
    while changed:
        changed = sk.prune_spurs(spur_ratio, 2.0)
        changed = sk.dissolve() or changed
        changed = sk.merge_junctions(merge_cells) or changed
        changed = sk.dissolve() or changed

    # Cells, lengths and costs of every edge at once.
    ids = list(sk.edges)
    cells_of = [sk.edge_cells(e) for e in ids]
    offsets = np.concatenate([[0], np.cumsum([len(c) for c in cells_of])]).astype(np.int64)
    all_cells = np.concatenate(cells_of) if cells_of else np.zeros((0, 2), dtype=np.int64)
    band = robot_radius / res
    support = cell_support(p_occ, all_cells, band)
    diameter = 2 * robot_radius if robot_radius > 0 else res  # as in Topology.route
    length, cost = segment_costs(support, all_cells, offsets, res, diameter)
    with np.errstate(invalid="ignore"):
        occupied = np.asarray(p_occ) >= 0.5
    if nearest is None:
        nearest = distance_transform(free, frame, nearest=True)[1]
    labels, _ = segment_rooms(free, occupied, dt, nearest, res, cells_of, robot_radius=robot_radius,
                              reachable=reachable, settings=rooms)

    # Node ids in raster order of their cells.
    alive = sorted(sk.adj, key=lambda n: (int(node_cells[n, 0]), int(node_cells[n, 1])))
    new_id = {n: i for i, n in enumerate(alive)}
    graph = nx.Graph()
    for n in alive:
        r, c = int(node_cells[n, 0]), int(node_cells[n, 1])
        x, y = frame.cell_to_world(r, c)
        branches = sk.degree(n)
        kind = "X" if branches >= 4 else "T" if branches == 3 else "L"
        graph.add_node(new_id[n], kind=kind, branches=branches, cell=(r, c), xy=(x, y),
                       clearance=float(dt[r, c]), place=int(labels[r, c]))
    # Python values of every edge at once (one conversion each, not one per edge).
    cell_pairs = list(zip(all_cells[:, 0].tolist(), all_cells[:, 1].tolist()))
    support_values = support.tolist()
    on_place = labels[all_cells[:, 0], all_cells[:, 1]] if len(all_cells) else np.zeros(0, dtype=labels.dtype)
    place_values = on_place.tolist()
    bounds = offsets.tolist()
    lengths, costs = length.tolist(), cost.tolist()
    for k, e in enumerate(ids):
        u, v = new_id[sk.edges[e][0]], new_id[sk.edges[e][1]]
        if graph.has_edge(u, v) and graph.edges[u, v]["cost"] <= costs[k]:
            continue
        lo, hi = bounds[k], bounds[k + 1]
        crossed: list[int] = []
        for label in place_values[lo:hi]:  # the places along the edge, each run once
            if label and (not crossed or crossed[-1] != label):
                crossed.append(label)
        graph.add_edge(u, v, length=lengths[k], probability=math.exp(-costs[k]), cost=costs[k], head=u,
                       cells=tuple(cell_pairs[lo:hi]), support=tuple(support_values[lo:hi]), places=tuple(crossed))
    return Topology(graph, frame, robot_radius=robot_radius, free=free, place_labels=labels)


# -- the graph ---------------------------------------------------------------------------

@dataclass(frozen=True)
class GraphRoute:
    """A route on the topological graph: the nodes passed and the waypoints (world x, y) to drive through.

    ``length`` is metres along the waypoints; ``probability`` that every
    edge (or part of an edge) used is empty; ``cost`` = -log probability.
    """

    nodes: tuple[int, ...]
    waypoints: tuple[tuple[float, float], ...]
    length: float
    probability: float
    cost: float


class Topology:
    """A topological map: ``graph`` (a ``networkx.Graph``, see the module docstring) in ``frame``.

    ``free`` (the free mask) and ``place_labels`` (the places' label array)
    are kept when the topology was built from a grid; a topology read from
    JSON has neither: routes then snap to the nearest skeleton cell without
    a line-of-sight check, and places are known by the nodes' ``place``.
    ``place_names`` maps place labels to names (default ``place<label>``).
    """

    def __init__(self, graph: nx.Graph, frame: GridFrame, *, robot_radius: float = 0.2,
                 free: np.ndarray | None = None, place_labels: np.ndarray | None = None,
                 place_names: Mapping[int, str] | None = None) -> None:
        self.graph = graph
        self.frame = frame
        self.robot_radius = float(robot_radius)
        self.free = free
        self.place_labels = place_labels
        self.place_names: dict[int, str] = dict(place_names or {})
        self._index: tuple[Any, np.ndarray, list[tuple[int, int] | int]] | None = None

    def __repr__(self) -> str:
        kinds = {k: sum(1 for _, d in self.graph.nodes(data="kind") if d == k) for k in "XTL"}
        return (f"Topology({self.graph.number_of_nodes()} nodes (X {kinds['X']}, T {kinds['T']}, L {kinds['L']}), "
                f"{self.graph.number_of_edges()} edges, {len(self.place_ids())} places)")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Topology):
            return NotImplemented
        return (self.frame == other.frame and self.robot_radius == other.robot_radius
                and self.place_names == other.place_names
                and dict(self.graph.nodes(data=True)) == dict(other.graph.nodes(data=True))
                and {frozenset((u, v)): d for u, v, d in self.graph.edges(data=True)}
                == {frozenset((u, v)): d for u, v, d in other.graph.edges(data=True)})

    __hash__ = None  # type: ignore[assignment]

    # -- levels -------------------------------------------------------------------

    def kinds(self) -> dict[str, int]:
        """How many nodes of each kind ("X", "T", "L")."""
        out = {"X": 0, "T": 0, "L": 0}
        for _, kind in self.graph.nodes(data="kind"):
            out[kind] = out.get(kind, 0) + 1
        return out

    def segments(self) -> tuple[SkeletonSegment, ...]:
        """The edges as stochastic SDT segments (cells from ``u`` to ``v``)."""
        out = []
        for u, v, d in self.graph.edges(data=True):
            cells = np.asarray(d["cells"], dtype=np.int64).reshape(-1, 2)
            if d["head"] != u:
                u, v = v, u
            out.append(SkeletonSegment(u, v, cells, d["length"], d["probability"], d["cost"]))
        return tuple(out)

    def place_ids(self) -> list[int]:
        """The place labels the graph touches (nodes or edges), sorted."""
        ids = {d for _, d in self.graph.nodes(data="place") if d}
        for _, _, crossed in self.graph.edges(data="places"):
            ids.update(crossed)
        return sorted(ids)

    def place_at(self, xy: Sequence[float]) -> int:
        """The place label at world ``xy`` (0 if none); without the label array, the nearest node's place."""
        r, c = self.frame.world_to_cell(xy[0], xy[1])
        if self.place_labels is not None and self.frame.contains_cell(r, c):
            label = int(self.place_labels[r, c])
            if label:
                return label
        node = self.nearest_node(xy)
        return 0 if node is None else int(self.graph.nodes[node]["place"])

    def nearest_node(self, xy: Sequence[float]) -> int | None:
        """The node nearest to world ``xy`` (None in an empty graph)."""
        best, where = None, math.inf
        for n, (x, y) in self.graph.nodes(data="xy"):
            d = math.hypot(x - xy[0], y - xy[1])
            if d < where:
                best, where = n, d
        return best

    def name_places(self, places: Mapping[str, Any]) -> dict[int, str]:
        """Name the map's places after the world's; returns label -> name.

        ``places`` maps a name to a region (a polygon: a sequence of world
        (x, y) points) or to a point. A region names the place that covers
        most of it (more than half of the region's cells on places), and
        each place takes the name of the region that covers most of it, so
        two rooms merged into one place give it one name, not two. A point
        names the place it lies in, unless a region named that place
        already. Without the label array (a topology read from JSON) a
        region is known by its first point.
        """
        regions = {name: where for name, where in places.items() if _is_polygon(where)}
        claims: dict[int, tuple[float, str]] = {}
        if regions and self.place_labels is not None:
            for name, polygon in regions.items():
                label, share, cover = self._covering_place(polygon)
                if label and share > 0.5 and cover > claims.get(label, (0.0, ""))[0]:
                    claims[label] = (cover, name)
        for name, where in places.items():
            xy = where[0] if _is_polygon(where) else where
            if name in regions and self.place_labels is not None:
                continue
            label = self.place_at(xy)
            if label and label not in claims:
                claims[label] = (0.0, name)
        self.place_names.update({label: name for label, (_, name) in claims.items()})
        return dict(self.place_names)

    def _covering_place(self, polygon: Sequence[Sequence[float]]) -> tuple[int, float, float]:
        """The place that covers most of a world polygon: its label, the share of the polygon's
        cells it covers, and the share of the place's cells inside the polygon."""
        from skimage.draw import polygon as fill

        labels = self.place_labels
        xy = np.asarray(polygon, dtype=float)
        rows, cols = self.frame.world_to_cell(xy[:, 0], xy[:, 1])
        rr, cc = fill(np.asarray(rows, dtype=float), np.asarray(cols, dtype=float), labels.shape)
        if rr.size == 0:
            return 0, 0.0, 0.0
        inside = labels[rr, cc]
        counts = np.bincount(inside, minlength=1)
        counts[0] = 0
        label = int(np.argmax(counts))
        if counts[label] == 0:
            return 0, 0.0, 0.0
        size = int((labels == label).sum())
        return label, counts[label] / rr.size, counts[label] / max(size, 1)

    def place_name(self, label: int) -> str:
        return self.place_names.get(label, f"place{label}")

    def facts(self, places: Mapping[str, Any] | None = None) -> list[tuple[str, ...]]:
        """``("place", name)`` for every place, ``("connected", a, b)`` (a < b) for places an edge crosses between.

        ``places`` (name -> world region or point) names the places first
        (see :meth:`name_places`); the others are ``place<label>``.
        """
        if places:
            self.name_places(places)
        out: list[tuple[str, ...]] = [("place", self.place_name(p)) for p in self.place_ids()]
        pairs: set[tuple[str, str]] = set()
        for u, v, d in self.graph.edges(data=True):
            seq = [self.graph.nodes[d["head"]]["place"], *d["places"],
                   self.graph.nodes[v if d["head"] == u else u]["place"]]
            seq = [p for p in seq if p]
            for a, b in zip(seq, seq[1:]):
                if a != b:
                    na, nb = sorted((self.place_name(a), self.place_name(b)))
                    pairs.add((na, nb))
        out.extend(("connected", a, b) for a, b in sorted(pairs))
        return out

    # -- routes ---------------------------------------------------------------------

    def _cell_index(self) -> tuple[Any, np.ndarray, list[tuple[int, int] | int]]:
        """A KD-tree over every edge cell (and lone node): (tree, cells, owner) with owner (u, v) or a node."""
        if self._index is None:
            from scipy.spatial import cKDTree

            chunks, owners = [], []
            for u, v, d in self.graph.edges(data=True):
                cells = np.asarray(d["cells"], dtype=np.int64).reshape(-1, 2)
                chunks.append(cells)
                owners.append(((u, v), len(cells)))
            for n in self.graph.nodes:
                if self.graph.degree(n) == 0:
                    chunks.append(np.asarray([self.graph.nodes[n]["cell"]], dtype=np.int64))
                    owners.append((n, 1))
            cells = np.concatenate(chunks) if chunks else np.zeros((0, 2), dtype=np.int64)
            owner_of: list[tuple[int, int] | int] = []
            for owner, count in owners:
                owner_of.extend([owner] * count)
            tree = cKDTree(cells) if len(cells) else None
            self._index = (tree, cells, owner_of)
        return self._index

    def _line_of_sight(self, a: tuple[int, int], b: tuple[int, int]) -> bool:
        if self.free is None:
            return True
        from skimage.draw import line

        h, w = self.free.shape
        if not (0 <= a[0] < h and 0 <= a[1] < w and 0 <= b[0] < h and 0 <= b[1] < w):
            return False
        rr, cc = line(int(a[0]), int(a[1]), int(b[0]), int(b[1]))
        return bool(self.free[rr, cc].all())

    def _attach(self, xy: Sequence[float], candidates: int = 64) -> tuple[Any, int, tuple[int, int]] | None:
        """Where a point joins the graph: (owner, index along the owner's cells, cell)."""
        tree, cells, owner_of = self._cell_index()
        if tree is None:
            return None
        r, c = self.frame.world_to_cell(xy[0], xy[1])
        k = min(candidates, len(cells))
        _, found = tree.query([r, c], k=k)
        found = np.atleast_1d(found)
        choice = next((i for i in found if self._line_of_sight((r, c), tuple(cells[i]))), found[0])
        owner = owner_of[int(choice)]
        cell = (int(cells[choice, 0]), int(cells[choice, 1]))
        if isinstance(owner, tuple):
            data = self.graph.edges[owner]
            index = data["cells"].index(cell)
            return (owner, index, cell)
        return (owner, 0, cell)

    def _node_at(self, where: tuple[Any, int, tuple[int, int]]) -> int | None:
        owner, _, cell = where
        if not isinstance(owner, tuple):
            return owner
        return next((n for n in owner if self.graph.nodes[n]["cell"] == cell), None)

    def _oriented(self, u: int, v: int) -> list[tuple[int, int]]:
        d = self.graph.edges[u, v]
        return list(d["cells"]) if d["head"] == u else list(reversed(d["cells"]))

    def _near(self, data: Mapping[str, Any], points: Sequence[Sequence[float]], radius: float) -> bool:
        """Whether an edge's skeleton cells pass within ``radius`` metres of any of ``points``."""
        if not points:
            return False
        cells = np.asarray(data["cells"], dtype=float).reshape(-1, 2)
        xs, ys = self.frame.cell_to_world(cells[:, 0], cells[:, 1])
        xs, ys = np.atleast_1d(xs), np.atleast_1d(ys)
        return any(float(np.min(np.hypot(xs - px, ys - py))) < radius for px, py in points)

    def route(self, a_xy: Sequence[float], b_xy: Sequence[float], *, risk: float = RISK, step: int = 5,
              tolerance: float | None = None, avoid: Sequence[Sequence[float]] = (),
              avoid_radius: float = 0.5) -> GraphRoute | None:
        """The best route from world point ``a_xy`` to ``b_xy``, or None if they are not connected.

        Each point joins the skeleton at its nearest cell in line of sight
        (on the free cells); the graph is searched for the least ``length +
        risk * cost`` (``risk`` metres per unit of -log P; 0: the shortest,
        large: the most probable). The waypoints are ``a_xy``, every
        ``step``-th skeleton cell along the route and ``b_xy``, simplified
        with ``approximate_polygon`` to within ``tolerance`` metres (default
        half the robot's radius) while every leg stays in line of sight.
        A part of an edge is charged the length and cost of its own cells.
        Edges passing within ``avoid_radius`` metres of a point of ``avoid``
        (a door seen closed, a blocked corridor) are left out: Layer III's
        re-routing on the topology.
        """
        start, goal = self._attach(a_xy), self._attach(b_xy)
        if start is None or goal is None:
            return None
        work = nx.MultiGraph()
        work.add_nodes_from(self.graph.nodes)
        work.add_edges_from(edge for edge in self.graph.edges(data=True) if not self._near(edge[2], avoid, avoid_radius))
        A, B = ("route", "a"), ("route", "b")
        res = self.frame.resolution
        diameter = 2 * self.robot_radius if self.robot_radius > 0 else res

        def part(d: Mapping[str, Any], i: int, j: int, end: Any) -> dict[str, Any]:
            """The stretch of edge data ``d`` from its i-th to its j-th cell (as oriented from ``head``)."""
            lo, hi = min(i, j), max(i, j)
            cells = np.asarray(d["cells"][lo:hi + 1], dtype=float).reshape(-1, 2)
            support = np.asarray(d["support"][lo:hi + 1], dtype=float)
            length, cost = segment_costs(support, cells, np.array([0, len(cells)]), res, diameter)
            piece = list(d["cells"][lo:hi + 1])
            return {"length": float(length[0]), "cost": float(cost[0]), "head": end,
                    "cells": tuple(piece if i <= j else piece[::-1])}

        def join(end: Any, where: tuple[Any, int, tuple[int, int]]) -> None:
            owner, i, cell = where
            if not isinstance(owner, tuple):
                work.add_edge(end, owner, length=0.0, cost=0.0, head=end, cells=(cell,))
                return
            d = self.graph.edges[owner]
            head = d["head"]
            tail = owner[1] if owner[0] == head else owner[0]
            for node, j in ((head, 0), (tail, len(d["cells"]) - 1)):  # two edges to one node when a ring
                piece = part(d, i, j, end)
                if not self._near(piece, avoid, avoid_radius):
                    work.add_edge(end, node, **piece)

        join(A, start)
        join(B, goal)
        if isinstance(start[0], tuple) and isinstance(goal[0], tuple) and set(start[0]) == set(goal[0]):
            piece = part(self.graph.edges[start[0]], start[1], goal[1], A)
            if not self._near(piece, avoid, avoid_radius):
                work.add_edge(A, B, **piece)
        elif start[2] == goal[2]:
            work.add_edge(A, B, length=0.0, cost=0.0, head=A, cells=(start[2],))

        def cost_of(d: Mapping[str, Any]) -> float:
            return d["length"] + risk * d["cost"]

        def weight(x: Any, y: Any, keyed: Mapping[Any, Mapping[str, Any]]) -> float:
            return min(cost_of(d) for d in keyed.values())

        try:
            path = nx.shortest_path(work, A, B, weight=weight)
        except (nx.NetworkXNoPath, nx.NodeNotFound):  # not found: every way to join the graph is avoided
            return None
        cells: list[tuple[int, int]] = []
        cost = 0.0
        for x, y in zip(path, path[1:]):
            d = min(work[x][y].values(), key=cost_of)
            piece = list(d["cells"]) if d["head"] == x else list(reversed(d["cells"]))
            cost += d["cost"]
            if cells and piece and cells[-1] == tuple(piece[0]):
                piece = piece[1:]
            cells.extend(tuple(c) for c in piece)
        waypoints = self._waypoints(a_xy, b_xy, cells, step, tolerance)
        length = float(sum(math.dist(p, q) for p, q in zip(waypoints, waypoints[1:])))
        nodes = [n for n in path if n not in (A, B)]
        first, last = self._node_at(start), self._node_at(goal)  # a point joined right at a node passes it
        if first is not None and nodes[:1] != [first]:
            nodes.insert(0, first)
        if last is not None and nodes[-1:] != [last]:
            nodes.append(last)
        nodes = tuple(nodes)
        return GraphRoute(nodes, waypoints, length, float(math.exp(-cost)), float(cost))

    def _waypoints(self, a_xy: Sequence[float], b_xy: Sequence[float], cells: list[tuple[int, int]], step: int,
                   tolerance: float | None) -> tuple[tuple[float, float], ...]:
        from skimage.measure import approximate_polygon

        step = max(1, int(step))
        picked = cells[::step]
        if cells and picked[-1] != cells[-1]:
            picked.append(cells[-1])
        rc = [self.frame.world_to_cell(a_xy[0], a_xy[1]), *picked, self.frame.world_to_cell(b_xy[0], b_xy[1])]
        arr = np.asarray(picked, dtype=float).reshape(-1, 2)
        xs, ys = self.frame.cell_to_world(arr[:, 0], arr[:, 1])
        points = np.vstack([[a_xy[0], a_xy[1]], np.column_stack([np.atleast_1d(xs), np.atleast_1d(ys)]),
                            [b_xy[0], b_xy[1]]]).astype(float)
        tol = 0.5 * self.robot_radius if tolerance is None else tolerance
        if tol <= 0 or len(points) <= 2:
            keep = list(range(len(points)))
        else:
            simple = approximate_polygon(points, tolerance=tol)
            # approximate_polygon keeps a subset of the points: find which, in order.
            keep, j = [], 0
            for p in simple:
                while not np.array_equal(points[j], p):
                    j += 1
                keep.append(j)
            keep = self._keep_in_sight(rc, keep)
        out: list[tuple[float, float]] = []
        for i in keep:
            p = (float(points[i, 0]), float(points[i, 1]))
            if not out or p != out[-1]:
                out.append(p)
        return tuple(out)

    def _keep_in_sight(self, rc: list[Any], keep: list[int]) -> list[int]:
        """Put points back between kept ones whose leg is not in line of sight on the free cells."""
        if self.free is None:
            return keep
        out = [keep[0]]
        stack = list(zip(keep, keep[1:]))[::-1]
        while stack:
            i, j = stack.pop()
            if j - i > 1 and not self._line_of_sight(rc[i], rc[j]):
                m = (i + j) // 2
                stack.extend([(m, j), (i, m)])
            else:
                out.append(j)
        return out

    def route_between_places(self, name_a: str, name_b: str, places_xy: Mapping[str, Sequence[float]],
                             **options: Any) -> GraphRoute | None:
        """:meth:`route` from the point of place ``name_a`` to that of ``name_b`` (``places_xy``: name -> x, y)."""
        for name in (name_a, name_b):
            if name not in places_xy:
                known = ", ".join(sorted(places_xy)) or "none"
                raise KeyError(f"no place named {name!r} (places: {known})")
        return self.route(places_xy[name_a], places_xy[name_b], **options)

    # -- files ----------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """The topology as plain JSON data (the grids ``free`` and ``place_labels`` are not included)."""
        return self._data(plain=True)

    def _data(self, *, plain: bool) -> dict[str, Any]:
        """:meth:`to_dict`'s data; unless ``plain`` the attributes' tuples stay tuples (``json`` writes a
        tuple as a list, and in C: :meth:`to_json` then spends no Python work per cell)."""
        nodes = sorted(self.graph.nodes(data=True))
        edges = sorted(self.graph.edges(data=True), key=lambda e: (min(e[:2]), max(e[:2])))
        return {
            "format": FORMAT, "version": VERSION,
            "frame": self._frame_data(),
            "robot_radius": self.robot_radius,
            "place_names": {str(k): v for k, v in sorted(self.place_names.items())},
            "nodes": [{"id": n, **{k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}} for n, d in nodes]
            if plain else [{"id": n, **d} for n, d in nodes],
            "edges": [{"u": u, "v": v, **{k: _plain(v) for k, v in d.items()}} for u, v, d in edges]
            if plain else [{"u": u, "v": v, **d} for u, v, d in edges],
        }

    def _frame_data(self) -> dict[str, Any]:
        f = self.frame
        return {"height": f.height, "width": f.width, "resolution": f.resolution, "origin": list(f.origin)}

    def to_json(self, path: str | Path) -> Path:
        """Write the graph (nodes, edges with their cells, the frame) as JSON; return the path."""
        return write_text(path, json.dumps(self._data(plain=False), separators=(",", ":")))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Topology:
        if data.get("format") != FORMAT:
            raise ValueError(f"not an atlas-rap topology (format {data.get('format')!r})")
        fr = data["frame"]
        frame = GridFrame.from_array([fr["height"], fr["width"], fr["resolution"], *fr["origin"]])
        graph = nx.Graph()
        for node in data["nodes"]:
            attrs = dict(node)
            n = attrs.pop("id")
            attrs["cell"] = _cell(attrs["cell"], frame, f"node {n}")
            attrs["xy"] = _numbers(attrs["xy"], 2, f"node {n}'s xy")
            _numbers([attrs["clearance"]], 1, f"node {n}'s clearance", low=0.0)
            graph.add_node(n, **attrs)
        for edge in data["edges"]:
            attrs = dict(edge)
            u, v = attrs.pop("u"), attrs.pop("v")
            if u not in graph or v not in graph:
                raise ValueError(f"edge {u}-{v} joins a node that is not in the map")
            what = f"edge {u}-{v}"
            attrs["cells"] = tuple(_cell(cell, frame, what) for cell in attrs["cells"])
            attrs["places"] = tuple(attrs["places"])
            attrs["support"] = _numbers(attrs["support"], len(attrs["support"]), f"{what}'s support", 0.0, 1.0)
            _numbers([attrs["length"], attrs["cost"]], 2, f"{what}'s length and cost", low=0.0)
            _numbers([attrs["probability"]], 1, f"{what}'s probability", 0.0, 1.0)
            graph.add_edge(u, v, **attrs)
        names = {int(k): v for k, v in data.get("place_names", {}).items()}
        return cls(graph, frame, robot_radius=float(data.get("robot_radius", 0.2)), place_names=names)

    @classmethod
    def from_json(cls, path: str | Path) -> Topology:
        """Read a topology written by :meth:`to_json`; anything else is a :class:`MapError` saying so."""
        try:
            text = read_at_most(path, MAX_JSON_BYTES)
            if len(text) > MAX_JSON_BYTES:
                raise ValueError(f"larger than {MAX_JSON_BYTES // 2**20} MiB")
            data = json.loads(text.decode("utf-8"))
            if not isinstance(data, dict):
                raise ValueError(f"it holds {type(data).__name__}, not an object")
            return cls.from_dict(data)
        except RecursionError:
            raise MapError(f"{path}: not a topological map written by atlas map (nested too deeply)") from None
        except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError, AttributeError) as exc:
            raise MapError(f"{path}: not a topological map written by atlas map ({exc}); make one with "
                             f"atlas map build --out DIR, then use DIR/topology.json") from None

    def to_graphml(self, path: str | Path) -> Path:
        """Write the graph as GraphML (networkx): tuples become scalars (row, col, x, y) or JSON strings.

        The file is the one ``networkx.write_graphml`` writes, byte for byte,
        but written straight out (:func:`_write_graphml`) rather than through
        an ElementTree of every attribute.
        """
        flat = nx.Graph()
        for n, d in self.graph.nodes(data=True):
            attrs = {k: v for k, v in d.items() if k not in ("cell", "xy")}
            attrs.update(row=d["cell"][0], col=d["cell"][1], x=d["xy"][0], y=d["xy"][1],
                         name=self.place_name(d["place"]) if d["place"] else "")
            flat.add_node(n, **attrs)
        for u, v, d in self.graph.edges(data=True):  # cells, support, places: one JSON string each
            attrs = {k: (json.dumps(val, separators=(",", ":")) if isinstance(val, (tuple, list)) else val)
                     for k, val in d.items()}
            flat.add_edge(u, v, **attrs)
        flat.graph.update(frame=json.dumps(self._frame_data()), robot_radius=self.robot_radius)
        return _write_graphml(flat, Path(path))


MAX_JSON_BYTES = 64 * 2**20
"""The largest topology file :meth:`Topology.from_json` reads."""


def _numbers(values: Any, count: int, what: str, low: float = -math.inf, high: float = math.inf) -> tuple:
    """``values`` checked: ``count`` finite numbers from ``low`` to ``high`` (a file's map is read, not trusted)."""
    values = tuple(values)
    if len(values) != count or not all(type(v) in (int, float) and -_LARGEST <= v <= _LARGEST and low <= v <= high
                                       for v in values):
        raise ValueError(f"{what} must be {count} finite number{'s' if count != 1 else ''}"
                         + (f" from {low:g} to {high:g}" if math.isfinite(low) or math.isfinite(high) else ""))
    return values


_LARGEST = sys.float_info.max


def _cell(values: Any, frame: GridFrame, what: str) -> tuple[int, int]:
    """A (row, col) cell of ``frame``."""
    cell = tuple(values)
    if len(cell) != 2 or not all(type(v) is int for v in cell) or not frame.contains_cell(*cell):
        raise ValueError(f"{what} has a cell {list(cell)} outside the map's {frame.height} x {frame.width} cells")
    return cell


def _write_graphml(graph: nx.Graph, out: Path) -> Path:
    """Write an undirected ``graph`` as ``networkx.write_graphml`` does (same keys, types, order and layout).

    Key ids are given in the order attributes are met (the graph's, then
    each node's, then each edge's), one key per name, type and scope, and
    listed last first, as networkx lists them.
    """
    from xml.sax.saxutils import escape

    from networkx.readwrite.graphml import GraphMLWriter

    xml_type = GraphMLWriter().xml_type  # networkx's own table of Python type -> GraphML type
    quote = {'"': "&quot;", "\r": "&#13;", "\n": "&#10;", "\t": "&#09;"}
    keys: dict[tuple[str, str, str], str] = {}

    def data(scope: str, attrs: Mapping[str, Any], indent: str) -> list[str]:
        lines = []
        for name, value in attrs.items():
            name = str(name)
            kind = type(value)
            if kind not in xml_type:
                raise nx.NetworkXError(f"GraphML writer does not support {kind} as data values.")
            key = keys.setdefault((name, xml_type[kind], scope), f"d{len(keys)}")
            lines.append(f'{indent}<data key="{key}">{escape(str(value))}</data>')
        return lines

    def element(tag: str, ids: str, attrs: Mapping[str, Any]) -> list[str]:
        inner = data(tag, attrs, "      ")
        if not inner:
            return [f"    <{tag} {ids} />"]
        return [f"    <{tag} {ids}>", *inner, f"    </{tag}>"]

    graph_data = data("graph", {k: v for k, v in graph.graph.items() if k not in ("node_default", "edge_default")},
                      "    ")
    body: list[str] = []
    for n, attrs in graph.nodes(data=True):
        body += element("node", f'id="{escape(str(n), quote)}"', attrs)
    for u, v, attrs in graph.edges(data=True):
        body += element("edge", f'source="{escape(str(u), quote)}" target="{escape(str(v), quote)}"', attrs)
    key_lines = [f'  <key id="{key}" for="{scope}" attr.name="{escape(name, quote)}" attr.type="{kind}" />'
                 for (name, kind, scope), key in reversed(keys.items())]
    edge_default = "directed" if graph.is_directed() else "undirected"
    root = ('<graphml xmlns="http://graphml.graphdrawing.org/xmlns" '
            'xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" '
            'xsi:schemaLocation="http://graphml.graphdrawing.org/xmlns '
            'http://graphml.graphdrawing.org/xmlns/1.0/graphml.xsd">')
    lines = ["<?xml version='1.0' encoding='utf-8'?>", root, *key_lines, f'  <graph edgedefault="{edge_default}">',
             *body, *graph_data, "  </graph>", "</graphml>"]
    return write_text(out, "\n".join(lines) + "\n")


def _is_polygon(where: Any) -> bool:
    """Whether a place is given as a polygon (points) rather than as one point."""
    return len(where) >= 3 and all(isinstance(p, (tuple, list, np.ndarray)) for p in where)


def _plain(value: Any) -> Any:
    """``value`` with its tuples, at any depth, as lists (JSON data)."""
    if isinstance(value, (tuple, list)):
        return [_plain(v) if isinstance(v, (tuple, list)) else v for v in value]
    return value

"""Geometric maps, the skeletonized distance transform and the topological graph on maps drawn here."""

from __future__ import annotations

import math
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
from skimage.draw import line

from atlas_rap.maps.abstraction import abstract
from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.geometry import geometric_map, outlines, region_edges
from atlas_rap.maps.sdt import (
    cell_support,
    distance_transform,
    free_space,
    skeleton,
    trace_skeleton,
)
from atlas_rap.maps.topology import Topology

RES = 0.05
WALL = 1.0  # P(occupied) of walls


def frame_for(p: np.ndarray, origin: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> GridFrame:
    return GridFrame(p.shape[0], p.shape[1], RES, origin)


def plus(n: int = 120, half: int = 16) -> np.ndarray:
    """Two corridors 1.6 m wide crossing in the middle of a 6 m square."""
    p = np.full((n, n), WALL, dtype=np.float32)
    c = n // 2
    p[c - half:c + half, 4:-4] = 0.0
    p[4:-4, c - half:c + half] = 0.0
    return p


def tee(n: int = 120, half: int = 16) -> np.ndarray:
    p = np.full((n, n), WALL, dtype=np.float32)
    c = n // 2
    p[c - half:c + half, 4:-4] = 0.0
    p[c:-4, c - half:c + half] = 0.0
    return p


def two_rooms() -> tuple[np.ndarray, tuple[slice, slice]]:
    """Two rooms of 4 x 4.5 m side by side, a 0.3 m wall between them with a 1 m door; the door's cells."""
    p = np.full((100, 180), WALL, dtype=np.float32)
    p[5:95, 5:85] = 0.0
    p[5:95, 91:175] = 0.0
    door = (slice(40, 60), slice(85, 91))
    p[door] = 0.0
    return p, door


def corridor(length: int = 240, notches: bool = False) -> np.ndarray:
    """A corridor 1.6 m wide and 11.6 m long (closed at both ends), with small notches in its walls if asked."""
    p = np.full((60, length), WALL, dtype=np.float32)
    p[14:46, 4:-4] = 0.0
    if notches:
        rng = np.random.default_rng(1)
        for x in range(10, length - 10, 12):
            depth, width = int(rng.integers(1, 4)), int(rng.integers(2, 5))
            p[14:14 + depth, x:x + width] = WALL
            p[46 - depth:46, x + 5:x + 5 + width] = WALL
    return p


def on_free_cells(topology: Topology, waypoints: tuple[tuple[float, float], ...], free: np.ndarray) -> bool:
    for (x0, y0), (x1, y1) in zip(waypoints, waypoints[1:]):
        r0, c0 = topology.frame.world_to_cell(x0, y0)
        r1, c1 = topology.frame.world_to_cell(x1, y1)
        rr, cc = line(r0, c0, r1, c1)
        if not free[rr, cc].all():
            return False
    return True


def route_cells(topology: Topology, waypoints: tuple[tuple[float, float], ...]) -> set[tuple[int, int]]:
    cells: set[tuple[int, int]] = set()
    for (x0, y0), (x1, y1) in zip(waypoints, waypoints[1:]):
        rr, cc = line(*topology.frame.world_to_cell(x0, y0), *topology.frame.world_to_cell(x1, y1))
        cells.update(zip(rr.tolist(), cc.tolist()))
    return cells


# -- geometry ------------------------------------------------------------------------

def test_edges_of_occupied_and_empty_regions_and_polygons() -> None:
    p = np.full((20, 30), 0.1, dtype=np.float32)
    p[5:10, 5:15] = 0.9  # an occupied block
    p[:, 25:] = np.nan  # unknown on the right
    frame = frame_for(p, (1.0, 2.0, 0.0))
    geo = geometric_map(p, frame)
    block = np.zeros_like(geo.occupied_edges)
    block[5:10, 5:15] = True
    assert (geo.occupied_edges == (block & ~np.pad(np.ones((3, 8), bool), ((6, 11), (6, 16))))).all()
    # Empty edges: around the block and along the unknown strip, not along the grid's border.
    assert geo.empty_edges[4, 5:15].all() and geo.empty_edges[10, 5:15].all() and geo.empty_edges[:, 24].all()
    assert not geo.empty_edges[0, 16:24].any() and not geo.empty_edges[:, 0].any()
    assert len(geo.polygons) == 1
    poly = geo.polygons[0]
    assert (poly[0] == poly[-1]).all()
    assert poly[:, 0].min() == pytest.approx(1.0 + 5 * RES) and poly[:, 0].max() == pytest.approx(1.0 + 15 * RES)
    assert poly[:, 1].min() == pytest.approx(2.0 + 10 * RES) and poly[:, 1].max() == pytest.approx(2.0 + 15 * RES)
    assert outlines(np.zeros((3, 3), bool), frame) == []
    assert region_edges(np.ones((4, 4), bool)).sum() == 0


# -- distance transform, skeleton, support ----------------------------------------------------

def test_distance_transform_counts_the_border_as_obstacle() -> None:
    frame = GridFrame(9, 9, RES)
    dt = distance_transform(np.ones((9, 9), bool), frame)
    assert dt[0, 0] == pytest.approx(RES) and dt[4, 4] == pytest.approx(5 * RES)
    free = free_space(np.array([[0.1, 0.5, np.nan, 0.7]]))
    assert free.tolist() == [[True, False, False, False]]


def test_cell_support_is_the_weakest_cell_of_the_band_and_unknown_is_a_half() -> None:
    p = np.zeros((11, 11), dtype=np.float32)
    p[5, 7] = 0.3
    cells = np.array([[5, 5], [1, 1]])
    assert cell_support(p, cells, 2.0).tolist() == pytest.approx([0.7, 1.0])
    p[5, 6] = np.nan
    assert cell_support(p, cells, 2.0)[0] == pytest.approx(0.5)
    assert cell_support(p, cells, 0.0)[0] == pytest.approx(1.0)


# -- topology ------------------------------------------------------------------------------

def test_a_crossing_of_two_corridors_is_one_x_and_four_ends() -> None:
    p = plus()
    frame = frame_for(p, (-3.0, 2.0, 0.0))
    topo = abstract(p, frame).topology
    assert topo.kinds() == {"X": 1, "T": 0, "L": 4}
    x = next(n for n, k in topo.graph.nodes(data="kind") if k == "X")
    data = topo.graph.nodes[x]
    assert abs(data["cell"][0] - 60) <= 2 and abs(data["cell"][1] - 60) <= 2
    assert data["xy"] == pytest.approx(frame.cell_to_world(*data["cell"]))
    assert data["clearance"] > 0.8
    assert topo.graph.degree(x) == 4
    for _, _, d in topo.graph.edges(data=True):
        assert 1.5 < d["length"] < 2.6 and d["probability"] == pytest.approx(1.0) and d["cost"] == pytest.approx(0.0)


def test_a_tee_is_one_t_and_three_ends() -> None:
    topo = abstract(tee(), frame_for(tee())).topology
    assert topo.kinds() == {"X": 0, "T": 1, "L": 3}


def test_junctions_closer_than_their_clearance_merge_into_a_crossing() -> None:
    def staggered(up: int, down: int) -> np.ndarray:  # a corridor crossed by one whose arms are offset
        p = np.full((160, 160), WALL, dtype=np.float32)
        p[64:96, 4:-4] = 0.0
        p[4:80, up:up + 32] = 0.0
        p[80:-4, down:down + 32] = 0.0
        return p

    near, far = staggered(50, 60), staggered(40, 80)  # 0.5 m apart (less than the clearance), 2 m apart
    for p, kinds in ((near, {"X": 1, "T": 0, "L": 4}), (far, {"X": 0, "T": 2, "L": 4})):
        frame = frame_for(p)
        free = free_space(p)
        dt = distance_transform(free, frame)
        assert trace_skeleton(skeleton(dt, free, 0.2), dt).junctions == 2
        assert abstract(p, frame).topology.kinds() == kinds


def test_spurs_from_bumpy_walls_are_pruned() -> None:
    p = corridor(notches=True)
    frame = frame_for(p)
    free = free_space(p)
    dt = distance_transform(free, frame)
    raw = trace_skeleton(skeleton(dt, free), dt)  # without the robot's clearance: a comb of spurs
    assert raw.junctions > 10
    assert abstract(p, frame).topology.kinds() == {"X": 0, "T": 0, "L": 2}
    assert abstract(p, frame, robot_radius=0.0).topology.kinds() == {"X": 0, "T": 0, "L": 2}


def test_two_rooms_joined_by_a_door_are_two_places_and_the_route_goes_through_the_door() -> None:
    p, door = two_rooms()
    frame = frame_for(p, (10.0, -5.0, 0.0))
    ab = abstract(p, frame)
    topo = ab.topology
    left, right = frame.cell_to_world(50, 45), frame.cell_to_world(50, 135)
    assert ab.places.max() == 2
    assert topo.place_at(left) != topo.place_at(right) and topo.place_at(left) and topo.place_at(right)
    assert ab.places[door].any()
    named = {"lab": left, "office": right}
    assert set(topo.facts(named)) == {("place", "lab"), ("place", "office"), ("connected", "lab", "office")}

    route = topo.route_between_places("lab", "office", named)
    assert route is not None
    assert route.waypoints[0] == pytest.approx(left) and route.waypoints[-1] == pytest.approx(right)
    assert on_free_cells(topo, route.waypoints, ab.free)
    door_cells = {(r, c) for r in range(door[0].start, door[0].stop) for c in range(door[1].start, door[1].stop)}
    assert route_cells(topo, route.waypoints) & door_cells
    assert 4.0 < route.length < 6.0 and route.probability == pytest.approx(1.0)
    # From a corner of one room to a corner of the other: still on free cells, still through the door.
    corner_a, corner_b = frame.cell_to_world(8, 8), frame.cell_to_world(92, 172)
    route = topo.route(corner_a, corner_b)
    assert route is not None and on_free_cells(topo, route.waypoints, ab.free)
    assert route_cells(topo, route.waypoints) & door_cells
    with pytest.raises(KeyError):
        topo.route_between_places("lab", "kitchen", named)


def test_places_are_cut_at_doors_only() -> None:
    p, _ = two_rooms()
    frame = frame_for(p)
    labels = abstract(p, frame).places
    free = free_space(p)
    assert labels.max() == 2 and (labels[free] > 0).all()
    wide = p.copy()
    wide[10:90, 85:91] = 0.0  # the wall mostly gone: one place
    assert abstract(wide, frame).places.max() == 1


def test_an_uncertain_stretch_lowers_the_probability_of_its_edge() -> None:
    p = np.full((100, 240), WALL, dtype=np.float32)
    p[10:42, 4:-4] = 0.001  # a well-known corridor
    p[58:90, 4:-4] = 0.001  # the same corridor ...
    p[58:90, 100:140] = 0.45  # ... with a stretch barely believed free
    p[58:64, 60:80] = np.nan  # and an unknown patch along one wall
    frame = frame_for(p)
    ab = abstract(p, frame)
    edges = sorted(ab.topology.graph.edges(data=True), key=lambda e: ab.topology.graph.nodes[e[0]]["cell"][0])
    assert len(edges) == 2
    certain, uncertain = edges[0][2], edges[1][2]
    assert certain["probability"] > 0.9
    assert uncertain["probability"] < 0.5 * certain["probability"]
    assert uncertain["cost"] == pytest.approx(-math.log(uncertain["probability"]))
    # The stochastic SDT carries the same numbers on its segments and cells.
    assert sorted(s.probability for s in ab.sdt.segments) == pytest.approx(
        sorted([certain["probability"], uncertain["probability"]]))
    grid = ab.sdt.probability_grid()
    assert np.nanmin(grid) == pytest.approx(uncertain["probability"], rel=1e-6)


def test_the_most_probable_way_round_is_chosen_when_the_risk_counts() -> None:
    # A ring corridor round a block: the top branch is shorter but has a doubtful stretch.
    p = np.full((140, 200), WALL, dtype=np.float32)
    p[10:130, 10:190] = 0.001
    p[30:100, 40:160] = WALL
    p[10:30, 90:110] = 0.45
    frame = frame_for(p)
    ab = abstract(p, frame)
    a, b = frame.cell_to_world(50, 25), frame.cell_to_world(50, 175)
    safe = ab.topology.route(a, b)
    short = ab.topology.route(a, b, risk=0.0)
    assert safe is not None and short is not None
    assert short.length < safe.length and safe.probability > 2 * short.probability
    assert max(y for _, y in short.waypoints) > frame.cell_to_world(30, 0)[1]  # over the block
    assert min(y for _, y in safe.waypoints) < frame.cell_to_world(100, 0)[1]  # under it
    for route in (safe, short):
        assert on_free_cells(ab.topology, route.waypoints, ab.free)


def test_json_round_trip_gives_the_same_graph(tmp_path: Path) -> None:
    p, _ = two_rooms()
    topo = abstract(p, frame_for(p, (0.5, 0.25, 0.0))).topology
    topo.name_places({"lab": topo.frame.cell_to_world(50, 45)})
    back = Topology.from_json(topo.to_json(tmp_path / "topo.json"))
    assert back == topo
    assert nx.utils.graphs_equal(back.graph, topo.graph)
    assert back.facts() == topo.facts()
    route = back.route(topo.frame.cell_to_world(50, 45), topo.frame.cell_to_world(50, 135))
    assert route is not None and route.nodes == topo.route(topo.frame.cell_to_world(50, 45),
                                                           topo.frame.cell_to_world(50, 135)).nodes


def test_graphml_is_written_and_read_by_networkx(tmp_path: Path) -> None:
    topo = abstract(plus(), frame_for(plus())).topology
    path = topo.to_graphml(tmp_path / "topo.graphml")
    read = nx.read_graphml(path)
    assert read.number_of_nodes() == 5 and read.number_of_edges() == 4
    kinds = sorted(d["kind"] for _, d in read.nodes(data=True))
    assert kinds == ["L", "L", "L", "L", "X"]
    for _, _, d in read.edges(data=True):
        assert isinstance(d["length"], float) and isinstance(d["cells"], str) and d["probability"] == 1.0


def test_an_empty_map_gives_an_empty_topology() -> None:
    p = np.ones((30, 30), dtype=np.float32)
    ab = abstract(p, frame_for(p))
    assert ab.topology.graph.number_of_nodes() == 0 and ab.places.max() == 0
    assert ab.topology.route((0.5, 0.5), (1.0, 1.0)) is None
    assert ab.topology.facts() == []

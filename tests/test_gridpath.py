"""Paths on occupancy grids (atlas_rap.maps.gridpath) in the lab-corridor-office building and on small grids."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.gridpath import (
    GridPath,
    GridPlanner,
    plan_path,
    shortest_route_length,
    world_occupancy,
)
from atlas_rap.model import Segment
from atlas_rap.sim.world import load_world

LAB_START = (1.5, 1.5)
OFFICE = (16.5, 8.0)


@pytest.fixture(scope="module")
def world():
    return load_world("lab-corridor-office")


@pytest.fixture(scope="module")
def true_map(world):
    return world_occupancy(world)


@pytest.fixture(scope="module")
def planner(world, true_map):
    p_occ, frame = true_map
    return GridPlanner(p_occ, frame, world.robot.radius)


def with_doors(world, **open_doors: bool):
    """``world`` with some doors opened or closed."""
    doors = dict(world.doors)
    for name, is_open in open_doors.items():
        doors[name.replace("_", "-")] = replace(doors[name.replace("_", "-")], open=is_open)
    return replace(world, doors=doors)


def crossings(path: GridPath, axis: int, value: float) -> list[float]:
    """The other coordinate where legs of ``path`` cross the line ``x = value`` (axis 0) or ``y = value`` (axis 1)."""
    found = []
    for p, q in zip(path.waypoints, path.waypoints[1:]):
        if (p[axis] - value) * (q[axis] - value) < 0:
            t = (value - p[axis]) / (q[axis] - p[axis])
            found.append(p[1 - axis] + t * (q[1 - axis] - p[1 - axis]))
    return found


def crosses(path: GridPath, axis: int, value: float, low: float, high: float) -> bool:
    return any(low < v < high for v in crossings(path, axis, value))


def wall_clearance(path: GridPath, p_occ: np.ndarray, frame: GridFrame) -> float:
    """Smallest distance from points along the legs (every 1 cm) to an occupied cell's square."""
    rows, cols = np.nonzero(p_occ > 0.5)
    cx, cy = frame.cell_to_world(rows, cols)
    half = frame.resolution / 2
    points = []
    for p, q in zip(path.waypoints, path.waypoints[1:]):
        n = max(2, int(math.dist(p, q) / 0.01) + 1)
        t = np.linspace(0.0, 1.0, n)[:, None]
        points.append(np.asarray(p) + t * (np.asarray(q) - np.asarray(p)))
    pts = np.vstack(points)
    dx = np.maximum(np.abs(pts[:, 0:1] - cx[None, :]) - half, 0.0)
    dy = np.maximum(np.abs(pts[:, 1:2] - cy[None, :]) - half, 0.0)
    return float(np.hypot(dx, dy).min())


# -- the true map ---------------------------------------------------------------------------

def test_world_occupancy_rasterises_walls_and_closed_doors_only(world, true_map) -> None:
    p_occ, frame = true_map
    assert frame.shape == (240, 440) and frame.resolution == 0.05
    assert set(np.unique(p_occ)) == {0.0, 1.0}
    assert p_occ[frame.world_to_cell(3.0, 4.0)] == 1.0  # the lab | corridor wall
    assert p_occ[frame.world_to_cell(6.5, 4.0)] == 0.0  # the open lab-door
    closed, _ = world_occupancy(load_world("lab-corridor-office-door-closed"))
    assert closed[frame.world_to_cell(16.5, 6.0)] == 1.0  # office-door shut
    assert p_occ[frame.world_to_cell(16.5, 6.0)] == 0.0


def test_lab_to_office_goes_through_the_doorways_and_keeps_off_walls(world, true_map, planner) -> None:
    p_occ, frame = true_map
    path = planner.plan(LAB_START, OFFICE)
    assert path is not None
    assert path.waypoints[0] == LAB_START and path.waypoints[-1] == OFFICE
    assert crosses(path, 1, 4.0, 6.0, 7.0)  # through the lab-door gap
    # With every door open, the storeroom way (storeroom-door, then storeroom-office-door) is the shorter one.
    assert crosses(path, 1, 6.0, 10.0, 11.0) and crosses(path, 0, 13.0, 7.5, 8.5)
    assert len(crossings(path, 1, 4.0)) == 1 and len(crossings(path, 1, 6.0)) == 1
    assert wall_clearance(path, p_occ, frame) >= world.robot.radius
    assert 2 < len(path.waypoints) < 15
    assert path.unknown_share == 0.0
    legs = sum(math.dist(p, q) for p, q in zip(path.waypoints, path.waypoints[1:]))
    assert path.length == pytest.approx(legs)


def test_with_the_storeroom_shut_the_path_takes_the_office_door(world) -> None:
    shut = with_doors(world, storeroom_door=False)
    p_occ, frame = world_occupancy(shut)
    path = plan_path(p_occ, frame, LAB_START, OFFICE, world.robot.radius)
    assert path is not None
    assert crosses(path, 1, 4.0, 6.0, 7.0)  # lab-door gap
    assert crosses(path, 1, 6.0, 16.0, 17.0)  # office-door gap
    assert not crosses(path, 0, 13.0, 6.0, 10.0)  # not through the storeroom
    assert wall_clearance(path, p_occ, frame) >= world.robot.radius
    assert len(path.waypoints) < 15


def test_with_the_office_door_closed_the_path_goes_round_by_the_storeroom() -> None:
    closed = load_world("lab-corridor-office-door-closed")
    p_occ, frame = world_occupancy(closed)
    path = plan_path(p_occ, frame, LAB_START, OFFICE, closed.robot.radius)
    assert path is not None
    assert not crosses(path, 1, 6.0, 16.0, 17.0)
    assert crosses(path, 1, 6.0, 10.0, 11.0) and crosses(path, 0, 13.0, 7.5, 8.5)
    assert wall_clearance(path, p_occ, frame) >= closed.robot.radius


# -- unknown cells ------------------------------------------------------------------------------

def test_an_unknown_grid_gives_the_straight_line_all_through_the_unknown(true_map) -> None:
    _, frame = true_map
    path = plan_path(np.full(frame.shape, np.nan), frame, LAB_START, OFFICE, 0.2)
    assert path is not None
    assert path.waypoints == (LAB_START, OFFICE)
    assert path.length == pytest.approx(math.dist(LAB_START, OFFICE))
    assert path.unknown_share == pytest.approx(1.0)


def test_the_known_mask_decides_what_is_unknown(true_map) -> None:
    _, frame = true_map
    prior = np.full(frame.shape, 0.5)
    unseen = plan_path(prior, frame, LAB_START, OFFICE, 0.2, known=np.zeros(frame.shape, dtype=bool))
    seen = plan_path(prior, frame, LAB_START, OFFICE, 0.2, known=np.ones(frame.shape, dtype=bool))
    assert unseen is not None and seen is not None
    assert unseen.unknown_share == pytest.approx(1.0)
    assert seen.unknown_share == 0.0
    assert seen.waypoints == unseen.waypoints == (LAB_START, OFFICE)


def test_known_free_space_is_not_cut_short_through_the_unknown() -> None:
    # A known free L-shaped corridor in an unknown square: the path follows the corridor round its corner
    # (cheaper than the unknown), and the simplified path does not cut the corner through the unknown.
    frame = GridFrame(100, 100, 0.05)  # 5 m x 5 m
    p_occ = np.full(frame.shape, np.nan)
    p_occ[80:100, 0:100] = 0.0  # bottom strip, y 0..1
    p_occ[0:100, 80:100] = 0.0  # right strip, x 4..5
    planner = GridPlanner(p_occ, frame, 0.2)
    path = planner.plan((0.5, 0.5), (4.5, 4.5))
    assert path is not None
    assert path.unknown_share == 0.0  # every leg, sampled every half cell, stays on known cells
    assert len(path.waypoints) >= 3


def test_downsampling_is_conservative() -> None:
    frame = GridFrame(40, 40, 0.05)
    p_occ = np.full(frame.shape, np.nan)
    p_occ[10, 10] = 1.0  # one occupied fine cell ...
    p_occ[30, 31] = 0.0  # ... and one known free fine cell
    planner = GridPlanner(p_occ, frame, 0.0, resolution=0.1, clearance_cost=0.0)
    assert planner.frame.shape == (20, 20) and planner.frame.resolution == pytest.approx(0.1)
    assert planner.impassable[5, 5] and planner.impassable.sum() == 1
    assert not planner.unknown[5, 5] and not planner.unknown[15, 15] and planner.unknown.sum() == 398


# -- no way through ------------------------------------------------------------------------------

def test_a_wall_across_the_building_leaves_no_path(true_map) -> None:
    p_occ, frame = true_map
    cut = p_occ.copy()
    cut[:, frame.world_to_cell(9.0, 0.0)[1]] = 1.0  # one fine cell thick, top to bottom
    assert plan_path(cut, frame, LAB_START, OFFICE, 0.2) is None


def test_a_gap_narrower_than_the_robot_leaves_no_path() -> None:
    frame = GridFrame(100, 100, 0.05)
    p_occ = np.zeros(frame.shape)
    col = frame.world_to_cell(2.5, 0.0)[1]
    p_occ[:, col] = 1.0
    narrow = p_occ.copy()
    narrow[40:46, col] = 0.0  # 0.3 m: less than the robot's diameter
    wide = p_occ.copy()
    wide[40:60, col] = 0.0  # 1 m
    assert plan_path(narrow, frame, (1.0, 2.5), (4.0, 2.5), 0.2) is None
    path = plan_path(wide, frame, (1.0, 2.5), (4.0, 2.5), 0.2)
    assert path is not None and wall_clearance(path, wide, frame) >= 0.2


# -- start and goal -----------------------------------------------------------------------------

def test_a_start_in_a_wall_is_moved_out_within_0_6_m(world, true_map, planner) -> None:
    p_occ, frame = true_map
    start = (3.0, 4.0)  # on the lab | corridor wall
    path = planner.plan(start, (4.0, 2.0))
    assert path is not None
    moved = path.waypoints[0]
    assert moved != start and math.dist(moved, start) <= 0.6
    assert abs(moved[1] - 4.0) >= world.robot.radius  # clear of the wall, on one side or the other
    assert not planner.blocked(path)
    assert wall_clearance(path, p_occ, frame) >= world.robot.radius


def test_a_start_deep_inside_an_obstacle_gives_no_path(true_map) -> None:
    p_occ, frame = true_map
    solid = p_occ.copy()
    r0, c0 = frame.world_to_cell(0.5, 3.0)
    r1, c1 = frame.world_to_cell(3.5, 0.0)
    solid[r0:r1 + 1, c0:c1 + 1] = 1.0  # a block from x 0.5 to 3.5, y 0 to 3 in the lab
    assert plan_path(solid, frame, (2.0, 1.5), (5.0, 2.0), 0.2) is None
    assert plan_path(solid, frame, (5.0, 2.0), (2.0, 1.5), 0.2) is None  # nor a goal


# -- replanning ---------------------------------------------------------------------------------

def test_blocked_sees_a_new_obstacle_across_the_path(world, true_map, planner) -> None:
    p_occ, frame = true_map
    path = planner.plan(LAB_START, OFFICE)
    assert path is not None and not planner.blocked(path)
    boxed = p_occ.copy()
    r0, c0 = frame.world_to_cell(9.6, 7.0)
    r1, c1 = frame.world_to_cell(11.4, 6.2)
    boxed[r0:r1 + 1, c0:c1 + 1] = 1.0  # a crate just inside the storeroom-door
    again = GridPlanner(boxed, frame, world.robot.radius)
    assert again.blocked(path)
    detour = again.plan(LAB_START, OFFICE)
    assert detour is not None and not again.blocked(detour)
    assert crosses(detour, 1, 6.0, 16.0, 17.0)  # round by the office door
    assert detour.length > path.length


def test_planning_is_deterministic_and_repeatable(world, true_map, planner) -> None:
    p_occ, frame = true_map
    first = planner.plan(LAB_START, OFFICE)
    planner.plan((4.0, 2.0), (10.0, 5.0))  # another plan in between on the same planner
    assert planner.plan(LAB_START, OFFICE) == first
    assert plan_path(p_occ, frame, LAB_START, OFFICE, world.robot.radius) == first


# -- the shortest route -------------------------------------------------------------------------

def test_shortest_route_length_bounds_the_planned_path(world, planner) -> None:
    straight = math.dist(LAB_START, OFFICE)
    shortest = shortest_route_length(world, LAB_START, OFFICE)
    path = planner.plan(LAB_START, OFFICE)
    assert path is not None
    assert straight < shortest < 1.3 * straight
    assert shortest <= path.length + planner.frame.resolution


def test_shortest_route_length_is_inf_when_the_goal_cannot_be_reached(world) -> None:
    cut = replace(world, walls=world.walls + (Segment((9.0, -1.0), (9.0, 11.0)),))
    assert shortest_route_length(cut, LAB_START, OFFICE) == math.inf
    assert math.isfinite(shortest_route_length(cut, LAB_START, (4.0, 2.0)))


def test_a_track_the_robot_drove_is_passable_though_the_map_closed_it() -> None:
    # A wall across a 5 m square with a 0.3 m gap, narrower than the robot: no way, until the
    # robot's own track through the gap is given (a sonar map can close a doorway behind it).
    frame = GridFrame(100, 100, 0.05)
    p_occ = np.zeros(frame.shape)
    col = frame.world_to_cell(2.5, 0.0)[1]
    p_occ[:, col] = 1.0
    p_occ[50:56, col] = 0.0
    start, goal = (1.0, 2.3), (4.0, 2.3)
    assert plan_path(p_occ, frame, start, goal, 0.2) is None
    track = [(1.5, 2.35), (2.5, 2.35), (3.5, 2.35)]
    path = GridPlanner(p_occ, frame, 0.2, tracks=[track]).plan(start, goal)
    assert path is not None
    assert [2.0 < y < 2.7 for y in crossings(path, 0, 2.5)] == [True]  # through the gap, once
    elsewhere = [(0.5, 4.0), (2.0, 4.0)]  # a track that never went through the wall opens nothing
    assert GridPlanner(p_occ, frame, 0.2, tracks=[elsewhere]).plan(start, goal) is None
    # the cells an earlier run's centre passed over (OccupancyGrid.driven) open the gap the same way
    driven = np.zeros(frame.shape, dtype=bool)
    row = frame.world_to_cell(0.0, 2.35)[0]
    driven[row - 2:row + 3, col - 20:col + 21] = True
    path = GridPlanner(p_occ, frame, 0.2, driven=driven).plan(start, goal)
    assert path is not None and [2.0 < y < 2.7 for y in crossings(path, 0, 2.5)] == [True]
    short_of_the_wall = np.zeros(frame.shape, dtype=bool)
    short_of_the_wall[row - 2:row + 3, col - 20:col - 5] = True
    assert GridPlanner(p_occ, frame, 0.2, driven=short_of_the_wall).plan(start, goal) is None
    with pytest.raises(ValueError, match="driven has shape"):
        GridPlanner(p_occ, frame, 0.2, driven=driven[1:])

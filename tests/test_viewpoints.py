"""Where Layer IV looks next (atlas_rap.maps.viewpoints) on small grids, and GridPlanner.costs_from."""

from __future__ import annotations

import math

import numpy as np
import pytest

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.maps.gridpath import GridPlanner
from atlas_rap.maps.viewpoints import VIEW_RADIUS, best_viewpoint, information_gain

FREE, OCCUPIED = -8.0, 8.0  # log-odds of cells the sonar has settled


def grid_of(log_odds: np.ndarray, seen: np.ndarray) -> OccupancyGrid:
    """A 0.05 m grid with the given log-odds, ``seen`` marking the cells ever updated."""
    height, width = log_odds.shape
    grid = OccupancyGrid(GridFrame(height, width, 0.05))
    grid.log_odds = log_odds.astype(np.float32)
    grid.updated[...] = seen
    return grid


def planner_for(grid: OccupancyGrid) -> GridPlanner:
    return GridPlanner.from_grid(grid, 0.2)


def corridor_and_unknown_room() -> OccupancyGrid:
    """A 12 m x 4 m floor: the west 6 m seen and free, the east 6 m never seen."""
    log_odds = np.zeros((80, 240))
    seen = np.zeros(log_odds.shape, dtype=bool)
    log_odds[:, :120], seen[:, :120] = FREE, True
    return grid_of(log_odds, seen)


def test_the_gain_of_a_spot_is_the_unsure_area_round_it_in_square_metres() -> None:
    grid = corridor_and_unknown_room()
    area = np.ones(grid.frame.shape, dtype=bool)
    gain = information_gain(grid, area)
    r, c = grid.frame.world_to_cell(9.0, 2.0)  # deep in the unknown, 3 m from what was seen
    disc = math.pi * VIEW_RADIUS ** 2
    # the floor is 4 m high: the disc round y = 2 is cut by its edges 2 m away, above and below
    assert gain[r, c] == pytest.approx(disc - 2 * _segment(VIEW_RADIUS, 2.0), rel=0.03)
    r, c = grid.frame.world_to_cell(1.0, 2.0)  # well inside the settled part
    assert gain[r, c] == pytest.approx(0.0, abs=0.1)


def _segment(radius: float, distance: float) -> float:
    """The area of the part of a disc of ``radius`` beyond a line ``distance`` from its centre."""
    return radius ** 2 * math.acos(distance / radius) - distance * math.sqrt(radius ** 2 - distance ** 2)


def test_only_the_area_counts() -> None:
    grid = corridor_and_unknown_room()
    area = np.zeros(grid.frame.shape, dtype=bool)
    area[:, :120] = True  # the area is the settled half only
    assert information_gain(grid, area).max() == pytest.approx(0.0, abs=0.1)
    assert best_viewpoint(grid, area, planner_for(grid), (1.0, 2.0)) is None


def test_the_viewpoint_is_on_known_free_ground_at_the_edge_of_the_unknown() -> None:
    grid = corridor_and_unknown_room()
    area = np.ones(grid.frame.shape, dtype=bool)
    found = best_viewpoint(grid, area, planner_for(grid), (1.0, 2.0))
    assert found is not None
    (x, y), gain = found
    assert 5.0 <= x <= 6.0  # as far east as the known ground goes, facing the unknown half
    assert 0.0 < y < 4.0
    assert gain >= 5.0  # square metres of the unknown half within 2.5 m


def test_a_spot_the_robot_cannot_reach_is_never_chosen() -> None:
    # A wall across the settled half at x = 3 m, the robot west of it: the unknown east half is
    # within 2.5 m only of ground east of the wall, which the robot cannot get to.
    grid = corridor_and_unknown_room()
    grid.log_odds[:, 58:62] = OCCUPIED
    area = np.ones(grid.frame.shape, dtype=bool)
    planner = planner_for(grid)
    assert best_viewpoint(grid, area, planner, (1.0, 2.0)) is None
    assert best_viewpoint(grid, area, planner, (4.5, 2.0)) is not None  # from the east side it can
    costs = planner.costs_from((1.0, 2.0))
    r, c = planner.frame.world_to_cell(4.5, 2.0)
    assert costs is not None and math.isinf(costs[r, c])
    r, c = planner.frame.world_to_cell(2.0, 2.0)
    assert math.isfinite(costs[r, c])


def test_costs_from_a_start_nowhere_near_passable_ground_is_none() -> None:
    log_odds = np.full((40, 40), OCCUPIED)
    grid = grid_of(log_odds, np.ones(log_odds.shape, dtype=bool))
    assert planner_for(grid).costs_from((1.0, 1.0)) is None

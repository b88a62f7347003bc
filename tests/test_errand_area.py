"""The area an errand needs (maps.errand_area): the fixed region the experiment measures map quality over."""

from __future__ import annotations

import numpy as np
import pytest

from atlas_rap.layers.monitoring import MonitoringLayer
from atlas_rap.layers.operational import OperationalLayer
from atlas_rap.layers.strategic import GRID_RESOLUTION, StrategicLayer
from atlas_rap.layers.tactical import TacticalLayer
from atlas_rap.maps.errand_area import errand_area
from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.maps.gridpath import GridPlanner, world_occupancy
from atlas_rap.sim.world import load_world


@pytest.fixture(scope="module")
def lab():
    world = load_world("lab-corridor-office")
    frame = GridFrame.covering(world.bounds, GRID_RESOLUTION)
    return world, frame, errand_area(world, frame, ["office", "lab"])


def cell(frame: GridFrame, x: float, y: float) -> tuple[int, int]:
    row, col = frame.world_to_cell(x, y)
    return int(row), int(col)


def test_the_area_takes_in_the_whole_shortest_route_and_the_rooms_it_passes(lab):
    world, frame, area = lab
    truth, _ = world_occupancy(world, frame.resolution)
    planner = GridPlanner(truth, frame, world.robot.radius, resolution=frame.resolution, clearance_cost=0.0)
    path = planner.plan(world.robot.start[:2], world.places["office"].point)
    for x, y in path.waypoints:
        assert area[cell(frame, x, y)], (x, y)
    for room in ("lab", "corridor", "office"):  # far corners of the rooms on the way, not only the route
        xs, ys = zip(*world.places[room].region)
        assert area[cell(frame, min(xs) + 0.3, min(ys) + 0.3)], room
        assert area[cell(frame, max(xs) - 0.3, max(ys) - 0.3)], room


def test_the_area_stops_at_the_walls_round_it(lab):
    world, frame, area = lab
    assert area[cell(frame, 3.0, 0.02)]  # the lab's south wall is in it (the structure the map needs)
    assert not area[cell(frame, 3.0, -0.3)]  # beyond it is not
    assert not area[cell(frame, 14.0, 2.0)]  # outside the building, south of the corridor
    assert area.sum() * frame.resolution ** 2 < 1.1 * 120.0  # the building's floor is 120 m^2, and the walls


def test_rooms_the_errand_does_not_pass_are_left_out():
    world = load_world("lab-corridor-office")
    frame = GridFrame.covering(world.bounds, GRID_RESOLUTION)
    to_corridor = errand_area(world, frame, ["corridor"])
    assert to_corridor[cell(frame, 4.0, 2.0)] and to_corridor[cell(frame, 18.0, 5.0)]
    assert not to_corridor[cell(frame, 18.0, 9.0)]  # the office is not on the way from the lab to the corridor


def test_the_area_is_the_same_whatever_the_run(lab):
    world, frame, area = lab
    assert np.array_equal(area, errand_area(world, frame, ["office", "lab"]))


def test_an_unknown_stop_or_a_foreign_frame_is_a_clear_error(lab):
    world, frame, _ = lab
    with pytest.raises(ValueError, match="no place named kitchen"):
        errand_area(world, frame, ["kitchen"])
    with pytest.raises(ValueError, match="own frame"):
        errand_area(world, GridFrame.covering((0, 0, 5, 5), 0.05), ["office"])


def test_a_map_of_the_area_scores_by_what_is_known_of_it(lab):
    world, frame, area = lab
    grid = OccupancyGrid.covering(world.bounds, GRID_RESOLUTION)
    assert grid.quality(area) == pytest.approx(0.0)  # all unknown: one bit of entropy a cell
    truth, _ = world_occupancy(world, frame.resolution)
    grid.log_odds[...] = np.where(truth > 0.5, 7.0, -7.0)  # every cell known as it truly is
    grid.updated[...] = True
    assert grid.quality(area) > 0.98


def test_each_layer_above_is_slower_than_the_one_below():
    """Seed 000 Fig. 2: a multirate system, the slowest layer on top."""
    periods = [layer.period for layer in (MonitoringLayer, OperationalLayer, TacticalLayer, StrategicLayer)]
    assert periods == sorted(periods) and len(set(periods)) == 4, periods

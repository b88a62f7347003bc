"""Occupancy grids from sonar (seed §3.2) and inference grids (§3.3): the update, convergence, files, reachability."""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest
from scipy import ndimage
from skimage.draw import line

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.grid import OccupancyGrid, SonarModel, binary_entropy
from atlas_rap.maps.inference import InferenceGrid
from atlas_rap.maps.rosmap import FREE, OCCUPIED, UNKNOWN, load_ros_map
from atlas_rap.model import SonarConfig
from atlas_rap.sim.physics import Simulation
from atlas_rap.sim.world import load_world
from atlas_rap.skills.scripted import drive_waypoints, there_and_back

SONAR = SonarConfig()
RADIUS = 0.2


def p_at(grid: OccupancyGrid, x: float, y: float) -> float:
    row, col = grid.frame.world_to_cell(x, y)
    return float(grid.probabilities()[row, col])


# -- one reading ---------------------------------------------------------------------------


def test_a_reading_lowers_p_in_its_cone_and_raises_it_at_the_echo() -> None:
    grid = OccupancyGrid.covering((0.0, 0.0, 6.0, 6.0))
    # robot at (1, 3) facing +x: the transducer is on the rim at x = 1.2, the echo 2 m further, at x = 3.2
    touched = grid.update_sonar(1.0, 3.0, 0.0, 2.0, 0.0, RADIUS, SONAR)
    assert touched > 0 and grid.cells_updated == touched
    for x in (1.3, 2.0, 2.9):
        assert p_at(grid, x, 3.0) < 0.5  # the empty cone
    assert p_at(grid, 3.21, 3.0) > 0.5  # the occupied arc
    assert p_at(grid, 3.21, 3.2) > 0.5  # ... across the beam (at 7.5 degrees off the axis: 0.26 m)
    assert p_at(grid, 3.6, 3.0) == 0.5  # behind the echo: nothing
    assert p_at(grid, 2.0, 3.6) == 0.5  # outside the cone: nothing
    assert p_at(grid, 0.5, 3.0) == 0.5  # behind the transducer
    # the same reading again and again: the cone empties fast; the arc rises slowly, since from one place
    # the echo could have come from any of its cells (other viewpoints' empty cones tell which)
    echo = [p_at(grid, 3.21, 3.0)]
    for _ in range(9):
        grid.update_sonar(1.0, 3.0, 0.0, 2.0, 0.0, RADIUS, SONAR)
        echo.append(p_at(grid, 3.21, 3.0))
    assert p_at(grid, 2.0, 3.0) < 0.01
    assert all(a < b for a, b in pairwise(echo)) and echo[-1] > 0.65
    assert 0 < grid.quality() < 1


def test_the_cone_follows_heading_and_transducer_angle() -> None:
    grid = OccupancyGrid.covering((0.0, 0.0, 6.0, 6.0))
    # heading 90 degrees, transducer at 90 degrees on the body: the beam points along -x
    grid.update_sonar(4.0, 3.0, math.pi / 2, [1.5], [math.pi / 2], RADIUS, SONAR)
    assert p_at(grid, 3.0, 3.0) < 0.5
    assert p_at(grid, 4.0 - RADIUS - 1.5 - 0.01, 3.0) > 0.5
    assert p_at(grid, 5.0, 3.0) == 0.5 and p_at(grid, 4.0, 4.0) == 0.5


def test_a_rotated_grid_puts_the_cone_where_the_world_has_it() -> None:
    grid = OccupancyGrid(GridFrame(80, 80, 0.05, (4.0, 0.0, math.pi / 2)))  # x along world +y, y along world -x
    assert grid.frame.extent == pytest.approx((0.0, 0.0, 4.0, 4.0))
    grid.update_sonar(1.0, 2.0, 0.0, 2.0, 0.0, RADIUS, SONAR)
    assert p_at(grid, 2.0, 2.0) < 0.5 and p_at(grid, 3.21, 2.0) > 0.5
    assert p_at(grid, 2.0, 2.6) == 0.5


def test_a_max_range_reading_empties_the_near_cone_and_adds_no_occupied_arc() -> None:
    model = SonarModel()
    grid = OccupancyGrid.covering((0.0, 0.0, 8.0, 4.0))
    grid.update_sonar(1.0, 2.0, 0.0, SONAR.max_range, 0.0, RADIUS, SONAR)
    p = grid.probabilities()
    assert (p <= 0.5).all()  # no arc anywhere
    assert p_at(grid, 1.5, 2.0) < 0.5
    end = 1.0 + RADIUS + model.max_range_fraction * SONAR.max_range
    assert p_at(grid, end + 0.1, 2.0) == 0.5  # only up to max_range_fraction of the range
    assert p_at(grid, 1.0 + RADIUS + SONAR.max_range, 2.0) == 0.5
    # a max-range reading is weaker evidence than an echo from further away
    echo = OccupancyGrid.covering((0.0, 0.0, 8.0, 4.0))
    echo.update_sonar(1.0, 2.0, 0.0, 4.0, 0.0, RADIUS, SONAR)
    assert p_at(echo, 1.5, 2.0) < p_at(grid, 1.5, 2.0)


def test_a_whole_ring_at_once_equals_its_beams_empty_cones_and_counts_cells() -> None:
    angles = np.arange(16) * (2 * math.pi / 16)
    ranges = np.full(16, 1.0)
    grid = OccupancyGrid.covering((0.0, 0.0, 6.0, 6.0))
    touched = grid.update_sonar(3.0, 3.0, 0.3, ranges, angles, RADIUS, SONAR)
    assert touched == grid.cells_updated > 16 * 50
    p = grid.probabilities()
    assert (p < 0.5).sum() > 16 * 20 and (p > 0.5).sum() > 16 * 5
    for a in angles:  # every beam emptied its cone and found its echo
        assert p_at(grid, 3.0 + 0.7 * math.cos(a + 0.3), 3.0 + 0.7 * math.sin(a + 0.3)) < 0.5
        assert p_at(grid, 3.0 + 1.2 * math.cos(a + 0.3), 3.0 + 1.2 * math.sin(a + 0.3)) > 0.5
    with pytest.raises(ValueError):
        grid.update_sonar(3.0, 3.0, 0.0, [1.0, 2.0], [0.0], RADIUS, SONAR)


def test_a_transducer_off_the_map_updates_only_the_cells_on_it() -> None:
    grid = OccupancyGrid.covering((0.0, 0.0, 4.0, 4.0))
    grid.update_sonar(-1.0, 2.0, 0.0, 2.0, 0.0, RADIUS, SONAR)  # from outside, looking in
    assert p_at(grid, 0.5, 2.0) < 0.5 and p_at(grid, 1.21, 2.0) > 0.5
    grid.update_sonar(2.0, -3.0, 0.0, 1.0, 0.0, RADIUS, SONAR)  # nowhere near: nothing
    assert grid.updated.sum() > 0


def test_log_odds_are_clamped_but_quality_can_reach_one() -> None:
    grid = OccupancyGrid.covering((0.0, 0.0, 4.0, 4.0))
    for _ in range(30):
        grid.update_sonar(0.5, 2.0, 0.0, 2.0, 0.0, RADIUS, SONAR)
    assert grid.log_odds.min() >= -grid.model.clamp and grid.log_odds.max() <= grid.model.clamp
    assert grid.log_odds.min() == pytest.approx(-10.0)
    assert binary_entropy(np.array([0.5, 0.0, 1.0])).tolist() == [1.0, 0.0, 0.0]
    grid.log_odds = np.where(grid.updated, 10.0, 0.0)
    assert grid.quality() > 0.999
    assert OccupancyGrid.covering((0.0, 0.0, 1.0, 1.0)).quality() == 0.0  # nothing known


def test_labels_probabilities_and_entropy() -> None:
    grid = OccupancyGrid(GridFrame(1, 4, 0.1))
    grid.log_odds = np.array([[-3.0, 0.0, 0.5, 3.0]])
    assert grid.probabilities().dtype == np.float32
    assert grid.labels().tolist() == [[FREE, UNKNOWN, UNKNOWN, OCCUPIED]]
    assert grid.labels(occupied=0.6, free=0.4).tolist() == [[FREE, UNKNOWN, OCCUPIED, OCCUPIED]]
    assert grid.labels().dtype == np.int8
    entropy = grid.entropy()
    assert entropy[0, 1] == pytest.approx(1.0)
    assert entropy[0, 0] == pytest.approx(entropy[0, 3]) and entropy[0, 0] < 0.3
    assert grid.quality(np.array([[False, True, False, False]])) == pytest.approx(0.0, abs=1e-6)


# -- files -----------------------------------------------------------------------------------


def sample_grid() -> OccupancyGrid:
    grid = OccupancyGrid.covering((-1.0, -0.5, 5.0, 3.5))
    angles = np.arange(16) * (2 * math.pi / 16)
    rng = np.random.default_rng(3)
    for x in np.linspace(0.5, 3.5, 8):
        grid.update_sonar(x, 1.5, 0.2, rng.uniform(0.3, 5.0, 16), angles, RADIUS, SONAR)
    return grid


def test_npz_round_trip(tmp_path) -> None:
    grid = sample_grid()
    path = grid.save_npz(tmp_path / "grid.npz")
    back = OccupancyGrid.load_npz(path)
    assert back.frame == grid.frame and back.model == grid.model
    assert np.array_equal(back.log_odds, grid.log_odds) and back.log_odds.dtype == np.float32
    assert np.array_equal(back.updated, grid.updated)
    assert back.quality() == grid.quality()
    assert back.run_qualities == [] == grid.run_qualities
    assert not back.driven.any()
    grid.mark_driven(1.0, 1.0, 0.1)  # the robot's centre passed (1, 1): a disc of 0.1 m round it
    row, col = grid.frame.world_to_cell(1.0, 1.0)
    assert grid.driven[row, col] and grid.driven[row, col + 2] and not grid.driven[row, col + 3]
    assert np.array_equal(OccupancyGrid.load_npz(grid.save_npz(tmp_path / "driven.npz")).driven, grid.driven)
    grid.run_qualities = [0.0, 0.841, 0.874]  # what the runs that carried it measured as they began
    assert OccupancyGrid.load_npz(grid.save_npz(tmp_path / "carried.npz")).run_qualities == [0.0, 0.841, 0.874]
    assert back.survey is None  # Layer IV's survey (atlas_rap.maps.survey) is carried when there is one
    grid.survey = sample_grid()
    grid.survey.log_odds = grid.survey.log_odds / 3
    surveyed = OccupancyGrid.load_npz(grid.save_npz(tmp_path / "surveyed.npz")).survey
    assert np.array_equal(surveyed.log_odds, grid.survey.log_odds) and np.array_equal(surveyed.updated, grid.updated)
    assert surveyed.quality() < grid.quality() and surveyed.frame == grid.frame
    with np.load(tmp_path / "surveyed.npz") as data:  # half a survey is no grid
        np.savez_compressed(tmp_path / "half.npz", **{k: data[k] for k in data.files if k != "survey_updated"})
    with pytest.raises(ValueError, match="needs both survey_log_odds and survey_updated"):
        OccupancyGrid.load_npz(tmp_path / "half.npz")
    # the abstraction levels' layout: frame and p_occ (what `atlas map render` reads)
    with np.load(path) as data:
        assert data["frame"].tolist() == [grid.frame.height, grid.frame.width, 0.05, -1.0, -0.5, 0.0]
        np.savez_compressed(tmp_path / "levels.npz", frame=data["frame"], p_occ=data["p_occ"])
    levels = OccupancyGrid.load_npz(tmp_path / "levels.npz")
    assert levels.run_qualities == [] and not levels.driven.any()  # a file without them
    assert np.allclose(levels.probabilities(), grid.probabilities(), atol=1e-6)
    assert np.array_equal(levels.labels(), grid.labels())


def test_a_contact_is_marked_occupied_as_surely_as_the_clamp_allows() -> None:
    grid = sample_grid()
    row, col = grid.frame.world_to_cell(1.0, 1.0)
    grid.mark_contact(1.0, 1.0)
    assert grid.log_odds[row, col] == grid.model.clamp and grid.updated[row, col]
    assert grid.log_odds[row, col + 1] < grid.model.clamp  # the one cell the body touched
    before = grid.log_odds.copy()
    grid.mark_contact(-50.0, -50.0)  # off the map: nothing
    assert np.array_equal(grid.log_odds, before)


def test_ros_map_round_trip_gives_the_same_labels(tmp_path) -> None:
    grid = sample_grid()
    labels = grid.labels()
    assert {FREE, OCCUPIED, UNKNOWN} <= set(np.unique(labels).tolist())
    grid.to_ros_map(tmp_path / "map.yaml")
    rosmap = load_ros_map(tmp_path / "map.yaml")
    assert rosmap.frame == grid.frame
    assert np.array_equal(rosmap.labels, labels)
    # and back into a grid: the same labels, unknown cells at the prior
    again = OccupancyGrid.from_ros_map(rosmap)
    assert np.array_equal(again.labels(), labels)
    assert np.all(again.log_odds[np.isnan(rosmap.occupancy)] == 0.0)
    known = labels != UNKNOWN  # to within a grey level (and one more where a threshold was near)
    assert np.allclose(again.probabilities()[known], grid.probabilities()[known], atol=1.01 / 255)
    # other thresholds: the YAML says them, and the labels still agree
    grid.to_ros_map(tmp_path / "strict.yaml", occupied=0.9, free=0.1, image_format="png")
    assert np.array_equal(load_ros_map(tmp_path / "strict.yaml").labels, grid.labels(0.9, 0.1))


# -- inference grid: reachability and observability -----------------------------------------


def two_rooms(door: float | None) -> OccupancyGrid:
    """Two 3 m x 3 m rooms side by side, known empty, split by a one-cell wall with a door ``door`` metres wide."""
    grid = OccupancyGrid(GridFrame(60, 120, 0.05))
    lo = np.full(grid.shape, -5.0, dtype=np.float32)
    lo[:, 60] = 5.0  # the wall between the rooms
    lo[0, :] = lo[-1, :] = lo[:, 0] = lo[:, -1] = 5.0  # the outer walls
    if door:
        cells = round(door / 0.05)
        lo[30 - cells // 2:30 - cells // 2 + cells, 60] = -5.0
    grid.log_odds = lo
    return grid


def test_reachable_does_not_leak_through_walls() -> None:
    closed = InferenceGrid(two_rooms(None), (1.5, 1.5), RADIUS, 5.0)
    assert closed.reachable[30, 30] and not closed.reachable[30, 90]
    assert not closed.reachable[:, 60:].any()
    # the robot's centre stays a radius from the walls: erosion by the robot's disc
    assert not closed.reachable[30, 1:4].any() and closed.reachable[30, 5]
    # a door the robot fits through joins the rooms; one it does not fit through does not
    assert InferenceGrid(two_rooms(1.0), (1.5, 1.5), RADIUS, 5.0).reachable[30, 90]
    assert not InferenceGrid(two_rooms(0.3), (1.5, 1.5), RADIUS, 5.0).reachable[30, 90]
    # a diagonal wall of one cell: its cells touch only at corners, and that is no way through
    grid = OccupancyGrid(GridFrame(40, 40, 0.05))
    lo = np.full(grid.shape, -5.0, dtype=np.float32)
    rr, cc = line(0, 0, 39, 39)
    lo[rr, cc] = 5.0
    grid.log_odds = lo
    point = InferenceGrid(grid, grid.frame.cell_to_world(30, 5), 0.0, 5.0)
    assert point.reachable[30, 5] and not point.reachable[5, 30]
    # unknown cells are not free: nothing is reachable beyond what the map knows
    unknown = OccupancyGrid(GridFrame(40, 40, 0.05))
    assert InferenceGrid(unknown, (1.0, 1.0), RADIUS, 5.0).reachable.sum() == 1  # just where it stands


def test_observable_stops_at_walls_and_sensor_range_and_counts_every_pose() -> None:
    grid = two_rooms(None)
    inference = InferenceGrid(grid, (1.5, 1.5), RADIUS, 1.0)
    seen = inference.observable
    assert seen[30, 30] and seen[30, 45]  # 0.75 m away
    assert not seen[30, 5]  # 1.25 m away: beyond radius + range
    far = InferenceGrid(grid, (2.5, 1.5), RADIUS, 5.0)
    assert far.observable[30, 60]  # the wall itself is seen...
    assert not far.observable[:, 61:].any()  # ...not what is behind it
    both = InferenceGrid(grid, (1.5, 1.5), RADIUS, 1.0, poses=[(1.5, 1.5, 0.0), (0.6, 0.6)])
    assert both.observable[59 - 12, 12] and not seen[59 - 12, 12]  # near the second pose
    assert (both.region_of_interest == (both.reachable | both.observable)).all()


def test_doubting_walls_makes_them_unknown_to_a_planner_with_a_weak_memory_of_them() -> None:
    grid = two_rooms(None)
    grid.updated[...] = True
    doubted = grid.doubt_walls(*grid.frame.cell_to_world(30, 60), 0.5)
    assert doubted == 21  # the wall's cells within 0.5 m (10 cells either side of its middle)
    assert not grid.updated[20:41, 60].any() and grid.updated[19, 60] and grid.updated[30, 59]
    assert (grid.probabilities()[20:41, 60] == pytest.approx(0.55, abs=1e-3)) and grid.log_odds[30, 59] == -5.0
    assert grid.doubt_walls(*grid.frame.cell_to_world(30, 60), 0.5) == 0  # doubted already: no wall there now


def test_the_walls_a_robot_cannot_see_are_doubted_and_those_it_sees_are_kept() -> None:
    from atlas_rap.maps.inference import doubt_unseen_walls

    grid = two_rooms(None)
    grid.updated[...] = True
    here = grid.frame.cell_to_world(30, 45)  # in the left room, 0.75 m from the wall between the rooms
    assert doubt_unseen_walls(grid, here, RADIUS, 5.0) > 0
    assert grid.updated[20:41, 60].all()  # the face of the wall between the rooms, in sight: kept
    assert grid.updated[0, 30:60].all() and grid.updated[59, 30:60].all()  # the left room's own walls: kept
    assert not grid.updated[20:41, 119].any()  # the right room's far wall, behind the one between: doubted
    assert grid.probabilities()[30, 119] == pytest.approx(0.55, abs=1e-3)
    assert grid.updated[30, 90]  # free cells are not doubted


# -- building a map by driving round the default world ---------------------------------------

WORLD = "lab-corridor-office"


def drive_and_map(seed: int = 0) -> tuple:
    """Drive lab -> office -> lab along plan_route's waypoints, fusing the sonar at 10 Hz at the TRUE pose."""
    world = load_world(WORLD)
    sim = Simulation(world, seed=seed)
    waypoints = there_and_back(world)
    grid = OccupancyGrid.covering(world.bounds, 0.05)
    angles = sim.sonar_angles
    poses = []

    def fuse(pose: tuple[float, float, float]) -> None:
        grid.update_sonar(*pose, sim.sonar(), angles, world.robot.radius, world.sonar)
        poses.append(pose)

    assert drive_waypoints(sim, waypoints, time_limit=300, on_tick=fuse) == len(waypoints)
    return world, grid, poses


def true_walls(world, frame: GridFrame) -> np.ndarray:
    """The world's walls (and the crate, there the whole run) rasterised on ``frame``, dilated by one cell."""
    segments = [(wall.a, wall.b) for wall in world.walls]
    for thing in world.disturbances:
        if thing.kind == "box" and thing.end is None:
            (cx, cy), h = thing.path[0], thing.size / 2
            corners = [(cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h)]
            segments += list(zip(corners, corners[1:] + corners[:1]))
    raster = np.zeros(frame.shape, dtype=bool)
    for a, b in segments:
        rr, cc = line(*frame.world_to_cell(*a), *frame.world_to_cell(*b))
        keep = (rr >= 0) & (rr < frame.height) & (cc >= 0) & (cc < frame.width)
        raster[rr[keep], cc[keep]] = True
    return ndimage.binary_dilation(raster, structure=np.ones((3, 3), dtype=bool))


@pytest.fixture(scope="module")
def mapped():
    return drive_and_map()


def test_driving_lab_office_lab_maps_the_walls(mapped) -> None:
    world, grid, _ = mapped
    labels = grid.labels()
    observed = labels != UNKNOWN
    walls = true_walls(world, grid.frame)
    # a cell is right when it is labelled occupied exactly where a wall is (within one cell)
    accuracy = float(((labels == OCCUPIED) == walls)[observed].mean())
    assert observed.sum() > 40_000  # most of lab, corridor and office (about 100 m^2 = 40,000 cells)
    assert accuracy >= 0.95, accuracy
    # no phantom obstacles: occupied cells more than a cell from a wall are rare
    assert ((labels == OCCUPIED) & ~walls).sum() < 0.01 * observed.sum()


def test_driving_lab_office_lab_gives_map_quality_above_0_9(mapped) -> None:
    world, grid, poses = mapped
    # region of interest: cells reachable from where the robot ends, or within sonar range and in line of
    # sight of some pose it fused a ring at (its whole path)
    inference = InferenceGrid(grid, poses[-1][:2], world.robot.radius, world.sonar.max_range, poses)
    region = inference.region_of_interest
    assert region.sum() > 40_000
    for name in ("lab", "corridor", "office"):
        row, col = grid.frame.world_to_cell(*world.places[name].point)
        assert inference.reachable[row, col], name
    assert inference.quality() > 0.9, inference.quality()
    assert grid.quality() > 0.8  # over every cell any reading touched (the default region)


# -- Layer IV, which builds the grid while the robot drives ------------------------------------


def test_layer_iv_fuses_each_new_ring_once_into_the_shared_grid() -> None:
    from atlas_rap.layers import MissionEngine, RunOptions
    from atlas_rap.skills.beliefs import GRID, POSES

    engine = MissionEngine(RunOptions(world=WORLD, seed=0, prior_map=False))
    engine.start()
    beliefs = engine.manager.context.beliefs
    grid = beliefs[GRID]
    assert isinstance(grid, OccupancyGrid) and grid.frame.resolution == 0.05
    assert not grid.updated.any()
    engine.simulation.command(0.4, 0.3)
    engine.advance(2.0)
    poses = beliefs[POSES]
    assert 15 <= len(poses) <= 21  # every ring of the 10 Hz sonar, none twice
    assert len(set(poses)) == len(poses) or engine.simulation.pose[:2] == poses[0][:2]
    assert grid.updated.sum() > 1000 and (grid.probabilities() < 0.5).sum() > 1000

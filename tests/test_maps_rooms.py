"""Places that are rooms: room segmentation scored against ground truth on generated floor plans
(plain, hard, scanned like SLAM) and on a real building (g4s_y2, when ../shared/data is there),
and the door rules on small plans drawn here (a door at a corner, wider than its corridor, a gap
beside a desk, a closet too small to be a room)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from floorplans import generate_plan, score

from atlas_rap.maps.abstraction import abstract
from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.rooms import RoomSettings

RES = 0.05
PLANS = range(12)


def owned_and_precision(seeds, furniture: bool, hard: bool = False,
                        slam: bool = False) -> tuple[float, float, list[str]]:
    """Over all the plans: the share of rooms with a place of their own, pixel-weighted precision,
    and what went wrong where (for the failure message)."""
    owned = rooms = 0
    on_room = inside = 0.0
    notes = []
    for seed in seeds:
        plan = generate_plan(seed, furniture=furniture, hard=hard, slam=slam)
        result = score(abstract(plan.occupancy, plan.frame).places, plan.rooms)
        owned += result.owned_rooms
        rooms += result.n_rooms
        weight = float((plan.rooms > 0).sum())
        on_room += weight
        inside += result.pixel_precision * weight
        if result.owned_rooms < result.n_rooms:
            notes.append(f"seed {seed}: {result.n_rooms - result.owned_rooms} of {result.n_rooms} rooms without "
                         f"a place of their own ({result.merged_rooms} merged, {result.split_rooms} split)")
    return owned / rooms, inside / on_room, notes


def test_on_clean_generated_plans_every_room_gets_a_place_of_its_own():
    owned, precision, notes = owned_and_precision(PLANS, furniture=False)
    assert owned >= 0.95, notes
    assert precision >= 0.95, notes


def test_with_furniture_rooms_still_get_places_of_their_own():
    owned, precision, notes = owned_and_precision(PLANS, furniture=True)
    assert owned >= 0.9, notes
    assert precision >= 0.9, notes


@pytest.mark.parametrize("furniture, least", [(False, 0.95), (True, 0.9)], ids=["clean", "furnished"])
def test_on_hard_plans_walls_of_1_to_8_cells_jambless_and_corner_doors_and_buildings_of_wings_make_rooms(
        furniture: bool, least: float):
    owned, precision, notes = owned_and_precision(range(8), furniture=furniture, hard=True)
    assert owned >= least, notes
    assert precision >= 0.9, notes


@pytest.mark.parametrize("furniture, least", [(False, 0.9), (True, 0.85)], ids=["clean", "furnished"])
def test_on_plans_scanned_like_slam_ragged_and_unseen_walls_and_speckle_still_make_rooms(furniture: bool, least: float):
    """The hard plans as a robot's scan. Below the hard plans' marks (issue 25 asks 0.95 and 0.9;
    over 50 seeds bench_places measures 0.950 and 0.895): where a room's furniture leaves no room-sized core
    and its door in a half-seen wall is not found, it joins the corridor."""
    owned, precision, notes = owned_and_precision(range(8), furniture=furniture, slam=True)
    assert owned >= least, notes
    assert precision >= 0.9, notes


# -- small plans drawn here --------------------------------------------------------------------

def box(height_m: float, width_m: float) -> np.ndarray:
    """An empty building of height x width metres inside a 0.2 m outer wall (P(occ): 1 wall, 0 free)."""
    p = np.ones((int(round(height_m / RES)) + 8, int(round(width_m / RES)) + 8), dtype=np.float32)
    p[4:-4, 4:-4] = 0.0
    return p


def wall(p: np.ndarray, rows: slice, cols: slice) -> None:
    p[rows, cols] = 1.0


def places_of(p: np.ndarray, **settings) -> np.ndarray:
    frame = GridFrame(p.shape[0], p.shape[1], RES)
    return abstract(p, frame, rooms=RoomSettings(**settings) if settings else None).places


def label_at(labels: np.ndarray, x_m: float, y_m: float) -> int:
    """The place at (x, y) metres from the inner top-left corner (rows down, columns right)."""
    return int(labels[4 + int(x_m / RES), 4 + int(y_m / RES)])


def test_a_door_at_a_corner_of_a_room_separates_it():
    p = box(6, 8)
    wall(p, slice(64, 68), slice(4, -4))  # a wall across at 3 m
    p[64:68, 4:24] = 0.0  # a 1 m door right at the left wall
    labels = places_of(p)
    assert labels.max() == 2
    assert label_at(labels, 1, 4) != label_at(labels, 5, 4)


def test_a_door_wider_than_its_narrow_corridor_still_separates_the_room():
    p = box(6, 8)
    wall(p, slice(28, 32), slice(4, -4))  # a corridor 1.2 m wide at the top (rows 4-28)
    p[28:32, 60:86] = 0.0  # a door 1.3 m wide, wider than the corridor
    labels = places_of(p)
    assert labels.max() == 2
    assert label_at(labels, 0.5, 4) != label_at(labels, 4, 4)


def test_a_gap_between_a_desk_and_the_wall_is_no_door():
    p = box(5, 6)
    p[40:60, 30:94] = 1.0  # a desk 1 x 3.2 m, 0.6 m from the left wall, its far end against the right wall
    labels = places_of(p)
    assert labels.max() == 1


def test_a_free_standing_table_leaves_one_room():
    p = box(5, 6)
    p[35:65, 30:70] = 1.0  # a table 1.5 x 2 m with 1.5 m all round
    assert places_of(p).max() == 1


def test_a_closet_smaller_than_the_minimum_room_area_joins_its_room():
    p = box(4, 6)
    wall(p, slice(4, 30), slice(24, 28))  # a closet 1 x 1.3 m in the corner, open by a door of 0.8 m
    wall(p, slice(26, 30), slice(4, 24))
    p[26:30, 6:22] = 0.0
    assert places_of(p).max() == 1  # 1.3 m² is under the default 2 m²
    # a building of closets: places from 1 m², and a core (room for the robot's centre beyond the door's
    # clearance) of 0.3 m² makes a room
    assert places_of(p, min_room_area=1.0, core_area=0.3).max() == 2


def test_an_opening_wider_than_a_door_does_not_cut_a_room():
    p = box(6, 8)
    wall(p, slice(64, 68), slice(4, -4))
    p[64:68, 40:84] = 0.0  # a 2.2 m opening: wider than any door
    assert places_of(p).max() == 1
    assert places_of(p, door_width=(0.6, 2.5)).max() == 2


@pytest.mark.parametrize("seed", [3, 7])
def test_the_same_plan_gives_the_same_places(seed):
    plan = generate_plan(seed, furniture=True)
    first = abstract(plan.occupancy, plan.frame).places
    second = abstract(plan.occupancy, plan.frame).places
    assert np.array_equal(first, second)


# -- the real maps in ../shared/data/maps (optional) ------------------------------------------

def _shared_map(name: str):
    from atlas_rap.maps.rosmap import load_ros_map

    path = Path(__file__).resolve().parents[2] / "shared" / "data" / "maps" / f"{name}.yaml"
    if not path.exists():
        pytest.skip(f"the shared real maps are not at {path.parent}")
    return load_ros_map(path)


def test_the_real_building_g4s_y2_gets_most_of_its_rooms_and_few_places_straddle_two():
    """A SLAM-style map of a real building (ROSE²'s G4S, 15 rooms with hand-drawn ground truth):
    walls mostly unknown, chairs and tables everywhere, doorways without jambs. The rooms off the
    corridor and the offices get places of their own; what still fails (issue 25) is the corridor,
    which meets the long hall below it through openings as wide as itself, and rooms whose
    furniture leaves two room-sized halves. Places rarely straddle rooms (pixel precision)."""
    from skimage.io import imread

    rosmap = _shared_map("rooms/g4s_y2")
    truth = imread(Path(rosmap.source).with_name("g4s_y2_rooms.png")).astype(np.int64)
    result = score(abstract(rosmap.occupancy, rosmap.frame).places, truth)
    assert result.n_rooms == 15
    assert result.owned_rooms >= 9, result
    assert result.pixel_precision >= 0.85, result


def test_the_turtlebot3_world_is_one_place():
    """One hexagonal arena with nine pillars and no door: one place, round the pillars."""
    rosmap = _shared_map("turtlebot3_world")
    assert abstract(rosmap.occupancy, rosmap.frame).places.max() == 1


def test_the_willow_garage_map_is_cut_at_its_doors():
    """Willow Garage's office, mapped by a robot (0.1 m cells). Its walls are soft greys that
    read as unknown, so every cell that is not free counts as wall. Checked by eye on the
    places picture: the big open lab areas and the rooms the robot looked into are places of
    their own, but the corridors are cut into pieces wherever a doorway opens off them into a
    room the robot did not enter, and where the ragged walls pinch them: 76 places before the
    pieces without a room's core joined their neighbours (issue 25), 58 after, still too many
    for the corridors (a known weakness on maps this rough). The bounds guard against a change
    that joins everything into a few places (9, before the walls were taken from the unknown
    cells) or that chops the corridors more than before."""
    rosmap = _shared_map("willow-2010-02-18-0.10")
    assert 30 <= abstract(rosmap.occupancy, rosmap.frame).places.max() <= 76

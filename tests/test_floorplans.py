"""The floor-plan test bed itself: generated plans are what they claim (measured on their images), the scorer scores.

Sizes are measured on the images, not read back from the generator: room
areas from label counts, door widths from the free gap in the wall, wall
thicknesses across door gaps and from the unknown outside, corridor widths
from runs of corridor cells, reachability from the free space eroded by the
robot's disc.
"""

from __future__ import annotations

import importlib.util
import json
import time
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.rosmap import FREE, OCCUPIED, UNKNOWN, load_ros_map
from atlas_rap.shipped import shipped_worlds
from atlas_rap.sim.world import load_world
from floorplans import (CORRIDOR_CLEAR, CORRIDOR_WIDTH, DOOR_WIDTH, FURNITURE_SIDE, HARD_DOOR_WIDTH,
                        HARD_OUTER_THICKNESS, HARD_ROTATION, HARD_WALL_THICKNESS, OPEN_PLAN_AREA, ROBOT_RADIUS,
                        ROOM_AREA, ROOMS_PER_PLAN, SLIVER, WALL_THICKNESS, FloorPlan, generate_plan, read_truth,
                        score, world_room_names, world_rooms, write_plan)

SEEDS = range(12)
EPS = 1e-6


@pytest.fixture(scope="module")
def plans() -> dict[int, FloorPlan]:
    return {seed: generate_plan(seed) for seed in SEEDS}


@pytest.fixture(scope="module")
def furnished() -> dict[int, FloorPlan]:
    return {seed: generate_plan(seed, furniture=True) for seed in SEEDS}


def within(value: float, bounds: tuple[float, float]) -> bool:
    return bounds[0] - EPS <= value <= bounds[1] + EPS


def runs(mask: np.ndarray, axis: int) -> np.ndarray:
    """Length (cells) of the run of ``mask`` cells through each cell along ``axis`` (0: down a column); 0 off it."""
    structure = np.zeros((3, 3), dtype=bool)
    if axis == 0:
        structure[:, 1] = True
    else:
        structure[1, :] = True
    labels, _ = ndimage.label(mask, structure)
    return np.bincount(labels.ravel())[labels] * mask


def robot_space(free: np.ndarray, plan: FloorPlan) -> np.ndarray:
    """Free cells eroded by the robot's disc: every cell whose centre is within r + half a cell is free."""
    reach = ROBOT_RADIUS / plan.frame.resolution + 0.5
    k = int(np.ceil(reach))
    yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
    return ndimage.binary_erosion(free, structure=yy ** 2 + xx ** 2 < reach ** 2, border_value=0)


def furniture_mask(plan: FloorPlan) -> np.ndarray:
    mask = np.zeros(plan.rooms.shape, dtype=bool)
    for item in plan.furniture:
        r0, r1, c0, c1 = item.box
        mask[r0:r1, c0:c1] = True
    return mask


def describe(plan: FloorPlan) -> str:
    areas = ", ".join(f"{n} {a:.1f}" for n, a in zip(plan.room_names, plan.room_areas()))
    hard = f", hard, turned {plan.rotation:g} deg" if plan.hard else ""
    return f"seed {plan.seed} ({plan.layout}, {plan.rooms.shape}{hard}): {areas}"


# -- the generator ---------------------------------------------------------------------------

def test_the_same_seed_draws_the_same_plan() -> None:
    for furniture in (False, True):
        a, b = generate_plan(7, furniture=furniture), generate_plan(7, furniture=furniture)
        assert np.array_equal(a.occupancy, b.occupancy, equal_nan=True)
        assert np.array_equal(a.rooms, b.rooms)
        assert (a.room_names, a.doors, a.furniture, a.frame) == (b.room_names, b.doors, b.furniture, b.frame)


def test_different_seeds_draw_different_plans(plans: dict[int, FloorPlan]) -> None:
    seen = {(p.rooms.shape, p.rooms.tobytes()) for p in plans.values()}
    assert len(seen) == len(plans)
    assert len({p.layout for p in plans.values()}) >= 4  # T, L, comb, cross, grid


def test_plans_have_10_to_40_rooms_of_4_to_60_square_metres_and_an_open_plan_area(plans: dict[int, FloorPlan]) -> None:
    for plan in plans.values():
        res = plan.frame.resolution
        areas = np.bincount(plan.rooms.ravel(), minlength=plan.n_rooms + 1)[1:] * res ** 2
        rooms = np.array([k != "corridor" for k in plan.room_kinds])
        assert ROOMS_PER_PLAN[0] <= plan.n_rooms <= ROOMS_PER_PLAN[1], describe(plan)
        assert all(within(a, ROOM_AREA) for a in areas[rooms]), describe(plan)
        assert (areas[rooms] >= OPEN_PLAN_AREA[0]).any(), describe(plan)
        assert plan.room_kinds[0] == "corridor" and len(set(plan.room_names)) == plan.n_rooms


def test_rooms_are_the_free_space_with_the_doors_closed(plans: dict[int, FloorPlan]) -> None:
    for plan in plans.values():
        rooms = plan.rooms
        # Each label is one 4-connected piece, and no two rooms touch: walls or door gaps lie between.
        pieces, count = ndimage.label(rooms > 0)
        assert count == plan.n_rooms
        assert all(len(np.unique(rooms[pieces == i])) == 1 for i in range(1, count + 1))
        for a, b in ((rooms[1:], rooms[:-1]), (rooms[:, 1:], rooms[:, :-1])):
            assert not ((a != b) & (a > 0) & (b > 0)).any()
        # Room cells are free; the other free cells are the door gaps.
        free = plan.occupancy == 0
        assert free[rooms > 0].all()
        gaps = np.zeros_like(free)
        for door in plan.doors:
            r0, r1, c0, c1 = door.box
            gaps[r0:r1, c0:c1] = True
        assert np.array_equal(free & (rooms == 0), gaps)


def test_outside_the_outer_wall_is_unknown(plans: dict[int, FloorPlan]) -> None:
    for plan in plans.values():
        occ = plan.occupancy
        unknown = np.isnan(occ)
        assert set(np.unique(occ[~unknown]).tolist()) == {0.0, 1.0}
        border = np.concatenate([unknown[0], unknown[-1], unknown[:, 0], unknown[:, -1]])
        assert border.all()
        _, count = ndimage.label(unknown)
        assert count == 1  # one outside, no unknown holes inside the building
        assert not (ndimage.binary_dilation(unknown) & (occ == 0)).any()  # a wall always stands between


def test_walls_are_0_1_to_0_25_m_thick(plans: dict[int, FloorPlan]) -> None:
    for plan in plans.values():
        res = plan.frame.resolution
        # The outer wall: free cells are at least (wall + 1) cells from the unknown, and the nearest exactly.
        to_outside = ndimage.distance_transform_edt(~np.isnan(plan.occupancy))
        assert within((to_outside[plan.occupancy == 0].min() - 1) * res, WALL_THICKNESS)
        # Inner walls, measured across each door gap: free cells between the two rooms' cells.
        for door in plan.doors:
            r0, r1, c0, c1 = door.box
            line = plan.rooms[(r0 + r1) // 2, :] if door.wall == "vertical" else plan.rooms[:, (c0 + c1) // 2]
            lo, hi = (c0, c1) if door.wall == "vertical" else (r0, r1)
            assert {int(line[lo - 1]), int(line[hi])} == set(door.rooms)
            assert (line[lo:hi] == 0).all()
            assert within((hi - lo) * res, WALL_THICKNESS)


def test_doors_are_0_7_to_1_3_m_gaps_between_the_rooms_they_join(plans: dict[int, FloorPlan]) -> None:
    kinds = set()
    for plan in plans.values():
        res, occ = plan.frame.resolution, plan.occupancy
        for door in plan.doors:
            r0, r1, c0, c1 = door.box
            assert (occ[r0:r1, c0:c1] == 0).all() and (plan.rooms[r0:r1, c0:c1] == 0).all()
            # The free gap along the wall, through the wall's middle, is the door's width, walled at both ends.
            if door.wall == "horizontal":
                line, at = occ[(r0 + r1) // 2, :], (c0 + c1) // 2
            else:
                line, at = occ[:, (c0 + c1) // 2], (r0 + r1) // 2
            gap = runs(line[None, :] == 0, 1)[0, at]
            assert within(gap * res, DOOR_WIDTH) and abs(gap * res - door.width) < EPS
            lo, hi = (c0, c1) if door.wall == "horizontal" else (r0, r1)
            assert line[lo - 1] == 1 and line[hi] == 1
            x, y = plan.frame.cell_to_world((r0 + r1 - 1) / 2, (c0 + c1 - 1) / 2)
            assert np.allclose(door.center, (x, y), atol=1e-5)
            kinds.add(tuple(sorted(plan.room_kinds[r - 1] == "corridor" for r in door.rooms)))
        counts = np.bincount(np.array([d.rooms for d in plan.doors]).ravel(), minlength=plan.n_rooms + 1)
        for label, kind in enumerate(plan.room_kinds, start=1):
            if kind != "corridor":
                assert 1 <= counts[label] <= 3, describe(plan)
    assert kinds == {(False, False), (False, True), (True, True)}  # room-room, room-corridor, fire doors


def test_corridors_are_1_2_to_3_m_wide_and_branch(plans: dict[int, FloorPlan]) -> None:
    for plan in plans.values():
        res = plan.frame.resolution
        corridor = np.isin(plan.rooms, plan.corridors)
        down, across = runs(corridor, 0), runs(corridor, 1)
        width = np.minimum(down, across)[corridor] * res  # a cell's corridor width: its shorter run
        assert width.min() >= CORRIDOR_WIDTH[0] - EPS, describe(plan)
        assert np.median(width) <= CORRIDOR_WIDTH[1] + EPS, describe(plan)
        long = 3.5 / res  # a branch runs at least 3.5 m (past the rooms beside it), plus the width it crosses
        assert ((across >= long) & (down * res <= CORRIDOR_WIDTH[1] + EPS)).any()  # a corridor along the rows...
        assert ((down >= long) & (across * res <= CORRIDOR_WIDTH[1] + EPS)).any()  # ...and one down the columns


@pytest.mark.parametrize("furniture", [False, True])
def test_every_room_is_reachable_from_every_other_by_a_robot_of_radius_0_2(
        furniture: bool, plans: dict[int, FloorPlan], furnished: dict[int, FloorPlan]) -> None:
    for plan in (furnished if furniture else plans).values():
        space = robot_space(plan.occupancy == 0, plan)
        _, count = ndimage.label(space)
        assert count == 1, describe(plan)  # one piece: every room reaches every other, and no pockets
        assert ndimage.maximum(space, plan.rooms, np.arange(1, plan.n_rooms + 1)).all()


def test_furniture_leaves_the_building_and_the_room_labels_alone(
        plans: dict[int, FloorPlan], furnished: dict[int, FloorPlan]) -> None:
    placements = set()
    for seed, plan in furnished.items():
        bare = plans[seed]
        assert (plan.frame, plan.doors, plan.room_names) == (bare.frame, bare.doors, bare.room_names)
        assert plan.furniture
        furniture = furniture_mask(plan)
        for item in plan.furniture:
            r0, r1, c0, c1 = item.box
            assert (bare.rooms[r0:r1, c0:c1] == item.room).all()
            assert all(within(side * plan.frame.resolution, FURNITURE_SIDE) for side in (r1 - r0, c1 - c0))
            placements.add(item.placement)
        assert np.array_equal(plan.rooms, np.where(furniture, 0, bare.rooms))
        assert np.array_equal(plan.occupancy, np.where(furniture, np.float32(1), bare.occupancy), equal_nan=True)
        assert not furniture[np.isin(bare.rooms, bare.corridors)].any()
    assert placements == {"wall", "sliver", "free"}


def test_furniture_keeps_clear_of_doors_and_leaves_slivers_of_0_3_to_0_9_m(
        plans: dict[int, FloorPlan], furnished: dict[int, FloorPlan]) -> None:
    slivers = 0
    for seed, plan in furnished.items():
        walls = plans[seed].occupancy
        res = plan.frame.resolution
        furniture = furniture_mask(plan)
        clear = round(1.0 / res)
        for door in plan.doors:  # nothing within 1 m in front of a door, either side
            r0, r1, c0, c1 = door.box
            if door.wall == "horizontal":
                r0, r1 = max(r0 - clear, 0), r1 + clear
            else:
                c0, c1 = max(c0 - clear, 0), c1 + clear
            assert not furniture[r0:r1, c0:c1].any()
        for item in plan.furniture:
            if item.placement != "sliver":
                continue
            r0, r1, c0, c1 = item.box
            # Walk from the piece to the wall (of the bare plan: other furniture may stand in a sliver).
            if item.side in ("left", "right"):
                line = walls[(r0 + r1) // 2]
                cells = line[:c0][::-1] if item.side == "left" else line[c1:]
            else:
                line = walls[:, (c0 + c1) // 2]
                cells = line[:r0][::-1] if item.side == "top" else line[r1:]
            gap = int(np.argmax(cells != 0))
            assert within(gap * res, SLIVER) and abs(gap * res - item.gap) < EPS
            slivers += 1
    assert slivers >= 5


def test_other_resolutions_and_sizes() -> None:
    plan = generate_plan(2, resolution=0.1, size=(20.0, 30.0))
    res = plan.frame.resolution
    rows, cols = np.nonzero(~np.isnan(plan.occupancy))
    assert abs((cols.max() - cols.min() + 1) * res - 20.0) <= 0.1 + EPS
    assert abs((rows.max() - rows.min() + 1) * res - 30.0) <= 0.1 + EPS
    assert all(within(d.width, DOOR_WIDTH) for d in plan.doors)
    x, y = plan.frame.cell_to_world(rows.max(), cols.min())  # the building's lower-left cell
    assert abs(x - res / 2) < EPS and abs(y - res / 2) < EPS
    with pytest.raises(ValueError):
        generate_plan(0, size=(6.0, 5.0))


def test_a_plan_round_trips_through_its_ros_map_and_ground_truth(furnished: dict[int, FloorPlan],
                                                                  tmp_path: Path) -> None:
    plan = furnished[3]
    yaml = write_plan(plan, tmp_path / "plans", "plan-3")
    rosmap = load_ros_map(yaml)
    expected = np.select([plan.occupancy == 0, plan.occupancy == 1], [FREE, OCCUPIED], UNKNOWN)
    assert np.array_equal(rosmap.labels, expected)
    assert np.array_equal(np.isnan(rosmap.occupancy), np.isnan(plan.occupancy))
    assert rosmap.frame == plan.frame
    rooms, info = read_truth(tmp_path / "plans", "plan-3")
    assert rooms.dtype == np.int32 and np.array_equal(rooms, plan.rooms)
    assert [r["name"] for r in info["rooms"]] == list(plan.room_names)
    assert [tuple(d["rooms"]) for d in info["doors"]] == [d.rooms for d in plan.doors]
    assert len(info["furniture"]) == len(plan.furniture) and info["seed"] == 3


def test_the_cli_writes_a_plan_and_its_preview(tmp_path: Path) -> None:
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "floorplans_cli.py"
    spec = importlib.util.spec_from_file_location("floorplans_cli", path)
    assert spec is not None and spec.loader is not None
    cli = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cli)
    assert cli.main(["--seed", "3", "--furniture", "--out", str(tmp_path)]) == 0
    names = {p.name for p in tmp_path.iterdir()}
    assert {"plan-3.yaml", "plan-3.pgm", "plan-3-rooms.png", "plan-3-rooms.json", "plan-3-preview.png"} <= names


# -- hard plans --------------------------------------------------------------------------------

HARD_SEEDS = range(10)  # seeds 3, 4 and 8 are not turned


@pytest.fixture(scope="module")
def hard_plans() -> dict[int, FloorPlan]:
    return {seed: generate_plan(seed, hard=True) for seed in HARD_SEEDS}


@pytest.fixture(scope="module")
def hard_cluttered() -> dict[int, FloorPlan]:
    return {seed: generate_plan(seed, hard=True, furniture=True, clutter_corridors=True) for seed in (0, 5, 7)}


def straight(plans: dict[int, FloorPlan]) -> list[FloorPlan]:
    """The plans that were not turned (their doors' boxes are their gaps)."""
    found = [p for p in plans.values() if p.rotation == 0.0]
    assert len(found) >= 2
    return found


def test_plain_plans_are_still_the_plans_of_old() -> None:
    """Benchmarks and tests depend on the plain plans: the same arrays for the same seed as before ``hard``."""
    import hashlib

    for seed, furniture, digest in (
            (0, False, "d231f66ac0bf904ef2945b66820941cb5b91d48005b96a0da85fcd137be29a48"),
            (1, True, "ceae0668ed962c93541059462c4aec91b59b6508df08bdceba2da2ddc2398f2d")):
        plan = generate_plan(seed, furniture=furniture, hard=False, clutter_corridors=False)
        assert hashlib.sha256(plan.occupancy.tobytes() + plan.rooms.tobytes()).hexdigest() == digest
        assert not plan.hard and plan.rotation == 0.0 and plan.specks == plan.holes == ()


def test_hard_plans_are_drawn_from_the_seed_and_are_the_plain_plans_building(
        hard_plans: dict[int, FloorPlan], hard_cluttered: dict[int, FloorPlan]) -> None:
    a = generate_plan(7, hard=True, furniture=True, clutter_corridors=True)
    b = hard_cluttered[7]
    assert np.array_equal(a.occupancy, b.occupancy, equal_nan=True) and np.array_equal(a.rooms, b.rooms)
    assert (a.doors, a.furniture, a.frame, a.rotation, a.specks, a.holes) == \
        (b.doors, b.furniture, b.frame, b.rotation, b.specks, b.holes)
    assert np.array_equal(a.furniture_cells(), b.furniture_cells())
    for seed in (3, 7):
        plain, hard = generate_plan(seed), hard_plans[seed]
        assert hard.hard and hard.room_names == plain.room_names and hard.room_kinds == plain.room_kinds
        assert sorted(d.rooms for d in hard.doors) == sorted(d.rooms for d in plain.doors)
        assert hard.rooms.shape != plain.rooms.shape or not np.array_equal(hard.rooms, plain.rooms)
    angles = [p.rotation for p in hard_plans.values()]
    assert 0.0 in angles and sum(a != 0.0 for a in angles) >= len(angles) // 2
    assert all(abs(a) <= HARD_ROTATION for a in angles) and min(angles) < 0 < max(angles)


@pytest.mark.parametrize("which", ["clean", "cluttered"])
def test_hard_rooms_are_the_free_space_with_the_doors_closed(
        which: str, hard_plans: dict[int, FloorPlan], hard_cluttered: dict[int, FloorPlan]) -> None:
    for plan in (hard_plans if which == "clean" else hard_cluttered).values():
        rooms, free = plan.rooms, plan.occupancy == 0
        pieces, count = ndimage.label(rooms > 0)
        assert count == plan.n_rooms, describe(plan)
        index = np.arange(1, count + 1)
        assert np.array_equal(ndimage.minimum(rooms, pieces, index), ndimage.maximum(rooms, pieces, index))
        # No two rooms touch, not even diagonally, turned or not: walls (or closed doors) lie between.
        for a, b in ((rooms[1:], rooms[:-1]), (rooms[:, 1:], rooms[:, :-1]),
                     (rooms[1:, 1:], rooms[:-1, :-1]), (rooms[1:, :-1], rooms[:-1, 1:])):
            assert not ((a != b) & (a > 0) & (b > 0)).any(), describe(plan)
        # The free cells are the rooms' and the door gaps': each gap lies in a door's box, between its rooms.
        assert free[rooms > 0].all()
        door_cells = plan.door_cells()
        gaps, n_gaps = ndimage.label(door_cells)
        assert n_gaps >= len(plan.doors)
        for i, (rs, cs) in enumerate(ndimage.find_objects(gaps), start=1):
            window = (slice(rs.start - 1, rs.stop + 1), slice(cs.start - 1, cs.stop + 1))
            mask = gaps[window] == i
            beside = set(np.unique(rooms[window][ndimage.binary_dilation(mask) & ~mask]).tolist()) - {0}
            doors = [d for d in plan.doors if d.box[0] <= rs.start and rs.stop <= d.box[1]
                     and d.box[2] <= cs.start and cs.stop <= d.box[3]]
            assert any(beside <= set(d.rooms) for d in doors), (describe(plan), beside)
        for door in plan.doors:
            r0, r1, c0, c1 = door.box
            assert door_cells[r0:r1, c0:c1].any()
        # Outside: unknown, one piece, and never next to a free cell, not even diagonally.
        unknown = np.isnan(plan.occupancy)
        assert unknown[0].all() and unknown[-1].all() and unknown[:, 0].all() and unknown[:, -1].all()
        assert ndimage.label(unknown)[1] == 1
        assert not (ndimage.binary_dilation(unknown, structure=np.ones((3, 3))) & free).any()


@pytest.mark.parametrize("which", ["clean", "cluttered"])
def test_hard_plans_are_connected_for_a_robot_of_radius_0_2(
        which: str, hard_plans: dict[int, FloorPlan], hard_cluttered: dict[int, FloorPlan]) -> None:
    plans = hard_plans if which == "clean" else hard_cluttered
    assert any(p.rotation != 0 for p in plans.values())
    for plan in plans.values():
        space = robot_space(plan.occupancy == 0, plan)
        _, count = ndimage.label(space)
        assert count == 1, describe(plan)
        assert ndimage.maximum(space, plan.rooms, np.arange(1, plan.n_rooms + 1)).all(), describe(plan)


def test_hard_walls_are_each_0_1_to_0_3_m_thick_outer_walls_up_to_0_35(hard_plans: dict[int, FloorPlan]) -> None:
    inner, outer = [], []
    for plan in straight(hard_plans):
        res, rooms = plan.frame.resolution, plan.rooms
        for door in plan.doors:  # across each door gap: the wall's thickness there
            r0, r1, c0, c1 = door.box
            line = rooms[(r0 + r1) // 2, :] if door.wall == "vertical" else rooms[:, (c0 + c1) // 2]
            lo, hi = (c0, c1) if door.wall == "vertical" else (r0, r1)
            assert {int(line[lo - 1]), int(line[hi])} == set(door.rooms)
            inner.append(round((hi - lo) * res, 6))
        occ = np.array(plan.occupancy)
        for r, c in plan.holes:
            occ[r, c] = 1.0
        # Outer walls: from the unknown along each row and column, the occupied run up to a room.
        for grid, labels in ((occ, rooms), (occ.T, rooms.T)):
            for line, names in zip(grid, labels):
                for cells, room in ((line, names), (line[::-1], names[::-1])):
                    start = int(np.argmax(~np.isnan(cells)))
                    run = int(np.argmax(cells[start:] != 1))
                    if names.any() and room[start + run] > 0:
                        outer.append(round(run * res, 6))
    assert all(within(t, HARD_WALL_THICKNESS) for t in inner) and len(set(inner)) >= 4, sorted(set(inner))
    outer = np.array(outer)
    assert outer.min() >= HARD_OUTER_THICKNESS[0] - EPS
    assert np.mean(outer <= HARD_OUTER_THICKNESS[1] + EPS) > 0.95  # (rows along an inner wall run on)
    assert len(set(outer[outer <= HARD_OUTER_THICKNESS[1] + EPS].tolist())) >= 4
    assert outer.max() > WALL_THICKNESS[1]  # thicker than a plain plan's


def test_hard_doors_are_anywhere_often_in_a_corner_some_double_some_narrow(hard_plans: dict[int, FloorPlan]) -> None:
    widths, flush, corners, total = [], 0, 0, 0
    for plan in straight(hard_plans):
        res, occ, rooms = plan.frame.resolution, plan.occupancy, plan.rooms
        for door in plan.doors:
            r0, r1, c0, c1 = door.box
            if door.wall == "horizontal":
                line, at, lo, hi = occ[(r0 + r1) // 2, :], (c0 + c1) // 2, c0, c1
                sides = [rooms[r0 - 1, :], rooms[r1, :]]
            else:
                line, at, lo, hi = occ[:, (c0 + c1) // 2], (r0 + r1) // 2, r0, r1
                sides = [rooms[:, c0 - 1], rooms[:, c1]]
            gap = runs(line[None, :] == 0, 1)[0, at]
            assert abs(gap * res - door.width) < EPS and line[lo - 1] == 1 and line[hi] == 1
            widths.append(door.width)
            # Flush in a corner: beside the door's end, on one side, the room stops (its side wall).
            in_corner = any(side[lo] > 0 and side[lo - 1] != side[lo] or side[hi - 1] > 0 and side[hi] != side[hi - 1]
                            for side in sides)
            assert in_corner or not door.corner
            total += 1
            flush += in_corner
            corners += door.corner
    assert all(within(w, HARD_DOOR_WIDTH) for w in widths)
    assert sum(w <= 0.65 for w in widths) >= 2 and sum(w >= 1.3 for w in widths) >= 4, sorted(widths)
    assert 0.25 <= corners / total <= 0.5 and corners <= flush <= 0.7 * total, (corners, flush, total)


def test_hard_plans_have_specks_and_wall_cells_missing(hard_plans: dict[int, FloorPlan]) -> None:
    for plan in hard_plans.values():
        occ, rooms, res = plan.occupancy, plan.rooms, plan.frame.resolution
        assert 4 <= len(plan.specks) and 8 <= len(plan.holes), describe(plan)
        to_gap = ndimage.distance_transform_edt(~plan.door_cells()) * res
        for r0, r1, c0, c1 in plan.specks:
            assert (r1 - r0) * (c1 - c0) <= 2
            assert (occ[r0:r1, c0:c1] == 1).all() and (rooms[r0:r1, c0:c1] == 0).all()
            ring = occ[r0 - 1:r1 + 1, c0 - 1:c1 + 1].copy()
            ring[1:-1, 1:-1] = 0
            assert (ring == 0).all()  # isolated
            assert to_gap[r0:r1, c0:c1].min() >= 1.0 - EPS  # never in (or near) a doorway
        cells = set(plan.holes)
        for r, c in plan.holes:
            assert occ[r, c] == 0 and rooms[r, c] > 0
            around = rooms[r - 1:r + 2, c - 1:c + 2]
            assert set(np.unique(around).tolist()) == {0, int(rooms[r, c])}  # one room's wall face
            assert not (plan.door_cells()[r - 1:r + 2, c - 1:c + 2]).any()
            assert not any((r + dr, c + dc) in cells for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc)


def test_cluttered_corridors_keep_a_metre_free(hard_cluttered: dict[int, FloorPlan]) -> None:
    bare = generate_plan(3)
    plan = generate_plan(3, clutter_corridors=True)
    res = plan.frame.resolution
    corridor = [f for f in plan.furniture if f.room in plan.corridors]
    assert len(corridor) >= 3 and {f.kind for f in corridor} <= {"bench", "printer", "locker", "plant"}
    assert np.array_equal(plan.rooms, np.where(furniture_mask(plan), 0, bare.rooms))
    clear = round(CORRIDOR_CLEAR / res)
    for item in corridor:
        r0, r1, c0, c1 = item.box
        assert item.placement == "wall" and (bare.rooms[r0:r1, c0:c1] == item.room).all()
        ahead = {"top": (r1, r1 + clear, c0, c1), "bottom": (r0 - clear, r0, c0, c1),
                 "left": (r0, r1, c1, c1 + clear), "right": (r0, r1, c0 - clear, c0)}[item.side]
        behind = {"top": (r0 - 1, r0, c0, c1), "bottom": (r1, r1 + 1, c0, c1),
                  "left": (r0, r1, c0 - 1, c0), "right": (r0, r1, c1, c1 + 1)}[item.side]
        assert (plan.occupancy[ahead[0]:ahead[1], ahead[2]:ahead[3]] == 0).all()  # 1 m of corridor in front
        assert (bare.occupancy[behind[0]:behind[1], behind[2]:behind[3]] == 1).all()  # a wall behind
    for hard in hard_cluttered.values():
        assert any(f.room in hard.corridors for f in hard.furniture)
        assert any(f.room not in hard.corridors for f in hard.furniture)


def test_a_hard_plan_at_0_1_m_keeps_its_walls_closed(tmp_path: Path) -> None:
    plan = generate_plan(0, hard=True, furniture=True, resolution=0.1)  # 1-cell walls, turned: thickened first
    assert plan.rotation != 0.0
    rooms = plan.rooms
    _, count = ndimage.label(rooms > 0, structure=np.ones((3, 3)))
    assert count == plan.n_rooms
    unknown = np.isnan(plan.occupancy)
    assert not (ndimage.binary_dilation(unknown, structure=np.ones((3, 3))) & (plan.occupancy == 0)).any()
    write_plan(plan, tmp_path, "hard")
    truth, info = read_truth(tmp_path, "hard")
    assert np.array_equal(truth, rooms) and info["rotation"] == plan.rotation
    assert [tuple(c) for c in info["holes"]] == list(plan.holes)


# -- the scorer --------------------------------------------------------------------------------

def test_the_ground_truth_scores_perfectly(plans: dict[int, FloorPlan]) -> None:
    plan = plans[0]
    result = score(plan.rooms, plan.rooms)
    assert result.mean_recall == result.mean_precision == result.pixel_precision == 1.0
    assert result.owned_rooms == result.n_rooms == result.n_places == plan.n_rooms
    assert result.owned_fraction == 1.0 and result.max_rooms_per_place == 1
    assert result.merged_rooms == result.split_rooms == result.places_off_rooms == 0
    # Places that spill over the walls are not wrong: only pixels on rooms count.
    spilled = np.where(plan.rooms > 0, plan.rooms, ndimage.grey_dilation(plan.rooms, size=(7, 7)))
    assert score(spilled, plan.rooms).to_dict() | {"rooms": None} == result.to_dict() | {"rooms": None}


def two_rooms_with_a_door(plan: FloorPlan) -> tuple[int, int]:
    return next(d.rooms for d in plan.doors if "corridor" not in {plan.room_kinds[r - 1] for r in d.rooms})


def test_a_place_over_two_rooms_is_reported_merged(plans: dict[int, FloorPlan]) -> None:
    plan = plans[1]
    a, b = two_rooms_with_a_door(plan)
    places = np.where(plan.rooms == b, a, plan.rooms)
    result = score(places, plan.rooms)
    assert result.merged_rooms == 2 and result.merged_places == 1 and result.max_rooms_per_place == 2
    assert result.n_places == plan.n_rooms - 1 and result.mean_recall == 1.0 and result.split_rooms == 0
    # The larger of the two still owns the place (IoU = its share >= 0.5), the smaller does not.
    assert result.owned_rooms == plan.n_rooms - 1
    areas = plan.room_areas()
    assert result.pixel_precision == pytest.approx(1 - min(areas[a - 1], areas[b - 1]) / areas.sum())


def test_a_room_over_two_places_is_reported_split(plans: dict[int, FloorPlan]) -> None:
    plan = plans[2]
    big = int(np.argmax(np.where(np.array(plan.room_kinds) == "corridor", 0, plan.room_areas()))) + 1
    rows, cols = np.nonzero(plan.rooms == big)
    places = plan.rooms.copy()
    right = cols > np.median(cols)
    places[rows[right], cols[right]] = plan.n_rooms + 1
    result = score(places, plan.rooms)
    assert result.split_rooms == 1 and result.merged_rooms == 0 and result.n_places == plan.n_rooms + 1
    assert result.mean_precision == 1.0
    recall = dict(zip(result.room_labels, result.room_recall))[big]
    assert 0.5 <= recall < 0.6
    # A sliver of another place (under 20 % of the room) is not a split.
    places = plan.rooms.copy()
    sliver = cols > np.quantile(cols, 0.9)
    places[rows[sliver], cols[sliver]] = plan.n_rooms + 1
    assert score(places, plan.rooms).split_rooms == 0


def test_places_off_the_rooms_are_counted_but_not_scored(plans: dict[int, FloorPlan]) -> None:
    plan = plans[0]
    places = plan.rooms.copy()
    places[np.isnan(plan.occupancy)] = 999  # a place outside the building
    result = score(places, plan.rooms)
    assert result.n_places == plan.n_rooms + 1 and result.places_off_rooms == 1
    assert result.mean_precision == 1.0 and result.owned_fraction == 1.0
    nothing = score(np.zeros_like(plan.rooms), plan.rooms)
    assert nothing.mean_recall == 0.0 and np.isnan(nothing.mean_precision) and nothing.owned_rooms == 0
    assert nothing.to_dict()["mean_precision"] is None
    json.dumps(nothing.to_dict(), allow_nan=False)
    with pytest.raises(ValueError):
        score(places[:-1], plan.rooms)


def test_the_score_does_not_depend_on_how_the_places_are_numbered(plans: dict[int, FloorPlan],
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    import floorplans

    plan = plans[4]
    a, b = two_rooms_with_a_door(plan)
    places = np.where(plan.rooms == b, a, plan.rooms)
    places[np.isnan(plan.occupancy)] = plan.n_rooms + 1
    expected = score(places, plan.rooms)
    assert expected.place_precision[-1] != expected.place_precision[-1]  # NaN: the place off the rooms
    renumbered = score(np.where(places > 0, places.astype(np.int64) * 10 ** 9 + 7, 0), plan.rooms)  # sorted, huge
    monkeypatch.setattr(floorplans, "_DENSE_BINS", 0)  # count the pairs that occur instead of a table
    sparse = score(places, plan.rooms)
    unlabelled = {k: v for k, v in expected.to_dict().items() if k not in ("rooms", "places")}
    for other in (renumbered, sparse):
        assert {k: v for k, v in other.to_dict().items() if k not in ("rooms", "places")} == unlabelled
        assert other.room_recall == expected.room_recall and other.room_iou == expected.room_iou
        assert np.array_equal(other.place_precision, expected.place_precision, equal_nan=True)
    assert sparse.to_dict() == expected.to_dict()
    json.dumps(expected.to_dict(), allow_nan=False)


def test_the_scorer_takes_a_4000_by_4000_image_in_well_under_a_second() -> None:
    cells = np.arange(4000)
    rooms = ((cells[:, None] // 200) * 20 + cells[None, :] // 200 + 1).astype(np.int32)
    rooms[(cells % 200 < 4)[:, None] | (cells % 200 < 4)[None, :]] = 0  # walls
    places = ((cells[:, None] // 130) * 40 + (cells[None, :] + 50) // 130 + 1).astype(np.int32)
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        result = score(places, rooms)
        best = min(best, time.perf_counter() - start)
    assert result.n_rooms == 400 and result.split_rooms > 0
    assert best < 1.0, f"{best:.2f} s"


# -- the shipped worlds' rooms ------------------------------------------------------------------

@pytest.mark.parametrize("name", shipped_worlds())
def test_every_shipped_world_gives_each_named_place_a_label(name: str) -> None:
    world = load_world(name)
    frame = GridFrame.covering(world.bounds, 0.05)
    labels = world_rooms(world, frame)
    names = world_room_names(world)
    assert names == tuple(world.places)
    areas = np.bincount(labels.ravel(), minlength=len(names) + 1)[1:]
    assert len(areas) == len(names) and (areas > 0).all(), dict(zip(names, areas))
    # A cell's label is the place World.place_at finds at its centre.
    rng = np.random.default_rng(0)
    rows, cols = rng.integers(0, frame.height, 300), rng.integers(0, frame.width, 300)
    xs, ys = frame.cell_to_world(rows, cols)
    expected = [names.index(p) + 1 if (p := world.place_at(x, y)) else 0 for x, y in zip(xs, ys)]
    assert labels[rows, cols].tolist() == expected

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
                        ROOM_AREA, ROOMS_PER_PLAN, SLAM_ANTIALIAS, SLAM_PATCH, SLAM_UNSEEN_RUN, SLAM_UNSEEN_SHARE,
                        SLIVER, WALL_THICKNESS, WING_CORRIDOR_WIDTH, WING_LAYOUTS, WING_ROOM_DEPTH, WING_ROOM_WIDTH,
                        FloorPlan, generate_plan, read_truth, score, world_room_names, world_rooms, write_plan)

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
    hard = f", {'slam' if plan.slam else 'hard'}, turned {plan.rotation:g} deg" if plan.hard else ""
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
    assert cli.main(["--seed", "3", "--furniture", "--out", str(tmp_path / "plain")]) == 0
    names = {p.name for p in (tmp_path / "plain").iterdir()}
    assert {"plan-3.yaml", "plan-3.pgm", "plan-3-rooms.png", "plan-3-rooms.json", "plan-3-preview.png"} <= names
    # the example of docs/how-to/maps.md: a SLAM-like scan, written and scored
    assert cli.main(["--seed", "3", "--furniture", "--slam", "--out", str(tmp_path / "slam"), "--score"]) == 0
    _, truth = read_truth(tmp_path / "slam", "plan-3")
    assert truth["slam"] is True and truth["hard"] is True


# -- hard plans --------------------------------------------------------------------------------

HARD_SEEDS = range(10)  # seeds 3, 4 and 8 are not turned; 2, 5, 6 are double-loaded, 8 and 9 L-shaped
MORE_HARD_SEEDS = range(10, 30)  # 11, 12, 19 and 23 are not turned; 12 and 15 are U-shaped


@pytest.fixture(scope="module")
def hard_plans() -> dict[int, FloorPlan]:
    return {seed: generate_plan(seed, hard=True) for seed in HARD_SEEDS}


@pytest.fixture(scope="module")
def many_hard(hard_plans: dict[int, FloorPlan]) -> dict[int, FloorPlan]:
    """Thirty hard plans, for the shares of layouts, wall thicknesses and second doors."""
    return hard_plans | {seed: generate_plan(seed, hard=True) for seed in MORE_HARD_SEEDS}


@pytest.fixture(scope="module")
def hard_cluttered() -> dict[int, FloorPlan]:
    return {seed: generate_plan(seed, hard=True, furniture=True, clutter_corridors=True) for seed in (0, 5, 7)}


def straight(plans: dict[int, FloorPlan]) -> list[FloorPlan]:
    """The plans that were not turned (their doors' boxes are their gaps)."""
    found = [p for p in plans.values() if p.rotation == 0.0]
    assert len(found) >= 2
    return found


def assert_rooms_are_the_free_pieces(plan: FloorPlan) -> None:
    """The room rule on a plan's images, turned or not, SLAM or not.

    Each room is one piece and no two touch, not even diagonally; the free
    cells in no room are door gaps, each in a door's box between its
    rooms; the image's border is unknown. Unless the plan is a SLAM scan
    (whose unknown may border anything), the outside is one piece that
    never touches a free cell.
    """
    rooms, free = plan.rooms, plan.occupancy == 0
    pieces, count = ndimage.label(rooms > 0)
    assert count == plan.n_rooms, describe(plan)
    index = np.arange(1, count + 1)
    assert np.array_equal(ndimage.minimum(rooms, pieces, index), ndimage.maximum(rooms, pieces, index))
    for a, b in ((rooms[1:], rooms[:-1]), (rooms[:, 1:], rooms[:, :-1]),
                 (rooms[1:, 1:], rooms[:-1, :-1]), (rooms[1:, :-1], rooms[:-1, 1:])):
        assert not ((a != b) & (a > 0) & (b > 0)).any(), describe(plan)
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
    unknown = np.isnan(plan.occupancy)
    assert unknown[0].all() and unknown[-1].all() and unknown[:, 0].all() and unknown[:, -1].all()
    if not plan.slam:
        assert ndimage.label(unknown)[1] == 1
        assert not (ndimage.binary_dilation(unknown, structure=np.ones((3, 3))) & free).any()


def assert_connected_for_the_robot(plan: FloorPlan) -> None:
    """The robot's space (radius 0.2 m) is one piece that reaches every room."""
    space = robot_space(plan.occupancy == 0, plan)
    _, count = ndimage.label(space)
    assert count == 1, describe(plan)
    assert ndimage.maximum(space, plan.rooms, np.arange(1, plan.n_rooms + 1)).all(), describe(plan)


def test_plain_plans_are_still_the_plans_of_old() -> None:
    """Benchmarks and tests depend on the plain plans: the same arrays for the same seed as before ``hard``."""
    import hashlib

    for seed, furniture, digest in (
            (0, False, "d231f66ac0bf904ef2945b66820941cb5b91d48005b96a0da85fcd137be29a48"),
            (1, True, "ceae0668ed962c93541059462c4aec91b59b6508df08bdceba2da2ddc2398f2d")):
        plan = generate_plan(seed, furniture=furniture, hard=False, clutter_corridors=False)
        assert hashlib.sha256(plan.occupancy.tobytes() + plan.rooms.tobytes()).hexdigest() == digest
        assert not plan.hard and plan.rotation == 0.0 and plan.specks == plan.holes == ()
        assert not plan.slam and plan.layout not in WING_LAYOUTS


def test_hard_plans_are_drawn_from_the_seed_and_are_the_plain_plans_building_or_one_of_wings(
        hard_plans: dict[int, FloorPlan], hard_cluttered: dict[int, FloorPlan]) -> None:
    a = generate_plan(7, hard=True, furniture=True, clutter_corridors=True)
    b = hard_cluttered[7]
    assert np.array_equal(a.occupancy, b.occupancy, equal_nan=True) and np.array_equal(a.rooms, b.rooms)
    assert (a.doors, a.furniture, a.frame, a.rotation, a.specks, a.holes) == \
        (b.doors, b.furniture, b.frame, b.rotation, b.specks, b.holes)
    assert np.array_equal(a.furniture_cells(), b.furniture_cells())
    for seed in (3, 7):  # not wings: the plain plan's building, its doors, and some second doors
        plain, hard = generate_plan(seed), hard_plans[seed]
        assert hard.layout == plain.layout
        assert hard.hard and hard.room_names == plain.room_names and hard.room_kinds == plain.room_kinds
        assert {d.rooms for d in hard.doors} == {d.rooms for d in plain.doors}
        assert len(hard.doors) >= len(plain.doors)
        assert hard.rooms.shape != plain.rooms.shape or not np.array_equal(hard.rooms, plain.rooms)
    wings = generate_plan(2, hard=True)
    assert wings.layout == "double-loaded" and generate_plan(2).layout not in WING_LAYOUTS
    assert generate_plan(2, hard=True, size=(30.0, 20.0)).layout not in WING_LAYOUTS  # a size: no wings
    angles = [p.rotation for p in hard_plans.values()]
    assert 0.0 in angles and sum(a != 0.0 for a in angles) >= len(angles) // 2
    assert all(abs(a) <= HARD_ROTATION for a in angles) and min(angles) < 0 < max(angles)


@pytest.mark.parametrize("which", ["clean", "cluttered"])
def test_hard_rooms_are_the_free_space_with_the_doors_closed(
        which: str, hard_plans: dict[int, FloorPlan], hard_cluttered: dict[int, FloorPlan]) -> None:
    for plan in (hard_plans if which == "clean" else hard_cluttered).values():
        assert_rooms_are_the_free_pieces(plan)


@pytest.mark.parametrize("which", ["clean", "cluttered"])
def test_hard_plans_are_connected_for_a_robot_of_radius_0_2(
        which: str, hard_plans: dict[int, FloorPlan], hard_cluttered: dict[int, FloorPlan]) -> None:
    plans = hard_plans if which == "clean" else hard_cluttered
    assert any(p.rotation != 0 for p in plans.values())
    for plan in plans.values():
        assert_connected_for_the_robot(plan)


def inner_walls(plan: FloorPlan) -> list[int]:
    """The thickness (cells) of a straight plan's inner walls: for each two rooms with a door between them
    (so facing each other across a wall), the shortest run of occupied cells from one to the other along a
    row or a column (holes put back in their walls first)."""
    occ, rooms = np.array(plan.occupancy), np.array(plan.rooms)
    for r, c in plan.holes:
        occ[r, c], rooms[r, c] = 1.0, 0
    shortest: dict[tuple[int, int], int] = {}
    for grid, labels in ((occ, rooms), (occ.T, rooms.T)):
        steps = np.diff(np.pad(grid == 1, ((0, 0), (1, 1))).astype(np.int8), axis=1)
        rows, starts = np.nonzero(steps == 1)
        _, ends = np.nonzero(steps == -1)
        inside = (starts > 0) & (ends < grid.shape[1])
        rows, starts, ends = rows[inside], starts[inside], ends[inside]
        a, b = labels[rows, starts - 1], labels[rows, ends]
        for x, y, n in zip(np.minimum(a, b).tolist(), np.maximum(a, b).tolist(), (ends - starts).tolist()):
            if x > 0 and x != y:
                shortest[x, y] = min(n, shortest.get((x, y), n))
    return [shortest[d.rooms] for d in plan.doors if d.rooms in shortest]


def test_hard_walls_are_each_1_to_8_cells_thick_inner_and_outer(many_hard: dict[int, FloorPlan]) -> None:
    inner, outer = [], []
    for plan in straight(many_hard):
        res, rooms = plan.frame.resolution, plan.rooms
        inner += [round(n * res, 6) for n in inner_walls(plan)]
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
    assert all(within(t, HARD_WALL_THICKNESS) for t in inner), sorted(set(inner))
    assert set(np.round(np.array(inner) / 0.05).astype(int).tolist()) == set(range(1, 9))  # 1-8 cells, all seen
    outer = np.array(outer)
    assert outer.min() >= HARD_OUTER_THICKNESS[0] - EPS
    assert np.mean(outer <= HARD_OUTER_THICKNESS[1] + EPS) > 0.95  # (rows along an inner wall run on)
    assert {0.05, 0.1} <= set(outer.tolist()) and (outer[outer <= HARD_OUTER_THICKNESS[1] + EPS] >= 0.3).any()


def test_a_turn_keeps_walls_of_one_cell_where_it_can(hard_plans: dict[int, FloorPlan]) -> None:
    """Turned plans keep 1-cell walls (a wall cell with two rooms on opposite sides); thickened only where needed."""
    turned = [p for p in hard_plans.values() if p.rotation != 0.0]
    thin = []
    for plan in turned:
        r = np.pad(plan.rooms, 1)
        wall = np.pad(plan.occupancy == 1, 1)
        across = ((r[:-2, 1:-1] > 0) & (r[2:, 1:-1] > 0) & (r[:-2, 1:-1] != r[2:, 1:-1])) | \
            ((r[1:-1, :-2] > 0) & (r[1:-1, 2:] > 0) & (r[1:-1, :-2] != r[1:-1, 2:]))
        thin.append(int((across & wall[1:-1, 1:-1]).sum()))
    assert sum(n > 50 for n in thin) >= len(turned) // 2, thin


def test_hard_plans_draw_buildings_of_wings_two_times_in_five(many_hard: dict[int, FloorPlan]) -> None:
    """Double-loaded corridors, and L and U buildings of them: rooms of 3-5 x 3.5-5 m along one corridor network."""
    layouts = [p.layout for p in many_hard.values()]
    assert set(WING_LAYOUTS) <= set(layouts), layouts
    assert 0.25 <= sum(w in WING_LAYOUTS for w in layouts) / len(layouts) <= 0.6, layouts
    side = (min(WING_ROOM_WIDTH[0], WING_ROOM_DEPTH[0]) - 0.35, max(WING_ROOM_WIDTH[1], WING_ROOM_DEPTH[1]) + 0.35)
    for plan in many_hard.values():
        if plan.layout not in WING_LAYOUTS:
            continue
        assert ROOMS_PER_PLAN[0] <= plan.n_rooms <= ROOMS_PER_PLAN[1], describe(plan)
        corridors = set(plan.corridors)
        # The corridors are one network: every corridor reaches the first through doors between corridors.
        joined, todo = {min(corridors)}, [min(corridors)]
        while todo:
            here = todo.pop()
            for door in plan.doors_of(here):
                other = (set(door.rooms) - {here}).pop()
                if other in corridors and other not in joined:
                    joined.add(other)
                    todo.append(other)
        assert joined == corridors, describe(plan)
        areas, onto = plan.room_areas(), 0
        for label, kind in enumerate(plan.room_kinds, start=1):
            if kind not in ("corridor", "open-plan"):  # a room of a row: 3-5 m by 3.5-5 m (its sides moved a bit)
                assert side[0] ** 2 <= areas[label - 1] <= side[1] ** 2, describe(plan)
            onto += kind != "corridor" and any(corridors & set(d.rooms) for d in plan.doors_of(label))
        assert onto >= 0.7 * (plan.n_rooms - len(corridors)), describe(plan)  # rows along corridors
        if plan.rotation != 0.0:
            continue
        res = plan.frame.resolution
        corridor = np.isin(plan.rooms, list(corridors))
        width = np.minimum(runs(corridor, 0), runs(corridor, 1))[corridor] * res
        assert within(float(np.median(width)), (WING_CORRIDOR_WIDTH[0] - 0.35, WING_CORRIDOR_WIDTH[1] + 0.35))
        rows, cols = np.nonzero(~np.isnan(plan.occupancy))
        box = np.isnan(plan.occupancy[rows.min():rows.max() + 1, cols.min():cols.max() + 1])
        if plan.layout == "double-loaded":  # a rectangle, its corridor from end wall to end wall
            length = max(corridor.any(axis=0).sum(), corridor.any(axis=1).sum()) * res
            assert not box.any() and length >= max(box.shape) * res - 2 * HARD_OUTER_THICKNESS[1] - EPS
        else:  # an L or a U: outside fills a good part of the bounding box, corridors run both ways
            assert box.mean() >= 0.15, describe(plan)
            assert (runs(corridor, 0) * res >= 8.0).any() and (runs(corridor, 1) * res >= 8.0).any()
        for label, kind in enumerate(plan.room_kinds, start=1):
            if kind not in ("corridor", "open-plan"):
                rr, cc = np.nonzero(plan.rooms == label)
                dims = sorted(((rr.max() - rr.min() + 1) * res, (cc.max() - cc.min() + 1) * res))
                assert side[0] <= dims[0] and dims[1] <= side[1], (describe(plan), label, dims)


def test_some_rooms_have_a_second_door_onto_their_corridor(many_hard: dict[int, FloorPlan]) -> None:
    with_one = with_two = 0
    for plan in many_hard.values():
        corridors = set(plan.corridors)
        for label, kind in enumerate(plan.room_kinds, start=1):
            if kind == "corridor":
                continue
            doors = plan.doors_of(label)
            assert 1 <= len(doors) <= 3, describe(plan)
            onto = [(set(d.rooms) - {label}).pop() for d in doors if corridors & set(d.rooms)]
            with_one += bool(onto)
            with_two += len(onto) > len(set(onto))
    assert 0.07 <= with_two / with_one <= 0.3, (with_two, with_one)  # a fifth of those with room for a second


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
    plan = generate_plan(0, hard=True, furniture=True, resolution=0.1)  # 1-cell walls, turned: thickened where rooms would touch
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


# -- slam plans --------------------------------------------------------------------------------

SLAM_SEEDS = (0, 2, 3, 5, 8)  # turned L, turned double-loaded, straight T, turned double-loaded, straight L-shaped


@pytest.fixture(scope="module")
def slam_plans() -> dict[int, FloorPlan]:
    return {seed: generate_plan(seed, slam=True) for seed in SLAM_SEEDS}


@pytest.fixture(scope="module")
def slam_furnished() -> dict[int, FloorPlan]:
    return {seed: generate_plan(seed, slam=True, furniture=True, clutter_corridors=True) for seed in (0, 5)}


def wall_faces(plan: FloorPlan) -> np.ndarray:
    """The wall cells next to a room cell (corners too) of a plan."""
    return (plan.occupancy == 1) & ndimage.binary_dilation(plan.rooms > 0, np.ones((3, 3), dtype=bool))


def test_a_slam_plan_is_the_hard_plan_of_its_seed_scanned(hard_plans: dict[int, FloorPlan],
                                                          slam_plans: dict[int, FloorPlan]) -> None:
    again = generate_plan(3, slam=True)
    assert np.array_equal(again.occupancy, slam_plans[3].occupancy, equal_nan=True)
    assert np.array_equal(again.rooms, slam_plans[3].rooms) and again.unexplored == slam_plans[3].unexplored
    for seed, scan in slam_plans.items():
        hard = hard_plans[seed]
        assert scan.slam and scan.hard and not hard.slam and hard.unexplored == ()
        assert (scan.frame, scan.layout, scan.rotation, scan.doors, scan.room_names, scan.room_kinds) == \
            (hard.frame, hard.layout, hard.rotation, hard.doors, hard.room_names, hard.room_kinds)
        # A room's cells in the scan were its cells in the hard plan, or wall cells beside them (a face moved in).
        rooms = scan.rooms > 0
        same = rooms & (scan.rooms == hard.rooms)
        moved_in = rooms & ~same
        assert (hard.occupancy[moved_in] == 1).all(), describe(scan)
        beside = np.zeros_like(moved_in)
        for axis, shift in ((0, 1), (0, -1), (1, 1), (1, -1)):
            beside |= np.roll(hard.rooms, shift, axis) == scan.rooms
        assert beside[moved_in].all()
        assert (scan.rooms[scan.occupancy != 0] == 0).all()


@pytest.mark.parametrize("which", ["clean", "furnished"])
def test_slam_rooms_are_the_free_space_with_the_doors_closed_and_connected(
        which: str, slam_plans: dict[int, FloorPlan], slam_furnished: dict[int, FloorPlan]) -> None:
    for plan in (slam_plans if which == "clean" else slam_furnished).values():
        assert_rooms_are_the_free_pieces(plan)
        assert_connected_for_the_robot(plan)


def test_slam_walls_read_unknown_in_stretches_of_0_5_to_3_m(hard_plans: dict[int, FloorPlan],
                                                           slam_plans: dict[int, FloorPlan]) -> None:
    eight = np.ones((3, 3), dtype=bool)
    for seed, scan in slam_plans.items():
        res, face = scan.frame.resolution, wall_faces(hard_plans[seed])
        unseen = face & np.isnan(scan.occupancy)
        share = unseen.sum() / face.sum()
        assert SLAM_UNSEEN_SHARE[0] - 0.05 <= share <= SLAM_UNSEEN_SHARE[1] + 0.1, (describe(scan), share)
        # Runs along the faces: most of the unseen cells lie in stretches of 0.5 m or more, mostly up to 3 m.
        stretches, _ = ndimage.label(unseen, eight)
        sizes = np.bincount(stretches.ravel())[1:]
        extent = np.array([max(a.stop - a.start, b.stop - b.start) * res for a, b in ndimage.find_objects(stretches)])
        long = extent >= SLAM_UNSEEN_RUN[0] - EPS
        assert sizes[long].sum() >= 0.85 * sizes.sum() and np.median(extent[long]) <= SLAM_UNSEEN_RUN[1]
        # Unknown is no longer only the outside: some rooms border it (a wall unseen through), inside too.
        unknown = np.isnan(scan.occupancy)
        pieces, count = ndimage.label(unknown)
        outside = pieces == pieces[0, 0]
        assert count > 1 and (ndimage.binary_dilation(outside, eight) & (scan.occupancy == 0)).any()


def test_slam_plans_have_unexplored_patches_of_0_2_to_1_m_in_nooks(hard_plans: dict[int, FloorPlan],
                                                                  slam_plans: dict[int, FloorPlan]) -> None:
    for seed, scan in slam_plans.items():
        hard, res = hard_plans[seed], scan.frame.resolution
        assert 1 <= len(scan.unexplored) <= scan.n_rooms // 2 + 2, describe(scan)
        to_gap = ndimage.distance_transform_edt(~hard.door_cells()) * res
        for r0, r1, c0, c1 in scan.unexplored:
            assert max(r1 - r0, c1 - c0) * res <= SLAM_PATCH[1] + res + EPS
            box = (slice(r0, r1), slice(c0, c1))
            taken = np.isnan(scan.occupancy[box]) & (hard.rooms[box] > 0)  # floor the scan did not see
            assert taken.any() and (hard.occupancy[box] == 1).any()  # ... against a wall (or furniture)
            assert to_gap[box][taken].min() >= 0.5 - EPS  # clear of the doors


def test_slam_plans_have_ragged_walls_grey_edges_and_speckle(hard_plans: dict[int, FloorPlan],
                                                            slam_plans: dict[int, FloorPlan]) -> None:
    cross = ndimage.generate_binary_structure(2, 1)
    for seed, scan in slam_plans.items():
        hard, occ = hard_plans[seed], scan.occupancy
        known = ~np.isnan(occ)
        grey = known & (occ > 0) & (occ < 1)
        blocked = ~known | (occ != 0)
        alone = ndimage.convolve(blocked.astype(np.int32), np.ones((3, 3), dtype=np.int32), mode="constant") == 1
        was_room = hard.rooms > 0
        # Anti-aliased edges: wall faces of 0.55-0.9.
        edges = grey & wall_faces(hard)
        assert edges.sum() >= 0.05 * wall_faces(hard).sum(), describe(scan)
        assert (occ[edges] >= SLAM_ANTIALIAS[0] - EPS).all() and (occ[edges] <= SLAM_ANTIALIAS[1] + EPS).all()
        # Speckle: single cells on the floor, most occupied, a few grey (0.25-0.75).
        specks = was_room & blocked & known & alone
        grey_specks = specks & grey
        assert specks.sum() >= 10 and 1 <= grey_specks.sum() <= 0.5 * specks.sum(), describe(scan)
        assert (occ[grey_specks] >= 0.25 - EPS).all() and (occ[grey_specks] <= 0.75 + EPS).all()
        assert (occ[specks & ~grey] == 1).all()
        # Ragged walls: faces moved out (floor next to a wall now occupied) and in (wall now floor).
        moved_out = was_room & blocked & known & ~alone & ndimage.binary_dilation(hard.occupancy == 1, cross)
        moved_in = (hard.occupancy == 1) & (scan.rooms > 0)
        assert moved_out.sum() >= 20 and moved_in.sum() >= 20, describe(scan)


def test_a_slam_plan_round_trips_through_its_ros_map(slam_plans: dict[int, FloorPlan], tmp_path: Path) -> None:
    plan = slam_plans[2]
    yaml = write_plan(plan, tmp_path, "slam-2")
    rosmap = load_ros_map(yaml)
    # A trinary reader's view of the 8-bit pixels: unknown between the thresholds.
    occ = (255 - np.rint(255 * (1 - np.nan_to_num(plan.occupancy, nan=0.5)))) / 255
    expected = np.select([np.isnan(plan.occupancy), occ < 0.196, occ > 0.65], [UNKNOWN, FREE, OCCUPIED], UNKNOWN)
    assert np.array_equal(rosmap.labels, expected)
    rooms, info = read_truth(tmp_path, "slam-2")
    assert np.array_equal(rooms, plan.rooms) and info["slam"] is True
    assert [tuple(b) for b in info["unexplored"]] == list(plan.unexplored)


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


def test_the_score_does_not_depend_on_how_the_places_are_numbered(plans: dict[int, FloorPlan]) -> None:
    plan = plans[4]
    a, b = two_rooms_with_a_door(plan)
    places = np.where(plan.rooms == b, a, plan.rooms)
    places[np.isnan(plan.occupancy)] = plan.n_rooms + 1
    expected = score(places, plan.rooms)
    assert expected.place_precision[-1] != expected.place_precision[-1]  # NaN: the place off the rooms
    renumbered = score(np.where(places > 0, places.astype(np.int64) * 10 ** 9 + 7, 0), plan.rooms)  # sorted, huge
    sparse = score(places, plan.rooms, dense_bins=0)  # count the pairs that occur instead of a table
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

"""Scan-to-map matching (issue 27, part 3: mapping that corrects its own pose), on maps drawn by hand: a
room, whose walls fix the pose in x, y and heading, and a corridor, whose walls fix it across and not
along. The sonar is reduced to its axis (one ray a beam) so that the ranges can be worked out exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.maps.scan_matching import MapMatcher, MatchSettings, SettledMap, correlative_match, scan_points

ANGLES = np.arange(16) * (2 * math.pi / 16)
RADIUS, MAX_RANGE = 0.2, 5.0
FRAME = GridFrame.covering((-1.0, -1.0, 11.0, 5.0), 0.05)


def box_ranges(pose, box):
    """The sonar's readings (from the rim, along each axis) of a robot at ``pose`` inside the axis-aligned
    ``box`` (xmin, ymin, xmax, ymax); a wall further than the sonar's range reads as no echo."""
    x, y, heading = pose
    xmin, ymin, xmax, ymax = box
    ranges = []
    for angle in ANGLES + heading:
        c, s = math.cos(angle), math.sin(angle)
        reach = min(((xmax - x) / c if c > 1e-9 else math.inf), ((xmin - x) / c if c < -1e-9 else math.inf),
                    ((ymax - y) / s if s > 1e-9 else math.inf), ((ymin - y) / s if s < -1e-9 else math.inf))
        ranges.append(min(reach - RADIUS, MAX_RANGE))
    return np.array(ranges)


def drawn_map(box, sides=("left", "right", "bottom", "top")):
    """Log-odds of a grid that has seen the inside of ``box`` free and the named sides as walls."""
    xmin, ymin, xmax, ymax = box
    rows, cols = np.indices(FRAME.shape)
    x, y = FRAME.cell_to_world(rows, cols)
    inside = (x > xmin) & (x < xmax) & (y > ymin) & (y < ymax)
    near = {"left": abs(x - xmin), "right": abs(x - xmax), "bottom": abs(y - ymin), "top": abs(y - ymax)}
    wall = np.zeros(FRAME.shape, dtype=bool)
    for side in sides:
        along = (y >= ymin - 0.05) & (y <= ymax + 0.05) if side in ("left", "right") else \
            (x >= xmin - 0.05) & (x <= xmax + 0.05)
        wall |= (near[side] <= 0.05) & along
    log_odds = np.where(wall, 10.0, np.where(inside, -10.0, 0.0)).astype(np.float32)
    return log_odds, wall | inside


def local_scan(truth, box, back=1.5, step=0.1):
    """Rings read while driving to ``truth`` along its heading over the last ``back`` metres, placed by
    the (here exact) odometry: the points of :func:`scan_points` and how many rings they are."""
    x, y, heading = truth
    rings = []
    for travelled in np.arange(back, -1e-9, -step):
        pose = (x - travelled * math.cos(heading), y - travelled * math.sin(heading), heading)
        rings.append((pose, box_ranges(pose, box)))
    return scan_points(rings, truth, ANGLES, RADIUS, MAX_RANGE, 0.0, 1), len(rings)


def test_in_a_room_the_match_pulls_an_offset_pose_back_in_x_y_and_heading():
    room = (1.0, 0.0, 5.0, 3.0)
    reference = SettledMap(*drawn_map(room), FRAME, MatchSettings())
    truth = (3.2, 1.4, 0.3)
    points, rings = local_scan(truth, room)
    believed = (truth[0] + 0.12, truth[1] - 0.1, truth[2] + math.radians(2.5))
    match = correlative_match(reference, believed, points, rings, MatchSettings())
    assert match is not None, "a room seen all round is matched"
    corrected = [b + c for b, c in zip(believed, match.correction)]
    before = math.hypot(believed[0] - truth[0], believed[1] - truth[1])
    after = math.hypot(corrected[0] - truth[0], corrected[1] - truth[1])
    print(f"position error {before:.3f} m -> {after:.3f} m, heading "
          f"{math.degrees(believed[2] - truth[2]):.2f} -> {math.degrees(corrected[2] - truth[2]):.2f} degrees")
    assert after < before / 2
    assert abs(corrected[2] - truth[2]) < abs(believed[2] - truth[2]) / 2


def test_in_a_corridor_the_match_corrects_across_it_and_leaves_the_pose_along_it_alone():
    corridor = (-1.0, 0.0, 11.0, 2.0)  # walls along y = 0 and y = 2, ends beyond the sonar's range
    reference = SettledMap(*drawn_map(corridor, sides=("bottom", "top")), FRAME, MatchSettings())
    truth = (5.0, 1.0, 0.0)
    points, rings = local_scan(truth, corridor)
    believed = (truth[0] + 0.2, truth[1] + 0.1, truth[2])
    match = correlative_match(reference, believed, points, rings, MatchSettings())
    assert match is not None
    dx, dy, dheading = match.correction
    print(f"correction ({dx:+.3f}, {dy:+.3f}, {math.degrees(dheading):+.2f} degrees)")
    assert dy == pytest.approx(-0.1, abs=0.03)  # across: pulled back onto the walls
    assert abs(dx) < 0.01  # along: the walls say nothing, and the pose is left where the odometry had it
    assert abs(dheading) < math.radians(0.5)


def test_a_scan_that_ends_mostly_in_space_never_mapped_is_not_matched():
    room = (1.0, 0.0, 5.0, 3.0)
    log_odds, updated = drawn_map(room)
    updated &= np.indices(FRAME.shape)[1] < FRAME.world_to_cell(2.0, 0.0)[1]  # only the room's west end seen
    reference = SettledMap(np.where(updated, log_odds, 0.0), updated, FRAME, MatchSettings())
    points, rings = local_scan((3.5, 1.5, 0.0), room)
    assert correlative_match(reference, (3.6, 1.4, 0.0), points, rings, MatchSettings()) is None


def test_a_cell_that_changed_lately_is_not_settled():
    room = (1.0, 0.0, 5.0, 3.0)
    log_odds, updated = drawn_map(room)
    earlier = (np.where(log_odds > 0, 1.0, log_odds).astype(np.float32), updated)  # the walls were still arcs
    fresh = SettledMap(log_odds, updated, FRAME, MatchSettings(), earlier)
    settled = SettledMap(log_odds, updated, FRAME, MatchSettings(), (log_odds, updated))
    assert fresh.walls == 0 and settled.walls > 0


def test_a_carried_map_is_matched_from_the_start_and_a_new_one_only_once_it_has_settled():
    room = (1.0, 0.0, 5.0, 3.0)
    carried = OccupancyGrid(FRAME)
    carried.log_odds, carried.updated[...] = drawn_map(room)
    truth = (3.2, 1.4, 0.0)
    for grid, corrected_at_once in ((carried, True), (OccupancyGrid(FRAME), False)):
        matcher = MapMatcher(ANGLES, RADIUS, MAX_RANGE, 0.0, 1)
        for travelled in np.arange(1.5, -1e-9, -0.1):  # drive in, reading the sonar
            pose = (truth[0] - travelled, truth[1], truth[2])
            matcher.add_ring(pose, box_ranges(pose, room))
        matcher.keep(0.0, grid)
        believed = (truth[0] + 0.1, truth[1] + 0.1, truth[2])
        corrected = matcher.correct(believed, truth, 0.0)
        assert (corrected is not None) == corrected_at_once
        if corrected is not None:
            assert math.dist(corrected[:2], truth[:2]) < math.dist(believed[:2], truth[:2]) / 2

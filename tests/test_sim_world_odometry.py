"""The robot's odometry noise and teleports in world files (issue 27): what a user writes, what the
model gets, and the located errors for what is wrong."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from atlas_rap.errors import Problem, SourceError
from atlas_rap.maps.rosmap import FREE, OCCUPIED, write_ros_map
from atlas_rap.model import DEFAULT_ODOMETRY_NOISE, NO_ODOMETRY_NOISE, OdometryNoise, Teleport, World
from atlas_rap.sim.world import load_world, shipped_worlds

ROOMS = """\
walls: [[0, 0, 6, 0], [6, 0, 6, 4], [6, 4, 0, 4], [0, 4, 0, 0], [3, 0, 3, 1.5], [3, 2.5, 3, 4]]
places:
  office: {point: [1.5, 2], region: [[0, 0], [3, 0], [3, 4], [0, 4]]}
  lab: {point: [4.5, 2], region: [[3, 0], [6, 0], [6, 4], [3, 4]]}
"""


def write_and_load(tmp_path: Path, text: str, name: str = "world.yaml") -> World:
    (tmp_path / name).write_text(text, encoding="utf-8")
    return load_world(tmp_path / name)


def problems_of(tmp_path: Path, text: str, name: str = "world.yaml") -> list[Problem]:
    with pytest.raises(SourceError) as caught:
        write_and_load(tmp_path, text, name)
    print(caught.value)  # shown when a test fails
    return caught.value.problems


def at(problem: Problem) -> tuple[int, int]:
    return problem.location.line, problem.location.column


# -- odometry noise -----------------------------------------------------------------------

def test_every_shipped_world_has_the_default_odometry_noise():
    for name in shipped_worlds():
        assert load_world(name).robot.odometry_noise == DEFAULT_ODOMETRY_NOISE, name


@pytest.mark.parametrize("robot, noise", [
    ("robot: {start: [1, 1]}\n", DEFAULT_ODOMETRY_NOISE),
    ("robot: {odometry_noise: {alpha1: 0.02, alpha2: 0.005, alpha3: 0.02, alpha4: 0.005}}\n", DEFAULT_ODOMETRY_NOISE),
    ("robot: {odometry_noise: {alpha3: 0.05}}\n", OdometryNoise(alpha3=0.05)),
    ("robot:\n  odometry_noise: off\n", NO_ODOMETRY_NOISE),
    ("robot:\n  odometry_noise: false\n", NO_ODOMETRY_NOISE),
    ("robot:\n  odometry_noise: {}\n", NO_ODOMETRY_NOISE),
    ("robot:\n  odometry_drift: 0.03\n", OdometryNoise(alpha1=0.03, alpha3=0.03)),
    ("robot:\n  odometry_drift: 0\n", NO_ODOMETRY_NOISE),
    ("robot:\n  odometry_drift: 0.0\n", NO_ODOMETRY_NOISE),
], ids=["default", "all-four", "some", "off", "false", "empty", "drift", "drift-0", "drift-0.0"])
def test_the_odometry_noise_a_world_file_gives(tmp_path, robot, noise):
    assert write_and_load(tmp_path, ROOMS + robot).robot.odometry_noise == noise


def test_an_alpha_that_is_negative_a_percentage_or_not_a_number_is_located(tmp_path):
    problems = problems_of(tmp_path, ROOMS + "robot:\n  odometry_noise: {alpha1: -0.1, alpha2: 2, alpha3: lots}\n")
    negative, percent, word = problems
    assert negative.message == "robot.odometry_noise.alpha1 must be at least 0, not -0.1" and at(negative) == (6, 28)
    assert percent.message == "robot.odometry_noise.alpha2 must be at most 1, not 2" and at(percent) == (6, 42)
    assert percent.hint == "it is a fraction, not a percentage: 2 % is 0.02"
    assert word.message == "robot.odometry_noise.alpha3 must be a number, not 'lots'" and at(word) == (6, 53)


def test_an_unknown_alpha_or_a_noise_that_is_neither_off_nor_a_mapping_is_located(tmp_path):
    [problem] = problems_of(tmp_path, ROOMS + "robot:\n  odometry_noise: {alpha5: 0.1}\n")
    assert problem.message == "unknown key 'alpha5' in robot.odometry_noise" and at(problem) == (6, 20)
    assert "alpha1" in problem.hint
    [problem] = problems_of(tmp_path, ROOMS + "robot:\n  odometry_noise: 0.02\n")
    assert problem.message.startswith("robot.odometry_noise must be a mapping of keys to values (or off) such as "
                                      "{alpha1: 0.02, alpha2: 0.005, alpha3: 0.02, alpha4: 0.005}, not the number 0.02")
    assert at(problem) == (6, 19)


def test_odometry_drift_off_says_how_to_turn_the_noise_off(tmp_path):
    [problem] = problems_of(tmp_path, ROOMS + "robot:\n  odometry_drift: off\n")
    assert problem.message == "robot.odometry_drift must be a number, not 'off'" and at(problem) == (6, 19)
    assert problem.hint == "write odometry_drift: 0 or odometry_noise: off for odometry without noise"


def test_odometry_noise_and_odometry_drift_together_is_an_error_at_the_second(tmp_path):
    [problem] = problems_of(tmp_path, ROOMS + "robot:\n  odometry_drift: 0.02\n  odometry_noise: off\n")
    assert at(problem) == (7, 3)
    assert problem.message == ("robot.odometry_noise and robot.odometry_drift (line 6) both say how the odometry "
                               "errs")
    assert problem.hint.startswith("keep one:")


# -- teleports ------------------------------------------------------------------------------

def test_teleports_are_read_in_radians_with_their_targets_in_the_bounds(tmp_path):
    teleports = "robot:\n  teleports: [{at: 40, to: [4.5, 1, 90]}, {at: 60, to: [1, 3]}]\n"
    world = write_and_load(tmp_path, ROOMS + teleports)
    assert world.robot.teleports == (Teleport(40.0, (4.5, 1.0, math.pi / 2)), Teleport(60.0, (1.0, 3.0, 0.0)))
    far = write_and_load(tmp_path, "robot:\n  teleports: [{at: 1, to: [30, -12, 0]}]\n")  # no walls: anywhere
    xmin, ymin, xmax, ymax = far.bounds
    assert xmax > 30 and ymin < -12


def test_a_teleport_into_a_wall_is_located_at_its_target_with_a_free_point_as_a_hint(tmp_path):
    [problem] = problems_of(tmp_path, ROOMS + "robot:\n  teleports:\n    - {at: 40, to: [3.05, 1, 0]}\n")
    assert at(problem) == (7, 20)
    assert problem.message == ("robot.teleports[0].to (3.05, 1) puts the robot 0.05 m from a wall "
                               "([3, 0, 3, 1.5] from line 1), less than its radius 0.2 m")
    assert problem.hint.startswith("move robot.teleports[0].to into free space; the nearest free point with room for "
                                   "the robot is at (")


def test_a_teleport_into_a_solid_block_or_onto_an_occupied_cell_of_the_map_is_refused(tmp_path):
    pillar = ("polygons:\n  - [[0, 0], [8, 0], [8, 4], [0, 4]]\n  - [[5, 1], [7, 1], [7, 3], [5, 3]]\n"
              "places:\n  lab: {point: [2, 2]}\n")
    [problem] = problems_of(tmp_path, pillar + "robot: {teleports: [{at: 5, to: [6, 2]}]}\n")
    assert problem.message.startswith("robot.teleports[0].to (6, 2) is inside polygons[1] (line 3), a closed outline")
    assert at(problem) == (6, 33)
    grid = np.full((60, 80), OCCUPIED, dtype=np.int8)
    grid[2:58, 2:78] = FREE
    grid[20:40, 50:70] = OCCUPIED  # a pillar: x 2.5..3.5, y 1..2
    write_ros_map(tmp_path / "pillar.yaml", grid, 0.05, (0.0, 0.0, 0.0))
    on_map = "map: pillar.yaml\nrobot:\n  start: [1, 1.5]\n  teleports: [{at: 5, to: [3, 1.5]}]\n"
    [problem] = problems_of(tmp_path, on_map)
    assert problem.message.startswith("robot.teleports[0].to (3, 1.5) is on an occupied cell of the map 'pillar.yaml'")
    assert at(problem) == (4, 27)


def test_teleports_out_of_time_order_or_without_a_target_are_located(tmp_path):
    problems = problems_of(tmp_path, ROOMS + "robot:\n  teleports:\n    - {at: 40, to: [1, 1]}\n"
                                             "    - {at: 30, to: [1, 3]}\n    - {at: 50}\n")
    order, missing = problems
    assert order.message == "robot.teleports[1] at 30 s comes before the teleport above it (40 s)"
    assert at(order) == (8, 12) and order.hint == "list the teleports in time order"
    assert missing.message == "robot.teleports[2] is missing the key 'to'" and at(missing) == (9, 7)
    [wall] = problems_of(tmp_path, ROOMS + "robot:\n  teleports:\n    - {at: 40, to: [1, 1]}\n"
                                          "    - {at: 30, to: [1, 3]}\n    - {at: 50, to: [3, 3]}\n")[1:]
    assert wall.message.startswith("robot.teleports[2].to (3, 3) puts the robot 0.00 m from a wall")  # its own index


# -- variants ----------------------------------------------------------------------------------

def test_a_variant_may_turn_the_noise_off_and_kidnap_the_robot(tmp_path):
    (tmp_path / "base.yaml").write_text(ROOMS, encoding="utf-8")
    world = write_and_load(tmp_path, "base: base.yaml\nrobot:\n  odometry_noise: off\n"
                                     "  teleports: [{at: 20, to: [4.5, 3, 180]}]\n", "variant.yaml")
    assert world.robot.odometry_noise.off and world.robot.teleports == (Teleport(20.0, (4.5, 3.0, math.pi)),)
    assert world.robot.start == load_world(tmp_path / "base.yaml").robot.start
    plain = write_and_load(tmp_path, "base: base.yaml\nrobot:\n  odometry_drift: 0.1\n", "drift.yaml")
    assert plain.robot.odometry_noise == OdometryNoise.drift(0.1)
    assert write_and_load(tmp_path, "base: base.yaml\n", "same.yaml").robot.odometry_noise == DEFAULT_ODOMETRY_NOISE


def test_a_variant_may_not_move_the_robot_start_and_its_teleports_are_checked_against_the_base(tmp_path):
    (tmp_path / "base.yaml").write_text(ROOMS, encoding="utf-8")
    start, teleport = problems_of(tmp_path, "base: base.yaml\nrobot:\n  start: [1, 1]\n"
                                            "  teleports: [{at: 5, to: [3.1, 2.6]}]\n", "variant.yaml")
    assert start.message == "a variant cannot change robot.start" and at(start) == (3, 3)
    assert start.hint.startswith("a variant may change the robot's odometry_noise, odometry_drift, teleports")
    assert teleport.message.startswith("robot.teleports[0].to (3.1, 2.6) puts the robot 0.10 m from a wall")
    assert at(teleport) == (4, 27) and teleport.location.file.endswith("variant.yaml")
    [typo] = problems_of(tmp_path, "base: base.yaml\nrobot: {odometry_nosie: off}\n", "variant.yaml")
    assert typo.message == "unknown key 'odometry_nosie' in robot" and "did you mean 'odometry_noise'?" in typo.hint

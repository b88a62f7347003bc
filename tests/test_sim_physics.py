"""The simulated robot: drive, walls, bumper, odometry, sonar, doors and disturbances.

Every world is built here in code: a 4 m x 4 m room, sometimes split by
an inner wall with a door at x = 2 (gap from y = 1.5 to 2.5).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from atlas_rap.model import (DEFAULT_ODOMETRY_NOISE, NO_ODOMETRY_NOISE, Disturbance, Door, OdometryNoise, RobotConfig,
                             Segment, SonarConfig, World)
from atlas_rap.sim.physics import Simulation
from atlas_rap.sim.sonar import SonarRing

ROOM = (Segment((0, 0), (4, 0)), Segment((4, 0), (4, 4)), Segment((4, 4), (0, 4)), Segment((0, 4), (0, 0)))
INNER = (Segment((2, 0), (2, 1.5)), Segment((2, 2.5), (2, 4)))
LEAF = Segment((2, 1.5), (2, 2.5))
EXACT = SonarConfig(range_noise=0.0, range_noise_per_m=0.0, specular_dropout=0.0)


def room(*, start=(1.0, 2.0, 0.0), walls=ROOM, doors=None, disturbances=(), sonar=EXACT,
         noise: OdometryNoise = DEFAULT_ODOMETRY_NOISE) -> World:
    """The 4 m room; its robot's odometry has the default noise, as a world built in code has."""
    return World("room", walls, {}, doors=doors or {}, disturbances=disturbances,
                 robot=RobotConfig(start=start, odometry_noise=noise), sonar=sonar, bounds=(0, 0, 4, 4))


def split_room(*, door_open=False, schedule=(), **kw) -> World:
    door = Door("door", ("west", "east"), (2.0, 2.0), LEAF, open=door_open, schedule=schedule)
    return room(walls=ROOM + INNER, doors={"door": door}, **kw)


def distance_to_segment(x: float, y: float, s: Segment) -> float:
    (ax, ay), (bx, by) = s.a, s.b
    vx, vy = bx - ax, by - ay
    t = max(0.0, min(1.0, ((x - ax) * vx + (y - ay) * vy) / (vx * vx + vy * vy)))
    return math.hypot(x - ax - t * vx, y - ay - t * vy)


# -- driving -------------------------------------------------------------------

def test_drives_straight_at_the_commanded_speed_in_free_space():
    sim = Simulation(room(start=(1.0, 2.0, 0.0)))
    sim.command(0.5, 0.0)
    sim.step_many(200)
    x, y, heading = sim.pose
    assert sim.time == pytest.approx(2.0)
    assert x == pytest.approx(1.0 + 0.5 * 2.0, abs=0.02)
    assert y == pytest.approx(2.0, abs=1e-6) and heading == pytest.approx(0.0, abs=1e-6)
    assert sim.velocity[0] == pytest.approx(0.5, abs=1e-3)


def test_drives_straight_along_any_heading():
    sim = Simulation(room(start=(1.0, 1.0, math.pi / 4)))
    sim.command(0.4, 0.0)
    sim.step_many(300)
    x, y, _ = sim.pose
    assert math.hypot(x - 1.0, y - 1.0) == pytest.approx(1.2, abs=0.02)
    assert x == pytest.approx(y, abs=1e-6)


def test_turns_at_the_commanded_rate_on_the_spot():
    sim = Simulation(room(start=(2.0, 2.0, 0.0)))
    sim.command(0.0, 1.0)
    sim.step_many(100)
    x, y, heading = sim.pose
    assert heading == pytest.approx(1.0, abs=0.02)
    assert (x, y) == pytest.approx((2.0, 2.0), abs=1e-6)
    sim.command(0.0, -1.5)
    sim.step_many(100)
    assert sim.pose[2] == pytest.approx(1.0 - 1.5, abs=0.03)


def test_commands_are_clipped_to_the_robot_limits():
    sim = Simulation(room())
    sim.command(5.0, -9.0)
    assert sim.commanded == (0.6, -2.0)


def test_drives_an_arc_of_the_commanded_radius():
    sim = Simulation(room(start=(2.0, 1.0, 0.0)))
    sim.command(0.5, 0.5)  # radius 1 m about (2, 2)
    sim.step_many(int(math.pi / 0.5 / sim.dt))  # half a turn
    x, y, heading = sim.pose
    assert (x, y) == pytest.approx((2.0, 3.0), abs=0.03)
    assert abs(heading) == pytest.approx(math.pi, abs=0.03)


def test_never_passes_through_a_wall_or_a_closed_door_under_random_commands():
    world = split_room(start=(1.0, 2.0, 0.0))
    sim = Simulation(world, seed=3)
    rng = np.random.default_rng(3)
    segments = ROOM + INNER + (LEAF,)
    radius, tolerance = world.robot.radius, 0.01
    closest, bumps = math.inf, 0
    for i in range(10_000):
        if i % 50 == 0:
            sim.command(rng.uniform(-0.6, 0.6), rng.uniform(-2.0, 2.0))
        sim.step()
        bumps += sim.bumped
        x, y, _ = sim.pose
        assert 0 < x < 2 and 0 < y < 4, f"step {i}: robot at ({x:.3f}, {y:.3f}) left the west half"
        closest = min(closest, min(distance_to_segment(x, y, s) for s in segments))
        assert closest >= radius - tolerance, f"step {i}: robot centre {closest:.4f} m from a wall"
    assert bumps > 0  # the run did push against walls
    assert sim.doors_open == {"door": False}


def test_stops_at_a_wall_and_holds_there():
    sim = Simulation(room(start=(3.0, 2.0, 0.0)))
    sim.command(0.6, 0.0)
    sim.step_many(500)
    x, _, _ = sim.pose
    assert 4.0 - x == pytest.approx(0.2 + 0.02, abs=0.005)  # robot radius + wall skin
    assert abs(sim.velocity[0]) < 1e-3


# -- bumper ----------------------------------------------------------------------

def test_bumper_reports_contact_and_its_direction():
    sim = Simulation(room(start=(3.0, 2.0, 0.0)))
    sim.command(0.5, 0.0)
    sim.step_many(50)
    assert not sim.bumped and sim.bump_angle is None
    sim.step_many(300)
    assert sim.bumped
    assert sim.bump_angle == pytest.approx(0.0, abs=0.05)  # dead ahead
    count = sim.bump_steps
    assert count > 0
    sim.command(-0.5, 0.0)
    sim.step_many(50)
    assert not sim.bumped and sim.bump_steps <= count + 2  # contact ends a step or two after reversing


def test_bumper_direction_in_the_body_frame():
    sim = Simulation(room(start=(2.0, 3.0, 0.0)))  # the north wall is on the robot's left
    sim.command(0.0, 0.0)
    sim.step()
    assert not sim.bumped
    sim = Simulation(room(start=(2.0, 3.0, -math.pi / 2)))  # facing south: backing up hits the north wall
    sim.command(-0.5, 0.0)
    sim.step_many(400)
    assert sim.bumped
    assert abs(sim.bump_angle) == pytest.approx(math.pi, abs=0.05)


# -- odometry --------------------------------------------------------------------

def test_odometry_without_noise_is_the_true_pose():
    sim = Simulation(room(noise=NO_ODOMETRY_NOISE))
    sim.command(0.4, 0.7)
    sim.step_many(300)
    assert sim.odometry == pytest.approx(sim.pose)


def test_odometry_drifts_with_noise_and_stays_close():
    sim = Simulation(room(start=(1.0, 1.0, 0.0), noise=OdometryNoise.drift(0.05)), seed=1)
    sim.command(0.4, 0.3)
    sim.step_many(400)
    (x, y, h), (ox, oy, oh) = sim.pose, sim.odometry
    assert (ox, oy, oh) != (x, y, h)
    assert math.hypot(ox - x, oy - y) < 0.3 and abs(oh - h) < 0.3


def test_odometry_integrates_the_true_motion_with_tiny_noise():
    sim = Simulation(room(start=(1.0, 1.0, 0.0), noise=OdometryNoise(1e-9, 1e-9, 1e-9, 1e-9)), seed=1)
    sim.command(0.4, 0.5)
    sim.step_many(500)
    assert sim.odometry == pytest.approx(sim.pose, abs=1e-6)


# -- sonar ------------------------------------------------------------------------

def test_sonar_angles_are_evenly_spaced_from_forward():
    sim = Simulation(room())
    angles = sim.sonar_angles
    assert len(angles) == 16 and angles[0] == 0.0
    assert np.allclose(np.diff(angles), 2 * math.pi / 16)


def test_sonar_reads_the_geometric_distance_exactly_without_noise():
    sim = Simulation(room(start=(1.0, 2.0, 0.0)))  # east wall 3 m ahead, west wall 1 m behind
    ranges = sim.sonar()
    assert ranges.dtype == np.float64 and ranges.shape == (16,)
    assert ranges[0] == pytest.approx(3.0 - 0.2, abs=1e-3)
    assert ranges[8] == pytest.approx(1.0 - 0.2, abs=1e-3)
    assert ranges[4] == pytest.approx(2.0 - 0.2, abs=1e-3)  # north wall, to the left
    assert ranges[12] == pytest.approx(2.0 - 0.2, abs=1e-3)


def test_sonar_noise_is_within_three_sigma():
    config = SonarConfig(range_noise=0.01, range_noise_per_m=0.01, specular_dropout=0.0)
    sim = Simulation(room(start=(1.0, 2.0, 0.0), sonar=config), seed=5)
    true = 3.0 - 0.2
    sigma = 0.01 + 0.01 * true
    readings = []
    for _ in range(50):
        sim.step()
        readings.append(sim.sonar()[0])
    readings = np.array(readings)
    assert np.all(np.abs(readings - true) <= 3 * sigma + 1e-3)
    assert readings.std() > 0.2 * sigma  # there is noise


def test_sonar_far_wall_reads_max_range_and_near_wall_min_range():
    config = SonarConfig(max_range=2.0, min_range=0.05, range_noise=0.0, range_noise_per_m=0.0,
                         specular_dropout=0.0)
    sim = Simulation(room(start=(3.7, 2.0, 0.0), sonar=config))
    sim.command(0.5, 0.0)
    sim.step_many(100)  # pressed against the east wall
    ranges = sim.sonar()
    assert ranges[0] == pytest.approx(0.05)  # 0.02 m to the wall's centre line: clipped up to min_range
    assert ranges[8] == 2.0  # west wall 3.6 m away: no echo


def test_sonar_drops_out_at_grazing_angles():
    wall = (Segment((3.0, -50.0), (3.0, 50.0)),)
    config = SonarConfig(count=16, range_noise=0.0, range_noise_per_m=0.0, specular_dropout=1.0,
                         specular_angle=math.radians(60.0))
    grazing = Simulation(room(start=(2.5, 0.0, math.radians(80.0)), walls=wall, sonar=config))
    assert grazing.sonar()[0] == config.max_range
    head_on = Simulation(room(start=(2.5, 0.0, 0.0), walls=wall, sonar=config))
    assert head_on.sonar()[0] == pytest.approx(0.3, abs=1e-3)


def test_sonar_never_sees_the_robot_itself():
    config = SonarConfig(max_range=5.0, range_noise=0.0, range_noise_per_m=0.0, specular_dropout=0.0)
    sim = Simulation(room(walls=(), sonar=config))
    assert np.all(sim.sonar() == 5.0)


def test_sonar_is_computed_once_per_step():
    sim = Simulation(room(sonar=SonarConfig()))
    first = sim.sonar()
    assert sim.sonar() is first
    assert not first.flags.writeable
    sim.step()
    assert sim.sonar() is not first


def test_fast_and_public_ray_casts_agree():
    sim = Simulation(split_room(start=(1.2, 1.7, 0.3)))
    x, y, heading = sim.pose
    fast = SonarRing(EXACT, 0.2, raw=True).scan(sim._space, x, y, heading, np.random.default_rng(0))
    public = SonarRing(EXACT, 0.2, raw=False).scan(sim._space, x, y, heading, np.random.default_rng(0))
    assert np.array_equal(fast, public)


def scripted_run(seed: int) -> tuple[list[np.ndarray], list]:
    world = split_room(door_open=True, sonar=SonarConfig(), noise=OdometryNoise.drift(0.02))
    sim = Simulation(world, seed=seed)
    scans = []
    for i in range(300):
        if i % 50 == 0:
            sim.command(0.3 + 0.05 * (i // 50), 0.8 * (-1) ** (i // 50))
        sim.step()
        if i % 10 == 0:
            scans.append(sim.sonar().copy())
    return scans, list(sim.path) + [sim.odometry]


def test_same_seed_same_readings_and_path_different_seed_different_noise():
    scans_a, path_a = scripted_run(11)
    scans_b, path_b = scripted_run(11)
    scans_c, path_c = scripted_run(12)
    assert all(np.array_equal(a, b) for a, b in zip(scans_a, scans_b)) and len(scans_a) == 30
    assert path_a == path_b
    assert not all(np.array_equal(a, c) for a, c in zip(scans_a, scans_c))
    assert path_a[:-1] == path_c[:-1]  # same commands, same true path; the odometry differs
    assert path_a[-1] != path_c[-1]


def test_path_is_sampled_every_path_every_steps():
    sim = Simulation(room(), path_every=5)
    sim.command(0.2, 0.0)
    sim.step_many(20)
    assert [round(p[0], 6) for p in sim.path] == [0.0, 0.05, 0.1, 0.15, 0.2]
    assert sim.path[-1][1:] == pytest.approx(sim.pose)


# -- doors ------------------------------------------------------------------------

def test_a_closed_door_blocks_and_an_opened_door_lets_the_robot_through():
    sim = Simulation(split_room(start=(1.0, 2.0, 0.0), door_open=False))
    assert sim.doors_open == {"door": False}
    assert sim.sonar()[0] == pytest.approx(1.0 - 0.2, abs=1e-3)  # the leaf echoes
    sim.command(0.5, 0.0)
    sim.step_many(400)
    assert sim.pose[0] == pytest.approx(2.0 - 0.22, abs=0.005)
    assert sim.bumped
    sim.set_door("door", True)
    assert sim.doors_open == {"door": True}
    assert sim.sonar()[0] == pytest.approx(3.0 - 0.2 - sim.pose[0] + 1.0, abs=1e-3)  # now the east wall
    sim.step_many(300)
    assert sim.pose[0] > 2.5


def test_door_schedule_applies_by_time():
    sim = Simulation(split_room(door_open=True, schedule=((0.5, False), (1.0, True))))
    assert sim.doors_open["door"] is True
    sim.run_until(0.5)
    assert sim.doors_open["door"] is False
    sim.run_until(1.0)
    assert sim.doors_open["door"] is True


def test_a_door_never_closes_on_the_robot():
    sim = Simulation(split_room(start=(2.0, 2.0, 0.0), door_open=True))
    sim.set_door("door", False)
    assert sim.doors_open["door"] is True  # the robot is in the doorway: the close waits
    sim.command(0.5, 0.0)
    sim.step_many(200)
    assert sim.pose[0] > 2.5
    assert sim.doors_open["door"] is False


def test_unknown_door_and_closing_an_opening_are_errors():
    opening = Door("gap", ("a", "b"), (2.0, 2.0))
    sim = Simulation(room(doors={"gap": opening}))
    with pytest.raises(KeyError):
        sim.set_door("nope", True)
    with pytest.raises(ValueError):
        sim.set_door("gap", False)
    assert sim.doors_open == {"gap": True}


# -- disturbances -------------------------------------------------------------------

def test_a_box_appears_at_its_start_time_and_the_sonar_sees_it():
    box = Disturbance("box", "box", start=1.0, path=((3.0, 2.0),), size=0.4, end=2.0)
    sim = Simulation(room(start=(1.0, 2.0, 0.0), disturbances=(box,)))
    assert sim.sonar()[0] == pytest.approx(2.8, abs=1e-3) and sim.obstacles() == []
    sim.run_until(0.99)
    assert sim.obstacles() == []
    sim.run_until(1.0)
    assert sim.obstacles() == [("box", (3.0, 2.0), 0.4)]
    assert sim.sonar()[0] == pytest.approx(2.8 - 1.2, abs=1e-3)  # the box's west face
    sim.run_until(2.0)
    assert sim.obstacles() == []
    assert sim.sonar()[0] == pytest.approx(2.8, abs=1e-3)


def test_the_robot_stops_at_a_box():
    box = Disturbance("box", "box", start=0.0, path=((3.0, 2.0),), size=0.4)
    sim = Simulation(room(start=(1.0, 2.0, 0.0), disturbances=(box,)))
    sim.command(0.6, 0.0)
    sim.step_many(600)
    assert sim.pose[0] == pytest.approx(2.8 - 0.2, abs=0.005)
    assert sim.bumped and sim.bump_angle == pytest.approx(0.0, abs=0.05)
    assert sim.sonar()[0] == 0.05  # the rim touches the box: min_range


def test_a_person_walks_its_path_and_leaves():
    person = Disturbance("walker", "person", start=0.5, path=((0.5, 0.5), (3.5, 0.5), (3.5, 3.5)),
                         size=0.4, speed=1.0)
    sim = Simulation(room(start=(2.0, 2.5, math.pi / 2), disturbances=(person,)))
    assert sim.obstacles() == []
    sim.run_until(2.0)
    ((kind, (x, y), size),) = sim.obstacles()
    assert kind == "person" and size == 0.4
    assert (x, y) == pytest.approx((0.5 + 1.5, 0.5), abs=0.02)
    sim.run_until(5.0)  # 4.5 m walked: round the corner
    ((_, (x, y), _),) = sim.obstacles()
    assert (x, y) == pytest.approx((3.5, 2.0), abs=0.02)
    sim.run_until(7.0)  # 6 m path done at 6.5 s
    assert sim.obstacles() == []


def test_the_sonar_sees_a_person_and_a_person_waits_for_the_robot():
    person = Disturbance("walker", "person", start=0.0, path=((3.0, 2.0), (0.5, 2.0)), size=0.4, speed=1.0,
                         end=10.0)
    sim = Simulation(room(start=(1.0, 2.0, 0.0), disturbances=(person,)))
    assert sim.sonar()[0] == pytest.approx(3.0 - 0.2 - 1.0 - 0.2, abs=1e-3)
    sim.run_until(3.0)
    ((_, (x, _), _),) = sim.obstacles()
    assert x == pytest.approx(1.0 + 0.2 + 0.2 + 0.05, abs=0.02)  # stopped short of the robot
    assert sim.pose[:2] == pytest.approx((1.0, 2.0), abs=1e-6) and not sim.bumped
    sim.run_until(10.0)
    assert sim.obstacles() == []


def test_unknown_disturbance_kind_is_an_error():
    with pytest.raises(ValueError, match="unknown kind"):
        Simulation(room(disturbances=(Disturbance("x", "cat", 0.0, ((1.0, 1.0),)),)))

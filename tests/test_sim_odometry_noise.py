"""Odometry noise as AMCL's alpha1-alpha4, on by default, and the kidnapped robot (issue 27).

The worlds are built here in code: an open floor without walls (so nothing but the noise parts
the odometry from the true pose), or a 4 m room for the teleports that meet a box. Statistics are
taken over many seeds; each run is a few thousand physics steps.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from atlas_rap.model import (DEFAULT_ODOMETRY_NOISE, NO_ODOMETRY_NOISE, Disturbance, OdometryNoise, RobotConfig,
                             Segment, Teleport, World)
from atlas_rap.sim.physics import Simulation
from atlas_rap.sim.sensors import wrap_angle

SEEDS = range(40)
ROOM = (Segment((0, 0), (4, 0)), Segment((4, 0), (4, 4)), Segment((4, 4), (0, 4)), Segment((0, 4), (0, 0)))


def open_floor(noise: OdometryNoise = DEFAULT_ODOMETRY_NOISE, teleports: tuple[Teleport, ...] = (),
               start=(0.0, 0.0, 0.0)) -> World:
    return World("open", (), {}, robot=RobotConfig(start=start, odometry_noise=noise, teleports=teleports),
                 bounds=(-20, -20, 20, 20))


def errors(sim: Simulation) -> tuple[float, float, float]:
    """The odometry's error in the robot's true frame: (along track, across track, heading)."""
    (x, y, h), (ox, oy, oh) = sim.pose, sim.odometry
    dx, dy = ox - x, oy - y
    return dx * math.cos(h) + dy * math.sin(h), dy * math.cos(h) - dx * math.sin(h), wrap_angle(oh - h)


def straight(noise: OdometryNoise, seed: int, metres: tuple[float, ...]) -> list[tuple[float, float, float]]:
    """Drive straight east at 0.5 m/s; the errors when the true pose has gone each of ``metres``."""
    sim = Simulation(open_floor(noise), seed=seed)
    sim.command(0.5, 0.0)
    found = []
    for distance in metres:
        while sim.pose[0] < distance:
            sim.step()
        found.append(errors(sim))
    return found


def spin(noise: OdometryNoise, seed: int, radians: float) -> tuple[float, float, float]:
    """Turn on the spot at 1 rad/s for ``radians``: the errors then."""
    sim = Simulation(open_floor(noise), seed=seed)
    sim.command(0.0, 1.0)
    sim.run_until(radians)
    sim.command(0.0, 0.0)
    sim.step_many(50)  # come to rest
    return errors(sim)


# -- on by default -----------------------------------------------------------------

def test_a_robot_has_the_default_noise_unless_told_otherwise():
    assert RobotConfig().odometry_noise == DEFAULT_ODOMETRY_NOISE == OdometryNoise(0.02, 0.005, 0.02, 0.005)
    assert not DEFAULT_ODOMETRY_NOISE.off and NO_ODOMETRY_NOISE.off
    assert OdometryNoise.drift(0.05) == OdometryNoise(alpha1=0.05, alpha3=0.05)
    assert OdometryNoise.drift(0.0).off


def test_with_the_default_noise_the_odometry_drifts_more_the_further_the_robot_drives():
    runs = np.array([straight(DEFAULT_ODOMETRY_NOISE, seed, (2.0, 8.0)) for seed in SEEDS])  # seed, distance, error
    position = np.hypot(runs[:, :, 0], runs[:, :, 1])
    print("mean position error at 2 m and 8 m:", position.mean(axis=0))
    assert (position[:, 1] > 0).all()
    assert position[:, 1].mean() > 2 * position[:, 0].mean()
    along = runs[:, 1, 0]  # a random walk: std alpha3 * sqrt(8 m), about 6 cm
    assert 0.6 * 0.02 * math.sqrt(8) < along.std() < 1.4 * 0.02 * math.sqrt(8)
    assert position[:, 1].max() < 0.4


def test_a_world_built_in_code_and_driven_round_has_odometry_apart_from_the_true_pose():
    sim = Simulation(open_floor(), seed=5)
    sim.command(0.4, 0.6)
    sim.step_many(1000)
    (x, y, h), (ox, oy, oh) = sim.pose, sim.odometry
    assert math.hypot(ox - x, oy - y) > 1e-4 and abs(wrap_angle(oh - h)) > 1e-5


def test_with_the_noise_off_the_odometry_is_the_true_pose_and_draws_no_random_numbers():
    sim = Simulation(open_floor(NO_ODOMETRY_NOISE), seed=5)
    state = sim.rng.bit_generator.state
    sim.command(0.4, 0.6)
    sim.step_many(1000)
    assert sim.odometry == sim.pose
    assert sim.rng.bit_generator.state == state


def test_the_noise_draws_from_the_run_generator_so_the_same_seed_gives_the_same_odometry():
    assert straight(DEFAULT_ODOMETRY_NOISE, 3, (3.0,)) == straight(DEFAULT_ODOMETRY_NOISE, 3, (3.0,))
    assert straight(DEFAULT_ODOMETRY_NOISE, 3, (3.0,)) != straight(DEFAULT_ODOMETRY_NOISE, 4, (3.0,))


# -- each alpha does what it says ----------------------------------------------------

def test_alpha1_alone_turning_on_the_spot_errs_in_heading_but_not_in_position():
    runs = np.array([spin(OdometryNoise(alpha1=0.05), seed, 2 * math.pi) for seed in SEEDS])
    assert np.abs(runs[:, :2]).max() < 1e-6
    assert 0.6 * 0.05 * math.sqrt(2 * math.pi) < runs[:, 2].std() < 1.4 * 0.05 * math.sqrt(2 * math.pi)


def test_alpha4_alone_turning_on_the_spot_errs_in_position_but_not_in_heading():
    runs = np.array([spin(OdometryNoise(alpha4=0.05), seed, 2 * math.pi) for seed in SEEDS])
    assert np.abs(runs[:, 2]).max() < 1e-9
    position = np.hypot(runs[:, 0], runs[:, 1])
    assert 0.6 * 0.05 * math.sqrt(2 * math.pi) < math.sqrt(np.mean(position ** 2)) < 1.4 * 0.05 * math.sqrt(2 * math.pi)


def test_alpha3_alone_driving_straight_errs_along_the_track_only():
    runs = np.array([straight(OdometryNoise(alpha3=0.05), seed, (4.0,))[0] for seed in SEEDS])
    along, across, heading = runs.T
    assert 0.6 * 0.05 * 2 < along.std() < 1.4 * 0.05 * 2  # std alpha3 * sqrt(4 m)
    assert np.abs(across).max() < 1e-6 and np.abs(heading).max() < 1e-9


def test_alpha2_alone_driving_straight_errs_in_heading_and_so_across_the_track():
    runs = np.array([straight(OdometryNoise(alpha2=0.05), seed, (4.0,))[0] for seed in SEEDS])
    along, across, heading = runs.T
    assert 0.6 * 0.05 * 2 < heading.std() < 1.4 * 0.05 * 2  # std alpha2 * sqrt(4 m)
    # the heading error, a random walk over the metres, bends the believed track: std alpha2 * (4 m)^1.5 / sqrt(3)
    # across it, and only second-order errors along it
    assert 0.6 * 0.05 * 8 / math.sqrt(3) < across.std() < 1.4 * 0.05 * 8 / math.sqrt(3)
    assert along.std() < across.std() / 5


def test_the_old_drift_is_alpha1_and_alpha3():
    a = straight(OdometryNoise.drift(0.03), 7, (2.0,))
    b = straight(OdometryNoise(alpha1=0.03, alpha3=0.03), 7, (2.0,))
    assert a == b


# -- the kidnapped robot ------------------------------------------------------------------

def test_a_teleport_moves_the_true_pose_but_not_the_odometry():
    sim = Simulation(open_floor(NO_ODOMETRY_NOISE, start=(1.0, 2.0, 0.0)))
    sim.command(0.5, 0.0)
    sim.step_many(100)
    before = sim.pose
    sim.teleport(3.0, 1.0, math.pi / 2)
    assert sim.pose == pytest.approx((3.0, 1.0, math.pi / 2))
    assert sim.odometry == pytest.approx(before)
    assert sim.velocity == (0.0, 0.0)  # set down at rest; the command still stands
    sim.step_many(200)
    # it drove 1 m north, truly; dead reckoning has it 1 m further east, where it believed it was heading
    x, y, heading = sim.pose
    ox, oy, oheading = sim.odometry
    assert (x, heading) == pytest.approx((3.0, math.pi / 2), abs=1e-6) and y > 1.8
    assert oy == pytest.approx(before[1], abs=1e-6) and ox - before[0] == pytest.approx(y - 1.0, abs=1e-6)
    assert oheading == pytest.approx(0.0, abs=1e-9)


def test_with_noise_dead_reckoning_goes_on_from_where_it_believed_the_robot_was():
    sim = Simulation(open_floor(), seed=2)
    sim.command(0.5, 0.3)
    sim.step_many(300)
    believed = sim.odometry
    sim.teleport(-5.0, 4.0, 0.0)
    assert sim.odometry == believed
    sim.step()
    assert math.dist(sim.odometry[:2], believed[:2]) < 0.02  # one step of driving, not the 8 m jump


def test_a_world_teleport_happens_at_its_time_and_the_true_path_shows_the_jump():
    world = open_floor(NO_ODOMETRY_NOISE, teleports=(Teleport(1.0, (5.0, 5.0, math.pi)),))
    sim = Simulation(world)
    sim.command(0.5, 0.0)
    sim.run_until(0.99)
    assert sim.pose[0] < 0.6 and sim.odometry == sim.pose
    sim.run_until(1.0)
    assert sim.pose[:2] == pytest.approx((5.0, 5.0))
    assert sim.odometry[:2] == pytest.approx((0.5, 0.0), abs=0.02)
    sim.run_until(2.0)
    jumps = [math.dist(a[1:3], b[1:3]) for a, b in zip(sim.path, sim.path[1:])]
    assert max(jumps) > 6.0 and sorted(jumps)[-2] < 0.1
    [(t, before, after)] = sim.kidnaps
    assert t == pytest.approx(1.0) and before[0] == pytest.approx(0.5, abs=0.02) and after == (5.0, 5.0, math.pi)
    assert sim.pose[0] < 5.0  # driving on, facing west now


def test_a_world_teleport_onto_a_box_waits_until_the_box_is_gone():
    box = Disturbance("crate", "box", 0.0, ((3.0, 3.0),), end=2.0, size=0.6)
    world = World("room", ROOM, {}, disturbances=(box,),
                  robot=RobotConfig(start=(1.0, 1.0, 0.0), teleports=(Teleport(1.0, (3.0, 3.0, 0.0)),)),
                  bounds=(0, 0, 4, 4))
    sim = Simulation(world)
    sim.run_until(1.5)
    assert sim.pose[:2] == pytest.approx((1.0, 1.0))
    sim.run_until(2.05)
    assert sim.pose[:2] == pytest.approx((3.0, 3.0))

"""The beam model of the sonar on ray casts (issue 27, the other sensor model): the ranges it expects are the
distances to the walls, a reading at max range is scored by where the beam can get no echo, and a filter
weighing its particles by it tracks a robot on the real simulation (tests/localisation_runs.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from localisation_runs import drive

from atlas_rap.maps.beam_model import BeamLikelihood, BeamModel
from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.localisation import LikelihoodField, wall_mask
from atlas_rap.model import Segment

# a 5 m x 5 m map at 5 cm with walls through the middle of the cells just right of x = 3 and just above
# y = 4, each one cell thick, so x = 3 and y = 4 are the surfaces a ray from the lower left meets
FRAME = GridFrame(100, 100, 0.05, (0.0, 0.0, 0.0))
WALLS = [Segment((3.025, 0.0), (3.025, 5.0)), Segment((0.0, 4.025), (5.0, 4.025))]
RADIUS = 0.2


def model(**settings) -> BeamModel:
    field = LikelihoodField(wall_mask(WALLS, FRAME, thickness=0.05), FRAME)
    return BeamModel(field, BeamLikelihood(**settings), robot_radius=RADIUS, max_range=5.0)


def test_the_ray_cast_expects_the_distance_to_the_wall_from_the_rim():
    poses = np.array([[1.0, 1.0, 0.0],            # facing the wall x = 3, 2 m from the centre
                      [1.0, 1.0, math.pi / 2],     # facing the wall y = 4, 3 m
                      [2.0, 2.0, math.pi / 4],     # diagonally into the corner of the two: sqrt(2) m to x = 3
                      [2.5, 1.0, math.pi / 3],     # 60 degrees up: 0.5 / cos(60) = 1 m to x = 3
                      [1.0, 1.0, math.pi]])        # facing away: the map's edge, no wall within 5 m
    expected, cosine = model().expected_ranges(poses, np.array([0.0]))
    by_hand = [2.0 - RADIUS, 3.0 - RADIUS, math.sqrt(2) - RADIUS, 1.0 - RADIUS, math.inf]
    assert expected[:4].ravel() == pytest.approx(by_hand[:4], abs=0.02)  # within the quarter cell a hit is placed to
    assert expected[4, 0, 0] == math.inf
    # the angle to the wall's normal: head-on, head-on, 45 and 60 degrees
    assert cosine[:4].ravel() == pytest.approx([1.0, 1.0, math.cos(math.pi / 4), math.cos(math.pi / 3)], abs=0.02)


def test_every_beam_of_a_ring_and_every_ray_of_a_cone_is_cast_from_the_heading():
    cone = model(beam_width=math.radians(20.0), rays=3)
    ring = np.arange(4) * math.pi / 2  # forward, left, back, right
    expected, _ = cone.expected_ranges(np.array([[1.0, 1.0, 0.0]]), ring)
    assert expected.shape == (1, 4, 3)
    forward, left = expected[0, 0], expected[0, 1]
    # the cone's edges reach the wall ahead farther than its axis, by 1 / cos(10 degrees)
    assert forward == pytest.approx([2.0 / math.cos(math.radians(10)) - RADIUS, 2.0 - RADIUS,
                                     2.0 / math.cos(math.radians(10)) - RADIUS], abs=0.02)
    assert left[1] == pytest.approx(3.0 - RADIUS, abs=0.02)
    # behind and right: the map's edge 1 m away, and nothing beyond it
    assert np.isinf(expected[0, 2:]).all()


def test_a_max_reading_is_likelier_where_no_wall_is_in_range_than_before_a_near_wall():
    beam = model(specular_angle=math.radians(60.0), specular_loss=0.8)
    poses = np.array([[1.0, 1.0, math.pi],        # nothing within range
                      [2.5, 1.0, 1.3],            # the wall x = 3 at 74 degrees from head-on: the echo glances off
                      [1.0, 1.0, 0.0]])           # the wall x = 3 head-on, 1.8 m away
    no_echo = beam.log_likelihood(poses, np.array([5.0]), np.array([0.0]))
    echo = beam.log_likelihood(poses, np.array([1.8]), np.array([0.0]))
    nothing, oblique, head_on = no_echo
    assert nothing > oblique > head_on
    assert math.exp(nothing - head_on) > 10  # z_max + z_hit against z_max alone
    assert echo[2] > echo[0]  # the echo, where the wall is 1.8 m ahead


def test_the_mixture_weights_must_add_up_to_one():
    with pytest.raises(ValueError, match="must be 1"):
        model(z_hit=0.9)


def test_the_filter_with_the_beam_model_tracks_a_robot_whose_odometry_drifts_5_percent():
    # measured (benchmarks/bench_sensor_models.py, seeds 0-9 at 5 % drift): RMSE 0.064 m on average, 0.068 m on
    # the worst seed, worst error 0.20 m
    ends, odometry_ends = [], []
    for seed in (0, 1, 2):
        run = drive(seed, model="beam")
        rmse = math.sqrt(np.mean(run.belief ** 2))
        assert rmse <= 0.1, (seed, rmse, run.belief.max())
        assert run.belief.max() <= 0.4, (seed, run.belief.max())
        ends.append(run.belief[-1])
        odometry_ends.append(run.odometry[-1])
        assert run.filter.count < run.filter.settings.max_particles  # KLD-sampling shrank the belief
    assert np.mean(ends) < np.mean(odometry_ends)

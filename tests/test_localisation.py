"""Monte Carlo localisation on a known map (issue 27, first part: the filter alone, not yet wired into
runs). It is checked on the real pymunk simulation of a shipped world, with drifting odometry and the
sonar ring's own noise and dropout, against the true pose the simulator keeps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from localisation_runs import drive

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.localisation import LikelihoodField, MotionNoise, ParticleFilter, wall_mask
from atlas_rap.model import Segment


def test_without_noise_every_particle_moves_exactly_as_the_odometry_did():
    frame = GridFrame(40, 40, 0.1, (0.0, 0.0, 0.0))
    field = LikelihoodField(np.zeros(frame.shape, dtype=bool), frame)
    pf = ParticleFilter(field, (1.0, 1.0, math.pi / 2), np.random.default_rng(0), spread=(0.0, 0.0, 0.0),
                        motion=MotionNoise(0.0, 0.0, 0.0, 0.0))
    # the odometry drove 1 m along its heading, then turned left a quarter: so did every particle
    pf.predict((5.0, 5.0, 0.0), (6.0, 5.0, math.pi / 2))
    assert np.allclose(pf.particles, [1.0, 2.0, math.pi], atol=1e-9) or \
        np.allclose(pf.particles, [1.0, 2.0, -math.pi], atol=1e-9)


def test_the_likelihood_field_is_the_distance_to_the_nearest_wall_capped():
    frame = GridFrame(60, 60, 0.05, (0.0, 0.0, 0.0))
    field = LikelihoodField(wall_mask([Segment((0.0, 1.5), (3.0, 1.5))], frame, thickness=0.05), frame,
                            max_distance=1.0)
    near = field.at(np.array([1.0, 1.0, 1.0]), np.array([1.5, 1.0, 0.2]))
    assert near[0] == pytest.approx(0.0, abs=0.03)
    assert near[1] == pytest.approx(0.5, abs=0.06)
    assert near[2] == pytest.approx(1.0)  # 1.3 m away: capped
    assert field.at(np.array([-5.0]), np.array([-5.0]))[0] == pytest.approx(1.0)  # off the map


def test_the_filter_tracks_a_robot_whose_odometry_drifts_5_percent_better_than_the_odometry():
    ends, odometry_ends = [], []
    for seed in (0, 1, 2):
        run = drive(seed)
        belief, odometry, pf = run.belief, run.odometry, run.filter
        assert math.sqrt(np.mean(belief ** 2)) <= 0.15, (seed, belief.max())
        ends.append(belief[-1])
        odometry_ends.append(odometry[-1])
        assert pf.count < pf.settings.max_particles  # KLD-sampling shrank the converged belief
    assert np.mean(ends) < np.mean(odometry_ends)


def test_the_same_seed_gives_the_same_belief():
    first, second = drive(4, seconds=6.0), drive(4, seconds=6.0)
    assert np.array_equal(first.belief, second.belief)
    assert np.array_equal(first.filter.particles, second.filter.particles)

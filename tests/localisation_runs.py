"""A robot driving in a shipped world with drifting odometry, localised by the particle filter: the errors
of the belief and of the odometry against the simulator's true pose, for the tests and
``benchmarks/bench_localisation.py`` alike (the true pose is read here, by the evaluation, only)."""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.localisation import LikelihoodField, ParticleFilter, SonarLikelihood, wall_mask
from atlas_rap.model import OdometryNoise
from atlas_rap.sim.physics import Simulation
from atlas_rap.sim.world import load_world


@dataclass
class Run:
    """One drive: the belief's and the odometry's position errors (m) at each scan, the filter at the
    end, the particle count at each update, and the filter's wall time (s) over the drive."""

    belief: np.ndarray
    odometry: np.ndarray
    filter: ParticleFilter
    particles: np.ndarray
    filter_seconds: float


def drive(seed: int, drift: float = 0.05, seconds: float = 30.0, world_name: str = "lab-corridor-office") -> Run:
    """Turn on the spot for 4 s, then wander on a slow sine of turn rate, with the sonar read at 10 Hz."""
    world = load_world(world_name)
    robot = dataclasses.replace(world.robot, odometry_noise=OdometryNoise.drift(drift))  # the old one-number model
    world = dataclasses.replace(world, robot=robot)
    sim = Simulation(world, seed=seed, dt=0.01)
    frame = GridFrame.covering(world.bounds, 0.05)
    pf = ParticleFilter(LikelihoodField(wall_mask(world.walls, frame), frame), sim.odometry,
                        np.random.default_rng(seed), robot_radius=world.robot.radius,
                        max_range=world.sonar.max_range,
                        sensor=SonarLikelihood(beam_width=world.sonar.beam_width, rays=world.sonar.rays_per_beam))
    angles = np.asarray(sim.sonar_angles)
    before, belief, odometry, counts, spent = sim.odometry, [], [], [], 0.0
    for step in range(int(seconds / 0.01)):
        t = step * 0.01
        sim.command(*((0.0, 0.8) if t < 4 else (0.35, 0.25 * math.sin(t / 3))))
        sim.step()
        if step % 10 == 9:  # the sonar's 10 Hz
            now, ranges = sim.odometry, sim.sonar()
            started = time.perf_counter()
            pf.predict(before, now)
            pf.correct(ranges, angles)
            pf.resample()
            (x, y, _), _ = pf.estimate()
            spent += time.perf_counter() - started
            before = now
            counts.append(pf.count)
            tx, ty, _ = sim.pose
            belief.append(math.hypot(x - tx, y - ty))
            odometry.append(math.hypot(now[0] - tx, now[1] - ty))
    return Run(np.array(belief), np.array(odometry), pf, np.array(counts), spent)

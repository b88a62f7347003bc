"""A robot driving in a shipped world with drifting odometry, localised by the particle filter: the errors
of the belief and of the odometry against the simulator's true pose, for the tests and
``benchmarks/bench_localisation.py`` alike (the true pose is read here, by the evaluation, only); and
``deliver.rap`` run whole on a drifting world (:func:`drifting_world`, :func:`deliver`), for the tests and
benchmarks of localisation in runs."""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from atlas_rap.layers import MissionEngine, RunOptions, RunResult
from atlas_rap.maps.beam_model import BeamLikelihood, BeamParticleFilter
from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.localisation import LikelihoodField, ParticleFilter, Pose, SonarLikelihood, wall_mask
from atlas_rap.model import OdometryNoise, World
from atlas_rap.sim.physics import Simulation
from atlas_rap.sim.world import load_world

DELIVER = Path(__file__).resolve().parents[1] / "rap_library" / "missions" / "deliver.rap"

WALL_DEPTH = 0.05
"""Where a wall's echo comes from, behind the first occupied cell a ray meets: wall_mask draws a wall as
the cells whose centres are within 0.05 m of its line, so the band's front is 0.05 m before it."""


@dataclass
class Run:
    """One drive: the belief's and the odometry's position errors (m) at each scan, the filter at the
    end, the particle count at each update, and the filter's wall time (s) over the drive."""

    belief: np.ndarray
    odometry: np.ndarray
    filter: ParticleFilter
    particles: np.ndarray
    filter_seconds: float


def localiser(world: World, start: Pose, rng: np.random.Generator, model: str = "field") -> ParticleFilter:
    """The particle filter on ``world``'s walls (a mask at 5 cm) around ``start``, weighing its particles by
    ``model``: ``"field"`` (the likelihood field) or ``"beam"`` (the beam model on ray casts,
    :mod:`atlas_rap.maps.beam_model`), each given the world's sonar."""
    frame = GridFrame.covering(world.bounds, 0.05)
    field, sonar = LikelihoodField(wall_mask(world.walls, frame), frame), world.sonar
    common = dict(robot_radius=world.robot.radius, max_range=sonar.max_range)
    if model == "beam":
        return BeamParticleFilter(field, start, rng, **common, beam=BeamLikelihood(
            beam_width=sonar.beam_width, rays=sonar.rays_per_beam, specular_angle=sonar.specular_angle,
            specular_loss=sonar.specular_dropout, wall_depth=WALL_DEPTH, min_range=sonar.min_range))
    if model == "field":
        return ParticleFilter(field, start, rng, **common,
                              sensor=SonarLikelihood(beam_width=sonar.beam_width, rays=sonar.rays_per_beam))
    raise ValueError(f"model is 'field' or 'beam', not {model!r}")


def wander(t: float) -> tuple[float, float]:
    """The drive's command at time ``t`` (s): turn on the spot for 4 s, then wander on a slow sine of turn rate."""
    return (0.0, 0.8) if t < 4 else (0.35, 0.25 * math.sin(t / 3))


def drive(seed: int, drift: float = 0.05, seconds: float = 30.0, world_name: str = "lab-corridor-office",
          model: str = "field", known_start: bool = True) -> Run:
    """Turn on the spot for 4 s, then wander on a slow sine of turn rate, with the sonar read at 10 Hz.

    ``model`` is the filter's sensor model (:func:`localiser`). Without ``known_start`` the filter starts
    from ``max_particles`` particles spread uniformly over the map's free space (global localisation)."""
    world = load_world(world_name)
    robot = dataclasses.replace(world.robot, odometry_noise=OdometryNoise.drift(drift))  # the old one-number model
    world = dataclasses.replace(world, robot=robot)
    sim = Simulation(world, seed=seed, dt=0.01)
    pf = localiser(world, sim.odometry, np.random.default_rng(seed), model)
    if not known_start:  # a kidnapped robot: anywhere on the map's free space, any heading
        pf.particles = pf._random_poses(pf.settings.max_particles)
        pf.weights = np.full(pf.count, 1.0 / pf.count)
    angles = np.asarray(sim.sonar_angles)
    before, belief, odometry, counts, spent = sim.odometry, [], [], [], 0.0
    for step in range(int(seconds / 0.01)):
        sim.command(*wander(step * 0.01))
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


def drifting_world(folder: Path, drift: float) -> str:
    """lab-corridor-office with odometry drifting ``drift`` per metre and per radian (a variant written
    into ``folder``): its path."""
    world = folder / f"drift-{drift}.yaml"
    world.write_text(f"base: lab-corridor-office\nname: lab-corridor-office\nrobot: {{odometry_drift: {drift}}}\n",
                     encoding="utf-8")
    return str(world)


@dataclass
class Delivered:
    """deliver.rap run to its end: the engine, how the run ended, and its wall time (s, the run alone)."""

    engine: MissionEngine
    result: RunResult
    seconds: float


def deliver(world: str, seed: int, *, records: list | None = None, **options) -> Delivered:
    """deliver.rap in ``world`` with ``seed`` and any other :class:`RunOptions` (``localisation``,
    ``prior_map``), to its end or 600 s; its trace records go into ``records`` if given."""
    engine = MissionEngine(RunOptions(world=world, seed=seed, **options))
    if records is not None:
        engine.trace.add_sink(records.append)
    engine.load_file(DELIVER, require_post=True)
    started = time.perf_counter()
    result = engine.run_mission(600)
    return Delivered(engine, result, time.perf_counter() - started)

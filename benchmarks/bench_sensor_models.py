"""Benchmark the localiser's two sensor models side by side (issue 27): the likelihood field and the beam model.

The lab's robot (``worlds/lab-corridor-office.yaml``, the real pymunk
simulation with its sonar ring's noise and specular dropout) turns on the
spot, then wanders for 30 simulated seconds (``tests/localisation_runs.py``
``drive``). On the same drives (same seeds, so the same true path, odometry
and sonar readings), the particle filter weighs its particles either by the
likelihood field (``field``: ``atlas_rap.maps.localisation``, the default)
or by the beam model on ray casts (``beam``: ``atlas_rap.maps.beam_model``);
motion, resampling, KLD-sampling and recovery are the same. The two models
take turns seed by seed, so the machine's load falls on both alike. One
JSON object a line:

- ``sensor-model-tracking``: per model and drift (2, 5 and 10 % of the odometry,
  from a known start): the belief's position RMSE (m; the mean over seeds and
  the worst seed), its worst error at any scan, the filter's wall time per
  update (predict, correct, resample, estimate; ms) and the particles per
  update (KLD-sampling: mean, least, most);
- ``sensor-model-global``: global localisation (a kidnapped robot): the filter
  starts from ``max_particles`` particles uniform over the map's free space,
  at 5 % drift; per model, on how many seeds the belief came within 0.5 m of
  the truth and stayed there to the end of the 30 s drive (``converged``), the
  median time it took (s), the median error at the end (m), and ms per update;
- ``sensor-model-one-scan``: how far one scan alone points at the robot,
  whatever the particles: at 5 scans of each seed's drive (2, 8, 14, 20 and
  26 s), 20000 poses uniform over the free space (the same for both models)
  are weighed by the scan; per model, the weight that falls within 0.5 m of
  the true position (the median and the mean over scans, and on how many
  scans it is the most; a uniform belief puts about 0.003 there).

Run: ``pip install . && python benchmarks/bench_sensor_models.py`` (``--seeds N``, default 10;
``--quick``: 3 seeds).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE.parent / "tests")]  # the checkout, and the test bed's drive

from localisation_runs import Run, drive, localiser, wander  # noqa: E402

MODELS = ("field", "beam")
DRIFTS = (0.02, 0.05, 0.1)
GLOBAL_DRIFT = 0.05
WITHIN = 0.5  # metres: a global localisation has converged once the belief stays this close
SCAN_PERIOD = 0.1  # seconds between the drive's sonar scans
ONE_SCAN_TIMES = (2.0, 8.0, 14.0, 20.0, 26.0)
CANDIDATES = 20000


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def ms_per_update(runs: list[Run]) -> float:
    return round(1000 * float(np.mean([run.filter_seconds / len(run.particles) for run in runs])), 3)


def tracking(model: str, drift: float, runs: list[Run]) -> dict:
    """One ``sensor-model-tracking`` record."""
    rmse = np.array([np.sqrt(np.mean(run.belief ** 2)) for run in runs])
    counts = np.concatenate([run.particles for run in runs])
    return {"bench": "sensor-model-tracking", "model": model, "drift": drift, "seeds": len(runs),
            "rmse_m": round(float(rmse.mean()), 3), "rmse_worst_seed_m": round(float(rmse.max()), 3),
            "max_error_m": round(float(max(run.belief.max() for run in runs)), 3),
            "ms_per_update": ms_per_update(runs),
            "particles_mean": round(float(counts.mean()), 1), "particles_min": int(counts.min()),
            "particles_max": int(counts.max())}


def settled_after(errors: np.ndarray) -> float | None:
    """The time (s) from which the errors stay within :data:`WITHIN` to the end, or None."""
    outside = np.flatnonzero(errors >= WITHIN)
    if outside.size == 0:
        return SCAN_PERIOD
    if outside[-1] == len(errors) - 1:
        return None
    return (outside[-1] + 2) * SCAN_PERIOD


def global_localisation(runs: dict[str, list[Run]]) -> dict:
    """The ``sensor-model-global`` record, the models side by side."""
    record: dict = {"bench": "sensor-model-global", "drift": GLOBAL_DRIFT, "within_m": WITHIN,
                    "seeds": len(next(iter(runs.values())))}
    for model, model_runs in runs.items():
        settled = [settled_after(run.belief) for run in model_runs]
        times = [t for t in settled if t is not None]
        record[model] = {"converged": len(times),
                         "median_time_s": round(float(np.median(times)), 1) if times else None,
                         "median_final_error_m": round(float(np.median([run.belief[-1] for run in model_runs])), 3),
                         "ms_per_update": ms_per_update(model_runs),
                         "converged_seeds": [seed for seed, t in enumerate(settled) if t is not None]}
    return record


def one_scan(seeds: range) -> dict:
    """The ``sensor-model-one-scan`` record: the weight one scan puts near the truth from a uniform belief."""
    from atlas_rap.model import OdometryNoise
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.sim.world import load_world

    world = load_world("lab-corridor-office")
    noise = OdometryNoise.drift(GLOBAL_DRIFT)
    world = dataclasses.replace(world, robot=dataclasses.replace(world.robot, odometry_noise=noise))
    near: dict[str, list[float]] = {model: [] for model in MODELS}
    for seed in seeds:
        sim = Simulation(world, seed=seed, dt=0.01)
        filters = {model: localiser(world, sim.odometry, np.random.default_rng(seed), model) for model in MODELS}
        angles = np.asarray(sim.sonar_angles)
        steps = {int(round(t / 0.01)) for t in ONE_SCAN_TIMES}
        for step in range(max(steps) + 1):
            sim.command(*wander(step * 0.01))
            sim.step()
            if step in steps:
                ranges, (x, y, _) = sim.sonar(), sim.pose
                candidates = filters[MODELS[0]]._random_poses(CANDIDATES)
                close = np.hypot(candidates[:, 0] - x, candidates[:, 1] - y) < WITHIN
                for model, pf in filters.items():
                    log_w = pf.log_likelihood(candidates, ranges, angles)
                    weights = np.exp(log_w - log_w.max())
                    near[model].append(float(weights[close].sum() / weights.sum()))
    record: dict = {"bench": "sensor-model-one-scan", "seeds": len(seeds), "scans": len(near[MODELS[0]]),
                    "candidates": CANDIDATES, "within_m": WITHIN}
    shares = np.array([near[model] for model in MODELS])
    for i, model in enumerate(MODELS):
        record[model] = {"median_weight_near": round(float(np.median(shares[i])), 3),
                         "mean_weight_near": round(float(np.mean(shares[i])), 3),
                         "scans_most": int(np.sum(shares[i] > np.delete(shares, i, axis=0).max(axis=0)))}
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="seeds per drift and for global localisation")
    parser.add_argument("--quick", action="store_true", help="3 seeds")
    args = parser.parse_args()
    seeds = range(3 if args.quick else args.seeds)
    for drift in DRIFTS:
        runs: dict[str, list[Run]] = {model: [] for model in MODELS}
        for seed in seeds:
            for model in MODELS:
                runs[model].append(drive(seed, drift=drift, model=model))
        for model in MODELS:
            emit(tracking(model, drift, runs[model]))
    runs = {model: [] for model in MODELS}
    for seed in seeds:
        for model in MODELS:
            runs[model].append(drive(seed, drift=GLOBAL_DRIFT, model=model, known_start=False))
    emit(global_localisation(runs))
    emit(one_scan(seeds))


if __name__ == "__main__":
    main()

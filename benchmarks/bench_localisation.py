"""Benchmark Monte Carlo localisation (issue 27): how well the robot knows where it is, and what it costs.

The lab's robot (``worlds/lab-corridor-office.yaml``, the real pymunk
simulation with its sonar ring's noise and dropout) turns on the spot, then
wanders for 30 simulated seconds with its odometry drifting 0, 2, 5 and
10 % per metre and per radian. At each 10 Hz sonar scan the particle filter
(``atlas_rap.maps.localisation``) predicts from the odometry, weighs the
scan, resamples and estimates; the peer is dead reckoning, the odometry
alone, on the same drive. One JSON object a line:

- ``localisation-drift``: per drift, over the seeds: the belief's and the
  odometry's position RMSE and worst error (m; the mean over seeds, and the
  worst seed), and the ratio of the two RMSEs (none at drift 0, where the
  odometry is exact);
- ``localisation-cost``: particles per update (KLD-sampling: mean, least,
  most) and the filter's wall time per sonar ring (ms).

- ``localisation-deliver``: ``deliver.rap`` on ``lab-corridor-office`` at
  5 % drift over ``--deliver-seeds`` seeds (default 20), with the localiser
  (``--localisation mcl``) beside dead reckoning (``odometry``), the peer:
  successes, the belief's position RMSE, and the wall time per simulated
  second of each and their ratio (per simulated second, because a run that
  fails or wanders lasts longer; the target is 1.5 or less).

Run: ``pip install . && python benchmarks/bench_localisation.py`` (``--seeds N``; ``--quick``: 3 seeds).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE.parent / "tests")]  # the checkout, and the test bed's drive

from localisation_runs import deliver, drifting_world, drive  # noqa: E402

DRIFTS = (0.0, 0.02, 0.05, 0.1)


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="seeds per drift (default 10)")
    parser.add_argument("--quick", action="store_true", help="3 seeds")
    parser.add_argument("--deliver-seeds", type=int, default=20, help="seeds of deliver.rap (default 20)")
    args = parser.parse_args()
    seeds = range(3 if args.quick else args.seeds)
    counts, per_ring = [], []
    for drift in DRIFTS:
        runs = [drive(seed, drift=drift) for seed in seeds]
        rmse = np.array([np.sqrt(np.mean(run.belief ** 2)) for run in runs])
        odometry = np.array([np.sqrt(np.mean(run.odometry ** 2)) for run in runs])
        emit({"bench": "localisation-drift", "drift": drift, "seeds": len(runs),
              "belief_rmse_m": round(float(rmse.mean()), 3), "belief_rmse_worst_m": round(float(rmse.max()), 3),
              "belief_max_m": round(float(max(run.belief.max() for run in runs)), 3),
              "odometry_rmse_m": round(float(odometry.mean()), 3),
              "odometry_max_m": round(float(max(run.odometry.max() for run in runs)), 3),
              "ratio_belief_to_odometry": round(float(rmse.mean() / odometry.mean()), 3) if odometry.mean() > 1e-6
              else None})
        for run in runs:
            counts.extend(run.particles.tolist())
            per_ring.append(run.filter_seconds / len(run.particles))
    emit({"bench": "localisation-cost", "particles_mean": round(float(np.mean(counts)), 1),
          "particles_min": int(np.min(counts)), "particles_max": int(np.max(counts)),
          "ms_per_sonar_ring": round(1000 * float(np.mean(per_ring)), 3)})
    deliver_side_by_side(range(3 if args.quick else args.deliver_seeds))


def deliver_side_by_side(seeds: range, drift: float = 0.05) -> None:
    """deliver.rap with the localiser and with dead reckoning, on the same seeds (one JSON line)."""
    import tempfile

    from atlas_rap.views.pose_error import pose_errors

    record: dict = {"bench": "localisation-deliver", "drift": drift, "seeds": len(seeds)}
    with tempfile.TemporaryDirectory() as folder:
        world = drifting_world(Path(folder), drift)
        for mode in ("mcl", "odometry"):
            ok, rmse, wall, simulated = 0, [], 0.0, 0.0
            for seed in seeds:
                run = deliver(world, seed, localisation=mode)
                wall += run.seconds
                simulated += run.result.time
                ok += run.result.ok
                rmse.append(pose_errors(run.engine.system).rmse)
            record[mode] = {"succeeded": ok, "rmse_m_mean": round(float(np.mean(rmse)), 3),
                            "rmse_m_worst": round(float(np.max(rmse)), 3),
                            "wall_ms_per_simulated_s": round(1000 * wall / simulated, 3)}
    record["ratio_wall_mcl_to_odometry"] = round(record["mcl"]["wall_ms_per_simulated_s"]
                                                 / record["odometry"]["wall_ms_per_simulated_s"], 3)
    emit(record)


if __name__ == "__main__":
    main()

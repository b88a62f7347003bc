"""Benchmark mapping with pose correction (issue 27, part 3): with it and without, on the same seeds.

Without a prior map the localiser corrects the odometry against the map
being built (``atlas_rap.maps.scan_matching``); ``--localisation odometry``
turns that off (dead reckoning), so the two are one flag apart. One JSON
object a line:

- ``mapping-deliver``: ``deliver.rap --no-prior-map`` on
  ``lab-corridor-office``, at the default odometry noise (``"drift":
  "default"``) over ``--seeds`` seeds (default 12) and at 5 % drift over
  ``--drift-seeds`` (default 6), for each mode (``mcl``: with the
  correction, ``odometry``: without): errands that succeeded, the belief's
  position RMSE (mean and worst seed, m; ``views.pose_error``), the map's
  agreement with the true walls (mean and least, ``maps.agreement``), each
  seed's RMSE and agreement, and the wall time per simulated second (ms);
- ``mapping-experiment``: the skill-acquisition experiment's seven runs
  (``views.experiment``, the map carried from run to run, no obstacle
  scenario) on ``--experiment-seeds`` seeds (default 3), for each mode: the
  map agreement and the pose RMSE of every run, and the wall time (s).

Run: ``pip install . && python benchmarks/bench_mapping_correction.py`` (``--quick``: 3 and 2 deliver
seeds, 1 experiment seed).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent), str(HERE.parent / "tests")]  # the checkout, and the test bed's runs

from localisation_runs import deliver, drifting_world  # noqa: E402
from atlas_rap.maps.agreement import map_agreement  # noqa: E402
from atlas_rap.views.experiment import Settings, skill_acquisition  # noqa: E402
from atlas_rap.views.pose_error import pose_errors  # noqa: E402

MODES = ("mcl", "odometry")


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def deliver_side_by_side(world: str, seeds: range, drift: float | None) -> None:
    """deliver.rap --no-prior-map with the correction and without, on the same seeds (one line)."""
    record: dict = {"bench": "mapping-deliver", "drift": "default" if drift is None else drift, "seeds": len(seeds)}
    for mode in MODES:
        ok, rmse, agreement, wall, simulated = 0, [], [], 0.0, 0.0
        for seed in seeds:
            run = deliver(world, seed, prior_map=False, localisation=mode)
            wall += run.seconds
            simulated += run.result.time
            ok += run.result.ok
            rmse.append(pose_errors(run.engine.system).rmse)
            agreement.append(map_agreement(run.engine.grid, run.engine.world.walls).share)
        record[mode] = {"succeeded": ok, "rmse_m_mean": round(float(np.mean(rmse)), 3),
                        "rmse_m_worst": round(float(np.max(rmse)), 3),
                        "agreement_mean": round(float(np.mean(agreement)), 4),
                        "agreement_least": round(float(np.min(agreement)), 4),
                        "rmse_m": [round(r, 3) for r in rmse], "agreement": [round(a, 4) for a in agreement],
                        "wall_ms_per_simulated_s": round(1000 * wall / simulated, 3)}
    emit(record)


def experiment(seed: int, runs: int = 7) -> None:
    """The experiment's runs with the correction and without, on one seed (one line)."""
    record: dict = {"bench": "mapping-experiment", "seed": seed, "runs": runs}
    for mode in MODES:
        with tempfile.TemporaryDirectory() as folder:
            started = time.perf_counter()
            data = skill_acquisition(folder, Settings(runs=runs, seed=seed, obstacles=None, localisation=mode))
            wall = time.perf_counter() - started
        record[mode] = {"succeeded": sum(run["ok"] for run in data["runs"]),
                        "agreement": [run["map_agreement"] for run in data["runs"]],
                        "rmse_m": [run["pose_rmse_m"] for run in data["runs"]], "wall_s": round(wall, 2)}
    emit(record)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=12, help="deliver seeds at the default noise (default 12)")
    parser.add_argument("--drift-seeds", type=int, default=6, help="deliver seeds at 5 %% drift (default 6)")
    parser.add_argument("--experiment-seeds", type=int, default=3, help="experiment seeds (default 3)")
    parser.add_argument("--quick", action="store_true", help="3 and 2 deliver seeds, 1 experiment seed")
    args = parser.parse_args()
    if args.quick:
        args.seeds, args.drift_seeds, args.experiment_seeds = 3, 2, 1
    with tempfile.TemporaryDirectory() as folder:
        deliver_side_by_side("lab-corridor-office", range(args.seeds), None)  # the default noise
        deliver_side_by_side(drifting_world(Path(folder), 0.05), range(args.drift_seeds), 0.05)
    for seed in range(args.experiment_seeds):
        experiment(seed)


if __name__ == "__main__":
    main()

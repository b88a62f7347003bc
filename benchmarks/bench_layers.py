"""Benchmark the ATLAS layers: the seed's whole experiment, and what mapping while driving costs.

Prints one JSON object a line:

- ``layers-experiment``: ``atlas experiment skill-acquisition`` in one
  process (seven errands with no prior map, the map carried from run to run,
  then the three cases of the obstacle scenario, then ``figures.json``, the
  CSV and the four PNGs): wall seconds, best of ``--runs`` (target: <= 60 s
  on a 2-core machine), with the simulated seconds it covers, the curves
  (quality and duration per run) beside the seed's, and each obstacle case's
  primary layers in turn.
- ``layers-experiment-seeds``: the same experiment over seeds 0-9, two
  seeds at a time in worker processes (``atlas experiment skill-acquisition
  --jobs 2``: each seed's folder with its figures, then the figures over
  all seeds), once: wall seconds (target: <= 120 s on a 2-core machine),
  with how many seeds crossed the quality threshold on each run and the
  median duration of the runs after the crossing against the optimal time.
- ``layers-mapping``: the same errand (lab -> office -> lab) on the prior
  map without mapping, and the same run with Layer IV fusing every sonar
  ring into the grid as it drives (``atlas map build --mission``'s run, the
  issue's measure): the wall-time ratio (target: <= 2).
- ``layers-exploring``: the errand with no prior map (``--no-prior-map``:
  Layer IV maps, measures the map and plans on the grid with MCP, Layer III
  rebuilds the topology, and the robot explores, so the run is longer in
  simulated time too) against the same run without mapping; also the ratio
  per simulated second.

All interleaved, best of ``--runs``, in one process after a warm-up run;
the mapping figures come first (after the experiment the same process runs
the errands a few per cent slower).

Run: ``python benchmarks/bench_layers.py`` (``--quick``: one run each; ``--only RECORD``: that record
alone, e.g. ``--only layers-experiment-seeds``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

# The seed's curves (seed 000 Fig. 12, read off the figure's description):
# quality crosses 90 % after the 4th run; the duration falls close to optimal after that.
SEED = {"quality_crosses_after_run": 4, "duration_near_optimal_from_run": 5}


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def bench_experiment(runs: int) -> None:
    from atlas_rap.views.experiment import Settings, skill_acquisition, write_results

    best, data = float("inf"), None
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as out:
            started = time.perf_counter()
            data = skill_acquisition(out, Settings())
            write_results(data, out)
            best = min(best, time.perf_counter() - started)
    cases = data.get("obstacles") or []
    simulated = sum(run["duration_s"] for run in data["runs"] + cases)
    crossed = next((run["run"] for run in data["runs"] if run["map_quality"] >= data["threshold"]), None)
    emit({"bench": "layers-experiment", "wall_s": round(best, 2), "target_s": 60.0, "runs": len(data["runs"]),
          "simulated_s": round(simulated, 1),
          "quality": [run["map_quality"] for run in data["runs"]],
          "duration_over_optimal": [round(run["duration_s"] / run["optimal_s"], 3) for run in data["runs"]],
          "ours": {"quality_crosses_after_run": crossed},
          "seed": SEED, "obstacles_ok": all(case["ok"] for case in cases),
          "obstacles": {case["case"]: case["seen"] for case in cases},
          "obstacles_as_expected": all(case["as_expected"] for case in cases)})


def bench_experiment_seeds(jobs: int = 2) -> None:
    from atlas_rap.views.experiment import Settings
    from atlas_rap.views.experiment_seeds import DEFAULT_SEEDS, skill_acquisition_seeds, write_seeds_results
    from atlas_rap.views.figures import obstacle_cases

    with tempfile.TemporaryDirectory() as out:
        started = time.perf_counter()
        data = skill_acquisition_seeds(out, Settings(), DEFAULT_SEEDS, jobs=jobs)
        write_seeds_results(data, out)
        wall = time.perf_counter() - started
    simulated = sum(run["duration_s"] for one in data["per_seed"] for run in one["runs"]) + sum(
        case["end_s"] - case.get("start_s", 0.0) for one in data["per_seed"] for case in obstacle_cases(one))
    after = data["summary"]["after_crossing"]
    emit({"bench": "layers-experiment-seeds", "wall_s": round(wall, 2), "target_s": 120.0, "jobs": jobs,
          "cpus": os.cpu_count(), "seeds": len(data["per_seed"]), "complete": data["complete"],
          "simulated_s": round(simulated, 1), "threshold": data["threshold"],
          "crossed_in": data["summary"]["crossed_in"]["histogram"],
          "after_crossing": {key: after[key] for key in ("runs", "median_duration_s", "optimal_s",
                                                         "ratio_to_optimal")},
          "seed": SEED})


def one_errand(mission: Path, **options) -> tuple[float, float]:
    from atlas_rap.layers import MissionEngine, RunOptions

    started = time.perf_counter()
    engine = MissionEngine(RunOptions(seed=0, **options))
    engine.load_file(mission, require_post=True)
    result = engine.run_mission(900)
    assert result.ok, result
    return time.perf_counter() - started, result.time


def bench_mapping(runs: int) -> None:
    from atlas_rap.views.experiment import Settings, errand_file

    kinds = {"without": {}, "mapping": {"mapping": True}, "exploring": {"prior_map": False}}
    with tempfile.TemporaryDirectory() as out:
        mission = errand_file(Path(out), Settings())
        for options in kinds.values():
            one_errand(mission, **options)  # imports and caches warm for all
        times: dict[str, list[tuple[float, float]]] = {kind: [] for kind in kinds}
        for _ in range(runs):
            for kind, options in kinds.items():
                times[kind].append(one_errand(mission, **options))
    best = {kind: min(values) for kind, values in times.items()}
    plain_wall, plain_sim = best["without"]
    for kind in ("mapping", "exploring"):
        wall, sim = best[kind]
        emit({"bench": f"layers-{kind}", "without_mapping_s": round(plain_wall, 3), "with_mapping_s": round(wall, 3),
              "ratio": round(wall / plain_wall, 2), "target_ratio": 2.0,
              "simulated_s": {"without": plain_sim, "with": sim},
              "ratio_per_simulated_s": round((wall / sim) / (plain_wall / plain_sim), 2)})


RECORDS = ["layers-mapping", "layers-experiment", "layers-experiment-seeds"]
"""What --only can name (layers-mapping also prints layers-exploring)."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="one run of each")
    parser.add_argument("--only", choices=RECORDS, help="this record alone")
    args = parser.parse_args()
    runs = 1 if args.quick else args.runs
    wanted = [args.only] if args.only else RECORDS
    if "layers-mapping" in wanted:
        bench_mapping(runs)  # first: the experiment leaves a process that runs the errands a few per cent slower
    if "layers-experiment" in wanted:
        bench_experiment(runs)
    if "layers-experiment-seeds" in wanted:
        bench_experiment_seeds()  # once: a minute or two; its seeds run in processes of their own


if __name__ == "__main__":
    main()

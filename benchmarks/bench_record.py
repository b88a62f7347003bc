"""Benchmark what recording a run for Foxglove costs: ``atlas run --record`` beside the same run without.

Runs ``rap_library/missions/deliver.rap`` in-process (the engine, as
``atlas run`` drives it; loading and interpreter start-up left out) with
and without a :class:`~atlas_rap.views.recording.RunRecorder` writing an
MCAP file (its close included), alternating the two so that both see the
same machine, and prints one JSON object a line:

- ``record``: on the prior map (no grid: poses, path, sonar, scene,
  route, trace), the best and the median wall seconds of each, and
  ``ratio`` = best with / best without (target <= 1.3);
- ``record-mapping``: the same errand with no prior map, where Layer IV
  builds the grid and the recorder sends it (at most once a simulated
  second) and Layer III's topologies.

Run: ``pip install '.[foxglove]' && python benchmarks/bench_record.py`` (``--runs N``; ``--quick``: 3 runs).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent)]  # the checkout, if not installed

MISSION = HERE.parent / "rap_library" / "missions" / "deliver.rap"


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def run_once(record_to: Path | None, prior_map: bool) -> tuple[float, float, int]:
    """One run of deliver.rap; (wall seconds of the run and the recorder's close, simulated seconds, MCAP bytes)."""
    from atlas_rap.layers import MissionEngine, RunOptions
    from atlas_rap.views.recording import RunRecorder

    engine = MissionEngine(RunOptions(seed=0, prior_map=prior_map))
    recorder = RunRecorder(engine, path=record_to) if record_to is not None else None
    engine.load_file(MISSION, require_post=True)
    start = time.perf_counter()
    try:
        result = engine.run_mission(600, pace=recorder.pace if recorder is not None else None)
    finally:
        if recorder is not None:
            recorder.close()
    wall = time.perf_counter() - start
    assert result.ok, "deliver.rap failed"
    return wall, result.time, record_to.stat().st_size if record_to is not None else 0


def bench(name: str, runs: int, prior_map: bool, folder: Path) -> None:
    plain, recorded, size, sim_s = [], [], 0, 0.0
    run_once(None, prior_map)  # warm up: imports, caches
    for i in range(runs):
        wall, sim_s, _ = run_once(None, prior_map)
        plain.append(wall)
        wall, _, size = run_once(folder / f"{name}-{i}.mcap", prior_map)
        recorded.append(wall)
    emit({"bench": name, "mission": "deliver.rap", "prior_map": prior_map, "runs": runs, "sim_s": round(sim_s, 2),
          "without_s": round(min(plain), 4), "with_s": round(min(recorded), 4),
          "without_median_s": round(statistics.median(plain), 4),
          "with_median_s": round(statistics.median(recorded), 4),
          "ratio": round(min(recorded) / min(plain), 3),
          "median_ratio": round(statistics.median(recorded) / statistics.median(plain), 3),
          "mcap_bytes": size, "target": 1.3})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7, help="runs of each (default 7)")
    parser.add_argument("--quick", action="store_true", help="3 runs of each")
    args = parser.parse_args()
    runs = 3 if args.quick else args.runs
    with tempfile.TemporaryDirectory() as folder:
        bench("record", runs, True, Path(folder))
        bench("record-mapping", max(1, runs // 2), False, Path(folder))


if __name__ == "__main__":
    main()

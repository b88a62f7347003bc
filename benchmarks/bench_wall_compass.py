"""Benchmark the wall compass: the pose without a prior map, with the compass and without, on several worlds.

Without a prior map the localiser corrects the odometry against the map
being built (``atlas_rap.maps.scan_matching``) and holds its heading to
the directions the building's walls run in (``atlas_rap.maps.wall_compass``).
This runs the same missions, seeds and worlds with the compass and with
``atlas_rap.skills.localising.WALL_COMPASS = None`` (the matcher alone, as
before the compass), one process, and prints one JSON object a line per
world:

- ``deliver.rap`` on ``lab-corridor-office``, the ATLAS experiment's world;
- the same on that world turned by 25 degrees about its corner (written
  into a temporary folder), so that no wall runs along the map's axes;
- a tour of ``office-building`` (office-2, office-4, the elevator lobby,
  office-1), whose robot starts by turning round;
- ``deliver-coffee.rap`` on ``maze`` and ``map-world.rap`` on
  ``small-office-map`` (walls from a ROS map image).

Each line: errands done, the belief's position RMSE (mean and worst run, m;
``views.pose_error``, the evaluation's only use of the true pose) and the
worst heading error (degrees) for each mode, the ratio of the mean RMSEs
(with / without: below 1 is better), and the wall time per simulated second
(ms). A last line sums up every world.

Run: ``pip install . && python benchmarks/bench_wall_compass.py`` (``--seeds N``: seeds 0..N-1 of each
world, default 4; ``--quick``: 2).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent)]

import atlas_rap.skills.localising as localising  # noqa: E402
from atlas_rap.layers import MissionEngine, RunOptions  # noqa: E402
from atlas_rap.maps.wall_compass import CompassSettings  # noqa: E402
from atlas_rap.sim.world import world_path  # noqa: E402
from atlas_rap.views.pose_error import pose_errors  # noqa: E402

MISSIONS = HERE.parent / "rap_library" / "missions"
OFFICE_TOUR = """;;; A tour of office-building for the wall compass's benchmark.
(include "{navigation}")
(world "office-building")
(define-rap (tour)
  (method
    (task-net
      (sequence
        (t1 (go-to office-2))
        (t2 (go-to office-4))
        (t3 (go-to elevator-lobby))
        (t4 (go-to office-1))))))
(post (tour))
"""
TURN = 25.0
"""Degrees the turned world is turned by."""


def turned_world(folder: Path, degrees: float) -> Path:
    """lab-corridor-office turned by ``degrees`` about (0, 0) and moved into the first quadrant: a world file."""
    world = yaml.safe_load(world_path("lab-corridor-office").read_text(encoding="utf-8"))
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))

    def point(x: float, y: float) -> list[float]:
        return [round(c * x - s * y + 12.0, 4), round(s * x + c * y + 2.0, 4)]

    world["name"] = f"lab-corridor-office-turned-{degrees:g}"
    world["polygons"] = [[point(*p) for p in polygon] for polygon in world["polygons"]]
    world["walls"] = [point(*w[:2]) + point(*w[2:]) for w in world["walls"]]
    for place in world["places"].values():
        place["point"] = point(*place["point"])
        place["region"] = [point(*p) for p in place["region"]]
    for door in world["doors"].values():
        door["segment"] = point(*door["segment"][:2]) + point(*door["segment"][2:])
    for disturbance in world.get("disturbances", []):
        disturbance["path"] = [point(*p) for p in disturbance["path"]]
    x, y, heading = world["robot"]["start"]
    world["robot"]["start"] = point(x, y) + [heading + degrees]
    path = folder / f"{world['name']}.yaml"
    path.write_text(yaml.safe_dump(world, sort_keys=False), encoding="utf-8")
    return path


def run(mission: Path, world: str, seed: int) -> dict:
    """One mission without a prior map: whether it succeeded, its pose errors and its wall time."""
    engine = MissionEngine(RunOptions(world=world, seed=seed, prior_map=False))
    engine.load_file(mission, require_post=True)
    started = time.perf_counter()
    result = engine.run_mission(900)
    wall = time.perf_counter() - started
    errors = pose_errors(engine.system)
    return {"ok": result.ok, "rmse": errors.rmse, "heading": errors.worst_heading_deg, "wall": wall,
            "simulated": result.time}


def side_by_side(name: str, mission: Path, world: str, seeds: range) -> dict:
    """The runs of one world with the compass and without: one JSON line."""
    record: dict = {"bench": "wall-compass", "world": name, "mission": mission.name, "seeds": len(seeds)}
    for mode, settings in (("compass", CompassSettings()), ("matcher-only", None)):
        localising.WALL_COMPASS = settings
        runs = [run(mission, world, seed) for seed in seeds]
        rmse = [r["rmse"] for r in runs]
        record[mode] = {"succeeded": sum(r["ok"] for r in runs), "rmse_m_mean": round(sum(rmse) / len(rmse), 3),
                        "rmse_m_worst": round(max(rmse), 3), "rmse_m": [round(v, 3) for v in rmse],
                        "heading_deg_worst": round(max(r["heading"] for r in runs), 1),
                        "wall_ms_per_simulated_s": round(1000 * sum(r["wall"] for r in runs)
                                                         / sum(r["simulated"] for r in runs), 2)}
    localising.WALL_COMPASS = CompassSettings()
    record["rmse_ratio"] = round(record["compass"]["rmse_m_mean"] / record["matcher-only"]["rmse_m_mean"], 3)
    print(json.dumps(record), flush=True)
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=4, help="seeds 0..N-1 of each world (default 4)")
    parser.add_argument("--quick", action="store_true", help="2 seeds of each world")
    args = parser.parse_args()
    seeds = range(2 if args.quick else args.seeds)
    with tempfile.TemporaryDirectory() as folder:
        tour = Path(folder) / "office-building-tour.rap"
        tour.write_text(OFFICE_TOUR.format(navigation=(HERE.parent / "rap_library" / "navigation.rap").as_posix()),
                        encoding="utf-8")
        turned = turned_world(Path(folder), TURN)
        cases = [("lab-corridor-office", MISSIONS / "deliver.rap", "lab-corridor-office"),
                 (f"lab-corridor-office turned {TURN:g} degrees", MISSIONS / "deliver.rap", str(turned)),
                 ("office-building", tour, "office-building"),
                 ("maze", MISSIONS / "deliver-coffee.rap", "maze"),
                 ("small-office-map", MISSIONS / "map-world.rap", "small-office-map")]
        records = [side_by_side(name, mission, world, seeds) for name, mission, world in cases]
    total = {mode: [v for r in records for v in r[mode]["rmse_m"]] for mode in ("compass", "matcher-only")}
    print(json.dumps({"bench": "wall-compass-all", "runs": len(total["compass"]),
                      "succeeded": {mode: sum(r[mode]["succeeded"] for r in records) for mode in total},
                      "rmse_m_mean": {mode: round(sum(v) / len(v), 3) for mode, v in total.items()},
                      "rmse_m_worst": {mode: round(max(v), 3) for mode, v in total.items()},
                      "rmse_ratio": round(sum(total["compass"]) / sum(total["matcher-only"]), 3)}), flush=True)


if __name__ == "__main__":
    main()

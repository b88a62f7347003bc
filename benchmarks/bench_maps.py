"""Benchmark the maps: how fast sonar readings go into an occupancy grid.

- ``maps-sonar-updates``: cell updates per second of
  ``OccupancyGrid.update_sonar`` with realistic readings: the 16-transducer
  rings the simulated robot reads at 10 Hz while driving lab → office → lab
  in ``worlds/lab-corridor-office.yaml`` (recorded once, true poses), fused
  one ring at a time into a fresh 0.05 m grid over the world. A cell update
  is one cell of one beam's empty cone or occupied arc
  (``OccupancyGrid.cells_updated``). Best of ``runs`` passes over the
  recording (target >= 10,000,000/s); the cone templates are built before
  timing (``template_build_s`` says how long that took).

- ``maps-abstraction``: the whole abstraction (distance transform →
  skeleton → places → topological graph) on synthetic 2,000 × 2,000 and
  4,000 × 4,000 floor plans, beside the bare scikit-image ``skeletonize`` +
  scipy ``distance_transform_edt`` calls on the same array, as a ratio
  (target <= 1.5; see ``bench_abstraction.py``, which also runs alone).
- ``maps-real``: when ``../shared/data/maps`` is there, every level of the
  two real ROS maps it holds, timed, with the pictures written to
  ``--pictures`` (default ``bench-maps-pictures/``).

Run: ``pip install . && python benchmarks/bench_maps.py`` (``--quick``:
fewer runs, the 2,000 plan only).
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent)]  # the checkout, if not installed

WORLD = "lab-corridor-office"
TARGET_UPDATES_PER_S = 10_000_000


def _record_rings(world) -> list[tuple[tuple[float, float, float], object]]:
    """(true pose, ranges) at 10 Hz along lab -> office -> lab (``skills.scripted``, as bench_sim.py drives)."""
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.skills.scripted import drive_waypoints, there_and_back

    sim = Simulation(world, seed=0)
    rings = []
    drive_waypoints(sim, there_and_back(world), on_tick=lambda pose: rings.append((pose, sim.sonar().copy())))
    return rings


def bench_sonar_updates(runs: int) -> dict:
    """Cell updates per second of ``update_sonar`` on a recorded drive; best of ``runs`` passes."""
    from atlas_rap.maps.grid import OccupancyGrid
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.sim.world import load_world

    world = load_world(WORLD)
    rings = _record_rings(world)
    angles = Simulation(world, seed=0).sonar_angles
    radius, sonar = world.robot.radius, world.sonar

    start = time.perf_counter()
    OccupancyGrid.covering(world.bounds, 0.05).update_sonar(*rings[0][0], rings[0][1], angles, radius, sonar)
    build = time.perf_counter() - start

    best, cells = math.inf, 0
    for _ in range(max(1, runs)):
        grid = OccupancyGrid.covering(world.bounds, 0.05)
        update = grid.update_sonar
        start = time.perf_counter()
        for (x, y, heading), ranges in rings:
            update(x, y, heading, ranges, angles, radius, sonar)
        best = min(best, time.perf_counter() - start)
        cells = grid.cells_updated
    return {"bench": "maps-sonar-updates", "world": WORLD, "rings": len(rings), "beams_per_ring": len(angles),
            "grid_cells": grid.frame.height * grid.frame.width, "resolution_m": grid.frame.resolution,
            "cells_per_ring": round(cells / len(rings), 1), "wall_s": round(best, 4),
            "us_per_ring": round(best / len(rings) * 1e6, 1),
            "cell_updates_per_s": round(cells / best), "target": TARGET_UPDATES_PER_S,
            "template_build_s": round(build, 3)}


def bench_real_maps(pictures: Path) -> list[dict]:
    """Every level of each real map in ../shared/data/maps, with pictures; [] when the data is absent."""
    from atlas_rap.maps.abstraction import abstract_map
    from atlas_rap.views.map_levels import write_levels
    from atlas_rap.maps.rosmap import load_ros_map

    folder = HERE.parent.parent / "shared" / "data" / "maps"
    records = []
    for map_yaml in sorted(folder.glob("*.yaml")) if folder.is_dir() else []:
        start = time.perf_counter()
        rosmap = load_ros_map(map_yaml)
        loaded = time.perf_counter()
        result = abstract_map(rosmap.occupancy, rosmap.frame, source=str(map_yaml))
        abstracted = time.perf_counter()
        written = write_levels(rosmap.occupancy, result, pictures / map_yaml.stem, title=map_yaml.stem)
        records.append({"bench": "maps-real", "map": map_yaml.name, "cells": rosmap.height * rosmap.width,
                        "load_s": round(loaded - start, 3), "abstract_s": round(abstracted - loaded, 3),
                        "write_levels_s": round(time.perf_counter() - abstracted, 3),
                        "nodes": result.topology.kinds(), "places": int(result.sdt.places.max()),
                        "pictures": str(pictures / map_yaml.stem), "files": len(written)})
    return records


def main() -> None:
    import argparse

    from bench_abstraction import bench_abstraction

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer runs, the 2,000 plan only")
    parser.add_argument("--pictures", type=Path, default=Path("bench-maps-pictures"))
    args = parser.parse_args()
    print(json.dumps(bench_sonar_updates(2 if args.quick else 5)), flush=True)
    for size in [2000] if args.quick else [2000, 4000]:
        print(json.dumps({**bench_abstraction(size, 1 if args.quick else 3), "bench": "maps-abstraction"}),
              flush=True)
    for record in bench_real_maps(args.pictures):
        print(json.dumps(record), flush=True)


if __name__ == "__main__":
    sys.path.insert(0, str(HERE))
    main()

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

Run: ``pip install . && python benchmarks/bench_maps.py``.
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
    """(true pose, ranges) at 10 Hz along lab -> office -> lab, steering as benchmarks/bench_sim.py does."""
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.skills.routes import plan_route

    sim = Simulation(world, seed=0)
    there = plan_route(world, world.robot.start[:2], "office")
    back = plan_route(world, world.places["office"].point, "lab")
    waypoints = list(there.waypoints) + list(back.waypoints)
    rings = []
    reached = 0
    while reached < len(waypoints) and sim.time < 600:
        x, y, heading = sim.pose
        gx, gy = waypoints[reached]
        if math.hypot(gx - x, gy - y) < 0.3:
            reached += 1
            continue
        error = (math.atan2(gy - y, gx - x) - heading + math.pi) % (2 * math.pi) - math.pi
        sim.command(0.5 * max(0.0, math.cos(error)) ** 2, 2.5 * error)
        rings.append(((x, y, heading), sim.sonar().copy()))
        sim.step_many(10)
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


if __name__ == "__main__":
    print(json.dumps(bench_sonar_updates(5)), flush=True)

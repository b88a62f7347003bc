"""Benchmark the simulated robot: how many simulated seconds run in one wall second.

Both measure the default world, ``worlds/lab-corridor-office.yaml`` (the
seed's lab, corridor and office; 15 wall segments, four doors, a person
crossing the corridor and a crate), and print one JSON object a line:

- ``sim-stack``: the whole stack running ``rap_library/missions/deliver.rap``
  (lab → office → lab): physics at 100 Hz, the skill manager at 20 Hz
  (sonar ring of 16 transducers × 3 rays read at 10 Hz, safety reflex,
  event monitors, navigation), the RAP sequencer at 10 Hz, no trace
  output. ``sim_s_per_wall_s`` is simulated seconds per wall second, best
  of several runs (target >= 100).
- ``sim-physics``: the same world and the same route (lab → office → lab,
  from the route planner), driven by a plain 10 Hz steering loop with the
  sonar read at 10 Hz, no skills and no sequencer (target >= 300); and,
  as ``"sonar": false``, the physics alone.

Run: ``pip install . && python benchmarks/bench_sim.py`` (``--quick`` for
fewer runs, to try it out).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent)]  # the checkout, if not installed

PHYSICS_HZ = 100
CONTROL_HZ = 10
WORLD = "lab-corridor-office"
MISSION = HERE.parent / "rap_library" / "missions" / "deliver.rap"


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def drive(with_sonar: bool) -> tuple[float, float, int]:
    """Drive the route once; (wall seconds, simulated seconds, waypoints reached)."""
    from atlas_rap.sim.physics import Simulation
    from atlas_rap.sim.world import load_world
    from atlas_rap.skills.scripted import drive_waypoints, there_and_back

    world = load_world(WORLD)
    sim = Simulation(world, seed=0, dt=1.0 / PHYSICS_HZ)
    waypoints = there_and_back(world)
    start = time.perf_counter()
    reached = drive_waypoints(sim, waypoints, control_hz=CONTROL_HZ,
                              on_tick=(lambda pose: sim.sonar()) if with_sonar else None)
    return time.perf_counter() - start, sim.time, reached


def run_stack() -> tuple[float, float, bool]:
    """Run deliver.rap in-process with the whole stack; (wall seconds, simulated seconds, ok)."""
    from atlas_rap.layers import MissionEngine, RunOptions

    engine = MissionEngine(RunOptions(world=WORLD, seed=0))
    engine.load_file(MISSION, require_post=True)
    start = time.perf_counter()
    result = engine.run_mission(600)
    return time.perf_counter() - start, result.time, result.ok


def bench_stack(runs: int) -> None:
    best, sim_s, ok = min(run_stack() for _ in range(runs))
    emit({"bench": "sim-stack", "mission": "deliver.rap", "world": WORLD, "ok": ok, "sim_s": round(sim_s, 2),
          "wall_s": round(best, 3), "sim_s_per_wall_s": round(sim_s / best, 1), "target": 100,
          "rates_hz": {"physics": 100, "skills": 20, "sequencer": 10, "sonar": 10}})


def bench_physics(runs: int) -> None:
    for with_sonar in (True, False):
        best, sim_s, reached = min(drive(with_sonar) for _ in range(runs))
        emit({"bench": "sim-physics", "world": WORLD, "sonar": with_sonar, "sim_s": round(sim_s, 2),
              "wall_s": round(best, 3), "sim_s_per_wall_s": round(sim_s / best, 1), "target": 300,
              "physics_hz": PHYSICS_HZ, "sonar_hz": CONTROL_HZ if with_sonar else 0,
              "waypoints_reached": reached})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer runs")
    args = parser.parse_args()
    runs = 1 if args.quick else 5
    bench_stack(runs)
    bench_physics(runs)


if __name__ == "__main__":
    main()

"""Driving the simulated robot without skills or RAPs: for benchmarks, map tests and experiments.

:func:`drive_waypoints` steers the robot at 10 Hz straight toward each
waypoint in turn (a turn-then-go controller on the true pose, no obstacle
avoidance), calling ``on_tick`` at every control tick before the physics
steps. :func:`there_and_back` gives the waypoints of a round trip between
the robot's start and a place, through the doors (``skills.routes``).
"""

from __future__ import annotations

import math
from typing import Callable

from atlas_rap.model import Point, World
from atlas_rap.skills.routes import plan_route

REACHED = 0.3  # metres from a waypoint that count as reached


def there_and_back(world: World, place: str = "office", home: str | None = None) -> list[Point]:
    """Waypoints from the robot's start to ``place`` and back to ``home`` (default: where it starts)."""
    there = plan_route(world, world.robot.start[:2], place)
    home = home or world.place_at(*world.robot.start[:2]) or place
    back = plan_route(world, world.places[place].point, home)
    if there is None or back is None:
        raise ValueError(f"no route between the start and {place} in {world.name}")
    return list(there.waypoints) + list(back.waypoints)


def drive_waypoints(sim, waypoints: list[Point], *, control_hz: int = 10, time_limit: float = 600.0,
                    on_tick: Callable[[tuple[float, float, float]], None] | None = None) -> int:
    """Drive through ``waypoints``; how many were reached before ``time_limit`` simulated seconds."""
    steps_per_tick = max(1, round(1.0 / (control_hz * sim.dt)))
    reached = 0
    while reached < len(waypoints) and sim.time < time_limit:
        x, y, heading = sim.pose
        gx, gy = waypoints[reached]
        if math.hypot(gx - x, gy - y) < REACHED:
            reached += 1
            continue
        error = (math.atan2(gy - y, gx - x) - heading + math.pi) % (2 * math.pi) - math.pi
        sim.command(0.5 * max(0.0, math.cos(error)) ** 2, 2.5 * error)
        if on_tick is not None:
            on_tick((x, y, heading))
        sim.step_many(steps_per_tick)
    return reached

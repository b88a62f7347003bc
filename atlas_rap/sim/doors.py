"""The doors of the simulated world: leaves that open and close, on command or on a schedule.

A door with a leaf (``Door.segment``) is a wall's pair of shapes
(:func:`~atlas_rap.sim.shapes.wall_shapes`), in the space while the door is
closed. A doorway without a leaf is always open. A door never closes on the
robot: a close that would overlap the robot waits until the robot is clear
(:class:`~atlas_rap.sim.events.WaitingChanges`).
"""

from __future__ import annotations

import math

import pymunk

from atlas_rap.model import Door
from atlas_rap.sim.events import TimedEvents, WaitingChanges
from atlas_rap.sim.shapes import COLLISION_SLOP, WALL_RADIUS, wall_shapes

__all__ = ["Doors"]


def _distance_to_segment(px: float, py: float, a: tuple[float, float], b: tuple[float, float]) -> float:
    (ax, ay), (bx, by) = a, b
    vx, vy = bx - ax, by - ay
    length2 = vx * vx + vy * vy
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((px - ax) * vx + (py - ay) * vy) / length2))
    return math.hypot(px - ax - t * vx, py - ay - t * vy)


class Doors:
    """The world's ``doors`` in ``space``: each leaf's two shapes and whether each door is open.

    Every door starts open; :meth:`close_the_closed` then closes those the
    world says are closed. ``robot`` is the robot's body and ``radius`` its
    radius, for the closes that must wait until it is clear.
    """

    def __init__(self, space: pymunk.Space, doors: dict[str, Door], waiting: WaitingChanges, robot: pymunk.Body,
                 radius: float) -> None:
        self._space, self._doors, self._waiting, self._robot, self._radius = space, doors, waiting, robot, radius
        self._shapes: dict[str, tuple[pymunk.Shape, pymunk.Shape]] = {}
        self.open: dict[str, bool] = {}
        for name, door in doors.items():
            self.open[name] = True
            if door.segment is not None:
                self._shapes[name] = wall_shapes(space, door.segment.a, door.segment.b)

    def schedule(self, events: TimedEvents) -> None:
        """Add each door's schedule to ``events``."""
        for name, door in self._doors.items():
            for when, is_open in door.schedule:
                events.add(when, self.set, name, bool(is_open))

    def close_the_closed(self) -> None:
        """Close the leaves the world says start closed (a leaf never closes on the robot)."""
        for name, door in self._doors.items():
            if door.segment is not None and not door.open:
                self.set(name, False)

    def set(self, name: str, open: bool) -> None:
        """Open or close the door ``name``; a close that would hit the robot waits until it is clear.

        Raises KeyError for an unknown door and ValueError for closing a
        doorway without a leaf.
        """
        if name not in self.open:
            raise KeyError(f"no door named {name!r}")
        door = self._doors[name]
        if door.segment is None:
            if not open:
                raise ValueError(f"door {name!r} is an opening without a leaf: it cannot close")
            return
        self._waiting.cancel(("door", name))
        if open:
            if not self.open[name]:
                self._space.remove(*self._shapes[name])
                self.open[name] = True
            return
        if not self.open[name]:
            return
        segment = door.segment

        def clear() -> bool:
            x, y = self._robot.position
            return _distance_to_segment(x, y, segment.a, segment.b) > self._radius + WALL_RADIUS + COLLISION_SLOP

        def close() -> None:
            self._space.add(*self._shapes[name])
            self.open[name] = False

        self._waiting.when_clear(("door", name), clear, close)

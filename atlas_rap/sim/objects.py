"""Objects in a simulated world: where each one is, what the gripper holds, what a colour camera sees.

The world's :class:`~atlas_rap.model.WorldObject`\\ s are not bodies of the
physics (the robot drives over them and the sonar does not see them); this
module keeps their state beside the :class:`~atlas_rap.sim.physics.Simulation`
and answers the robot's two devices that deal with them:

* **The colour camera** (:meth:`ObjectSim.look`) sits on the robot's centre
  and looks along its heading. It sees an object when the object is within
  its field of view (``fov``, the whole angle) and ``max_range`` (centre to
  centre), and the line from the camera to the object's centre crosses no
  wall, no closed door leaf, no box and no person (the world model's walls,
  the simulation's door states and its disturbances: the same things the
  sonar echoes from). Objects in the gripper or in a bin are not seen. A
  view reports each object's name, colour, kind, bearing (radians,
  counter-clockwise from the heading) and range, exactly: the camera has
  no noise and draws no random numbers, so adding it changes no other
  reading of a run.
* **The gripper** (:meth:`ObjectSim.pick_up`, :meth:`ObjectSim.drop`)
  picks up a piece of trash within ``reach`` of the robot's centre when it
  holds nothing, carries it (the item moves with the robot, just ahead of
  its rim), and drops it into a bin within reach; the item then stays in
  the bin. Each refusal is returned as the reason, in words.

The world moves objects too (:class:`~atlas_rap.model.ObjectMove`): someone
picks a ball up and puts it elsewhere, at a time or when the robot first
comes within some distance of it. Moves happen in :meth:`ObjectSim.update`,
which every query calls first, so they follow the simulated time and the
robot's true pose whoever asks; a move due while the object is in the
gripper or in a bin is dropped (the world does not take things from the
robot). Nothing here is random: the same run sees the same things.

``body`` is the simulated robot: anything with ``time``, ``pose`` (true
x, y, heading), ``radius``, ``doors_open`` and ``obstacles()`` as
:class:`~atlas_rap.sim.physics.Simulation` has them.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from atlas_rap.model import Point, World, WorldObject

__all__ = ["CARRY_GAP", "ObjectSim", "View"]

CARRY_GAP = 0.1
"""Metres beyond the robot's rim where a carried item is held."""


class View(NamedTuple):
    """One object as the colour camera sees it: bearing in radians from the robot's heading
    (counter-clockwise), range in metres from the robot's centre to the object's."""

    name: str
    colour: str
    kind: str
    bearing: float
    range: float


class ObjectSim:
    """The state of ``world``'s objects beside the simulated robot ``body``; see the module docstring."""

    def __init__(self, world: World, body: Any) -> None:
        self.world = world
        self.body = body
        self.objects: dict[str, WorldObject] = dict(world.objects)
        self.positions: dict[str, Point] = {name: obj.position for name, obj in self.objects.items()}
        self.carried: str | None = None
        self.in_bin: dict[str, str] = {}  # item → bin
        self._moves = {name: list(obj.moves) for name, obj in self.objects.items() if obj.moves}
        self.moved: list[tuple[float, str, Point]] = []  # (time, object, where to): what the world did
        self._walls = np.array([(s.a[0], s.a[1], s.b[0], s.b[1]) for s in world.walls], dtype=float).reshape(-1, 4)
        self._leaves = {name: door.segment for name, door in world.doors.items() if door.segment is not None}

    # -- where things are ---------------------------------------------------------------

    def update(self) -> None:
        """Carry out the world's moves that are due now (by time, or by the robot coming near)."""
        if not self._moves:
            return
        now = self.body.time
        x, y, _ = self.body.pose
        for name in list(self._moves):
            pending = self._moves[name]
            while pending:
                move = pending[0]
                if not self.lying(name):
                    pending.clear()  # in the gripper or a bin: the world leaves it alone
                    break
                due = (move.at is not None and now >= move.at - 1e-9) or (
                    move.near is not None and math.dist((x, y), self.positions[name]) <= move.near)
                if not due:
                    break
                pending.pop(0)
                self.positions[name] = move.to
                self.moved.append((now, name, move.to))
            if not pending:
                del self._moves[name]

    def position(self, name: str) -> Point:
        """Where object ``name`` is now (in the gripper: just ahead of the robot)."""
        if name == self.carried:
            x, y, heading = self.body.pose
            ahead = self.body.radius + CARRY_GAP
            return x + ahead * math.cos(heading), y + ahead * math.sin(heading)
        return self.positions[name]

    def lying(self, name: str) -> bool:
        """Whether the object lies free on the floor (not in the gripper, not in a bin)."""
        return name != self.carried and name not in self.in_bin

    def distance(self, name: str) -> float:
        """Metres from the robot's centre to the object's."""
        x, y, _ = self.body.pose
        return math.dist((x, y), self.position(name))

    # -- the colour camera -------------------------------------------------------------------

    def look(self, fov: float, max_range: float) -> list[View]:
        """What a camera on the robot's centre, facing its heading, sees now (see the module docstring)."""
        self.update()
        x, y, heading = self.body.pose
        half = fov / 2
        seen: list[View] = []
        blockers = None
        for name, obj in self.objects.items():
            if not self.lying(name):
                continue
            ox, oy = self.positions[name]
            distance = math.hypot(ox - x, oy - y)
            if distance > max_range:
                continue
            direction = math.atan2(oy - y, ox - x) - heading
            bearing = math.atan2(math.sin(direction), math.cos(direction)) if distance > 1e-9 else 0.0
            if abs(bearing) > half:
                continue
            if blockers is None:
                blockers = self._blockers()
            if self._clear((x, y), (ox, oy), *blockers):
                seen.append(View(name, obj.colour, obj.kind, bearing, distance))
        return seen

    def clear_line(self, a: Point, b: Point) -> bool:
        """Whether the line from ``a`` to ``b`` crosses no wall, closed door, box or person."""
        return self._clear(a, b, *self._blockers())

    def _blockers(self) -> tuple[np.ndarray, list[tuple[Point, float]]]:
        """The segments (walls, closed door leaves, the sides of boxes) and discs (people) that hide things."""
        segments = [self._walls]
        closed = [self._leaves[name] for name, is_open in self.body.doors_open.items()
                  if not is_open and name in self._leaves]
        if closed:
            segments.append(np.array([(s.a[0], s.a[1], s.b[0], s.b[1]) for s in closed], dtype=float))
        discs: list[tuple[Point, float]] = []
        for kind, (cx, cy), size in self.body.obstacles():
            h = size / 2
            if kind == "box":
                corners = [(cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h)]
                segments.append(np.array([(*corners[i], *corners[(i + 1) % 4]) for i in range(4)], dtype=float))
            else:
                discs.append(((cx, cy), h))
        return np.concatenate(segments) if len(segments) > 1 else segments[0], discs

    @staticmethod
    def _clear(a: Point, b: Point, segments: np.ndarray, discs: list[tuple[Point, float]]) -> bool:
        if len(segments) and _crosses(a, b, segments).any():
            return False
        for centre, radius in discs:
            if _point_segment_distance(centre, a, b) < radius:
                return False
        return True

    # -- the gripper ---------------------------------------------------------------------

    def pick_up(self, name: str, reach: float) -> str | None:
        """Take ``name`` into the gripper; None when done, else why not."""
        self.update()
        why = self.why_not_pick_up(name, reach)
        if why is None:
            self.carried = name
        return why

    def why_not_pick_up(self, name: str, reach: float) -> str | None:
        """Why the gripper cannot pick up ``name`` now (None: it can)."""
        obj = self.objects.get(name)
        if obj is None:
            return f"there is no object named {name}"
        if obj.kind == "bin":
            return f"{name} is a bin: bins stay where they are"
        if self.carried == name:
            return None
        if self.carried is not None:
            return f"the gripper is holding {self.carried}"
        if name in self.in_bin:
            return f"{name} is in {self.in_bin[name]}"
        distance = self.distance(name)
        if distance > reach:
            return f"{name} is {distance:.2f} m from the robot; the gripper reaches {reach:g} m"
        return None

    def drop(self, name: str, bin_name: str, reach: float) -> str | None:
        """Drop the item ``name`` from the gripper into the bin ``bin_name``; None when done, else why not."""
        self.update()
        why = self.why_not_drop(name, bin_name, reach)
        if why is None:
            self.carried = None
            self.in_bin[name] = bin_name
            self.positions[name] = self.positions[bin_name]
        return why

    def why_not_drop(self, name: str, bin_name: str, reach: float) -> str | None:
        """Why the gripper cannot drop ``name`` into ``bin_name`` now (None: it can)."""
        if self.carried != name:
            return f"the gripper is not holding {name}" + (f" (it holds {self.carried})" if self.carried else
                                                           " (it is empty)")
        target = self.objects.get(bin_name)
        if target is None:
            return f"there is no object named {bin_name}"
        if target.kind != "bin":
            return f"{bin_name} is not a bin"
        distance = self.distance(bin_name)
        if distance > reach:
            return f"{bin_name} is {distance:.2f} m from the robot; the gripper reaches {reach:g} m"
        return None


def _crosses(a: Point, b: Point, segments: np.ndarray) -> np.ndarray:
    """For each segment row (x1, y1, x2, y2), whether it crosses or touches the segment a-b."""
    ax, ay = a
    bx, by = b
    px, py, qx, qy = segments[:, 0], segments[:, 1], segments[:, 2], segments[:, 3]
    d1 = (qx - px) * (ay - py) - (qy - py) * (ax - px)
    d2 = (qx - px) * (by - py) - (qy - py) * (bx - px)
    d3 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
    d4 = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax)
    return (d1 * d2 <= 0) & (d3 * d4 <= 0) & ~((d1 == 0) & (d2 == 0))  # collinear overlaps do not hide


def _point_segment_distance(p: Point, a: Point, b: Point) -> float:
    (px, py), (ax, ay), (bx, by) = p, a, b
    vx, vy = bx - ax, by - ay
    length2 = vx * vx + vy * vy
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((px - ax) * vx + (py - ay) * vy) / length2))
    return math.hypot(px - ax - t * vx, py - ay - t * vy)

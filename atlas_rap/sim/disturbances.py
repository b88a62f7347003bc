"""The disturbances of the simulated world: boxes that appear and go, people who walk.

A ``box`` is a static axis-aligned square of side ``size`` centred on
``path[0]``, present from ``start`` until ``end`` (for ever when ``end`` is
None). A ``person`` is a kinematic disc of diameter ``size`` that appears at
``path[0]`` at ``start`` and walks the polyline ``path`` at ``speed``; it
stops and waits while its next step would bring it within
:data:`PERSON_CLEARANCE` of the robot (people give way, and a kinematic body
could otherwise squeeze the robot into a wall); it is removed at ``end``, or
at the end of its path when ``end`` is None (with an ``end``, it stands at
its last point until then). A disturbance that would appear on top of the
robot waits until the robot is clear.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import pymunk

from atlas_rap.model import Disturbance
from atlas_rap.sim.events import TimedEvents, WaitingChanges
from atlas_rap.sim.shapes import COLLISION_SLOP, OBSTACLE_FILTER, WALL_FRICTION

__all__ = ["PERSON_CLEARANCE", "Disturbances", "Person"]

PERSON_CLEARANCE = 0.05  # m: a person waits rather than come closer than this to the robot


class Person:
    """A person walking a polyline: its body, shape and progress."""

    __slots__ = ("body", "done", "leg", "points", "radius", "shape", "spec")

    def __init__(self, spec: Disturbance) -> None:
        self.spec = spec
        self.radius = spec.size / 2
        self.points = [(float(x), float(y)) for x, y in spec.path]
        self.body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.body.position = self.points[0]
        self.shape = pymunk.Circle(self.body, self.radius)
        self.shape.filter = OBSTACLE_FILTER
        self.shape.friction = WALL_FRICTION
        self.leg = 0  # walking from points[leg] to points[leg + 1]
        self.done = len(self.points) < 2


class Disturbances:
    """The world's disturbances in ``space``: the boxes and the people present now.

    ``robot`` is the robot's body and ``radius`` its radius (people give way
    to it, and nothing appears on it); ``dt`` is the physics step.
    :attr:`persons` is changed in place, so a caller may hold it and test it
    cheaply.
    """

    def __init__(self, space: pymunk.Space, specs: Sequence[Disturbance], waiting: WaitingChanges,
                 robot: pymunk.Body, radius: float, dt: float) -> None:
        self._space, self._specs, self._waiting, self._robot = space, specs, waiting, robot
        self._radius, self._dt = radius, dt
        self.persons: list[Person] = []
        self._boxes: dict[str, tuple[pymunk.Shape, tuple[float, float], float]] = {}

    def schedule(self, events: TimedEvents) -> None:
        """Add each disturbance's coming and going to ``events``; a ValueError for a disturbance
        of an unknown kind, a person without a path or a box without a position."""
        for spec in self._specs:
            if spec.kind == "box":
                events.add(spec.start, self._add_box, spec)
                if spec.end is not None:
                    events.add(spec.end, self._remove_box, spec.name)
            elif spec.kind == "person":
                if not spec.path:
                    raise ValueError(f"person {spec.name!r} has no path")
                person = Person(spec)
                events.add(spec.start, self._add_person, person)
                if spec.end is not None:
                    events.add(spec.end, self._remove_person, person)
            else:
                raise ValueError(f"disturbance {spec.name!r}: unknown kind {spec.kind!r} (box or person)")
            if spec.kind == "box" and not spec.path:
                raise ValueError(f"box {spec.name!r} has no position (path[0])")

    def present(self) -> list[tuple[str, tuple[float, float], float]]:
        """The disturbances present now as ``(kind, (x, y), size)``, the form ``render_run`` takes."""
        found: list[tuple[str, tuple[float, float], float]] = [
            ("box", center, size) for _, center, size in self._boxes.values()]
        for person in self.persons:
            x, y = person.body.position
            found.append(("person", (x, y), person.spec.size))
        return found

    def _add_box(self, spec: Disturbance) -> None:
        cx, cy = float(spec.path[0][0]), float(spec.path[0][1])
        h = spec.size / 2
        shape = pymunk.Poly(self._space.static_body,
                            [(cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h)])
        shape.filter = OBSTACLE_FILTER
        shape.friction = WALL_FRICTION

        def clear() -> bool:
            x, y = self._robot.position
            dx = max(abs(x - cx) - h, 0.0)
            dy = max(abs(y - cy) - h, 0.0)
            return math.hypot(dx, dy) > self._radius + COLLISION_SLOP

        def add() -> None:
            self._space.add(shape)
            self._boxes[spec.name] = (shape, (cx, cy), float(spec.size))

        self._waiting.when_clear(("box", spec.name), clear, add)

    def _remove_box(self, name: str) -> None:
        self._waiting.cancel(("box", name))
        box = self._boxes.pop(name, None)
        if box is not None:
            self._space.remove(box[0])

    def _add_person(self, person: Person) -> None:
        px, py = person.points[0]

        def clear() -> bool:
            x, y = self._robot.position
            return math.hypot(x - px, y - py) > self._radius + person.radius + PERSON_CLEARANCE

        def add() -> None:
            self._space.add(person.body, person.shape)
            self.persons.append(person)

        self._waiting.when_clear(("person", id(person)), clear, add)

    def _remove_person(self, person: Person) -> None:
        self._waiting.cancel(("person", id(person)))
        if person in self.persons:
            self.persons.remove(person)
            self._space.remove(person.body, person.shape)

    def walk_people(self) -> None:
        """Set each person's velocity for this step: along its path, or 0 while the robot is in the way."""
        rx, ry = self._robot.position
        dt = self._dt
        finished = []
        for person in self.persons:
            body = person.body
            if person.done:
                body.velocity = (0.0, 0.0)
                if person.spec.end is None:
                    finished.append(person)
                continue
            x, y = body.position
            step = person.spec.speed * dt
            tx, ty = x, y
            leg = person.leg
            points = person.points
            while step > 0 and leg < len(points) - 1:  # walk `step` metres along the polyline
                nx, ny = points[leg + 1]
                gap = math.hypot(nx - tx, ny - ty)
                if gap <= step:
                    tx, ty, step, leg = nx, ny, step - gap, leg + 1
                else:
                    tx, ty, step = tx + (nx - tx) * step / gap, ty + (ny - ty) * step / gap, 0.0
            near = self._radius + person.radius + PERSON_CLEARANCE
            if math.hypot(tx - rx, ty - ry) < near and math.hypot(tx - rx, ty - ry) < math.hypot(x - rx, y - ry):
                body.velocity = (0.0, 0.0)  # give way
                continue
            body.velocity = ((tx - x) / dt, (ty - y) / dt)
            person.leg = leg
            if leg >= len(points) - 1:
                person.done = True
        for person in finished:
            self._remove_person(person)

"""The simulated robot in a world: pymunk physics, drive, bumper, odometry, doors, disturbances.

:class:`Simulation` builds a pymunk space from a :class:`~atlas_rap.model.World`
and steps it at a fixed ``dt`` (SI units, zero gravity):

* **Walls** are static segments of radius :data:`WALL_RADIUS` that the robot
  collides with, each with a zero-thickness copy on its centre line that
  only the sonar sees (so readings measure the world's true geometry; see
  :mod:`atlas_rap.sim.sonar`).
* **Doors** with a leaf (``Door.segment``) are the same pair of shapes,
  in the space while the door is closed. :meth:`Simulation.set_door` opens
  and closes them; a door's ``schedule`` is applied by time inside
  :meth:`Simulation.step`. A door never closes on the robot: a close that
  would overlap the robot waits until the robot is clear.
* **The robot** is a dynamic disc driven the way pymunk's tank example
  drives its tank: a kinematic *control body* is joined to it by a
  :class:`pymunk.PivotJoint` and a :class:`pymunk.GearJoint`, both with
  ``max_bias = 0`` (they match velocities, never correct positions) and
  bounded forces (:data:`DRIVE_IMPULSE` / ``dt``, :data:`TURN_IMPULSE` / ``dt``). Each step the
  control body gets the commanded forward speed along the robot's current
  heading and the commanded turn rate; the joints drag the robot after it
  like very strong wheel friction, while contacts with walls are hard
  constraints the joints cannot overcome, so the robot stops at walls
  instead of being pushed through them.
* **Bumper.** A pre-solve collision callback on the robot's shape notes
  every step in which the robot touches anything (wall, door leaf, box,
  person) and the direction of the deepest contact.
* **Odometry** integrates the true body-frame motion of every step. With
  ``RobotConfig.odometry_drift`` = d > 0, each step's forward travel ``ds``
  and turn ``dθ`` get Gaussian errors of standard deviation
  ``d * sqrt(|ds|)`` and ``d * sqrt(|dθ|)``, so the error is a random walk
  with standard deviation d after 1 m travelled (or 1 rad turned). With
  d = 0 odometry is the true pose.
* **Disturbances.** A ``box`` is a static axis-aligned square of side
  ``size`` centred on ``path[0]``, present from ``start`` until ``end``
  (for ever when ``end`` is None). A ``person`` is a kinematic disc of
  diameter ``size`` that appears at ``path[0]`` at ``start`` and walks the
  polyline ``path`` at ``speed``; it stops and waits while its next step
  would bring it within :data:`PERSON_CLEARANCE` of the robot (people give
  way, and a kinematic body could otherwise squeeze the robot into a wall);
  it is removed at ``end``, or at the end of its path when ``end`` is
  None (with an ``end``, it stands at its last point until then). A
  disturbance that would appear on top of the robot waits until the robot
  is clear.
* **Randomness.** One ``numpy.random.Generator`` (``default_rng(seed)``)
  serves the sonar noise, the sonar dropout and the odometry drift; the
  same world, seed and command sequence give the same readings and path.

The sonar is computed only when :meth:`Simulation.sonar` is asked, at most
once per step (a second call in the same step returns the same reading).
The robot's true pose is recorded in :attr:`Simulation.path` every
``path_every`` steps (default 10: every 0.1 s at the default ``dt``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pymunk

from atlas_rap.model import Disturbance, Door, World
from atlas_rap.sim.sonar import (
    ECHO_CATEGORY,
    OBSTACLE_CATEGORY,
    ROBOT_CATEGORY,
    SENSOR_CATEGORY,
    WALL_CATEGORY,
    SonarRing,
)

__all__ = ["DRIVE_IMPULSE", "PERSON_CLEARANCE", "ROBOT_MASS", "TURN_IMPULSE", "WALL_RADIUS", "Simulation"]

WALL_RADIUS = 0.02  # m: collision thickness either side of a wall's centre line
ROBOT_MASS = 10.0  # kg
# The joints' force limits are set per step as impulse / dt, so that one step can change the robot's
# speed by at most 2 m/s and its turn rate by 10 rad/s whatever dt is (at dt = 0.01 s: 2000 N and
# 200 N m, so a command is met within a step or two). A fixed force would push the robot deeper into
# walls at large dt (the joint's impulse per step grows with dt and fights the contact).
DRIVE_IMPULSE = 20.0  # N s: ROBOT_MASS * 2 m/s
TURN_IMPULSE = 2.0  # N m s: the disc's moment of inertia (0.2 kg m^2) * 10 rad/s
ROBOT_FRICTION = 0.3  # robot against walls and obstacles (Chipmunk multiplies the two frictions)
WALL_FRICTION = 0.5
COLLISION_SLOP = 0.002  # m of overlap the solver allows before pushing apart
PERSON_CLEARANCE = 0.05  # m: a person waits rather than come closer than this to the robot
_ROBOT_COLLISION_TYPE = 1
_EVENT_EPS = 1e-9  # events at time t fire on the step whose end time is >= t - eps
_NOISE_BLOCK = 1024  # odometry drift normals drawn this many at a time

_ROBOT_FILTER = pymunk.ShapeFilter(categories=ROBOT_CATEGORY, mask=WALL_CATEGORY | OBSTACLE_CATEGORY)
_WALL_FILTER = pymunk.ShapeFilter(categories=WALL_CATEGORY, mask=ROBOT_CATEGORY)
_ECHO_ONLY_FILTER = pymunk.ShapeFilter(categories=ECHO_CATEGORY, mask=SENSOR_CATEGORY)
_OBSTACLE_FILTER = pymunk.ShapeFilter(categories=OBSTACLE_CATEGORY, mask=ROBOT_CATEGORY | SENSOR_CATEGORY)


def _wrap(angle: float) -> float:
    """``angle`` in (-pi, pi]."""
    return math.pi - (math.pi - angle) % (2 * math.pi)


def _distance_to_segment(px: float, py: float, a: tuple[float, float], b: tuple[float, float]) -> float:
    (ax, ay), (bx, by) = a, b
    vx, vy = bx - ax, by - ay
    length2 = vx * vx + vy * vy
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((px - ax) * vx + (py - ay) * vy) / length2))
    return math.hypot(px - ax - t * vx, py - ay - t * vy)


class _Person:
    """A person walking a polyline: its body, shape and progress."""

    __slots__ = ("body", "done", "leg", "points", "radius", "shape", "spec")

    def __init__(self, spec: Disturbance) -> None:
        self.spec = spec
        self.radius = spec.size / 2
        self.points = [(float(x), float(y)) for x, y in spec.path]
        self.body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.body.position = self.points[0]
        self.shape = pymunk.Circle(self.body, self.radius)
        self.shape.filter = _OBSTACLE_FILTER
        self.shape.friction = WALL_FRICTION
        self.leg = 0  # walking from points[leg] to points[leg + 1]
        self.done = len(self.points) < 2


class Simulation:
    """The simulated robot in ``world``; see the module docstring for the model.

    ``seed`` seeds the one random generator of the run; ``dt`` is the
    physics step in seconds; the true pose is added to :attr:`path` every
    ``path_every`` steps.
    """

    def __init__(self, world: World, seed: int = 0, dt: float = 0.01, *, path_every: int = 10) -> None:
        if dt <= 0:
            raise ValueError("dt must be positive")
        if path_every < 1:
            raise ValueError("path_every must be at least 1")
        self.world = world
        self.dt = float(dt)
        self.rng = np.random.default_rng(seed)
        robot = world.robot
        self.radius = float(robot.radius)
        self.max_speed = float(robot.max_speed)
        self.max_turn_rate = float(robot.max_turn_rate)

        space = pymunk.Space()
        space.gravity = (0.0, 0.0)
        space.collision_slop = COLLISION_SLOP
        space.iterations = 10
        self._space = space
        for wall in world.walls:
            space.add(*self._wall_shapes(wall.a, wall.b))

        # the robot and its drive
        x, y, heading = (float(v) for v in robot.start)
        body = pymunk.Body(ROBOT_MASS, pymunk.moment_for_circle(ROBOT_MASS, 0.0, self.radius))
        body.position = (x, y)
        body.angle = heading
        shape = pymunk.Circle(body, self.radius)
        shape.filter = _ROBOT_FILTER
        shape.friction = ROBOT_FRICTION
        shape.elasticity = 0.0
        shape.collision_type = _ROBOT_COLLISION_TYPE
        control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        control.position = (x, y)
        control.angle = heading
        pivot = pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0))
        pivot.max_bias = 0.0
        pivot.max_force = DRIVE_IMPULSE / self.dt
        gear = pymunk.GearJoint(control, body, 0.0, 1.0)
        gear.max_bias = 0.0
        gear.max_force = TURN_IMPULSE / self.dt
        space.add(body, shape, control, pivot, gear)
        self._body, self._shape, self._control = body, shape, control
        space.on_collision(_ROBOT_COLLISION_TYPE, None, pre_solve=self._on_contact)
        self._v = 0.0
        self._omega = 0.0

        # bumper
        self._bumped = False
        self._bump_depth = 0.0
        self._bump_normal = (1.0, 0.0)
        self._bump_steps = 0

        # odometry
        self._drift = float(robot.odometry_drift)
        self._last = (x, y, heading)
        self._odo = [x, y, heading]
        self._odo_noise = np.empty(0)
        self._odo_noise_at = 0

        # doors: the two shapes of each leaf, and whether each door is open
        self._door_shapes: dict[str, tuple[pymunk.Shape, pymunk.Shape]] = {}
        self._doors_open: dict[str, bool] = {}
        for name, door in world.doors.items():
            self._doors_open[name] = True
            if door.segment is not None:
                self._door_shapes[name] = self._wall_shapes(door.segment.a, door.segment.b)

        # timed events: door schedules and disturbances; things waiting for the robot to move
        self._persons: list[_Person] = []
        self._boxes: dict[str, tuple[pymunk.Shape, tuple[float, float], float]] = {}
        # (key, is the robot clear?, apply): changes waiting for the robot to move out of the way
        self._waiting: list[tuple[tuple[str, object], Callable[[], bool], Callable[[], None]]] = []
        events: list[tuple[float, int, Callable[..., None], tuple]] = []
        for name, door in world.doors.items():
            for when, is_open in door.schedule:
                events.append((float(when), len(events), self.set_door, (name, bool(is_open))))
        for spec in world.disturbances:
            if spec.kind == "box":
                events.append((float(spec.start), len(events), self._add_box, (spec,)))
                if spec.end is not None:
                    events.append((float(spec.end), len(events), self._remove_box, (spec.name,)))
            elif spec.kind == "person":
                if not spec.path:
                    raise ValueError(f"person {spec.name!r} has no path")
                person = _Person(spec)
                events.append((float(spec.start), len(events), self._add_person, (person,)))
                if spec.end is not None:
                    events.append((float(spec.end), len(events), self._remove_person, (person,)))
            else:
                raise ValueError(f"disturbance {spec.name!r}: unknown kind {spec.kind!r} (box or person)")
            if spec.kind == "box" and not spec.path:
                raise ValueError(f"box {spec.name!r} has no position (path[0])")
        events.sort(key=lambda e: (e[0], e[1]))
        self._events = events
        self._event_at = 0
        self._next_event = events[0][0] - _EVENT_EPS if events else math.inf

        self._ring = SonarRing(world.sonar, self.radius)
        self._sonar_step = -1
        self._sonar_reading = np.empty(0)

        self._steps = 0
        self._path_every = path_every
        self._path_countdown = path_every
        self._path: list[tuple[float, float, float, float]] = [(0.0, x, y, _wrap(heading))]

        for name, door in world.doors.items():  # initial door states (a leaf never closes on the robot)
            if door.segment is not None and not door.open:
                self.set_door(name, False)
        self._fire_events()  # everything due at time 0

    # -- building -------------------------------------------------------------

    def _wall_shapes(self, a, b) -> tuple[pymunk.Shape, pymunk.Shape]:
        """The collision segment and the sonar's zero-thickness copy of a wall from a to b."""
        a, b = (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))
        solid = pymunk.Segment(self._space.static_body, a, b, WALL_RADIUS)
        solid.filter = _WALL_FILTER
        solid.friction = WALL_FRICTION
        solid.elasticity = 0.0
        echo = pymunk.Segment(self._space.static_body, a, b, 0.0)
        echo.filter = _ECHO_ONLY_FILTER
        return solid, echo

    # -- driving --------------------------------------------------------------

    def command(self, v: float, omega: float) -> None:
        """Drive at forward speed ``v`` (m/s) and turn rate ``omega`` (rad/s, counter-clockwise), clipped to the robot's limits."""
        v = max(-self.max_speed, min(self.max_speed, float(v)))
        omega = max(-self.max_turn_rate, min(self.max_turn_rate, float(omega)))
        self._v, self._omega = v, omega
        self._control.angular_velocity = omega
        if v == 0.0:
            self._control.velocity = (0.0, 0.0)

    @property
    def commanded(self) -> tuple[float, float]:
        """The current (v, omega) command after clipping."""
        return self._v, self._omega

    def step(self) -> None:
        """Advance the world by ``dt``: doors and disturbances due, people walking, the robot driving."""
        v = self._v
        if v != 0.0:
            heading = self._body.angle
            self._control.velocity = (v * math.cos(heading), v * math.sin(heading))
        if self._persons:
            self._walk_people()
        self._bumped = False
        self._space.step(self.dt)
        if self._bumped:
            self._bump_steps += 1
        self._steps += 1
        if self._drift:
            self._integrate_odometry()
        if self._waiting:
            self._retry_waiting()
        if self._steps * self.dt >= self._next_event:
            self._fire_events()
        self._path_countdown -= 1
        if not self._path_countdown:
            self._path_countdown = self._path_every
            x, y = self._body.position
            self._path.append((self._steps * self.dt, x, y, _wrap(self._body.angle)))

    def step_many(self, n: int) -> None:
        """``n`` steps."""
        step = self.step
        for _ in range(n):
            step()

    def run_until(self, t: float) -> None:
        """Step until :attr:`time` >= ``t``."""
        step = self.step
        while self._steps * self.dt < t - _EVENT_EPS:
            step()

    # -- state ----------------------------------------------------------------

    @property
    def time(self) -> float:
        """Simulated seconds since the start."""
        return self._steps * self.dt

    @property
    def steps(self) -> int:
        """Physics steps since the start."""
        return self._steps

    @property
    def pose(self) -> tuple[float, float, float]:
        """The true (x, y, heading), heading in (-pi, pi]."""
        x, y = self._body.position
        return x, y, _wrap(self._body.angle)

    @property
    def velocity(self) -> tuple[float, float]:
        """The true body-frame (forward speed, turn rate)."""
        body = self._body
        vx, vy = body.velocity
        heading = body.angle
        return vx * math.cos(heading) + vy * math.sin(heading), body.angular_velocity

    @property
    def odometry(self) -> tuple[float, float, float]:
        """The pose as dead reckoning has it (starting at the true start pose); the true pose without drift."""
        if not self._drift:
            return self.pose
        x, y, heading = self._odo
        return x, y, _wrap(heading)

    @property
    def path(self) -> list[tuple[float, float, float, float]]:
        """The true poses (t, x, y, heading) so far, every ``path_every`` steps from t = 0 (do not modify)."""
        return self._path

    @property
    def bumped(self) -> bool:
        """Whether the robot touched a wall, door leaf or obstacle during the last step."""
        return self._bumped

    @property
    def bump_steps(self) -> int:
        """How many steps so far the robot touched something: a bump between two looks shows as a change."""
        return self._bump_steps

    @property
    def bump_angle(self) -> float | None:
        """Body-frame direction of the last step's deepest contact (0 = straight ahead), or None without one."""
        if not self._bumped:
            return None
        nx, ny = self._bump_normal
        return _wrap(math.atan2(ny, nx) - self._body.angle)

    def _on_contact(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        points = arbiter.contact_point_set.points
        depth = min(p.distance for p in points) if points else 0.0
        if not self._bumped or depth < self._bump_depth:
            normal = arbiter.normal  # from the robot (first shape) toward what it touches
            if arbiter.shapes[0] is not self._shape:
                normal = -normal
            self._bumped, self._bump_depth, self._bump_normal = True, depth, (normal.x, normal.y)

    def _integrate_odometry(self) -> None:
        body = self._body
        x, y = body.position
        heading = body.angle
        lx, ly, lh = self._last
        self._last = (x, y, heading)
        turn = heading - lh
        mid = lh + turn / 2
        c, s = math.cos(mid), math.sin(mid)
        dx, dy = x - lx, y - ly
        forward, lateral = dx * c + dy * s, dy * c - dx * s
        at = self._odo_noise_at
        if at + 2 > len(self._odo_noise):
            self._odo_noise, at = self.rng.standard_normal(_NOISE_BLOCK), 0
        noise = self._odo_noise
        self._odo_noise_at = at + 2
        d = self._drift
        forward += d * math.sqrt(abs(forward)) * noise[at]
        turn += d * math.sqrt(abs(turn)) * noise[at + 1]
        odo = self._odo
        mid = odo[2] + turn / 2
        c, s = math.cos(mid), math.sin(mid)
        odo[0] += forward * c - lateral * s
        odo[1] += forward * s + lateral * c
        odo[2] += turn

    # -- sonar ----------------------------------------------------------------

    def sonar(self) -> np.ndarray:
        """The sonar ring's reading now: ranges in metres (float64, ``max_range`` = no echo), read-only.

        Computed when asked, at most once per step: a second call in the same
        step returns the same array (and draws no more random numbers).
        """
        if self._sonar_step != self._steps:
            x, y = self._body.position
            reading = self._ring.scan(self._space, x, y, self._body.angle, self.rng)
            reading.setflags(write=False)
            self._sonar_reading, self._sonar_step = reading, self._steps
        return self._sonar_reading

    @property
    def sonar_angles(self) -> np.ndarray:
        """Body-frame angles of the transducers: the first 0 (forward), counter-clockwise, evenly spaced."""
        return self._ring.angles

    # -- doors ----------------------------------------------------------------

    @property
    def doors_open(self) -> dict[str, bool]:
        """Every door's state now: True when open (a doorway without a leaf is always open)."""
        return dict(self._doors_open)

    def set_door(self, name: str, open: bool) -> None:
        """Open or close the door ``name``; a close that would hit the robot waits until it is clear.

        Raises KeyError for an unknown door and ValueError for closing a
        doorway without a leaf.
        """
        if name not in self._doors_open:
            raise KeyError(f"no door named {name!r}")
        door: Door = self.world.doors[name]
        if door.segment is None:
            if not open:
                raise ValueError(f"door {name!r} is an opening without a leaf: it cannot close")
            return
        self._cancel(("door", name))
        if open:
            if not self._doors_open[name]:
                self._space.remove(*self._door_shapes[name])
                self._doors_open[name] = True
            return
        if not self._doors_open[name]:
            return
        segment = door.segment

        def clear() -> bool:
            x, y = self._body.position
            return _distance_to_segment(x, y, segment.a, segment.b) > self.radius + WALL_RADIUS + COLLISION_SLOP

        def close() -> None:
            self._space.add(*self._door_shapes[name])
            self._doors_open[name] = False

        self._when_clear(("door", name), clear, close)

    # -- disturbances ---------------------------------------------------------

    def obstacles(self) -> list[tuple[str, tuple[float, float], float]]:
        """The disturbances present now as ``(kind, (x, y), size)``, the form ``render_run`` takes."""
        found: list[tuple[str, tuple[float, float], float]] = [
            ("box", center, size) for _, center, size in self._boxes.values()]
        for person in self._persons:
            x, y = person.body.position
            found.append(("person", (x, y), person.spec.size))
        return found

    def _add_box(self, spec: Disturbance) -> None:
        cx, cy = float(spec.path[0][0]), float(spec.path[0][1])
        h = spec.size / 2
        shape = pymunk.Poly(self._space.static_body,
                            [(cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h)])
        shape.filter = _OBSTACLE_FILTER
        shape.friction = WALL_FRICTION

        def clear() -> bool:
            x, y = self._body.position
            dx = max(abs(x - cx) - h, 0.0)
            dy = max(abs(y - cy) - h, 0.0)
            return math.hypot(dx, dy) > self.radius + COLLISION_SLOP

        def add() -> None:
            self._space.add(shape)
            self._boxes[spec.name] = (shape, (cx, cy), float(spec.size))

        self._when_clear(("box", spec.name), clear, add)

    def _remove_box(self, name: str) -> None:
        self._cancel(("box", name))
        box = self._boxes.pop(name, None)
        if box is not None:
            self._space.remove(box[0])

    def _add_person(self, person: _Person) -> None:
        px, py = person.points[0]

        def clear() -> bool:
            x, y = self._body.position
            return math.hypot(x - px, y - py) > self.radius + person.radius + PERSON_CLEARANCE

        def add() -> None:
            self._space.add(person.body, person.shape)
            self._persons.append(person)

        self._when_clear(("person", id(person)), clear, add)

    def _remove_person(self, person: _Person) -> None:
        self._cancel(("person", id(person)))
        if person in self._persons:
            self._persons.remove(person)
            self._space.remove(person.body, person.shape)

    def _walk_people(self) -> None:
        """Set each person's velocity for this step: along its path, or 0 while the robot is in the way."""
        rx, ry = self._body.position
        dt = self.dt
        finished = []
        for person in self._persons:
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
            near = self.radius + person.radius + PERSON_CLEARANCE
            if math.hypot(tx - rx, ty - ry) < near and math.hypot(tx - rx, ty - ry) < math.hypot(x - rx, y - ry):
                body.velocity = (0.0, 0.0)  # give way
                continue
            body.velocity = ((tx - x) / dt, (ty - y) / dt)
            person.leg = leg
            if leg >= len(points) - 1:
                person.done = True
        for person in finished:
            self._remove_person(person)

    # -- events ---------------------------------------------------------------

    def _when_clear(self, key: tuple[str, object], clear: Callable[[], bool], apply: Callable[[], None]) -> None:
        """Apply a change now if the robot is clear of it, else as soon as it is."""
        if clear():
            apply()
        else:
            self._waiting.append((key, clear, apply))

    def _cancel(self, key: tuple[str, object]) -> None:
        self._waiting = [w for w in self._waiting if w[0] != key]

    def _retry_waiting(self) -> None:
        still = []
        for key, clear, apply in self._waiting:
            if clear():
                apply()
            else:
                still.append((key, clear, apply))
        self._waiting = still

    def _fire_events(self) -> None:
        now = self._steps * self.dt
        events = self._events
        while self._event_at < len(events) and events[self._event_at][0] - _EVENT_EPS <= now:
            _, _, action, args = events[self._event_at]
            self._event_at += 1
            action(*args)
        self._next_event = events[self._event_at][0] - _EVENT_EPS if self._event_at < len(events) else math.inf

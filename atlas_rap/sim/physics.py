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
* **Odometry** integrates the true body-frame motion of every step, with
  the errors of ``RobotConfig.odometry_noise`` (AMCL's alpha1-alpha4; see
  :mod:`~atlas_rap.sim.sensors`), on by default. With the noise off,
  odometry is the true pose: nothing is integrated and no random number is
  drawn for it, until a kidnap.
* **Kidnaps.** :meth:`Simulation.teleport` puts the robot somewhere else
  without telling its odometry, which goes on from where it believed it
  was; ``RobotConfig.teleports`` are done at their times. A world's
  teleport waits while a box, a person or a closed door leaf is where the
  robot would land; :meth:`Simulation.teleport` itself does not wait.
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
  serves the sonar noise, the sonar dropout and the odometry noise; the
  same world, seed and command sequence give the same readings and path.

The sonar is computed only when :meth:`Simulation.sonar` is asked, at most
once per step (a second call in the same step returns the same reading).
The robot's true pose is recorded in :attr:`Simulation.path` every
``path_every`` steps (default 10: every 0.1 s at the default ``dt``).

:class:`Simulation` holds the parts that do this: its sensors
(:mod:`~atlas_rap.sim.sensors`: bumper, odometry, sonar), its doors
(:mod:`~atlas_rap.sim.doors`), its disturbances
(:mod:`~atlas_rap.sim.disturbances`), and the changes waiting for their time
or for the robot to move (:mod:`~atlas_rap.sim.events`); its own methods
drive the robot, step the world and delegate to them.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk

from atlas_rap.model import RobotConfig, Teleport, World
from atlas_rap.sim.disturbances import PERSON_CLEARANCE, Disturbances
from atlas_rap.sim.doors import Doors
from atlas_rap.sim.events import EVENT_EPS, TimedEvents, WaitingChanges
from atlas_rap.sim.sensors import Bumper, Odometry, Sonar, wrap_angle
from atlas_rap.sim.shapes import COLLISION_SLOP, WALL_RADIUS, wall_shapes
from atlas_rap.sim.sonar import OBSTACLE_CATEGORY, ROBOT_CATEGORY, WALL_CATEGORY

__all__ = ["DRIVE_IMPULSE", "PERSON_CLEARANCE", "ROBOT_MASS", "TURN_IMPULSE", "WALL_RADIUS", "Simulation"]

ROBOT_MASS = 10.0  # kg
# The joints' force limits are set per step as impulse / dt, so that one step can change the robot's
# speed by at most 2 m/s and its turn rate by 10 rad/s whatever dt is (at dt = 0.01 s: 2000 N and
# 200 N m, so a command is met within a step or two). A fixed force would push the robot deeper into
# walls at large dt (the joint's impulse per step grows with dt and fights the contact).
DRIVE_IMPULSE = 20.0  # N s: ROBOT_MASS * 2 m/s
TURN_IMPULSE = 2.0  # N m s: the disc's moment of inertia (0.2 kg m^2) * 10 rad/s
ROBOT_FRICTION = 0.3  # robot against walls and obstacles (Chipmunk multiplies the two frictions)
_ROBOT_COLLISION_TYPE = 1

_ROBOT_FILTER = pymunk.ShapeFilter(categories=ROBOT_CATEGORY, mask=WALL_CATEGORY | OBSTACLE_CATEGORY)


def _space_with_walls(world: World) -> pymunk.Space:
    """A pymunk space without gravity, holding the world's walls."""
    space = pymunk.Space()
    space.gravity = (0.0, 0.0)
    space.collision_slop = COLLISION_SLOP
    space.iterations = 10
    for wall in world.walls:
        space.add(*wall_shapes(space, wall.a, wall.b))
    return space


def _add_robot(space: pymunk.Space, robot: RobotConfig, dt: float) -> tuple[pymunk.Body, pymunk.Shape, pymunk.Body]:
    """The robot's disc at its start pose and the kinematic control body that drives it (module
    docstring), added to ``space``: (body, shape, control body)."""
    x, y, heading = (float(v) for v in robot.start)
    radius = float(robot.radius)
    body = pymunk.Body(ROBOT_MASS, pymunk.moment_for_circle(ROBOT_MASS, 0.0, radius))
    body.position = (x, y)
    body.angle = heading
    shape = pymunk.Circle(body, radius)
    shape.filter = _ROBOT_FILTER
    shape.friction = ROBOT_FRICTION
    shape.elasticity = 0.0
    shape.collision_type = _ROBOT_COLLISION_TYPE
    control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    control.position = (x, y)
    control.angle = heading
    pivot = pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0))
    pivot.max_bias = 0.0
    pivot.max_force = DRIVE_IMPULSE / dt
    gear = pymunk.GearJoint(control, body, 0.0, 1.0)
    gear.max_bias = 0.0
    gear.max_force = TURN_IMPULSE / dt
    space.add(body, shape, control, pivot, gear)
    return body, shape, control


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
        self.world, self.dt, self.rng = world, float(dt), np.random.default_rng(seed)
        robot = world.robot
        self.radius, self.max_speed, self.max_turn_rate = (float(robot.radius), float(robot.max_speed),
                                                           float(robot.max_turn_rate))
        self._space = _space_with_walls(world)
        self._body, shape, self._control = _add_robot(self._space, robot, self.dt)
        self._v = self._omega = 0.0
        self._bumper = Bumper(self._body, shape)
        self._space.on_collision(_ROBOT_COLLISION_TYPE, None, pre_solve=self._bumper.on_contact)
        start = tuple(float(v) for v in robot.start)
        self._odometry = Odometry(self._body, start, robot.odometry_noise, self.rng)
        self._integrating = not robot.odometry_noise.off  # else odometry is the true pose (until a kidnap)
        self._add_doors_and_disturbances(world)
        self._sonar = Sonar(world.sonar, self.radius, self._space, self._body, self.rng)
        self._steps = 0
        self._path_every = self._path_countdown = path_every
        self._path: list[tuple[float, float, float, float]] = [(0.0, start[0], start[1], wrap_angle(start[2]))]
        self._kidnaps: list[tuple[float, tuple[float, float, float], tuple[float, float, float]]] = []
        self._doors.close_the_closed()
        self._fire_events()  # everything due at time 0

    def _add_doors_and_disturbances(self, world: World) -> None:
        """The world's doors and disturbances, their timed events, and the changes waiting for the robot."""
        self._changes, self._events = WaitingChanges(), TimedEvents()
        self._waiting = self._changes.pending  # (key, is the robot clear?, apply): tested every step
        self._doors = Doors(self._space, world.doors, self._changes, self._body, self.radius)
        self._disturbances = Disturbances(self._space, world.disturbances, self._changes, self._body, self.radius,
                                          self.dt)
        self._persons = self._disturbances.persons  # tested every step
        self._doors.schedule(self._events)
        self._disturbances.schedule(self._events)
        for i, teleport in enumerate(world.robot.teleports):
            self._events.add(teleport.at, self._teleport_when_clear, i, teleport)
        self._events.start()
        self._next_event = self._events.next_time

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
            self._disturbances.walk_people()
        bumper = self._bumper
        bumper.bumped = False
        self._space.step(self.dt)
        if bumper.bumped:
            bumper.steps += 1
        self._steps += 1
        if self._integrating:
            self._odometry.integrate()
        if self._waiting:
            self._changes.retry()
        if self._steps * self.dt >= self._next_event:
            self._fire_events()
        self._path_countdown -= 1
        if not self._path_countdown:
            self._path_countdown = self._path_every
            x, y = self._body.position
            self._path.append((self._steps * self.dt, x, y, wrap_angle(self._body.angle)))

    def step_many(self, n: int) -> None:
        """``n`` steps."""
        step = self.step
        for _ in range(n):
            step()

    def run_until(self, t: float) -> None:
        """Step until :attr:`time` >= ``t``."""
        step = self.step
        while self._steps * self.dt < t - EVENT_EPS:
            step()

    def teleport(self, x: float, y: float, heading: float) -> None:
        """Put the robot at (``x``, ``y``) facing ``heading`` (radians), at rest, without telling its
        odometry: a kidnap. Dead reckoning goes on from where it believed the robot was, so
        :attr:`odometry` no longer follows :attr:`pose`; :attr:`path` shows the jump.

        The command in force stays in force (the controller does not know either). Nothing is
        checked: a robot put inside a wall or an obstacle is pushed out by the physics.
        """
        before = self.pose
        if not self._integrating:  # the odometry was the true pose: it starts dead reckoning from it
            self._odometry.reset(before)
            self._integrating = True
        body, control = self._body, self._control
        body.position = control.position = (float(x), float(y))
        body.angle = control.angle = float(heading)
        body.velocity = (0.0, 0.0)
        body.angular_velocity = 0.0
        self._space.reindex_shapes_for_body(body)
        self._odometry.ignore_jump()
        self._sonar.forget()
        self._kidnaps.append((self.time, before, self.pose))

    def _teleport_when_clear(self, index: int, teleport: Teleport) -> None:
        """The world's ``index``-th teleport, as soon as nothing (box, person, closed door leaf) is where
        the robot would land."""
        x, y, heading = teleport.to
        reach = self.radius + COLLISION_SLOP

        def clear() -> bool:
            return not self._space.point_query((float(x), float(y)), reach, _ROBOT_FILTER)

        self._changes.when_clear(("teleport", index), clear, lambda: self.teleport(x, y, heading))

    def _fire_events(self) -> None:
        """Fire the timed events due now, and note when the next one is."""
        self._events.fire(self._steps * self.dt)
        self._next_event = self._events.next_time

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
        return x, y, wrap_angle(self._body.angle)

    @property
    def velocity(self) -> tuple[float, float]:
        """The true body-frame (forward speed, turn rate)."""
        body = self._body
        vx, vy = body.velocity
        heading = body.angle
        return vx * math.cos(heading) + vy * math.sin(heading), body.angular_velocity

    @property
    def odometry(self) -> tuple[float, float, float]:
        """The pose as dead reckoning has it (starting at the true start pose); with the odometry noise
        off, the true pose (and after a kidnap, dead reckoning without errors from where the robot was)."""
        if not self._integrating:
            return self.pose
        return self._odometry.pose

    @property
    def path(self) -> list[tuple[float, float, float, float]]:
        """The true poses (t, x, y, heading) so far, every ``path_every`` steps from t = 0 (do not modify)."""
        return self._path

    @property
    def kidnaps(self) -> list[tuple[float, tuple[float, float, float], tuple[float, float, float]]]:
        """The teleports so far as (t, true pose before, true pose after): where :attr:`path` jumps
        (do not modify)."""
        return self._kidnaps

    @property
    def bumped(self) -> bool:
        """Whether the robot touched a wall, door leaf or obstacle during the last step."""
        return self._bumper.bumped

    @property
    def bump_steps(self) -> int:
        """How many steps so far the robot touched something: a bump between two looks shows as a change."""
        return self._bumper.steps

    @property
    def bump_angle(self) -> float | None:
        """Body-frame direction of the last step's deepest contact (0 = straight ahead), or None without one."""
        return self._bumper.angle

    # -- sonar ----------------------------------------------------------------

    def sonar(self) -> np.ndarray:
        """The sonar ring's reading now: ranges in metres (float64, ``max_range`` = no echo), read-only.

        Computed when asked, at most once per step: a second call in the same
        step returns the same array (and draws no more random numbers).
        """
        return self._sonar.read(self._steps)

    @property
    def sonar_angles(self) -> np.ndarray:
        """Body-frame angles of the transducers: the first 0 (forward), counter-clockwise, evenly spaced."""
        return self._sonar.ring.angles

    # -- doors and disturbances -----------------------------------------------

    @property
    def doors_open(self) -> dict[str, bool]:
        """Every door's state now: True when open (a doorway without a leaf is always open)."""
        return dict(self._doors.open)

    def set_door(self, name: str, open: bool) -> None:
        """Open or close the door ``name``; a close that would hit the robot waits until it is clear.

        Raises KeyError for an unknown door and ValueError for closing a
        doorway without a leaf.
        """
        self._doors.set(name, open)

    def obstacles(self) -> list[tuple[str, tuple[float, float], float]]:
        """The disturbances present now as ``(kind, (x, y), size)``, the form ``render_run`` takes."""
        return self._disturbances.present()

"""The simulated robot's sensors: the bumper, odometry and the sonar ring, read from its pymunk body.

* **Bumper** (:class:`Bumper`). A pre-solve collision callback on the
  robot's shape notes every step in which the robot touches anything (wall,
  door leaf, box, person) and the direction of the deepest contact.
* **Odometry** (:class:`Odometry`) integrates the true body-frame motion of
  every step, with the errors of :class:`~atlas_rap.model.OdometryNoise`
  (AMCL's alpha1-alpha4): each step's turn ``dθ`` and forward travel ``ds``
  get Gaussian errors of standard deviation
  ``sqrt(alpha1² |dθ| + alpha2² |ds|)`` and ``sqrt(alpha3² |ds| + alpha4² |dθ|)``.
  Variances add, so the error is a random walk: its standard deviation is
  alpha3 after 1 m driven straight, alpha1 after 1 rad turned on the spot.
  A jump of the body that is not driving (a kidnap) is not counted
  (:meth:`Odometry.ignore_jump`).
* **Sonar** (:class:`Sonar`): the ring of :class:`~atlas_rap.sim.sonar.SonarRing`
  on the robot, computed only when asked, at most once per step.

The odometry's noise and the sonar's noise and dropout draw from the one
random generator of the run, in the order the simulation asks them.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk

from atlas_rap.model import OdometryNoise, SonarConfig
from atlas_rap.sim.sonar import SonarRing

__all__ = ["Bumper", "Odometry", "Sonar", "wrap_angle"]

_NOISE_BLOCK = 1024  # odometry noise normals drawn this many at a time


def wrap_angle(angle: float) -> float:
    """``angle`` in (-pi, pi]."""
    return math.pi - (math.pi - angle) % (2 * math.pi)


class Bumper:
    """Whether the robot (``body``, ``shape``) touched anything during the last step, and where.

    The simulation sets :attr:`bumped` False before each physics step, hands
    :meth:`on_contact` to pymunk as the robot's pre-solve callback, and counts
    the steps with a contact in :attr:`steps` after it.
    """

    __slots__ = ("_body", "_shape", "bumped", "depth", "normal", "steps")

    def __init__(self, body: pymunk.Body, shape: pymunk.Shape) -> None:
        self._body, self._shape = body, shape
        self.bumped = False
        self.depth = 0.0
        self.normal = (1.0, 0.0)
        self.steps = 0

    def on_contact(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        """Note a contact of this step: the deepest one's direction, from the robot outwards."""
        points = arbiter.contact_point_set.points
        depth = min(p.distance for p in points) if points else 0.0
        if not self.bumped or depth < self.depth:
            normal = arbiter.normal  # from the robot (first shape) toward what it touches
            if arbiter.shapes[0] is not self._shape:
                normal = -normal
            self.bumped, self.depth, self.normal = True, depth, (normal.x, normal.y)

    @property
    def angle(self) -> float | None:
        """Body-frame direction of the last step's deepest contact (0 = straight ahead), or None without one."""
        if not self.bumped:
            return None
        nx, ny = self.normal
        return wrap_angle(math.atan2(ny, nx) - self._body.angle)


class Odometry:
    """Dead reckoning of ``body`` from its ``start`` pose (x, y, heading), erring by ``noise`` (module
    docstring), its errors drawn from ``rng``: two standard normals a step, none when the noise is off."""

    def __init__(self, body: pymunk.Body, start: tuple[float, float, float], noise: OdometryNoise,
                 rng: np.random.Generator) -> None:
        self._body, self.noise, self._rng = body, noise, rng
        x, y, heading = start
        self._last = (x, y, heading)
        self._odo = [x, y, heading]
        self._noise = np.empty(0)
        self._noise_at = 0
        a1, a2, a3, a4 = (float(a) for a in (noise.alpha1, noise.alpha2, noise.alpha3, noise.alpha4))
        self._variances = (a1 * a1, a2 * a2, a3 * a3, a4 * a4)
        self._noisy = not noise.off

    @property
    def pose(self) -> tuple[float, float, float]:
        """The pose as dead reckoning has it, heading in (-pi, pi]."""
        x, y, heading = self._odo
        return float(x), float(y), wrap_angle(float(heading))

    def reset(self, pose: tuple[float, float, float]) -> None:
        """Believe ``pose`` and measure from the body's pose now (for a simulation that had not been
        integrating because its odometry was the true pose)."""
        x, y = self._body.position
        self._last = (x, y, self._body.angle)
        self._odo = [float(pose[0]), float(pose[1]), float(pose[2])]

    def ignore_jump(self) -> None:
        """The body has just been put somewhere without driving there (a kidnap): measure from its
        new pose, keeping the estimate, so the jump is not counted as motion."""
        x, y = self._body.position
        self._last = (x, y, self._body.angle)

    def integrate(self) -> None:
        """Add the body's motion since the last call, with its noise."""
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
        if self._noisy:
            at = self._noise_at
            if at + 2 > len(self._noise):
                self._noise, at = self._rng.standard_normal(_NOISE_BLOCK), 0
            noise = self._noise
            self._noise_at = at + 2
            v1, v2, v3, v4 = self._variances
            ds, dtheta = abs(forward), abs(turn)
            forward += math.sqrt(v3 * ds + v4 * dtheta) * noise[at]
            turn += math.sqrt(v1 * dtheta + v2 * ds) * noise[at + 1]
        odo = self._odo
        mid = odo[2] + turn / 2
        c, s = math.cos(mid), math.sin(mid)
        odo[0] += forward * c - lateral * s
        odo[1] += forward * s + lateral * c
        odo[2] += turn


class Sonar:
    """The sonar ring (``config``) on ``body`` (of ``radius``), sensing ``space``, its noise from ``rng``."""

    def __init__(self, config: SonarConfig, radius: float, space: pymunk.Space, body: pymunk.Body,
                 rng: np.random.Generator) -> None:
        self.ring = SonarRing(config, radius)
        self._space, self._body, self._rng = space, body, rng
        self._step = -1
        self._reading = np.empty(0)

    def read(self, step: int) -> np.ndarray:
        """The reading at physics step ``step``: computed on the first call of the step, the same
        array (and no more random numbers) on later ones; read-only."""
        if self._step != step:
            x, y = self._body.position
            reading = self.ring.scan(self._space, x, y, self._body.angle, self._rng)
            reading.setflags(write=False)
            self._reading, self._step = reading, step
        return self._reading

    def forget(self) -> None:
        """The robot has been moved within a step (a kidnap): the next read computes a new reading."""
        self._step = -1

"""The sonar ring: ray-cast range readings with noise and specular dropout.

The model, per scan (one reading per transducer):

* **Geometry.** ``count`` transducers sit on the robot's rim, evenly
  spaced, the first facing forward (body angle 0), counter-clockwise.
  Each beam is sampled by ``rays_per_beam`` rays spread evenly across
  ``beam_width`` (one ray: the beam axis; two or more: from
  ``-beam_width/2`` to ``+beam_width/2`` inclusive). A ray's range is
  measured from the rim, so a wall 2 m ahead of the robot's centre reads
  ``2 - radius``. Rays are cast with pymunk's ``Space.segment_query_first``
  from the robot's centre out to ``radius + max_range`` (the same ray
  as one from the rim, but it also finds a surface the rim has pressed
  into, which then reads ``min_range``), with a :class:`pymunk.ShapeFilter`
  that sees only what echoes (:data:`ECHO_FILTER`): never the robot
  itself.
* **Specular dropout.** Sound hitting a smooth surface at a grazing angle
  reflects away and never returns. For each ray that hits, the incidence
  angle is the angle between the ray and the hit surface's normal
  (``SegmentQueryInfo.normal``; 0 = head-on). Beyond ``specular_angle``
  that ray's echo is lost with probability ``specular_dropout``
  (independently per ray).
* **Reading.** A beam reads the nearest surviving echo of its rays; with
  none it reads ``max_range`` (no echo). An echo at true range ``r`` gets
  Gaussian noise of standard deviation
  ``range_noise + range_noise_per_m * r``. Readings are clipped to
  ``[min_range, max_range]``.
* **Randomness.** Every scan draws exactly ``count`` standard normals and
  ``count * rays_per_beam`` uniforms from the generator it is given,
  whatever the geometry, so the stream (and so every later draw in the
  run) does not depend on what the rays happened to hit.

The ray casts are the one loop that cannot be vectorised; everything
around them (ray ends, incidence, dropout, noise) is numpy. The casts go
straight to Chipmunk's ``cpSpaceSegmentQueryFirst`` through pymunk's cffi
binding when it is available (the same query ``Space.segment_query_first``
makes, without building a ``SegmentQueryInfo`` per ray); otherwise
through the public method.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk

from atlas_rap.model import SonarConfig

__all__ = [
    "ECHO_CATEGORY",
    "ECHO_FILTER",
    "OBSTACLE_CATEGORY",
    "ROBOT_CATEGORY",
    "SENSOR_CATEGORY",
    "WALL_CATEGORY",
    "SonarRing",
]

# Shape categories shared with sim.physics. Walls and door leaves are two
# shapes each: a slightly thick one the robot collides with (WALL) and a
# zero-thickness copy on the centre line that only the sonar sees (ECHO),
# so readings measure the true geometry. Boxes and people (OBSTACLE) are
# exact already and are both collided with and seen.
ROBOT_CATEGORY = 0b00001
WALL_CATEGORY = 0b00010
ECHO_CATEGORY = 0b00100
OBSTACLE_CATEGORY = 0b01000
SENSOR_CATEGORY = 0b10000  # the category of the sonar's queries

ECHO_FILTER = pymunk.ShapeFilter(categories=SENSOR_CATEGORY, mask=ECHO_CATEGORY | OBSTACLE_CATEGORY)

try:  # the raw Chipmunk query: no per-ray Python objects
    from pymunk._chipmunk_cffi import ffi as _ffi
    from pymunk._chipmunk_cffi import lib as _lib

    _RAW = hasattr(_lib, "cpSpaceSegmentQueryFirst")
except ImportError:  # pragma: no cover - a pymunk without the cffi module
    _RAW = False


class SonarRing:
    """A ring of sonar transducers on a disc robot of ``robot_radius``; see the module docstring.

    >>> ring = SonarRing(SonarConfig(count=4, rays_per_beam=1), robot_radius=0.2)
    >>> [round(float(a), 4) for a in ring.angles]
    [0.0, 1.5708, 3.1416, 4.7124]
    """

    def __init__(self, config: SonarConfig, robot_radius: float, *, raw: bool | None = None) -> None:
        if config.count < 1 or config.rays_per_beam < 1:
            raise ValueError("a sonar ring needs at least one transducer and one ray per beam")
        if not 0 <= config.min_range <= config.max_range:
            raise ValueError("sonar ranges need 0 <= min_range <= max_range")
        self.config = config
        self.robot_radius = float(robot_radius)
        count, rays = config.count, config.rays_per_beam
        #: body-frame beam axes, the first 0 (forward), counter-clockwise, evenly spaced
        self.angles = np.arange(count, dtype=np.float64) * (2 * math.pi / count)
        self.angles.setflags(write=False)
        offsets = (np.linspace(-config.beam_width / 2, config.beam_width / 2, rays)
                   if rays > 1 else np.zeros(1))
        self._ray_angles = (self.angles[:, None] + offsets[None, :]).ravel()  # (count*rays,)
        self._cos_specular = math.cos(config.specular_angle)
        self._rays = count * rays
        self._raw = _RAW if raw is None else (raw and _RAW)
        if self._raw:
            self._info = _ffi.new("cpSegmentQueryInfo *")
        # scratch arrays reused every scan
        self._alpha = np.empty(self._rays)
        self._normal = np.empty((self._rays, 2))

    @property
    def ray_count(self) -> int:
        """Rays cast per scan: ``count * rays_per_beam``."""
        return self._rays

    def scan(self, space: pymunk.Space, x: float, y: float, heading: float,
             rng: np.random.Generator) -> np.ndarray:
        """One reading per transducer (float64 metres) for a robot at (x, y, heading) in ``space``."""
        cfg = self.config
        length = self.robot_radius + cfg.max_range
        world = self._ray_angles + heading
        dx, dy = np.cos(world), np.sin(world)
        start = (float(x), float(y))
        ex, ey = x + length * dx, y + length * dy
        alpha, normal = self._alpha, self._normal
        alpha.fill(np.inf)
        if self._raw:
            query, info, cp_space, filt = _lib.cpSpaceSegmentQueryFirst, self._info, space._space, ECHO_FILTER
            for i, end in enumerate(zip(ex.tolist(), ey.tolist())):
                if query(cp_space, start, end, 0.0, filt, info):
                    alpha[i] = info.alpha
                    normal[i, 0] = info.normal.x
                    normal[i, 1] = info.normal.y
        else:
            query_first = space.segment_query_first
            for i, end in enumerate(zip(ex.tolist(), ey.tolist())):
                hit = query_first(start, end, 0.0, ECHO_FILTER)
                if hit is not None:
                    alpha[i] = hit.alpha
                    normal[i, 0], normal[i, 1] = hit.normal

        noise = rng.standard_normal(cfg.count)
        chance = rng.random(self._rays)
        hit = np.isfinite(alpha)
        distance = alpha * length - self.robot_radius
        if cfg.specular_dropout > 0:
            with np.errstate(invalid="ignore"):
                cos_incidence = np.abs(dx * normal[:, 0] + dy * normal[:, 1])
            lost = hit & (cos_incidence < self._cos_specular) & (chance < cfg.specular_dropout)
            distance[lost] = np.inf
        nearest = distance.reshape(cfg.count, cfg.rays_per_beam).min(axis=1)
        echo = np.isfinite(nearest)
        sigma = cfg.range_noise + cfg.range_noise_per_m * np.where(echo, nearest, 0.0)
        reading = np.where(echo, nearest + sigma * noise, cfg.max_range)
        np.clip(reading, cfg.min_range, cfg.max_range, out=reading)
        return reading

"""The beam model of a range reading, on ray casts: the other sensor model of Monte Carlo localisation.

*Probabilistic Robotics* (Thrun, Burgard and Fox 2005, ch. 6.3), AMCL's ``beam`` model, for the sonar
ring. For each pose and beam, the range the map predicts (:meth:`BeamModel.expected_ranges`) is ray-cast
on the same occupancy mask as the likelihood field (:class:`~atlas_rap.maps.localisation.LikelihoodField`),
every particle x beam x ray at once: each ray marches by the distance to the nearest wall (the field's
distance transform, less a cell and a half, so no step crosses a wall), at least half a cell, until it
stands in an occupied cell or passes the sonar's reach. The reading is then scored by the four-part
mixture (:class:`BeamLikelihood`):

- ``z_hit``: a Gaussian of ``sigma_hit`` around the expected range (truncated to ``[0, max_range]``),
  at its best fit across the beam's cone (the sonar reads the nearest echo of its rays);
- ``z_short``: an exponential of rate ``lambda_short`` below the expected range (people, boxes, things
  not on the map that answer first);
- ``z_max``: a point mass at ``max_range``, no echo. This is where a sonar differs from a laser: a beam
  gets no echo when nothing is in range, or when the wall it meets is oblique (more than
  ``specular_angle`` from its normal) and the sound glances off (with probability ``specular_loss`` per
  ray). The hit share of every ray that cannot echo is moved onto ``z_max``, so a max reading is likely
  where the map says nothing is in range or the wall is oblique, and unlikely in front of a near wall
  (the likelihood field can only leave max readings out);
- ``z_rand``: a uniform over ``[0, max_range]``.

:class:`BeamParticleFilter` is :class:`~atlas_rap.maps.localisation.ParticleFilter` with this model in
place of the likelihood field (motion, resampling, KLD-sampling and recovery are the filter's own).

Which model the localiser should use, measured side by side (``benchmarks/bench_sensor_models.py``:
``lab-corridor-office``, the real simulation with the sonar's noise and specular dropout, the 30 s wander
drive of ``tests/localisation_runs.py`` from a known start, seeds 0-9, both models on the same drives;
RMSE the mean over seeds, worst the largest error at any scan, time per predict-correct-resample-estimate
on a shared 2-core machine)::

    drift   position RMSE (m)   worst error (m)   ms per update    particles (mean)
            field     beam      field    beam     field    beam    field    beam
     2 %    0.029     0.042     0.11     0.63      1.3     8.8      268     151
     5 %    0.030     0.041     0.11     0.16      1.5     8.7      269     149
    10 %    0.038     0.044     0.18     0.19      1.0     7.4      265     148

(The times are from a machine busy with other work; on a quiet one both are about half that.)

Global localisation (3000 particles uniform over the free space, 5 % drift): the belief came within
0.5 m and stayed there to the end of the 30 s on 2 of 10 seeds with either model, the same seeds
(2, 8); on the others both settled in another corner of the building (the robot spends the drive in a
corner of the lab). Whether it converges is decided by whether one of the 3000 particles starts near
the robot with its heading, not by the model (the localiser finds a lost robot by a search instead:
:mod:`atlas_rap.maps.relocalisation`). One scan alone does point more strongly at the robot with the
beam model (from 20000 uniform poses, 50 scans: the weight within 0.5 m of the truth is 0.16 median,
0.34 mean, against the field's 0.10 and 0.15; more on 30 of the 50 scans), as it scores no-echo
readings and the free space along each beam, which the field cannot.

**The localiser should keep the likelihood field.** It tracks better at every drift (RMSE 0.029-0.038 m
against 0.041-0.044 m) at a sixth of the cost, and it forgives a map's wall a few centimetres off: a
beam-model Gaussian sits on one ray-cast range, so it needs ``wall_depth`` and ``min_range`` right
(0.146 m RMSE without them, measured with the earlier wall drawing). Global localisation with this
filter is a tie. The beam model's stronger single scan
could seed the recovery's sensor-resetting guesses (``ParticleFilter._guessed_poses``) while the
field tracks; that hybrid is not measured here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import ndtr

from atlas_rap.maps.localisation import LikelihoodField, ParticleFilter, Pose

__all__ = ["BeamLikelihood", "BeamModel", "BeamParticleFilter"]

CHUNK = 2048
"""Particles scored at a time: bounds the ray arrays (particles x beams x rays) of a large belief."""


@dataclass(frozen=True)
class BeamLikelihood:
    """How the beam model scores a reading: ``z_hit``, ``z_short``, ``z_max`` and ``z_rand`` weigh the
    hit Gaussian (``sigma_hit`` metres), the short exponential (rate ``lambda_short`` per metre), the
    no-echo point mass and the uniform (they sum to 1). A ray whose expected wall is more than
    ``specular_angle`` from head-on loses its echo with probability ``specular_loss`` (the sonar's own
    ``specular_angle`` and ``specular_dropout``); ``beam_width`` and ``rays`` spread each beam's rays
    across its cone, as the sonar does (one ray: the laser's model).

    The expected range is where a ray meets the first occupied cell, plus ``wall_depth``: where in the
    wall the echo comes from. 0 for a map whose occupied cells are the walls' surfaces; a map drawn by
    :func:`~atlas_rap.maps.localisation.wall_mask` makes each wall a band of cells around its line, half
    of it in front (0.05 m for its default thickness of 0.1 m). ``min_range`` is the sonar's: it reads
    nothing nearer, so a wall nearer than that is expected there. Both matter: on
    ``lab-corridor-office``'s drive (10 seeds at 5 % drift, the robot much of the time against a wall)
    the position RMSE is 0.146 m without either, 0.087 m with ``wall_depth`` alone, 0.111 m with
    ``min_range`` alone and 0.064 m with both."""

    z_hit: float = 0.7
    z_short: float = 0.1
    z_max: float = 0.05
    z_rand: float = 0.15
    sigma_hit: float = 0.2
    lambda_short: float = 0.5
    specular_angle: float = math.radians(60.0)
    specular_loss: float = 0.8
    beam_width: float = 0.0
    rays: int = 1
    wall_depth: float = 0.0
    min_range: float = 0.0


class BeamModel:
    """Ranges ray-cast on a map, and the log-likelihood of a sonar scan at poses (see the module docstring).

    ``robot_radius`` is where the sonar sits (readings are measured from the rim), ``max_range`` its
    range: a reading there is no echo."""

    STEP = 0.5
    """The shortest step of a ray's march, in cells: a hit is placed half of it back, within a quarter cell."""
    BURST = 16
    """Steps a ray takes at once when few rays are left (see :meth:`cast`)."""
    BURST_BELOW = 1024
    """How few rays are left when they start taking :attr:`BURST` steps at once."""

    def __init__(self, field: LikelihoodField, settings: BeamLikelihood = BeamLikelihood(), *,
                 robot_radius: float = 0.2, max_range: float = 5.0) -> None:
        total = settings.z_hit + settings.z_short + settings.z_max + settings.z_rand
        if not math.isclose(total, 1.0, abs_tol=1e-6):
            raise ValueError(f"z_hit + z_short + z_max + z_rand must be 1, not {total:g}")
        self.field, self.settings = field, settings
        self.robot_radius, self.max_range = float(robot_radius), float(max_range)
        rays = max(1, settings.rays)
        self._offsets = np.linspace(-settings.beam_width / 2, settings.beam_width / 2, rays) if rays > 1 \
            else np.zeros(1)
        # the distance field in cells (0: occupied) and the walls' outward normals along the frame's x and
        # y (the distance's gradient; row 0 is the top), flattened with a border as wide as a ray's reach
        # (``_margin`` cells, beyond it nothing): a ray from anywhere on the map never leaves them, so a
        # lookup needs no clipping
        frame = field.frame
        self._limit = (self.robot_radius + self.max_range) / frame.resolution
        margin = self._margin = int(math.ceil(self._limit)) + 2
        self._stride = frame.width + 2 * margin
        self._top = frame.height - 1 + 2 * margin  # the flat row of v = -margin
        d_row, d_col = np.gradient(field.distance.astype(np.float64))
        nx, ny = d_col, -d_row
        norm = np.hypot(nx, ny)
        norm[norm == 0] = 1.0
        border = field.max_distance / frame.resolution
        self._cells = np.pad(field.distance / frame.resolution, margin, constant_values=border).ravel()
        self._nx = np.pad(nx / norm, margin).ravel()
        self._ny = np.pad(ny / norm, margin).ravel()

    def _index(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Where points ``u``, ``v`` (cells along the frame's x and y from its origin, plus ``_margin``:
        from 0 to the far border) are in the flattened arrays."""
        return (self._top - v.astype(np.int64)) * self._stride + u.astype(np.int64)

    def cast(self, u: np.ndarray, v: np.ndarray, cu: np.ndarray, cv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """March rays from ``u``, ``v`` (cells along the frame's x and y from its origin, on the map or
        its edge) along unit directions ``cu``, ``cv`` as far as the sonar reaches: how far each goes to
        its first occupied cell (in cells; inf if none is in reach), and the cosine of its angle to the
        wall's normal there.

        A ray steps by the distance transform less a cell and a half (no wall is nearer), at least
        :attr:`STEP`. A ray that grazes a wall can only creep, so once fewer than :attr:`BURST_BELOW`
        rays are left each takes :attr:`BURST` steps of :attr:`STEP` at once (one numpy call for many
        small ones)."""
        n, limit = len(u), self._limit
        reach, cosine = np.full(n, np.inf), np.ones(n)
        which, t = np.arange(n), np.zeros(n)
        ua, va, cua, cva = u + self._margin, v + self._margin, cu, cv
        cells, step, index = self._cells, self.STEP, self._index
        while which.size:
            if which.size > self.BURST_BELOW:  # one step each
                d = cells.take(index(ua + t * cua, va + t * cva))
                hit = d == 0.0
                th = t[hit]
                last_t, last_d = t, d
            else:
                ts = np.minimum(t[:, None] + step * np.arange(self.BURST), limit)
                d = cells.take(index(ua[:, None] + ts * cua[:, None], va[:, None] + ts * cva[:, None]))
                occupied = d == 0.0
                hit = occupied.any(axis=1)
                th = ts[hit, occupied[hit].argmax(axis=1)]
                last_t, last_d = ts[:, -1], d[:, -1]
            if th.size:
                reach[which[hit]] = np.where(th > 0, th - step / 2, 0.0)  # the wall began within the last step
                free = index(ua[hit] + (th - step) * cua[hit], va[hit] + (th - step) * cva[hit])
                cosine[which[hit]] = np.abs(cua[hit] * self._nx.take(free) + cva[hit] * self._ny.take(free))
            done = hit | (last_t >= limit)
            t = np.minimum(last_t + np.maximum(last_d - 1.5, step), limit)  # no wall is nearer than d - 1.5
            if done.any():
                keep = ~done
                which, t, ua, va, cua, cva = which[keep], t[keep], ua[keep], va[keep], cua[keep], cva[keep]
        return reach, cosine

    def expected_ranges(self, p: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The ranges (m, from the rim; inf where no wall is within ``max_range``) the map predicts for every
        ray of every beam (body angles ``angles``) at each pose of ``p`` (n x 3), n x beams x rays, and
        the cosines of the rays' angles to the walls' normals."""
        p = np.atleast_2d(np.asarray(p, dtype=float))
        angles = np.asarray(angles, dtype=float)
        frame = self.field.frame
        ox, oy, yaw = frame.origin
        dx, dy = p[:, 0] - ox, p[:, 1] - oy
        if yaw:
            dx, dy = math.cos(yaw) * dx + math.sin(yaw) * dy, math.cos(yaw) * dy - math.sin(yaw) * dx
        bearing = (angles[:, None] + self._offsets[None, :]).ravel()
        direction = (p[:, 2] - yaw)[:, None] + bearing[None, :]
        rays = direction.shape[1]
        # a pose off the map is taken to its edge (there is nothing to see beyond it)
        u = np.repeat(np.clip(dx / frame.resolution, -1.0, frame.width + 1.0), rays)
        v = np.repeat(np.clip(dy / frame.resolution, -1.0, frame.height + 1.0), rays)
        reach, cosine = self.cast(u, v, np.cos(direction).ravel(), np.sin(direction).ravel())
        ranges = np.maximum(reach * frame.resolution + self.settings.wall_depth - self.robot_radius,
                            self.settings.min_range)  # the sonar reads nothing nearer
        shape = (len(p), len(angles), len(self._offsets))
        return ranges.reshape(shape), cosine.reshape(shape)

    def log_likelihood(self, p: np.ndarray, ranges: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """The log-likelihood of one scan (every reading, max ones included) at each pose of ``p`` (n x 3)."""
        ranges, angles = np.asarray(ranges, dtype=float), np.asarray(angles, dtype=float)
        if len(p) > CHUNK:
            return np.concatenate([self.log_likelihood(p[i:i + CHUNK], ranges, angles)
                                   for i in range(0, len(p), CHUNK)])
        s, z_max_range = self.settings, self.max_range
        expected, cosine = self.expected_ranges(p, angles)
        beyond = ~(expected < z_max_range)
        # the chance each ray gets no echo: none within range, or an oblique wall; a beam, none of its rays
        lost = np.where(beyond, 1.0, np.where(cosine < math.cos(s.specular_angle), s.specular_loss, 0.0))
        silent = lost.prod(axis=2)
        z = ranges[None, :]
        # the hit Gaussian around each ray's expected range, normalised over [0, max_range], best ray kept
        mean = np.minimum(expected, z_max_range)
        sigma = s.sigma_hit
        inside = ndtr((z_max_range - mean) / sigma) - ndtr(-mean / sigma)
        gauss = np.exp(-0.5 * ((z[:, :, None] - mean) / sigma) ** 2) / (sigma * math.sqrt(2 * math.pi) * inside)
        hit = np.where(beyond, 0.0, gauss).max(axis=2)
        # the short exponential below the nearest expected range of the beam
        nearest = mean.min(axis=2)
        lam = s.lambda_short
        with np.errstate(divide="ignore", invalid="ignore"):
            short = np.where(z <= nearest, lam * np.exp(-lam * z) / -np.expm1(-lam * nearest), 0.0)
        short = np.nan_to_num(short, nan=0.0, posinf=0.0)
        echo = s.z_hit * (1.0 - silent) * hit + s.z_short * short + s.z_rand / z_max_range
        no_echo = s.z_max + s.z_hit * silent
        is_max = ranges >= z_max_range - 1e-6
        return np.log(np.where(is_max[None, :], no_echo, echo)).sum(axis=1)


class BeamParticleFilter(ParticleFilter):
    """:class:`~atlas_rap.maps.localisation.ParticleFilter` weighing its particles by the beam model
    (:class:`BeamModel` with ``beam``) instead of the likelihood field; every other argument is the
    filter's. The likelihood field is still built (the filter's map, its free space and its distances
    are the ray casts' too). The recovery averages follow what :meth:`correct` makes of the scan's
    log-likelihood, a mean per echo: here max readings are scored too, so they weigh on it a little."""

    def __init__(self, field: LikelihoodField, start: Pose, rng: np.random.Generator, *,
                 beam: BeamLikelihood = BeamLikelihood(), **options: Any) -> None:
        self.beam = beam
        super().__init__(field, start, rng, **options)

    def use_map(self, field: LikelihoodField) -> None:
        """Localise on ``field`` from now on: the ray casts move onto it too."""
        super().use_map(field)
        self.model = BeamModel(field, self.beam, robot_radius=self.robot_radius, max_range=self.max_range)

    def log_likelihood(self, p: np.ndarray, ranges: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """The beam model's log-likelihood of one scan at each pose of ``p`` (n x 3), max readings included."""
        return self.model.log_likelihood(p, ranges, angles)

"""The localiser: the robot's pose belief, an always-on skill (issue 27).

Every skill and layer that needs to know where the robot is reads the
:data:`~atlas_rap.skills.beliefs.POSE` belief and the ``pose`` wire; this
skill is what writes them. It is a skill, beside the sonar ring and the
bumper, for the reason 3T puts sensing in the skill layer: it runs at the
sensors' rate whatever the sequencer and the layers are doing, it needs only
the body (odometry and sonar) and the robot's map, and when the skills run on
another host over the bus (``atlas skills serve``) it runs there, beside the
sensors, so the belief never waits on the network. The layers and RAPs see
its result, not its workings: the pose, and the facts ``(localised)`` and
``(lost)``.

How it knows where the robot is, in the manner of nav2's AMCL
(:class:`~atlas_rap.maps.localisation.ParticleFilter`):

- **With a prior map** (the world's walls): Monte Carlo localisation on it,
  from the robot's start pose (AMCL's ``initial_pose``). When a new sonar
  ring has come and the odometry has moved :data:`UPDATE_DISTANCE` or
  turned :data:`UPDATE_ANGLE` since the last update (AMCL's
  ``update_min_d`` / ``update_min_a``: a robot standing still sees the same
  echoes again and must not grow surer of them), the particles move by the
  odometry's motion, the ring weighs them and they are resampled. Between
  updates the pose is the last estimate moved as the odometry has moved
  since (AMCL's ``map`` → ``odom`` transform: cheap, and as smooth as the
  odometry). Random particles are injected when the scans fit worse than
  they used to (``recovery_alpha_slow`` / ``_fast``). Once lost, the rings
  are kept until they span a turn on the spot (the relocalise RAP's spin)
  or :data:`SEARCH_DISTANCE` of driving; then the whole map is searched for
  where they fit (:mod:`atlas_rap.maps.relocalisation`) and the filter
  starts again from the best poses. The robot counts as localised again
  only after such a search: random particles alone settle as readily on a
  wrong room as on the right one.
- **Without one** (``--no-prior-map``, the experiment; ``atlas map build`` has its world's walls):
  the odometry, corrected against the map being built
  (:class:`~atlas_rap.maps.scan_matching.MapMatcher`, on Layer IV's grid,
  the :data:`~atlas_rap.skills.beliefs.GRID` belief): the rings of the last
  metre and a half of travel are matched to the grid as it was a few
  seconds ago, where it has settled, when the robot sees mostly settled
  space: when it comes back to where it has been, or drives on a map
  carried from an earlier run (``--map-in``), whose frame it keeps. Where
  it explores, the position is its odometry's, and the heading is held to
  the directions the building's walls run in, learnt from the same local
  scans (:class:`~atlas_rap.maps.wall_compass.WallCompass`, the
  :data:`WALL_COMPASS` settings). Measured with ``deliver.rap
  --no-prior-map`` at the default noise on 12 seeds and in the experiment
  (``benchmarks/bench_mapping_correction.py``; docs/how-to/localise.md has the table).
  The particle filter on the grid being built was measured first and made
  the pose worse (2 % drift, seeds 0-3: 0 of 4 errands, RMSE 3.5 m, against
  4 of 4 and 0.8 m by odometry alone): a sonar grid's walls are arcs where
  they have been seen from one place only, and the filter locks onto the
  wrong fit. Without the grid (the skills on another host, ``atlas skills
  serve``) the pose is the odometry. No facts are posted, and no
  :data:`~atlas_rap.skills.beliefs.POSE_ESTIMATE`: the robot is never
  (lost) in a map it is drawing.
- **When the odometry has no noise** (a world with ``odometry_noise: off``),
  or when the run asks for dead reckoning (``atlas run --localisation
  odometry``, to compare, with a prior map or without): the odometry is the
  pose, and nothing is estimated; no facts are posted.

``(localised)`` holds while the belief's position spread (the root of the
covariance's x and y variances) is under :data:`LOCALISED_SPREAD` metres
and its heading spread under :data:`LOCALISED_HEADING` radians; ``(lost)``
replaces it when either goes over twice that, or when the scans fit much
worse than they used to (``ParticleFilter.surprised``: a tight belief in
the wrong place), and ``(localised)`` comes back when the spreads are under
the limits and the scans fit again (a hysteresis, so the facts do not
flap). Exactly one of the two is in memory while the filter runs.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from atlas_rap.logic import Compound
from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.localisation import (LikelihoodField, ParticleFilter, SonarLikelihood, between, compose, wall_mask,
                                         wrap)
from atlas_rap.maps.relocalisation import best_poses
from atlas_rap.maps.scan_matching import MapMatcher
from atlas_rap.maps.wall_compass import CompassSettings, WallCompass
from atlas_rap.skills.beliefs import GRID, LOCALISATION, POSE, POSE_ESTIMATE, POSE_TRACK, SONAR, PoseEstimate
from atlas_rap.skills.catalog import registered
from atlas_rap.skills.robot import Pose
from atlas_rap.skills.skill import Skill

__all__ = ["LOCALISED_HEADING", "LOCALISED_SPREAD", "Localiser", "UPDATE_ANGLE", "UPDATE_DISTANCE", "WALL_COMPASS"]

UPDATE_DISTANCE = 0.2
"""Metres the odometry must move between two updates (AMCL's ``update_min_d``, 0.25 m by default).
Measured with ``deliver.rap`` on ``lab-corridor-office`` at 5 % drift over 10 seeds, with the same
value for :data:`UPDATE_ANGLE` (and a quarter of it in doubt): 0.1, 0.15 and 0.2 give position RMSEs of
0.072, 0.075 and 0.077 m (worst seeds 0.088, 0.104 and 0.099 m), all 10 errands done, in 0.39, 0.36 and
0.31 s of wall time a run."""
UPDATE_ANGLE = 0.2
"""Radians the odometry must turn between two updates (AMCL's ``update_min_a``, 0.2 by default)."""
DOUBT = 0.8
DOUBTFUL_STEP = 0.25
"""While the scans fit worse of late (the fast likelihood average under :data:`DOUBT` of the slow one)
or the robot is lost, it updates at this share of :data:`UPDATE_DISTANCE` and :data:`UPDATE_ANGLE`:
a kidnap is noticed in fewer metres and a turn on the spot gives the search more rings. Kidnapped
from the corridor into the lab (``tests/test_localisation_in_runs.py``), 8 seeds, found again within
30 s: every 0.1 always, 8 of 8 (at most 20 s); every 0.2 always, 5 of 8; every 0.2, or 0.05 in
doubt, as here, 8 of 8 (at most 14 s)."""
MAP_RESOLUTION = 0.05
"""Metres per cell of the likelihood field on a prior map."""
LOCALISED_SPREAD = 0.3
"""Metres: the largest position spread (1 sigma) at which the robot counts as localised; lost at twice it."""
LOCALISED_HEADING = math.radians(15.0)
"""Radians: the largest heading spread at which the robot counts as localised; lost at twice it."""
SEARCH_TURN = 2 * math.pi
"""Radians the robot turns while lost (the relocalise RAP's spin) before its rings are searched for."""
SEARCH_DISTANCE = 2.0
"""Metres it drives while lost before its rings are searched for, if it does not turn."""
START_SPREAD = (0.1, 0.1, math.radians(5.0))
"""The initial belief's spread (x, y, heading) around the start pose."""
WALL_COMPASS: CompassSettings | None = CompassSettings()
"""Without a prior map: the settings of the wall compass that holds the heading to the walls'
directions (:mod:`atlas_rap.maps.wall_compass`); None turns it off, as
``benchmarks/bench_wall_compass.py`` does to compare."""


@registered("localiser")
class Localiser(Skill):
    """The pose belief: ``pose`` = (x, y, heading) where the robot believes it is (module docstring)."""

    outputs = ("pose",)

    def init(self, context) -> None:
        super().init(context)
        world, robot = context.world, context.robot
        exact = world is None or robot is None or world.robot.odometry_noise.off
        self.exact = exact or context.beliefs.get(LOCALISATION) == "odometry"
        self.filter: ParticleFilter | None = None
        self.matcher: MapMatcher | None = None
        self.localised: bool | None = None
        self._last_ranges = None
        if robot is not None:
            context.beliefs[POSE] = robot.odometry  # the start pose, before the first period
        # the poses believed, for the evaluation, when they can be wrong: odometry with noise
        self._track: list[tuple[float, float, float, float]] | None = None if exact else []
        if self._track is not None:
            context.beliefs[POSE_TRACK] = self._track
        if self.exact:
            return
        self._odometry = robot.odometry
        self._angles = np.asarray(robot.sonar_angles, dtype=float)
        if not world.walls:  # no prior map: the odometry, corrected against the map being built
            self.matcher = MapMatcher(self._angles, world.robot.radius, world.sonar.max_range,
                                      world.sonar.beam_width, world.sonar.rays_per_beam)
            self.compass = WallCompass(WALL_COMPASS) if WALL_COMPASS is not None else None
            self._anchor = ((self._odometry, None), self._odometry)
            return
        self._sensor = SonarLikelihood(beam_width=world.sonar.beam_width, rays=world.sonar.rays_per_beam)
        rng = context.rng.spawn(1)[0] if context.rng is not None else np.random.default_rng(0)
        self.filter = ParticleFilter(self._prior_field(world), self._odometry, rng, spread=START_SPREAD,
                                     robot_radius=world.robot.radius, max_range=world.sonar.max_range,
                                     sensor=self._sensor)
        self._anchor = (self.filter.estimate(), self._odometry)
        self._lost_rings: list[tuple[Pose, np.ndarray, np.ndarray]] = []
        self._searched = False

    @staticmethod
    def _prior_field(world) -> LikelihoodField:
        frame = GridFrame.covering(world.bounds, MAP_RESOLUTION)
        return LikelihoodField(wall_mask(world.walls, frame), frame)

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        context = self.context
        odometry = context.robot.odometry
        if self.exact:
            context.beliefs[POSE] = odometry
            if self._track is not None:
                self._track.append((context.now(), *odometry))
            return {"pose": odometry}
        if self.matcher is not None:
            pose = self._corrected(odometry)
            context.beliefs[POSE] = pose
            self._track.append((context.now(), *pose))
            return {"pose": pose}
        updated = self._update(odometry)
        if updated is not None:
            self._anchor = (updated, odometry)
            pose, covariance = updated
            now = context.now()
            localised = self._localised(covariance)
            context.beliefs[POSE_ESTIMATE] = PoseEstimate(now, pose, covariance, self.filter.particles.copy(),
                                                          localised)
        (estimate, _), at = self._anchor
        pose = compose(estimate, between(at, odometry))  # the last estimate, moved as the odometry has since
        context.beliefs[POSE] = pose
        self._track.append((context.now(), *pose))
        return {"pose": pose}

    def _corrected(self, odometry: Pose) -> Pose:
        """Without a prior map: the last correction moved as the odometry has since, corrected again by a
        match against the grid when one is due, and its heading by the wall compass on the same local scan."""
        (estimate, _), at = self._anchor
        pose = compose(estimate, between(at, odometry))
        reading, grid = self.context.beliefs.get(SONAR), self.context.beliefs.get(GRID)
        if reading is None or grid is None or reading[0] is self._last_ranges:
            return pose
        self._last_ranges = reading[0]
        now = self.context.now()
        matcher = self.matcher
        matcher.add_ring(odometry, reading[0])
        matcher.keep(now, grid)
        corrected = matcher.correct(pose, odometry, now)
        if corrected is not None:
            pose = corrected
        if matcher.scan is not None and self.compass is not None:
            turn = self.compass.correction(matcher.scan, pose[2])
            if turn is not None:
                pose = (pose[0], pose[1], wrap(pose[2] + turn))
        if matcher.scan is not None:  # a match was due (a correction is made only then)
            self._anchor = ((pose, None), odometry)
        return pose

    def _update(self, odometry: Pose) -> tuple[Pose, np.ndarray] | None:
        """Move, weigh and resample the particles on a new ring, once the robot has moved enough since
        the last update: the estimate of the weighed particles (before resampling, so that particles
        just injected at random count by their weight, not as much as the rest), or None."""
        reading = self.context.beliefs.get(SONAR)
        if reading is None or reading[0] is self._last_ranges:
            return None
        last, pf = self._odometry, self.filter
        step = 1.0 if self.localised and pf.w_fast >= DOUBT * pf.w_slow else DOUBTFUL_STEP
        if math.hypot(odometry[0] - last[0], odometry[1] - last[1]) < step * UPDATE_DISTANCE \
                and abs(wrap(odometry[2] - last[2])) < step * UPDATE_ANGLE:
            return None
        self._last_ranges = reading[0]
        pf.predict(last, odometry)
        self._odometry = odometry
        pf.correct(reading[0], self._angles)
        if self.localised is False:
            self._search(odometry, reading[0])
        else:
            self._lost_rings.clear()
        estimate = pf.estimate()
        pf.resample()
        return estimate

    def _search(self, odometry: Pose, ranges: np.ndarray) -> None:
        """While lost, keep the rings; once they span a turn on the spot or :data:`SEARCH_DISTANCE` of
        driving, search the whole map for where they fit (:mod:`atlas_rap.maps.relocalisation`) and
        start the filter again from the best poses found."""
        rings = self._lost_rings
        rings.append((odometry, ranges, self._angles))
        turned = sum(abs(wrap(b[0][2] - a[0][2])) for a, b in zip(rings, rings[1:]))
        travelled = sum(math.hypot(b[0][0] - a[0][0], b[0][1] - a[0][1]) for a, b in zip(rings, rings[1:]))
        if turned < SEARCH_TURN and travelled < SEARCH_DISTANCE:
            return
        poses, scores = best_poses(self.filter, rings, odometry, clearance=self.context.world.robot.radius)
        self.filter.reseed(poses, scores / len(rings))
        rings.clear()
        self._searched = True

    def _localised(self, covariance: np.ndarray) -> bool:
        """Whether the robot counts as localised now (with the hysteresis of the module docstring);
        ``(localised)`` or ``(lost)`` is posted when that changes."""
        spread = math.sqrt(max(0.0, covariance[0, 0] + covariance[1, 1]))
        heading = math.sqrt(max(0.0, covariance[2, 2]))
        if self.filter.surprised:
            localised = False
        elif self.localised is False:  # found again only by a search of the whole map (see _search)
            localised = self._searched and spread <= LOCALISED_SPREAD and heading <= LOCALISED_HEADING
        else:
            localised = spread <= 2 * LOCALISED_SPREAD and heading <= 2 * LOCALISED_HEADING
        if localised != self.localised:
            self._searched = False
            if self.localised is not None:
                self.context.retract_fact(Compound("lost" if localised else "localised", ()))
            self.context.assert_fact(Compound("localised" if localised else "lost", ()))
            self.localised = localised
        return localised

"""Scan-to-map matching for a robot that maps as it goes: the pose corrected against the map being built.

Without a prior map the robot knows where it is by its odometry, and the
occupancy grid (:class:`~atlas_rap.maps.grid.OccupancyGrid`) is drawn from
that pose, drift and all. :class:`MapMatcher` pulls the pose back onto the
map where the map can say something, by correlative scan matching (Olson
2009, as Karto and Cartographer search): a small grid of (x, y, heading)
offsets round the pose, each scored by how well the sonar fits the map
there, weighed by a prior toward the odometry.

A ring of 16 sonars gives little to match, and a sonar grid is a poor thing
to match against while it is being drawn, so each part is chosen for that
(measured: see docs/how-to/localise.md):

- **A local scan, not a ring.** The rings of the last :attr:`MatchSettings.window`
  metres of travel, one every :attr:`~MatchSettings.ring_spacing` metres or
  :attr:`~MatchSettings.ring_turn` radians, placed relative to each other by
  the odometry (which drifts little over a metre or two): a few hundred
  beams instead of 16.
- **The map as it was, and only where it has settled.** The reference is the
  grid as it was :attr:`~MatchSettings.lag` seconds ago (so the scan is never
  matched against walls drawn from its own rings), and of that only the cells
  that had not changed for :attr:`~MatchSettings.settled_for` seconds before
  (:class:`SettledMap`). Cells at the edge of what has been seen are arcs
  drawn from one view; matching against them pulled the pose backwards along
  its way by some 5 cm a match, and a robot matched every 25 cm ran away.
- **Only where the robot sees settled space.** A match is made only when at
  least :attr:`~MatchSettings.coverage` of the scan's beams end in settled
  cells (free, or at a wall): when the robot comes back to a place it has
  mapped, or drives on a map carried from an earlier run (``--map-in``).
  Where it explores, the matcher leaves the pose alone (the localiser's
  wall compass, :mod:`atlas_rap.maps.wall_compass`, holds its heading).
- **The likelihood field of the settled walls**, each beam scored at its best
  fit across its cone (the sonar reads the nearest echo across its 15
  degrees), beams ending in unsettled or unknown cells scored as neither
  hit nor miss; the sum over the beams counted as :attr:`~MatchSettings.temper`
  rings' worth of evidence however many rings the scan holds (the beams of
  one wall seen from ten places are not ten independent readings).
- **A prior toward the odometry**, :attr:`~MatchSettings.prior_xy` metres and
  :attr:`~MatchSettings.prior_heading` radians: each match moves the pose by
  the mean of the posterior over the offsets, so a match that says little
  moves it little; and only along the directions the match decides (where
  the posterior is much narrower than the prior: across a corridor, not
  along it), and only when the best fit is inside the search, not on its
  edge (a slope is no peak). Without these two, matching against a map
  only three seconds old (a lag of 3 s, settled for 2 s) left the pose
  1.5-2.7 m off along the corridor on seven seeds of twelve; with them,
  0.44-0.48 m on average, against 0.53 m by dead reckoning.

The carried map keeps its frame: a map from an earlier run counts as
settled from the start, and the pose is pulled onto it.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.localisation import wrap

__all__ = ["Echoes", "Match", "MatchSettings", "MapMatcher", "SettledMap", "correlative_match", "scan_echoes",
           "scan_points"]

Pose = tuple[float, float, float]


@dataclass(frozen=True)
class MatchSettings:
    """How :class:`MapMatcher` builds its scans, its reference and its search (module docstring)."""

    ring_spacing: float = 0.1
    """Metres travelled between two rings kept for the local scan (or :attr:`ring_turn` radians turned)."""
    ring_turn: float = 0.1
    window: float = 1.5
    """Metres of travel the local scan covers."""
    match_every: float = 0.25
    """Metres travelled (or :attr:`match_turn` radians turned) between two matches."""
    match_turn: float = 0.3
    snapshot_every: float = 2.0
    """Seconds between two copies of the grid kept for the reference."""
    lag: float = 5.0
    """Seconds: the reference is the grid as it was at least this long ago."""
    settled_for: float = 3.0
    """Seconds for which a cell must not have changed (by more than :attr:`settled_change` in
    log-odds) to count in the reference."""
    settled_change: float = 0.5
    occupied: float = 0.65
    """P(occupied) above which a settled cell is a wall."""
    free: float = 0.2
    """P(occupied) below which a settled cell is free: a beam ending there is a miss."""
    sigma_hit: float = 0.1
    """Metres: the spread of a beam's end round the nearest wall."""
    z_rand: float = 0.05
    """The likelihood of a beam's end anywhere (a reading nothing on the map explains)."""
    unknown_distance: float = 0.15
    """A beam ending in a cell neither free nor near a wall scores as one this far from a wall."""
    coverage: float = 0.8
    """The share of the scan's beams that must end in settled cells for a match to be made."""
    temper: float = 5.0
    """How many rings' worth of evidence the whole scan counts for."""
    search_xy: float = 0.3
    """Metres searched either way in x and y, in steps of :attr:`step_xy`."""
    step_xy: float = 0.1
    search_heading: float = math.radians(8.0)
    """Radians searched either way, in steps of :attr:`step_heading`: wider than the wall compass's
    6 degrees, so a heading that a turn put further off than both can still be pulled back where
    the map is settled (at 4 degrees, a robot that turned round at the corridor's end 7 degrees off
    stayed so and got lost; Karto and Cartographer search 20 degrees)."""
    step_heading: float = math.radians(1.0)
    prior_xy: float = 0.1
    """Metres: the prior's spread in x and y round the odometry's pose."""
    prior_heading: float = math.radians(2.0)
    min_beams: int = 20
    """A scan with fewer echoes is not matched."""
    interior: bool = True
    """Match only when the best offset is inside the search, not on its edge (a slope is no peak)."""
    decisive: float = 0.7
    """A correction is kept along a direction (and in heading) only where the posterior's spread is
    under this share of the prior's."""


@dataclass(frozen=True)
class Match:
    """One match: the ``correction`` (dx, dy, dheading) to add to the pose (the posterior's mean over the
    offsets searched), its standard deviations ``sigma_xy`` (metres, x and y together) and ``sigma_heading``
    (radians), and the ``coverage`` of the scan by settled cells."""

    correction: Pose
    sigma_xy: float
    sigma_heading: float
    coverage: float


class SettledMap:
    """The reference of a match: a grid's log-odds scored as a likelihood field of its settled walls.

    ``log_odds`` and ``updated`` are a grid's arrays at some time; ``earlier`` the same arrays
    :attr:`MatchSettings.settled_for` seconds before (None: every cell counts as settled, as a map
    carried from an earlier run does). :attr:`score` is each cell's log-likelihood of a beam ending in
    it, :attr:`settled` whether a beam ending there says anything; both are padded by
    :attr:`pad` cells and flipped so that row ``floor(v) + pad`` holds the frame's ``v``-th row
    from the bottom.
    """

    def __init__(self, log_odds: np.ndarray, updated: np.ndarray, frame: GridFrame, settings: MatchSettings,
                 earlier: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        s = settings
        self.frame = frame
        seen = np.asarray(updated, dtype=bool)
        if earlier is not None:
            seen = seen & earlier[1] & (np.abs(log_odds - earlier[0]) <= s.settled_change)
        p = 1.0 / (1.0 + np.exp(-np.asarray(log_odds, dtype=np.float64)))
        walls = seen & (p > s.occupied)
        self.walls = int(walls.sum())
        distance = ndimage.distance_transform_edt(~walls) * frame.resolution if self.walls \
            else np.full(frame.shape, np.inf)
        score = np.log(np.exp(-0.5 * (distance / s.sigma_hit) ** 2) + s.z_rand)
        neutral = math.log(math.exp(-0.5 * (s.unknown_distance / s.sigma_hit) ** 2) + s.z_rand)
        settled = (seen & (p < s.free)) | (distance <= s.unknown_distance)
        self.pad = int(math.ceil(s.search_xy / frame.resolution)) + 2
        self.score = np.pad(np.flipud(np.where(settled, score, neutral)), self.pad,
                            constant_values=neutral).astype(np.float32)
        self.settled = np.pad(np.flipud(settled), self.pad, constant_values=False)
        self.width = self.score.shape[1]

    def cells(self, points: np.ndarray) -> np.ndarray:
        """The flat indices into :attr:`score` of world ``points`` (..., 2); off the map is on its border."""
        frame = self.frame
        ox, oy, yaw = frame.origin
        dx, dy = points[..., 0] - ox, points[..., 1] - oy
        if yaw:
            cos, sin = math.cos(yaw), math.sin(yaw)
            dx, dy = cos * dx + sin * dy, cos * dy - sin * dx
        u = np.clip(np.floor(dx / frame.resolution), -1, frame.width).astype(np.int64) + self.pad
        v = np.clip(np.floor(dy / frame.resolution), -1, frame.height).astype(np.int64) + self.pad
        return v * self.width + u


def _ring_echoes(rings: list[tuple[Pose, np.ndarray]], odometry: Pose, angles: np.ndarray, max_range: float):
    """Each ring of ``rings`` with an echo, in the frame of the robot at ``odometry``: (x, y, the
    bearings of its echoing beams, their ranges)."""
    c0, s0 = math.cos(odometry[2]), math.sin(odometry[2])
    for (x, y, heading), ranges in rings:
        echo = ranges < max_range - 1e-6
        if echo.any():
            dx, dy = x - odometry[0], y - odometry[1]  # the ring's pose in the robot's frame now
            yield dx * c0 + dy * s0, dy * c0 - dx * s0, angles[echo] + (heading - odometry[2]), ranges[echo]


def scan_points(rings: list[tuple[Pose, np.ndarray]], odometry: Pose, angles: np.ndarray, robot_radius: float,
                max_range: float, beam_width: float, rays: int) -> np.ndarray:
    """The ends of the echoes of ``rings`` ((odometry when read, ranges from the rim)), ``rays`` points
    across each beam's cone, in the frame of the robot at ``odometry``: an array (beams, rays, 2)."""
    offsets = np.linspace(-beam_width / 2, beam_width / 2, rays) if rays > 1 else np.zeros(1)
    ends = []
    for rx, ry, bearings, ranges in _ring_echoes(rings, odometry, angles, max_range):
        bearing = bearings[:, None] + offsets[None, :]
        reach = (ranges + robot_radius)[:, None]
        ends.append(np.stack([rx + reach * np.cos(bearing), ry + reach * np.sin(bearing)], axis=-1))
    return np.concatenate(ends) if ends else np.zeros((0, len(offsets), 2))


@dataclass(frozen=True)
class Echoes:
    """The echoes of a local scan (:func:`scan_echoes`), in the frame of a robot: where each sonar sat
    (``origins``, (N, 2)), the bearing of its beam's axis (``bearings``, radians) and its range
    (``ranges``, metres from the sonar); ``half_width``: half the beam's cone (radians). What the wall
    compass (:mod:`atlas_rap.maps.wall_compass`) reads."""

    origins: np.ndarray
    bearings: np.ndarray
    ranges: np.ndarray
    half_width: float


def scan_echoes(rings: list[tuple[Pose, np.ndarray]], odometry: Pose, angles: np.ndarray, robot_radius: float,
                max_range: float, beam_width: float) -> Echoes:
    """The echoes of ``rings`` ((odometry when read, ranges from the rim)) as :class:`Echoes`, in the
    frame of the robot at ``odometry``."""
    parts = [(rx + robot_radius * np.cos(bearings), ry + robot_radius * np.sin(bearings), bearings, ranges)
             for rx, ry, bearings, ranges in _ring_echoes(rings, odometry, angles, max_range)]
    if not parts:
        return Echoes(np.zeros((0, 2)), np.zeros(0), np.zeros(0), beam_width / 2)
    x, y, bearings, ranges = (np.concatenate(column) for column in zip(*parts))
    return Echoes(np.stack([x, y], axis=1), bearings, ranges, beam_width / 2)


def correlative_match(reference: SettledMap, pose: Pose, points: np.ndarray, rings: int,
                      settings: MatchSettings) -> Match | None:
    """Match a local scan (``points`` from :func:`scan_points`, made of ``rings`` rings) to ``reference``
    round ``pose``: the posterior's mean over the offsets searched, kept along the directions it
    decides (module docstring); None when the scan has too few beams, too few of them end in settled
    cells, or the best fit is on the edge of the search."""
    s = settings
    if len(points) < s.min_beams:
        return None
    frame = reference.frame
    res = frame.resolution
    table, settled = reference.score.ravel(), reference.settled.ravel()

    def world(heading: float, local: np.ndarray) -> np.ndarray:
        c, si = math.cos(heading), math.sin(heading)
        return np.stack([pose[0] + c * local[..., 0] - si * local[..., 1],
                         pose[1] + si * local[..., 0] + c * local[..., 1]], axis=-1)

    coverage = float(settled.take(reference.cells(world(pose[2], points))).any(axis=1).mean())
    if coverage < s.coverage:
        return None
    turns = np.arange(-s.search_heading, s.search_heading + 1e-9, s.step_heading)
    step = max(1, int(round(s.step_xy / res)))
    reach = int(round(s.search_xy / res)) // step * step
    steps = np.arange(-reach, reach + 1, step)
    du, dv = np.meshgrid(steps, steps, indexing="xy")
    du, dv = du.ravel(), dv.ravel()
    shift = dv * reference.width + du  # the offsets in cells of the frame, as flat index steps
    rays = points.shape[1]
    by_ray = np.ascontiguousarray(points.transpose(1, 0, 2))  # (rays, beams, 2): each ray's points together
    log_fit = np.empty((len(turns), len(shift)))
    for i, turn in enumerate(turns):
        cells = reference.cells(world(pose[2] + turn, by_ray)).reshape(rays, 1, -1)
        fit = table.take(cells + shift[None, :, None])  # (rays, offsets, beams)
        best = fit[0]
        for other in fit[1:]:  # each beam at its best fit across its cone
            np.maximum(best, other, out=best)
        log_fit[i] = best.sum(axis=1)
    yaw = frame.origin[2]
    ox, oy = du * res, dv * res  # the offsets in the frame's axes, then in the world's
    wx, wy = (ox, oy) if not yaw else (math.cos(yaw) * ox - math.sin(yaw) * oy,
                                       math.sin(yaw) * ox + math.cos(yaw) * oy)
    log_post = (s.temper / max(rings, 1)) * log_fit \
        - 0.5 * ((wx ** 2 + wy ** 2) / s.prior_xy ** 2)[None, :] - 0.5 * (turns ** 2 / s.prior_heading ** 2)[:, None]
    best_turn, best_shift = np.unravel_index(int(np.argmax(log_post)), log_post.shape)
    if s.interior and (best_turn in (0, len(turns) - 1) or max(abs(du[best_shift]), abs(dv[best_shift])) == reach):
        return None  # the best fit on the edge of the search: a slope, not a peak
    weight = np.exp(log_post - log_post.max())
    weight /= weight.sum()
    by_turn, by_shift = weight.sum(axis=1), weight.sum(axis=0)
    mt, mx, my = float(by_turn @ turns), float(by_shift @ wx), float(by_shift @ wy)
    rx, ry = wx - mx, wy - my
    covariance = np.array([[by_shift @ (rx * rx), by_shift @ (rx * ry)], [by_shift @ (rx * ry), by_shift @ (ry * ry)]])
    var_heading = float(by_turn @ (turns - mt) ** 2)
    # keep the correction only along the directions the match decides: where the posterior is much
    # narrower than the prior (along a corridor it is not, and a slope there is no evidence)
    values, vectors = np.linalg.eigh(covariance)
    kept = np.zeros(2)
    for value, vector in zip(values, vectors.T):
        if value < s.decisive ** 2 * s.prior_xy ** 2:
            kept += (vector @ (mx, my)) * vector
    mx, my = float(kept[0]), float(kept[1])
    if var_heading >= s.decisive ** 2 * s.prior_heading ** 2:
        mt = 0.0
    return Match((mx, my, mt), math.sqrt(float(values.sum())), math.sqrt(var_heading), coverage)


class MapMatcher:
    """The pose of a robot that maps, corrected against its map (module docstring).

    Feed it every new ring (:meth:`add_ring`) and the grid as it grows (:meth:`keep`); ask
    :meth:`correct` for the pose now. ``angles`` are the sonars' body-frame directions,
    ``robot_radius`` where they sit, ``max_range`` the range that means no echo, ``beam_width`` and
    ``rays`` the cone each reading is scored across.
    """

    def __init__(self, angles: np.ndarray, robot_radius: float, max_range: float, beam_width: float,
                 rays: int = 3, settings: MatchSettings = MatchSettings()) -> None:
        self.angles = np.asarray(angles, dtype=float)
        self.robot_radius, self.max_range = float(robot_radius), float(max_range)
        self.beam_width, self.rays = float(beam_width), int(rays)
        self.settings = settings
        self.rings: deque[tuple[Pose, np.ndarray, float]] = deque()  # (odometry, ranges, travelled)
        self.travelled = 0.0
        self._last_odometry: Pose | None = None
        self._matched_at: tuple[float, float] | None = None  # (travelled, heading) at the last match
        self._snapshots: list[tuple[float, np.ndarray, np.ndarray]] = []  # (time, log_odds, updated)
        self._grid = None  # the grid copied
        self._frame: GridFrame | None = None
        self._cells_updated = 0  # the grid's count of cell updates at the last copy
        self._reference: SettledMap | None = None
        self._reference_of: tuple[float, float] | None = None  # the snapshots' times it was made from
        self.matches = 0  # matches made (a correction applied)
        self.scan: Echoes | None = None  # the local scan of the last call of correct that was due

    def add_ring(self, odometry: Pose, ranges: np.ndarray) -> None:
        """A new sonar ring read at ``odometry``: kept for the local scan when the robot has moved enough."""
        s = self.settings
        if self._last_odometry is not None:
            self.travelled += math.dist(odometry[:2], self._last_odometry[:2])
        self._last_odometry = odometry
        last = self.rings[-1] if self.rings else None
        if last is None or self.travelled - last[2] >= s.ring_spacing \
                or abs(wrap(odometry[2] - last[0][2])) >= s.ring_turn:
            self.rings.append((odometry, np.array(ranges, dtype=float), self.travelled))
        while self.rings and self.travelled - self.rings[0][2] > s.window:
            self.rings.popleft()

    def keep(self, now: float, grid) -> None:
        """Copy the grid (an :class:`~atlas_rap.maps.grid.OccupancyGrid`) when a copy is due. The first
        copy of a grid that already holds a map (carried from an earlier run) counts as settled long ago."""
        s = self.settings
        if grid is not self._grid:  # a new grid: start again
            self._grid, self._frame, self._snapshots = grid, grid.frame, []
            self._reference, self._reference_of = None, None
            carried = bool(grid.updated.any())
            self._cells_updated = grid.cells_updated
            self._snapshots.append((-math.inf if carried else now, grid.log_odds.copy(), grid.updated.copy()))
            return
        if now - self._snapshots[-1][0] >= s.snapshot_every and grid.cells_updated != self._cells_updated:
            self._cells_updated = grid.cells_updated  # an unchanged grid (mapping off) needs no new copy
            self._snapshots.append((now, grid.log_odds.copy(), grid.updated.copy()))
            horizon = now - s.lag - s.settled_for - 2 * s.snapshot_every  # older copies are never used again
            while len(self._snapshots) > 2 and self._snapshots[1][0] < horizon:
                self._snapshots.pop(0)

    def due(self, odometry: Pose) -> bool:
        """Whether the robot has moved enough since the last match for another."""
        s = self.settings
        if self._matched_at is None:
            return True
        travelled, heading = self._matched_at
        return self.travelled - travelled >= s.match_every or abs(wrap(odometry[2] - heading)) >= s.match_turn

    def correct(self, pose: Pose, odometry: Pose, now: float) -> Pose | None:
        """The pose corrected by a match of the local scan round ``pose`` (the robot at ``odometry``),
        when one is due and the robot sees enough settled space; else None (keep the pose). When one
        was due, :attr:`scan` holds the local scan's :class:`Echoes` in the frame of the robot at
        ``odometry``, matched or not; else None."""
        self.scan = None
        if not self.due(odometry):
            return None
        self._matched_at = (self.travelled, odometry[2])
        rings = [(o, r) for o, r, _ in self.rings]
        self.scan = scan_echoes(rings, odometry, self.angles, self.robot_radius, self.max_range, self.beam_width)
        reference = self._settled_map(now)
        if reference is None or not reference.walls:
            return None
        points = scan_points(rings, odometry, self.angles, self.robot_radius, self.max_range, self.beam_width,
                             self.rays)
        match = correlative_match(reference, pose, points, len(self.rings), self.settings)
        if match is None:
            return None
        self.matches += 1
        dx, dy, dh = match.correction
        return pose[0] + dx, pose[1] + dy, wrap(pose[2] + dh)

    def _settled_map(self, now: float) -> SettledMap | None:
        """The reference now: the latest copy at least :attr:`~MatchSettings.lag` old, its settled cells
        judged against the latest copy :attr:`~MatchSettings.settled_for` older still."""
        s = self.settings
        old = [snap for snap in self._snapshots if snap[0] <= now - s.lag]
        if not old:
            return None
        ref = old[-1]
        if ref[0] == -math.inf:
            earlier, key = None, (ref[0], -math.inf)  # a carried map: settled from the start
        else:
            before = [snap for snap in self._snapshots if snap[0] <= ref[0] - s.settled_for]
            if not before:
                return None  # too early to tell what has settled
            earlier, key = (before[-1][1], before[-1][2]), (ref[0], before[-1][0])
        if key != self._reference_of:
            self._reference = SettledMap(ref[1], ref[2], self._frame, s, earlier)
            self._reference_of = key
        return self._reference

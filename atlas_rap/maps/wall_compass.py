"""A compass from the walls: the heading of a robot that maps, held to the directions its building's walls run in.

Without a prior map, the scan matcher (:mod:`atlas_rap.maps.scan_matching`)
corrects the pose only where the robot sees space it has mapped before.
Where it explores, nothing did, and the heading drifts: on the
skill-acquisition experiment's first run, up to 10 degrees by the far end
of the corridor (seed 1, at the default odometry noise), which bends the
map it draws for good. But the walls ahead, unmapped as they are, run in
the directions of the walls behind: a building is made of a few wall
directions, mostly two at right angles, and any wall seen says which way
the robot faces, to within the few degrees it may have drifted. This is
the "Manhattan world" of structured-environment SLAM and of indoor
robots with poor range sensors; here the directions are learnt from the
scans, not taken from the map's axes, so a building at any angle to its
map is served:

- **Where a sonar's echo comes from.** A sonar hears the nearest surface in
  its cone. A wall along a direction t reflects a beam from the direction in
  its cone nearest the wall's normal: straight back along the normal when
  the cone holds it (the foot of the perpendicular, at the range measured),
  else along the cone's edge. So for each direction tried, each echo of the
  local scan (the scan matcher's: the rings of the last 1.5 m, placed by the
  odometry, turned into the world's frame by the heading believed) is placed
  there, not on its beam's axis: a wall the robot draws near at a slant then
  keeps its direction (on the axes, its echoes tilt by a degree or more;
  ``tests/test_maps_wall_compass.py``).
- **A line.** Each echo's offset across t is binned
  (:attr:`CompassSettings.offset_bin`, 5 cm); the scan's *sharpness* along t
  is the sum of the squared counts of each pair of neighbouring bins, which
  peaks when t runs along a wall (:func:`sharpness`).
- **The building's directions.** A scan whose walls no learnt direction
  accounts for votes for its sharpest direction over the half turn (1 degree
  bins), when :attr:`~CompassSettings.min_support` echoes lie on that line.
  A peak of :attr:`~CompassSettings.min_votes` votes is learnt, with the one
  at right angles to it (:attr:`~CompassSettings.right_angles`), and then
  kept as it is: the first votes come from where the robot starts, whose
  heading is known, and a heading that drifts later cannot move them.
  Without the right angles, a robot that turned round at its start learnt
  the halls of ``office-building`` 6 degrees off, from its second wall
  direction, and held its heading to that. Walls at 60 degrees (the
  TurtleBot3 world's hexagon) are learnt as directions of their own.
- **The correction.** The sharpest line within
  :attr:`~CompassSettings.tolerance` (6 degrees) of a learnt direction, found
  in 1 degree steps then 0.25 degree steps round the best, turns the heading
  by :attr:`~CompassSettings.gain` (a half) of its difference from it; not
  when it is on the window's edge (a slope, not a peak), nor without the
  support. A wall that truly runs a few degrees off a learnt direction would
  pull the heading toward it: the case this does not serve.

The gain was measured, not tuned to a seed: without a prior map, on
``deliver.rap`` (lab-corridor-office, seeds 0-5), a tour of
``office-building`` (0-3), ``map-world.rap`` (small-office-map, 0-3),
``deliver-coffee.rap`` (maze, 0-3) and a drive along the corridor of the
Willow Garage ROS map (0-3), the position RMSE over the 22 runs was 0.172 m
at a gain of 0.25 (2 errands failed), 0.174 m at 0.5 (none failed, worst run
0.32 m) and 0.234 m at 1 (the Willow map's runs 0.57 m). The tables are in
docs/how-to/localise.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from atlas_rap.maps.scan_matching import Echoes

__all__ = ["CompassSettings", "WallCompass", "sharpness"]


@dataclass(frozen=True)
class CompassSettings:
    """What :class:`WallCompass` takes for a line, a direction and a correction (module docstring)."""

    tolerance: float = math.radians(6.0)
    """Radians either side of a learnt direction in which a scan's line is taken to run along it."""
    step: float = math.radians(0.25)
    """Radians between the directions tried near a learnt one."""
    vote_step: float = math.radians(1.0)
    """Radians between the directions tried over the half turn for a vote (the votes' bins)."""
    offset_bin: float = 0.05
    """Metres: the width of a bin of the echoes' offsets across a direction."""
    min_support: int = 12
    """Echoes that must lie on a line (in two neighbouring bins) for it to vote or to correct."""
    min_votes: int = 5
    """Votes a direction needs to be learnt."""
    peak_width: float = math.radians(3.0)
    """Radians either side of a learnt direction's bin whose votes it is the mean of."""
    right_angles: bool = True
    """Whether a direction learnt brings the one at right angles to it (module docstring)."""
    gain: float = 0.5
    """The share of the difference from a learnt direction the heading is turned by at each scan."""


def sharpness(echoes: Echoes, directions: np.ndarray, offset_bin: float) -> tuple[np.ndarray, np.ndarray]:
    """How sharply the reflections of ``echoes`` line up along each of ``directions`` (radians, in the
    echoes' frame): the sum of the squared counts of each pair of neighbouring offset bins across the
    direction, and the largest such count (the echoes on the best line). Two arrays, one value per
    direction.

    A sonar hears the nearest surface in its cone, so a wall along a direction reflects each beam from
    the direction in its cone nearest the wall's normal: straight back along the normal when the cone
    holds it (the foot of the perpendicular, at the range measured), else along the cone's edge. Each
    echo is placed so for each direction tried, which keeps walls seen at a slant from tilting their
    line of echoes (the beam's axis would)."""
    normal_x, normal_y = -np.sin(directions), np.cos(directions)
    # the cosine of the angle between each beam's axis and the wall's normal; its sign says which of the
    # normal's two senses faces the beam
    facing = np.outer(normal_x, np.cos(echoes.bearings)) + np.outer(normal_y, np.sin(echoes.bearings))
    along = np.abs(facing)
    cw, sw = math.cos(echoes.half_width), math.sin(echoes.half_width)
    # the reflection's share of the range across the wall: 1 when the cone holds the normal, else the
    # cosine of the angle from the cone's nearer edge to the normal
    across = np.where(along >= cw, 1.0, along * cw + np.sqrt(np.clip(1.0 - along * along, 0.0, None)) * sw)
    offsets = np.outer(normal_x, echoes.origins[:, 0]) + np.outer(normal_y, echoes.origins[:, 1]) \
        + np.copysign(across, facing) * echoes.ranges[None, :]
    bins = np.floor(offsets / offset_bin).astype(np.int64)
    bins -= bins.min(axis=1, keepdims=True)
    width = int(bins.max()) + 2
    rows = np.arange(len(directions))[:, None] * width
    counts = np.bincount((bins + rows).ravel(), minlength=len(directions) * width).reshape(len(directions), width)
    pairs = counts[:, :-1] + counts[:, 1:]
    return (pairs.astype(np.float64) ** 2).sum(axis=1), pairs.max(axis=1)


class WallCompass:
    """Learns the directions a building's walls run in from local scans, and says how far to turn the
    heading to hold a scan's walls to them (module docstring)."""

    def __init__(self, settings: CompassSettings = CompassSettings()) -> None:
        self.settings = settings
        self._bins = int(round(math.pi / settings.vote_step))
        self._angles = np.arange(self._bins) * (math.pi / self._bins)
        self.votes = np.zeros(self._bins)
        self._learnt: list[float] = []

    def directions(self) -> list[float]:
        """The learnt directions (radians in [0, pi)), in the order they were learnt."""
        return list(self._learnt)

    def _learn(self) -> None:
        """Learn the peaks of the votes that have enough of them and lie away from the directions
        learnt already: each the mean of the votes within :attr:`CompassSettings.peak_width` of its
        bin, then fixed, so that the votes of a heading that drifts later do not move it."""
        s, votes = self.settings, self.votes
        half = max(1, int(round(s.peak_width / s.vote_step)))
        window = np.arange(-half, half + 1)
        for b in np.argsort(-votes, kind="stable"):
            if votes[b] < 1:
                break
            near = (b + window) % self._bins
            weights = votes[near]
            if weights.sum() < s.min_votes or votes[b] < weights.max():
                continue  # too few votes, or not the peak
            angle = ((b + float(weights @ window) / float(weights.sum())) * (math.pi / self._bins)) % math.pi
            if all(abs(math.remainder(angle - d, math.pi)) > 2 * s.tolerance for d in self._learnt):
                self._learnt.append(angle)
                if s.right_angles:
                    self._learnt.append((angle + math.pi / 2) % math.pi)

    def correction(self, echoes: Echoes, heading: float) -> float | None:
        """The turn (radians) to add to the robot's ``heading`` so that the walls of the local scan
        ``echoes`` (in the robot's frame) run along a learnt direction, or None (no learnt direction
        near, or no line that decides). A scan whose walls no learnt direction accounts for then votes
        for its sharpest direction, which may teach a new one."""
        s = self.settings
        if len(echoes.ranges) < s.min_support:
            return None
        c, si = math.cos(heading), math.sin(heading)
        origins = echoes.origins @ np.array([[c, si], [-si, c]])
        world = Echoes(origins, echoes.bearings + heading, echoes.ranges, echoes.half_width)
        turn, explained = self._turn(world)
        if not explained:  # a line no learnt direction accounts for: its vote may teach a new one
            scores, support = sharpness(world, self._angles, s.offset_bin)
            best = int(np.argmax(scores))
            if support[best] >= s.min_support:
                self.votes[best] += 1.0
                self._learn()
        return turn

    def _turn(self, world: Echoes) -> tuple[float | None, bool]:
        """The turn for ``world`` (echoes in the world's frame) and whether a line within the tolerance of
        a learnt direction has the support: searched in :attr:`~CompassSettings.vote_step` steps, then in
        :attr:`~CompassSettings.step` steps round the best."""
        s = self.settings
        coarse = np.arange(-s.tolerance, s.tolerance + 1e-9, s.vote_step)
        best: tuple[float, float, int] | None = None  # (score, offset from the direction, its index)
        best_direction = 0.0
        for direction in self._learnt:
            scores, support = sharpness(world, direction + coarse, s.offset_bin)
            i = int(np.argmax(scores))
            if support[i] >= s.min_support and (best is None or scores[i] > best[0]):
                best, best_direction = (float(scores[i]), float(coarse[i]), i), direction
        if best is None:
            return None, False
        if best[2] in (0, len(coarse) - 1):
            return None, True  # the best fit on the window's edge: a slope, not a peak
        fine = best[1] + np.arange(-s.vote_step, s.vote_step + 1e-9, s.step)
        scores, _ = sharpness(world, best_direction + fine, s.offset_bin)
        return -s.gain * float(fine[int(np.argmax(scores))]), True

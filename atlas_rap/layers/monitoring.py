"""Layer I, Monitoring: raw sonar, detection, and feedback control (seed Table 1).

Always active and the highest priority. At the skills' rate it

- keeps the reflexes on (the safety reflex slows, stops and backs off;
  with Layer I not enabled they are off, see ``skills/safety.py``);
- logs every new sonar ring with its pose, for Layer IV to fuse at its
  own, slower period (and keeps the last few for Layer III's assessment);
  while it logs rings, it also logs where the bumper touched something
  (the :data:`~atlas_rap.skills.beliefs.BUMP` belief: the point on the
  robot's rim, at the pose it believed it had), for Layer IV to mark;
- watches the way ahead: an echo in the strip the robot will sweep on its
  way to the route's next waypoint, nearer than the waypoint and within
  :data:`LOOK_AHEAD` metres,
  that the map does not explain (an echo from a cell the grid already
  believes occupied is structure: a wall is Layer IV's to plan round).
  Seen for ``obstacle-after`` seconds it asserts ``(obstacle short-lived)``;
  still there after ``long-lived-after`` seconds, ``(obstacle long-lived)``
  and the :data:`~atlas_rap.skills.beliefs.OBSTACLE` belief (where it is);
  clear for ``clear-after`` seconds, ``(obstacle none)``. The times are
  ``(layer-setting ...)`` facts of the rules file.

When primary it holds the robot still (the stack sets the ``HOLD`` belief);
alone it drives reactively, straight for the goal with the reflexes on.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from atlas_rap.layers.layer import Layer
from atlas_rap.layers.route_geometry import distance_to_polyline, echo_points, route_ahead
from atlas_rap.logic import Compound
from atlas_rap.model import Point
from atlas_rap.skills.beliefs import BUMP, GRID, OBSTACLE, POSE, REFLEXES, ROUTE, SONAR, PlannedRoute

RECENT_RINGS = 30
"""Rings kept for Layer III's assessment of an obstacle (3 s of a 10 Hz sonar)."""

LOOK_AHEAD = 0.7
"""Metres from the robot's rim within which an echo on the way ahead is an obstacle."""

OCCUPIED_LOG_ODDS = 0.0
"""Cells the grid believes more likely occupied than not (P(occ) > 0.5) explain an echo."""

EXPLAINED_WITHIN = 4
"""Cells (0.2 m on a 0.05 m grid) round an echo's point in which an obstacle on the grid explains it:
a sonar beam is 15 degrees wide, so the point is known to a few centimetres only."""

MARGIN = 0.1
"""Metres either side of the robot's width that its swept path takes in."""


class MonitoringLayer(Layer):
    """Layer I; see the module docstring."""

    name = "I"
    period = 0.05

    def start(self) -> None:
        self.stack.beliefs[REFLEXES] = True
        self.ring_log: list[tuple[tuple[float, float, float], np.ndarray, np.ndarray]] = []
        self.recent: deque[tuple[tuple[float, float, float], np.ndarray, np.ndarray]] = deque(maxlen=RECENT_RINGS)
        self._last_ranges = None
        self.contacts: list[tuple[float, float]] = []
        self._last_bump = None
        self._echo: Point | None = None
        self.state = "none"
        self.seen_since: float | None = None
        self.clear_since: float | None = None
        self.stack.assert_fact(self, "obstacle", "none")

    def tick(self, now: float) -> None:
        beliefs = self.stack.beliefs
        pose, reading = beliefs.get(POSE), beliefs.get(SONAR)
        if pose is None or reading is None:
            return
        ranges, angles = reading
        bump = beliefs.get(BUMP)
        if bump is not None and bump is not self._last_bump:  # a new contact: where the body touched
            self._last_bump = bump
            if self.stack.logging_rings:
                reach = self.stack.robot_radius
                self.contacts.append((pose[0] + reach * math.cos(pose[2] + bump[1]),
                                      pose[1] + reach * math.sin(pose[2] + bump[1])))
        if ranges is not self._last_ranges:  # a new ring (the sonar's 10 Hz): look again
            self._last_ranges = ranges
            self.recent.append((pose, ranges, angles))
            if self.stack.logging_rings:
                self.ring_log.append((pose, ranges, angles))
            self._echo = self._in_the_way(pose, ranges, angles)
        echo = self._echo
        stack = self.stack
        if echo is not None:
            self.clear_since = None
            if self.seen_since is None:
                self.seen_since = now
            lasted = now - self.seen_since  # since the obstacle was first seen, flickers included
            if self.state == "none" and lasted >= stack.setting("obstacle-after", 0.5):
                self.state = "short-lived"
                stack.post(self, [("assert", _fact("short-lived"))])
            if self.state == "short-lived" and lasted >= stack.setting("long-lived-after", 4.0):
                self.state = "long-lived"
                beliefs[OBSTACLE] = echo
                stack.post(self, [("assert", _fact("long-lived"))])
            return
        if self.state == "none":
            self.seen_since = None  # a glimpse shorter than obstacle-after: nothing
            return
        if self.clear_since is None:
            self.clear_since = now
        if now - self.clear_since >= stack.setting("clear-after", 0.5):
            self.state, self.seen_since = "none", None
            stack.post(self, [("assert", _fact("none"))])

    def _in_the_way(self, pose, ranges: np.ndarray, angles: np.ndarray) -> Point | None:
        """Where an unexplained echo in the robot's swept path is, or None.

        The swept path is the strip as wide as the robot (plus ``MARGIN``)
        along the next ``LOOK_AHEAD`` metres of the route (past the next
        waypoint, on along the route, but not past its goal): a door jamb
        beside the way is not in it; a person crossing it, or a box just
        beyond a doorway the route goes through, is.
        """
        route = self.stack.beliefs.get(ROUTE)
        if route is None:
            return None
        x, y, heading = pose
        radius = self.stack.robot_radius
        echoes, hit = echo_points(x, y, heading, ranges, angles, radius, LOOK_AHEAD + radius + MARGIN)
        if not hit.any():  # farther echoes cannot be in the strip
            return None
        reach = ranges[hit] + radius
        ahead = route_ahead((x, y), route.waypoints, route.index, LOOK_AHEAD + radius)
        if len(ahead) < 2 or math.dist(ahead[0], ahead[-1]) <= radius + 0.05:
            return None
        near = distance_to_polyline(echoes, ahead[1:] if len(ahead) > 2 else ahead) < radius + MARGIN
        near &= distance_to_polyline(echoes, ahead[:1]) > radius  # not beside or behind the robot itself
        near &= _beyond_start(echoes, ahead)
        if not near.any():
            return None
        nearest = int(np.argmin(np.where(near, reach, np.inf)))
        point = (float(echoes[nearest, 0]), float(echoes[nearest, 1]))
        return None if self._explained(point) else point

    def _explained(self, point: Point) -> bool:
        """An echo from where the grid already has an obstacle is structure, not news."""
        grid = self.stack.beliefs.get(GRID)
        if grid is None:
            return False
        row, col = grid.frame.world_to_cell(*point)
        if not grid.frame.contains_cell(row, col):
            return True
        span = EXPLAINED_WITHIN
        window = grid.log_odds[max(row - span, 0):row + span + 1, max(col - span, 0):col + span + 1]
        return bool((window > OCCUPIED_LOG_ODDS).any())

    def drain(self) -> list[tuple[tuple[float, float, float], np.ndarray, np.ndarray]]:
        """The rings logged since the last call (Layer IV fuses them)."""
        rings, self.ring_log = self.ring_log, []
        return rings

    def drain_contacts(self) -> list[tuple[float, float]]:
        """Where the bumper touched something since the last call (Layer IV marks them)."""
        contacts, self.contacts = self.contacts, []
        return contacts

    def route(self, goal: str, start: Point, closed: set[str]) -> PlannedRoute | str | None:
        """Alone, Layer I heads straight for the goal; the reflexes keep it safe."""
        return PlannedRoute((self.stack.world.places[goal].point,), {}, "I")


def _fact(state: str) -> Compound:
    return Compound("obstacle", (state,))


def _beyond_start(points: np.ndarray, ahead: np.ndarray) -> np.ndarray:
    """Points ahead of the robot along the first leg of the route (not behind it)."""
    direction = ahead[1] - ahead[0]
    return (points - ahead[0]) @ direction > 0

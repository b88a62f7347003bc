"""Event skills: always on, they turn what the robot senses into facts in RAP memory.

- ``place-monitor``: ``(at robot PLACE)`` when the robot enters a named
  place (a memory rule such as ``at-is-unique`` retracts the old one);
- ``door-monitor``: ``(door-closed DOOR)`` / ``(door-open DOOR)`` when the
  sonar beam that points through a nearby doorway (the whole beam inside
  the doorway, seen nearly head-on) echoes at the door's distance (closed)
  or well beyond it (open), three readings in a row (a beam counts only
  when it fits through the doorway however wrong the pose belief may be,
  within two sigmas of its covariance; nothing while the robot is lost, and
  everything seen before is forgotten once it is found again); it keeps the belief
  the route planner uses, and ``(edge-blocked A B)`` while no door it
  believes open joins places A and B;
- ``bump-monitor``: ``(bumped robot)`` on contact, retracted a second after
  the last one.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from atlas_rap.logic import Compound
from atlas_rap.skills.avoidance import angle_wrap
from atlas_rap.skills.beliefs import CLOSED_DOORS, POSE_ESTIMATE
from atlas_rap.skills.catalog import registered
from atlas_rap.skills.skill import Skill


@registered("place-monitor")
class PlaceMonitor(Skill):
    """Asserts ``(at robot PLACE)`` on entering a place."""

    inputs = ("pose",)

    def init(self, context) -> None:
        super().init(context)
        self.last: str | None = None

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        pose = inputs["pose"]
        if pose is None:
            return {}
        place = self.context.world.place_at(pose[0], pose[1])
        if place is not None and place != self.last:
            self.last = place
            self.context.assert_fact(Compound("at", ("robot", place)))
        return {}


@registered("door-monitor")
class DoorMonitor(Skill):
    """Watches doorways within ``sensing_range`` with the sonar; asserts their state when it changes."""

    inputs = ("pose", "sonar")
    sensing_range = 3.0
    nearest = 0.4  # closer, the robot is in the doorway and its beams see the frame
    tolerance = 0.3
    readings_needed = 3

    def init(self, context) -> None:
        super().init(context)
        self.doors = [door for door in context.world.doors.values() if door.segment is not None]
        self.state: dict[str, str] = {}
        self.evidence: dict[str, tuple[str, int]] = {}
        self.was_lost = False
        context.beliefs.setdefault(CLOSED_DOORS, set())

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        pose, sonar = inputs["pose"], inputs["sonar"]
        if pose is None or sonar is None:
            return {}
        ranges, angles = sonar
        world = self.context.world
        radius, half_beam = world.robot.radius, world.sonar.beam_width / 2
        x, y, heading = pose
        estimate = self.context.beliefs.get(POSE_ESTIMATE)
        if estimate is not None and not estimate.localised:
            self.was_lost = True  # a robot that does not know where it is cannot tell which door it sees
            return {}
        if self.was_lost:
            self._forget()
        for door in self.doors:
            cx, cy = door.center
            distance = math.hypot(cx - x, cy - y)
            if not self.nearest < distance < self.sensing_range:
                continue
            beam = int(np.argmin(np.abs(angle_wrap(angles + heading - math.atan2(cy - y, cx - x)))))
            margin = _bearing_doubt(estimate.covariance, distance) if estimate is not None else 0.0
            along = _through_doorway(door.segment, x, y, heading + float(angles[beam]), half_beam + margin)
            if along is None:
                continue  # the whole beam would not fit through the doorway: a reading says nothing
            expected = along - radius
            reading = float(ranges[beam])
            if abs(reading - expected) <= self.tolerance:
                self._evidence(door.name, "closed")
            elif reading > expected + 0.6:
                self._evidence(door.name, "open")
        return {}

    def _forget(self) -> None:
        """Found again after being lost: what was seen of the doors before may have been seen from the
        wrong place (a kidnapped robot takes a frame for a closed door), so it is all forgotten, facts
        too, and the doors are looked at afresh."""
        self.was_lost = False
        context, closed = self.context, self.context.beliefs[CLOSED_DOORS]
        for door, seen in self.state.items():
            context.retract_fact(Compound(f"door-{seen}", (door,)))
            a, b = context.world.doors[door].between
            for pair in ((a, b), (b, a)):
                context.retract_fact(Compound("edge-blocked", pair))
        closed.clear()
        self.state.clear()
        self.evidence.clear()

    def _evidence(self, door: str, seen: str) -> None:
        previous, count = self.evidence.get(door, ("", 0))
        count = count + 1 if previous == seen else 1
        self.evidence[door] = (seen, count)
        if count < self.readings_needed or self.state.get(door) == seen:
            return
        self.state[door] = seen
        closed = self.context.beliefs[CLOSED_DOORS]
        context = self.context
        if seen == "closed":
            closed.add(door)
            context.retract_fact(Compound("door-open", (door,)))
            context.assert_fact(Compound("door-closed", (door,)))
        else:
            closed.discard(door)
            context.retract_fact(Compound("door-closed", (door,)))
            context.assert_fact(Compound("door-open", (door,)))
        a, b = context.world.doors[door].between
        others = [d for d in context.world.doors.values() if set(d.between) == {a, b} and d.name not in closed]
        for pair in ((a, b), (b, a)):
            if others:
                context.retract_fact(Compound("edge-blocked", pair))
            else:
                context.assert_fact(Compound("edge-blocked", pair))


def _bearing_doubt(covariance: np.ndarray, distance: float) -> float:
    """Radians by which a beam's true bearing to something ``distance`` metres away may differ from
    the believed one: two sigmas of the belief's heading and of its position across the line of sight.
    The door monitor counts a beam only when the whole beam, widened by this, fits through the doorway:
    a beam that may graze the frame would read the frame as a closed door."""
    heading = math.sqrt(max(0.0, float(covariance[2, 2])))
    position = math.sqrt(max(0.0, float(covariance[0, 0] + covariance[1, 1])) / 2)
    return 2.0 * (heading + position / max(distance, 1e-6))


@registered("bump-monitor")
class BumpMonitor(Skill):
    """Asserts ``(bumped robot)`` on contact; retracts it ``hold`` seconds after the last one."""

    inputs = ("bump",)
    hold = 1.0

    def init(self, context) -> None:
        super().init(context)
        self.last_bump: float | None = None

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        now = self.context.now()
        if inputs["bump"] is not None:
            if self.last_bump is None:
                self.context.assert_fact(Compound("bumped", ("robot",)))
            self.last_bump = now
        elif self.last_bump is not None and now - self.last_bump > self.hold:
            self.last_bump = None
            self.context.retract_fact(Compound("bumped", ("robot",)))
        return {}


def _through_doorway(segment, x: float, y: float, direction: float, half_beam: float) -> float | None:
    """How far along a beam from (x, y) the door's line is, if the whole beam passes inside the doorway.

    None when the beam misses the doorway, grazes it (less than 30° off the
    door's line), or is wider there than the gap, so part of it would echo
    off the frame.
    """
    (ax, ay), (bx, by) = segment.a, segment.b
    dx, dy = math.cos(direction), math.sin(direction)
    ex, ey = bx - ax, by - ay
    width = math.hypot(ex, ey)
    denominator = dx * ey - dy * ex
    if width == 0 or abs(denominator) < width * math.sin(math.radians(60)):
        return None
    along = ((ax - x) * ey - (ay - y) * ex) / denominator
    across = ((ax - x) * dy - (ay - y) * dx) / denominator * width  # metres from a along the door
    spread = along * math.tan(half_beam) / abs(denominator / width)
    if along <= 0 or across - spread < 0.05 or across + spread > width - 0.05:
        return None
    return along

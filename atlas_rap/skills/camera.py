"""Visual skills: the colour camera, looking around, and approaching what it sees.

The 3T robots found things by colour (seed 003 §4: the JSC robot searched
for coloured shirts, Chip found trash and bins): visual skills search for
and track colours, and skill events tell the RAPs what is in view. Here:

- ``colour-camera`` (always on, 10 Hz) looks along the robot's heading
  through the robot's :data:`~atlas_rap.skills.beliefs.OBJECTS` devices
  (in a simulated world, :mod:`atlas_rap.sim.objects`: a 60° field of view,
  5 m, walls and closed doors hide things) and keeps, for every object it
  has seen, its latest :class:`~atlas_rap.skills.beliefs.Sighting` (where
  on the map, bearing and range, when) in the
  :data:`~atlas_rap.skills.beliefs.SIGHTINGS` belief and in its
  ``sightings`` output. It posts facts only when something changes, never
  a bearing or a range (they change at every step; tracking skills read
  the belief):

  - ``(in-view OBJ COLOUR)`` when OBJ comes into view; retracted when it has
    been out of view for :attr:`ColourCamera.out_of_view_after` seconds;
  - ``(seen OBJ COLOUR PLACE)``: OBJ was last seen in PLACE (the place at
    its position on the map, else the place whose point is nearest);
    asserted on coming into view and when it is seen in another place;
    this is the search's memory of where things are;
  - ``(is-a OBJ KIND)`` (object, trash or bin), the first time it is seen;
  - ``(lost ...)`` is retracted when OBJ is seen again.

- ``(look-around)`` turns the robot on the spot once all the way round
  (at :attr:`LookAround.turn_rate`), so the camera sees the whole place;
  it finishes ``:succeed``.
- ``(approach OBJ)`` drives to OBJ by its latest sighting, around echoes,
  and finishes ``:succeed`` when it is within :data:`STOP_AT` (0.5 m from
  centre to centre; 0.65 m for a bin) and in view. It tracks the object
  while it drives: each new sighting moves the goal. Not seen for
  :attr:`Approach.lost_after` seconds, it has lost it: it retracts
  ``(seen OBJ COLOUR PLACE)``, asserts ``(lost OBJ COLOUR PLACE)`` (where
  it was last seen) and fails with the reason; making no progress, it
  asserts ``(blocked robot approach)`` and fails, as the motion skills do.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from atlas_rap.logic import Compound, Var
from atlas_rap.skills.avoidance import angle_difference, steer
from atlas_rap.skills.beliefs import HOLD, OBJECTS, SIGHTINGS, SPEED_LIMIT, Sighting
from atlas_rap.skills.catalog import registered
from atlas_rap.skills.motion import _Driving
from atlas_rap.skills.routes import where_is
from atlas_rap.skills.skill import Skill

STOP_AT = {"bin": 0.65}
"""Metres (centre to centre) at which ``approach`` stops short of an object, by kind."""

STOP_AT_DEFAULT = 0.5
"""The same for every other kind: within the gripper's reach (``pick-up`` reaches 0.6 m)."""

FRESH = 0.35
"""Seconds within which a sighting counts as seeing the object now."""


@registered("colour-camera")
class ColourCamera(Skill):
    """The colour camera: sightings in, facts out when something changes; see the module docstring."""

    inputs = ("pose",)
    outputs = ("sightings",)
    fov = math.radians(60.0)
    max_range = 5.0
    out_of_view_after = 1.0

    def init(self, context) -> None:
        super().init(context)
        self.in_view: dict[str, tuple[str, float]] = {}  # (in-view OBJ COLOUR) asserted: OBJ → (colour, last seen)
        self.kinds: set[str] = set()  # objects whose (is-a ...) is posted
        context.beliefs.setdefault(SIGHTINGS, {})

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        context = self.context
        devices = context.beliefs.get(OBJECTS)
        pose = inputs["pose"]
        if devices is None or pose is None:
            return {}
        now = context.now()
        x, y, heading = pose
        sightings = context.beliefs.setdefault(SIGHTINGS, {})
        seen: list[Sighting] = []
        for view in devices.look(self.fov, self.max_range):
            name, colour = view.name, view.colour
            ox = x + view.range * math.cos(heading + view.bearing)
            oy = y + view.range * math.sin(heading + view.bearing)
            place = where_is(context.world, ox, oy)
            before = sightings.get(name)
            sighting = Sighting(name, colour, view.kind, ox, oy, place, view.bearing, view.range, now)
            sightings[name] = sighting
            seen.append(sighting)
            if name not in self.kinds:
                self.kinds.add(name)
                context.assert_fact(Compound("is-a", (name, view.kind)))
            entering = name not in self.in_view
            if entering:
                context.retract_matching(Compound("lost", (name, Var("colour"), Var("place"))))
                context.assert_fact(Compound("in-view", (name, colour)))
            if place is not None and (entering or before is None or before.place != place):
                if before is not None and before.place not in (None, place):
                    context.retract_fact(Compound("seen", (name, colour, before.place)))
                context.assert_fact(Compound("seen", (name, colour, place)))
            self.in_view[name] = (colour, now)
        for name, (colour, last) in list(self.in_view.items()):
            if now - last > self.out_of_view_after + 1e-9:
                del self.in_view[name]
                context.retract_fact(Compound("in-view", (name, colour)))
        return {"sightings": tuple(seen)}


@registered("look-around")
class LookAround(Skill):
    """``(look-around)``: turn on the spot once all the way round, so the camera sees the whole place,
    and the sonar ring, whose beams leave gaps between them, has had a beam in every direction
    (``go-to``'s look-again in ``rap_library/navigation.rap``: nav2's Spin recovery)."""

    inputs = ("pose",)
    outputs = ("command",)
    turn_rate = 1.2  # rad/s: about 5 s a turn, 0.12 rad between camera frames

    def enable(self, args: tuple[Any, ...]) -> None:
        super().enable(args)
        self.turned = 0.0
        self.last: float | None = None

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        pose = inputs["pose"]
        if pose is None:
            return {}
        if self.last is not None:
            self.turned += angle_difference(pose[2], self.last)
        self.last = pose[2]
        if self.turned >= 2 * math.pi:
            self.context.finish(self)
            return {"command": (0.0, 0.0)}
        return {"command": (0.0, self.turn_rate)}


@registered("approach")
class Approach(_Driving):
    """``(approach OBJ)``: drive up to an object by its sightings; see the module docstring."""

    lost_after = 3.0

    def enable(self, args: tuple[Any, ...]) -> None:
        super().enable(args)
        self.target = str(args[0])
        self.since = self.context.now()

    def transform(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        context = self.context
        pose = inputs["pose"]
        if pose is None:
            return {}
        now = context.now()
        sighting = (context.beliefs.get(SIGHTINGS) or {}).get(self.target)
        if sighting is None:
            context.finish(self, ":fail", f"{self.target} has not been seen")
            return {"command": (0.0, 0.0)}
        if now - max(sighting.time, self.since) > self.lost_after:
            return self.lose(sighting)
        if HOLD in context.beliefs:
            self.progress.reset(now)
        goal = (sighting.x, sighting.y)
        distance = math.dist(pose[:2], goal)
        if distance <= STOP_AT.get(sighting.kind, STOP_AT_DEFAULT):
            if now - sighting.time <= FRESH:
                context.finish(self)
                return {"command": (0.0, 0.0)}
            error = angle_difference(math.atan2(goal[1] - pose[1], goal[0] - pose[0]), pose[2])
            return {"command": (0.0, max(-self.max_turn, min(self.max_turn, 2.0 * error)))}  # look at it again
        if self.progress.stuck(distance, now):
            return self.give_up(f"no progress toward {self.target} for {self.progress.patience:g} s")
        limit = context.beliefs.get(SPEED_LIMIT)
        speed = self.max_speed if limit is None else self.max_speed * limit
        return {"command": steer(pose, goal, inputs["sonar"], max_speed=speed, max_turn=self.max_turn,
                                 arrive_radius=0.8)}

    def lose(self, sighting: Sighting) -> dict[str, Any]:
        """The object is out of sight: forget where it was seen, say where it was lost, and fail."""
        context = self.context
        context.retract_matching(Compound("seen", (self.target, Var("colour"), Var("place"))))
        if sighting.place is not None:
            context.assert_fact(Compound("lost", (self.target, sighting.colour, sighting.place)))
        context.finish(self, ":fail", f"lost sight of {self.target} ({sighting.colour}): "
                                      f"not seen for {self.lost_after:g} s")
        return {"command": (0.0, 0.0)}

"""Layer III, Tactical: situation assessment and re-routing on the topological and geometric maps.

Two jobs (seed Table 1 and §5.2):

- **The topology from the grid.** In a run without a prior map, every
  ``topology-every`` seconds (a layer setting) and only when Layer IV has
  changed the grid since, it runs the abstraction (distance transform,
  skeleton, places, topology: :func:`atlas_rap.maps.abstraction.abstract`)
  on the grid's reachable part and names the places after the world's
  named places that fall inside them. The topology is the
  :data:`~atlas_rap.skills.beliefs.TOPOLOGY` belief, and what it connects
  is RAP memory: ``(connected lab corridor)`` (both ways), retracted when a
  newer map no longer joins them.
- **Assessment of a block.** When something has stood in the robot's way
  for long (Layer I's ``(obstacle long-lived)`` and the
  :data:`~atlas_rap.skills.beliefs.OBSTACLE` belief), Layer III assesses it
  at its next tick, whichever layer is primary (situation assessment is its
  job, seed Table 1). It fuses the last few sonar rings into the grid (so the
  obstacle is on the map even when mapping is off), forgets what an older
  map said lies just behind the obstacle's face (unknown, so no route goes
  through its unseen side), rebuilds the topology, finds the stretch of the
  route the obstacle blocks (from the place the robot is in to the next
  place the route was to reach) and asserts ``(route-blocked A B)``. With a
  prior map (places and doors, no grid) it leaves the route's next door out
  when the obstacle is near it or on the way to it and another way exists;
  else the route stands and the motion skills steer round the obstacle. Then the seed's
  two cases (§5.2): a way round on what it knows, ``(way-round A B)`` (the
  rules make Layer III primary: it drives the new route), or none,
  ``(no-route)`` (the rules hand over to Layer IV, which remaps).
- **Re-routing.** Primary for a way round, it selects the new route at its
  next tick (one tactical period after it took over: ``navigate-to`` asks
  again) and asserts ``(rerouted A B)``; the rules hand back to Layer II.
  After a block cut every known way, Layer IV remaps and drives the robot
  to the goal it was cut from, mapping the way it finds; meanwhile Layer III
  rebuilds the topology at each of its ticks when the grid changed once the
  robot is sent on, and as soon as the rebuilt map has a route there it
  asserts ``(remapped A B)`` and retracts ``(no-route)``: the new way is on
  the map, and Layer II follows it.

A block stays for the rest of the run.
"""

from __future__ import annotations

import math

import numpy as np

from atlas_rap.layers.layer import Layer
from atlas_rap.layers.operational import route_on_maps
from atlas_rap.layers.route_geometry import distance_to_polyline, echo_points
from atlas_rap.logic import Compound
from atlas_rap.model import Point
from atlas_rap.skills.beliefs import CLOSED_DOORS, GOAL, GRID, OBSTACLE, POSE, ROUTE, TOPOLOGY, PlannedRoute


UNSEEN_DEPTH = 0.8
"""Metres behind an obstacle's face that become unknown when Layer III puts it on the map."""

NEAR_OBSTACLE = 1.0
"""Metres from the obstacle within which an echo is of the obstacle."""

DOOR_BLOCK = 2.0
"""Metres from the next door of a route within which an obstacle blocks that door (prior map)."""

ON_THE_WAY = 0.5
"""Metres from the route to its next door within which an obstacle blocks the way to that door (prior map)."""

LOOK_EVERY = 1.0
"""Seconds between two rebuilds of the topology while Layer III looks for a way round a block on the map
Layer IV is remapping (``_look_for_a_way``): the grid changes at every tick while Layer IV maps, and a
rebuild at every tick (4 a second) made a tour of office-building whose way stayed cut for minutes take
2.5 times its wall time (214 rebuilds instead of 27)."""


class TacticalLayer(Layer):
    """Layer III; see the module docstring."""

    name = "III"
    plans = True
    period = 0.25  # between Layer II's 0.1 s and Layer IV's 0.5 s (seed Fig. 2: slower layers above)

    def start(self) -> None:
        self.built_version = -1
        self.built_at = -math.inf
        self.connected: set[tuple[str, str]] = set()
        self.assessed: Point | None = None
        self.blocked: tuple[str, str] | None = None  # the stretch of the last block assessed
        self.rerouting = False  # a way round was found: select it once primary
        self.awaiting_way: str | None = None  # no way round to this goal: Layer IV remaps and drives there
        if not self.stack.prior_map and self.stack.beliefs.get(GRID) is not None:
            self.rebuild(0.0)  # a map carried from an earlier run (--map-in): its topology from the start

    def tick(self, now: float) -> None:
        stack = self.stack
        goal = stack.beliefs.get(GOAL)
        looking = self.awaiting_way is not None and goal is not None and goal.place != self.awaiting_way
        if not stack.prior_map and stack.beliefs.get(GRID) is not None and stack.grid_version != self.built_version:
            if now - self.built_at >= stack.setting("topology-every", 10.0) or stack.primary in ("II", "III") \
                    or (looking and now - self.built_at >= LOOK_EVERY):
                self.rebuild(now)
                if looking:
                    self._look_for_a_way()
        if self.rerouting and stack.primary == "III":
            self.rerouting = False
            stack.replanned()
            stack.post(self, [("assert", _fact("rerouted", *self.blocked))])
            return
        obstacle = stack.beliefs.get(OBSTACLE)
        if obstacle is not None and obstacle != self.assessed and stack.holds("obstacle", "long-lived"):
            self.assessed = obstacle
            self.assess(obstacle)

    def rebuild(self, now: float) -> None:
        """The topology of the grid as it is now, its places named; ``connected`` facts follow it."""
        from atlas_rap.maps.abstraction import abstract
        from atlas_rap.maps.inference import InferenceGrid

        stack, beliefs = self.stack, self.stack.beliefs
        grid = beliefs[GRID]
        self.built_version, self.built_at = stack.grid_version, now
        pose = beliefs.get(POSE) or stack.world.robot.start
        inference = InferenceGrid(grid, pose[:2], stack.robot_radius, stack.world.sonar.max_range)
        reachable = inference.reachable
        if reachable.sum() < 50:
            return
        p_occ = inference.occupancy  # the grid's probabilities, read once; reachable is made from them already
        p_occ[~grid.updated] = np.nan
        try:
            topology = abstract(p_occ, grid.frame, stack.robot_radius, reachable=reachable).topology
        except ValueError:
            return  # too little map to abstract yet
        facts = topology.facts(stack.world.place_shapes())
        beliefs[TOPOLOGY] = topology
        pairs = {(a, b) for kind, *rest in facts if kind == "connected" for a, b in [rest]}
        pairs = pairs | {(b, a) for a, b in pairs}
        changes = [("retract", _connected(pair)) for pair in sorted(self.connected - pairs)]
        changes += [("assert", _connected(pair)) for pair in sorted(pairs - self.connected)]
        self.connected = pairs
        if changes:
            stack.post(self, changes)
        if stack.primary in ("II", "III"):
            stack.replanned()

    def assess(self, obstacle: Point) -> None:
        """The obstacle blocks a stretch of the route: update the map with what the sonar sees
        now, say which stretch is blocked, and whether there is a way round it on what the
        robot knows (``(way-round A B)``) or none (``(no-route)``)."""
        stack = self.stack
        grid = stack.beliefs.get(GRID)
        monitor = stack.layers.get("I")
        if grid is not None and monitor is not None and not stack.prior_map:
            for (x, y, heading), ranges, angles in monitor.recent:
                grid.update_sonar(float(x), float(y), float(heading), ranges, angles, stack.robot_radius,
                                  stack.world.sonar)
            self._forget_behind(grid, obstacle, monitor.recent)
            stack.grid_version += 1
            self.rebuild(stack.sequencer.now())
        a, b = self.blocked = self._edge_at(obstacle)
        if grid is None or stack.prior_map:  # on a grid built from sonar the obstacle is on the map now
            stack.blocks.append(obstacle)
        stack.post(self, [("assert", _fact("route-blocked", a, b))])
        goal = stack.beliefs.get(GOAL)
        pose = stack.beliefs.get(POSE)
        if goal is None or pose is None:
            return
        closed = stack.beliefs.get(CLOSED_DOORS) or set()
        door = self._door_ahead(obstacle) if stack.prior_map else None
        if door is not None:
            stack.blocked_doors.add(door)
        answer = self.route(goal.place, pose[:2], closed)
        if not isinstance(answer, PlannedRoute) and door is not None:
            stack.blocked_doors.discard(door)  # the only way is past it: keep the route, steer round the obstacle
            answer = self.route(goal.place, pose[:2], closed)
        if isinstance(answer, PlannedRoute):
            self.rerouting = True
            stack.post(self, [("assert", _fact("way-round", a, b))])
        else:
            self.awaiting_way = None if stack.prior_map else goal.place
            stack.post(self, [("assert", _fact("no-route"))])

    def _look_for_a_way(self) -> None:
        """After Layer IV has remapped its way round a block to the goal it was cut from: a
        route on the rebuilt map to where the robot is sent next hands the drive back
        (``(remapped A B)`` for the block's stretch; ``(no-route)`` no longer holds). Until
        the robot is there, the way it is driving is being mapped: Layer IV keeps it."""
        stack = self.stack
        goal, pose = stack.beliefs.get(GOAL), stack.beliefs.get(POSE)
        if goal is None or pose is None or stack.primary != "IV":
            return
        closed = stack.beliefs.get(CLOSED_DOORS) or set()
        if not isinstance(self.route(goal.place, pose[:2], closed), PlannedRoute):
            return
        self.awaiting_way = None
        changes = [("retract", _fact("no-route"))] if stack.holds("no-route") else []
        stack.post(self, changes + [("assert", _fact("remapped", *self.blocked))])

    def _door_ahead(self, obstacle: Point) -> str | None:
        """On the prior map: the next door of the route, if the obstacle is near it (it blocks the way
        in) or on the stretch of the route that leads to it (it blocks the way there)."""
        route = self.stack.beliefs.get(ROUTE)
        if route is None:
            return None
        ahead = [(index, door) for door, index in route.doors.items() if index >= route.index - 1]
        if not ahead:
            return None
        index, door = min(ahead)
        if math.dist(self.stack.world.doors[door].center, obstacle) < DOOR_BLOCK:
            return door
        pose = self.stack.beliefs.get(POSE)
        leg = ([pose[:2]] if pose is not None else []) + list(route.waypoints[max(route.index, 0):index + 1])
        on_the_way = len(leg) >= 2 and distance_to_polyline(np.asarray([obstacle]), np.asarray(leg))[0] < ON_THE_WAY
        return door if on_the_way else None

    def _forget_behind(self, grid, obstacle: Point, rings) -> None:
        """What lies behind an obstacle's face is not known any more: the cells up to
        ``UNSEEN_DEPTH`` beyond the echoes near it, believed free from an older map,
        become unknown (so no route is planned through the obstacle's unseen side)."""
        frame = grid.frame
        depth = np.arange(frame.resolution, UNSEEN_DEPTH, frame.resolution / 2)
        radius = self.stack.robot_radius
        for (x, y, heading), ranges, angles in rings:
            echoes, hit = echo_points(x, y, heading, ranges, angles, radius, self.stack.world.sonar.max_range)
            near = np.hypot(echoes[:, 0] - obstacle[0], echoes[:, 1] - obstacle[1]) < NEAR_OBSTACLE
            if not near.any():
                continue
            direction = (heading + angles[hit])[near]
            along = (ranges[hit][near] + radius)[:, None] + depth[None, :]
            px = x + along * np.cos(direction)[:, None]
            py = y + along * np.sin(direction)[:, None]
            rows, cols = frame.world_to_cell(px.ravel(), py.ravel())
            rows, cols = np.asarray(rows), np.asarray(cols)
            inside = (rows >= 0) & (rows < frame.height) & (cols >= 0) & (cols < frame.width)
            rows, cols = rows[inside], cols[inside]
            free = grid.log_odds[rows, cols] < 0
            grid.log_odds[rows[free], cols[free]] = 0.0
            grid.updated[rows[free], cols[free]] = False

    def _edge_at(self, obstacle: Point) -> tuple[str, str]:
        """The places the blocked stretch of the route joins: where the robot is, and the
        first place the route was to reach past the obstacle."""
        stack = self.stack
        pose = stack.beliefs.get(POSE)
        here = self._place(pose[:2]) if pose is not None else self._place(obstacle)
        route = stack.beliefs.get(ROUTE)
        ahead = route.waypoints[route.index:] if route is not None else ()
        for point in (obstacle, *ahead):
            there = self._place(point)
            if there != here:
                return here, there
        return here, here

    def _place(self, xy: Point) -> str:
        """The name of the place a point is in: on the topology, else the world's nearest place."""
        topology = self.stack.beliefs.get(TOPOLOGY)
        if topology is not None:
            label = topology.place_at(xy)
            if label:
                return topology.place_name(label)
        world = self.stack.world
        named = world.place_at(*xy)
        if named is not None or not world.places:
            return named or "nowhere"
        return min(world.places.values(), key=lambda place: math.dist(place.point, xy)).name

    def route(self, goal: str, start: Point, closed: set[str]) -> PlannedRoute | str:
        return route_on_maps(self.stack, goal, start, closed, self.name)


def _connected(pair: tuple[str, str]) -> Compound:
    return _fact("connected", *pair)


def _fact(functor: str, *args: str) -> Compound:
    return Compound(functor, tuple(args))


"""Layer IV, Strategic: mapping and planning on the occupancy grid (seed Table 1, §3).

The slowest layer. At its period it

- **maps** while memory says ``(mapping on)`` (the rules decide): it fuses
  every sonar ring Layer I logged since its last tick into the
  :data:`~atlas_rap.skills.beliefs.GRID` belief, at the pose the robot
  believed it had (the recursive Bayesian update of
  :meth:`~atlas_rap.maps.grid.OccupancyGrid.update_sonar`); a rules file's
  ``mapping-speed`` (a fraction of top speed) caps the motion skills while it
  maps without a prior map (the shipped rules set none: docs/how-to/layers.md). **The survey**:
  the same rings, those read ``map-update-distance`` metres or
  ``map-update-turn`` radians apart (0.5 and 0.5 unless a rules file says otherwise),
  go into the grid's ``survey`` too, which the map quality is measured on
  and exploring looks at (:mod:`atlas_rap.maps.survey`: a ring read from
  nearly where the last was is not independent evidence). **Contacts**: where the bumper touched
  something (Layer I's log) the grid is marked occupied
  (:meth:`~atlas_rap.maps.grid.OccupancyGrid.mark_contact`), the point
  joins the stack's ``contacts``, which its grid planners keep as obstacles
  even in the disc round the robot they otherwise take as free, and the
  route being driven is planned again: sonar misses a door jamb met
  edge-on (kobuki's ``bumper2pc`` feeds ROS costmaps the same way);
- **measures the map** every ``quality-every`` seconds in a run without a
  prior map: ``(map-quality Q)``, one minus the mean entropy of a region
  of interest on the survey, which the rules compare with their threshold. The region is
  the ``area`` the layer is given when the run has an errand (``RunOptions.errand``,
  the experiment's: :func:`~atlas_rap.maps.errand_area.errand_area`, fixed
  before the first run, so the quality rises only as the map of that area
  firms up); else the explored region and the surroundings of the places the
  robot has been sent to (:func:`~atlas_rap.maps.inference.explored_quality`);
- **plans** when it drives: the cheapest path on the grid with
  ``skimage.graph.MCP`` (:class:`~atlas_rap.maps.gridpath.GridPlanner`),
  unknown cells passable at a cost (optimistic planning) within the
  world's extent (``World.extent``), re-planned as soon as the grid shows
  the path blocked. With no path at all, it tries in turn (each measured
  in docs/how-to/layers.md):
  1. the ways the robot has driven, taken as passable: its believed track
     of this run and the cells its centre passed in the runs that carried
     the grid (``OccupancyGrid.driven``), but near a block and where this
     run's sonar is surer of an obstacle (a sonar map can close a doorway
     behind the robot with the arcs of echoes off its jambs);
  2. once ``(no-route)`` already holds for the goal (navigation.rap's
     ``go-to`` has turned the robot on the spot, ``look-again``), the last
     try: cells occupied with P under ``FAINT_OCCUPIED`` taken as unknown
     (slanting echoes' arcs can close a doorway too far away to see
     through); then, once while no way is said of the goal, the walls it
     remembers but cannot see from where it is, and those within sonar
     reach of the goal (a door drawn shut as the robot passed, a wall
     drawn where a drifting pose put it), doubted. The way leads the robot
     to look, and the sonar decides;

  then ``(no-route)`` and a reason that says so. (When Layer II or III
  has no route on the known map, the stack asserts ``(no-route)`` too, and
  the rules hand the drive to Layer IV, which explores; it holds until the
  robot is sent somewhere else.) When a block Layer III assessed cut every
  known way, Layer IV first remaps: it doubts the walls it remembers within
  sonar range but cannot see from where the robot is
  (:meth:`StrategicLayer._remap`), plans through them and maps what it finds;
- **explores** in the runs after the first, while it maps an errand's
  ``area`` and the map it began the run with is under the rules'
  threshold (``map-quality-threshold``) and has never reached it: on its way to
  each place the robot is sent to, it goes by the
  reachable spot from which the sonar would learn most of the area the survey
  is still unsure of (:func:`~atlas_rap.maps.viewpoints.best_viewpoint`),
  chosen once per place and forgotten once passed. The first run (no map
  yet: the grid it began with had no cell seen) only finds the way; once
  the robot has a map that is still poor, the runs after it look where it
  is poor, so a map cannot stall under the threshold because the errand
  always takes the same way (seed §5.2: in the initial runs the robot "had
  to explore its surroundings while trying to find a path to the goal").
  ``(layer-setting explore 0)`` turns it off; with ``(layer-setting
  explore-when-stalled 1)`` a run explores only once the errand's way taken
  again has stopped paying (the run before added less than the hysteresis
  to the quality) while the map has never reached the threshold
  (:mod:`atlas_rap.layers.exploring`). A viewpoint the robot has come no
  nearer to for 30 s is given up (explore_lite's ``progress_timeout``).

The grid can be carried from run to run (``atlas run --map-in/--map-out``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from atlas_rap.layers.exploring import GIVEN_UP, ViewpointWatch, explores_this_run
from atlas_rap.layers.layer import Layer, LayerStack
from atlas_rap.layers.route_geometry import distance_to_polyline, echo_points
from atlas_rap.logic import Compound, Var
from atlas_rap.maps.survey import SURVEY_SPACING, RingSpacing
from atlas_rap.model import Point
from atlas_rap.skills.beliefs import GOAL, GRID, POSE, POSE_TRACK, POSES, SONAR, SPEED_LIMIT, PlannedRoute

if TYPE_CHECKING:
    from atlas_rap.maps.gridpath import GridPath, GridPlanner


class StrategicLayer(Layer):
    """Layer IV; see the module docstring. ``grid`` is a map to start from (``--map-in``); ``area``
    a fixed region (a mask on the grid) to measure the map's quality over."""

    name = "IV"
    plans = True
    period = 0.5  # the slowest layer (seed Fig. 2): above Layer III's 0.25 s

    def __init__(self, stack: LayerStack, grid=None, area: np.ndarray | None = None) -> None:
        from atlas_rap.maps.grid import OccupancyGrid

        super().__init__(stack)
        world = stack.world
        grid = stack.beliefs[GRID] = grid if grid is not None else OccupancyGrid.covering(world.bounds, GRID_RESOLUTION)
        self.area = area
        self.map_carried = bool(grid.updated.any())  # a map from an earlier run (--map-in)
        if grid.survey is None:  # a grid file without one (the levels' grid.npz, an older one) is its own
            grid.survey = OccupancyGrid(grid.frame, grid.model)
            grid.survey.log_odds, grid.survey.updated[...] = grid.log_odds.copy(), grid.updated
        if area is not None and area.shape != stack.beliefs[GRID].frame.shape:
            raise ValueError(f"the area is {area.shape} cells, the grid {stack.beliefs[GRID].frame.shape}")
        stack.beliefs.setdefault(POSES, [])

    def start(self) -> None:
        stack, world = self.stack, self.stack.world
        self.sonar = world.sonar
        self.quality_at = -math.inf
        self.goals: list[Point] = []  # where the robot has been sent: part of the region the quality is of
        self.no_route_goal: str | None = None  # the goal (no-route) was said of
        self.doubted_for: str | None = None  # the goal the last try has doubted the unseen walls for
        self.path = None
        self.path_goal: str | None = None
        self.path_version = -1
        self._last_ranges = None
        self._marked: Point | None = None  # where the last footprint was marked free
        self._carried = stack.beliefs[GRID].log_odds.copy()  # the map as this run found it (_along_driven_ways)
        self.spacing = RingSpacing(stack.setting("map-update-distance", SURVEY_SPACING),
                                   stack.setting("map-update-turn", SURVEY_SPACING))
        self.viewpoint: Point | None = None  # where the robot looks on its way (_viewpoint)
        self.viewpoint_goal: str | None = None  # the goal it was chosen for
        self.looked_from: list[Point] = []  # the viewpoints of this run so far
        self.watch = ViewpointWatch()  # the robot's way to the viewpoint (_watch_viewpoint)
        self.explores = False  # whether this run looks where the map is unsure (_explores)
        if stack.prior_map:
            stack.assert_fact(self, "mapping", "on")
        else:
            self.quality_at = 0.0
            quality = self._measure()
            qualities = stack.beliefs[GRID].run_qualities  # what the runs that carried the grid began with
            earlier = list(qualities)
            qualities.append(quality)
            self.explores = self._explores(quality, earlier)
        stack.logging_rings = stack.holds("mapping", "on")

    def tick(self, now: float) -> None:
        stack, beliefs = self.stack, self.stack.beliefs
        mapping = stack.holds("mapping", "on")
        stack.logging_rings = mapping
        rings = self._rings()
        echoes: list[np.ndarray] = []
        if mapping and rings:
            grid, poses = beliefs[GRID], beliefs[POSES]
            driving = stack.driver == self.name
            for (x, y, heading), ranges, angles in rings:  # one by one: each ring's arcs see the rings before
                pose = (float(x), float(y), float(heading))
                for fused in (grid, grid.survey) if self.spacing.counts(pose) else (grid,):
                    fused.update_sonar(*pose, ranges, angles, stack.robot_radius, self.sonar)
                if self._marked is None or math.dist(self._marked, pose[:2]) >= FOOTPRINT_SPACING:
                    for marked in (grid, grid.survey):  # where the robot stands is free in both
                        marked.mark_free(pose[0], pose[1], stack.robot_radius)
                    grid.mark_driven(pose[0], pose[1], DRIVEN_RADIUS)
                    self._marked = pose[:2]
                poses.append(pose)
                if driving:
                    echoes.append(echo_points(x, y, heading, ranges, angles, stack.robot_radius,
                                              self.sonar.max_range)[0])
            stack.grid_version += 1
        contacts = self._contacts()
        if mapping and contacts:
            for x, y in contacts:
                for marked in (beliefs[GRID], beliefs[GRID].survey):  # touched: occupied in both
                    marked.mark_contact(x, y)
                stack.contacts.append((x, y))
            stack.grid_version += 1
            if stack.driver == self.name:
                stack.replanned()
        cap = stack.setting("mapping-speed", 1.0)
        if mapping and not stack.prior_map and cap < 1.0:
            beliefs[SPEED_LIMIT] = cap
        else:
            beliefs.pop(SPEED_LIMIT)
        if not stack.prior_map and now - self.quality_at >= stack.setting("quality-every", 2.0):
            self.quality_at = now
            self._measure()
        if stack.driver == self.name and echoes:
            self._watch_path(np.concatenate(echoes))
        self._watch_viewpoint(now)

    def _watch_viewpoint(self, now: float) -> None:
        """Forget the viewpoint once the robot has passed it (a re-plan then goes straight to the
        goal), or given it up (re-planned at once): :class:`~atlas_rap.layers.exploring.ViewpointWatch`."""
        pose = self.stack.beliefs.get(POSE)
        if self.viewpoint is None or pose is None:
            return
        done = self.watch.follow(self.viewpoint, pose[:2], now)
        if done is not None:
            self.viewpoint = None
            if done == GIVEN_UP:
                self.stack.replanned()

    def _monitor(self):
        """Layer I, whose logs of rings and contacts this layer drains; None when it is not running."""
        monitor = self.stack.layers.get("I")
        return monitor if monitor is not None and "I" in self.stack.enabled else None

    def _contacts(self) -> list[tuple[float, float]]:
        """Where the bumper touched something since the last tick (Layer I's log)."""
        monitor = self._monitor()
        return monitor.drain_contacts() if monitor is not None else []

    def _rings(self):
        """The rings to fuse: Layer I's log, or the latest ring when Layer I is not running."""
        monitor = self._monitor()
        if monitor is not None:
            return monitor.drain()
        reading, pose = self.stack.beliefs.get(SONAR), self.stack.beliefs.get(POSE)
        if reading is None or pose is None or reading[0] is self._last_ranges:
            return []
        self._last_ranges = reading[0]
        return [(pose, *reading)]

    def quality(self) -> float:
        """The map quality as the rules see it (three decimals): 1 - mean entropy of the survey over
        the area given, else over the explored region and round the places the robot has been sent to."""
        from atlas_rap.maps.inference import explored_quality

        if self.area is not None:
            return round(self.stack.beliefs[GRID].survey.quality(self.area), 3)
        goal = self.stack.beliefs.get(GOAL)
        if goal is not None and goal.point not in self.goals:
            self.goals.append(goal.point)
        return round(explored_quality(self.stack.beliefs[GRID].survey, goals=self.goals), 3)

    def _measure(self) -> float:
        """Tell memory the map quality, ``(map-quality Q)``; return Q."""
        quality = self.quality()
        self.stack.assert_fact(self, "map-quality", quality)
        return quality

    def _watch_path(self, echoes: np.ndarray) -> None:
        """Re-plan when the grid shows the path blocked: an echo within the robot's reach of
        the path, from a cell the grid now believes occupied. Only the echoes of the rings
        just fused can have changed that, so nothing else is looked at."""
        stack = self.stack
        goal = stack.beliefs.get(GOAL)
        if goal is None or self.path is None or self.path_goal != goal.place or not len(echoes):
            return
        near = echoes[distance_to_polyline(echoes, np.asarray(self.path.waypoints)) < stack.robot_radius + NEAR_PATH]
        if not len(near):
            return
        grid = stack.beliefs[GRID]
        rows, cols = grid.frame.world_to_cell(near[:, 0], near[:, 1])
        rows, cols = np.asarray(rows), np.asarray(cols)
        inside = (rows >= 0) & (rows < grid.frame.height) & (cols >= 0) & (cols < grid.frame.width)
        if (grid.log_odds[rows[inside], cols[inside]] > OCCUPIED_LOG_ODDS).any():
            stack.replanned()

    def route(self, goal: str, start: Point, closed: set[str]) -> PlannedRoute | str:
        """The cheapest path on the grid, the unknown passable at a cost. ``(no-route)`` holds
        while there is none, and is forgotten when the robot is sent somewhere else."""
        stack = self.stack
        if stack.holds("no-route"):
            current = stack.beliefs.get(GOAL)
            if self.no_route_goal is None:
                self.no_route_goal = current.place if current is not None else goal
                self._remap()
            elif goal != self.no_route_goal:  # sent somewhere else: the way there is not known to be cut
                stack.post(self, [("retract", Compound("no-route", ()))])
                self.no_route_goal = self.doubted_for = None
        self.path_goal, self.path_version = goal, stack.grid_version
        planner = stack.grid_planner(unknown_passable=True)
        target = stack.world.places[goal].point
        via = self._viewpoint(goal, start, planner)
        self.path = planner.plan(start, target) if via is None else self._via(planner, start, via, target)
        if self.path is None:
            self.path = self._along_driven_ways(start, target)
        last_try = self.no_route_goal == goal  # (no-route) already holds for this goal
        if self.path is None and last_try:
            self.path = self._along_driven_ways(start, target, faint_below=FAINT_OCCUPIED)
            if self.path is None and self.doubted_for != goal:
                # once while no way is said of this goal: where every way is cut, the robot gives up
                unseen = self._doubt_unseen_walls()
                if self._doubt_walls_round(target) or unseen:
                    self.doubted_for = goal
                    # not along the driven ways: a doubted cell behind a wall seen now would free the
                    # driven planning cell it shares with that wall
                    self.path = stack.grid_planner(unknown_passable=True,
                                                   faint_below=FAINT_OCCUPIED).plan(start, target)
        if self.path is None:
            stack.assert_fact(self, "no-route")
            return (f"no way to {goal} on the occupancy grid, not even through its unknown part"
                    f"{' nor where it is only faintly occupied' if last_try else ''}: every way is blocked")
        return PlannedRoute(self.path.waypoints, {}, self.name)

    def _along_driven_ways(self, start: Point, target: Point, faint_below: float | None = None) -> GridPath | None:
        """No way at all, not even through the unknown; yet the robot got where it is, so a way it
        has driven may be the way on (module docstring, "plans"): the cheapest path with the
        robot's believed track of this run passable, and the grid's driven cells but those this
        run's sonar has made surer are occupied (a wall seen now is not the map's old mistake)
        (:meth:`LayerStack.grid_planner`'s ``track`` and ``driven``). With ``faint_below``, the
        last try: the cells the grid holds occupied with P under it count as unknown too. None
        when there is still none."""
        points: list[Point] = []
        for _, x, y, _ in self.stack.beliefs.get(POSE_TRACK) or ():
            if not points or math.dist(points[-1], (x, y)) >= FOOTPRINT_SPACING:
                points.append((float(x), float(y)))
        grid = self.stack.beliefs[GRID]
        driven = grid.driven & (grid.log_odds <= self._carried)  # this run's echoes overrule the memory
        if not points and not driven.any() and faint_below is None:
            return None
        planner = self.stack.grid_planner(unknown_passable=True, track=points, driven=driven,
                                          faint_below=faint_below)
        return planner.plan(start, target)

    def _explores(self, quality: float, earlier: list[float]) -> bool:
        """Whether this run explores (module docstring, "explores"): ``explore`` is not 0, the layer
        has an errand's area, the run began on a map carried from an earlier run, and
        :func:`explores_this_run` says so of the ``quality`` it began with and those the ``earlier``
        runs began with (the rules' threshold, hysteresis and ``explore-when-stalled``)."""
        stack = self.stack
        if self.area is None or not self.map_carried or stack.setting("explore", 1.0) <= 0.0:
            return False
        return explores_this_run(quality, earlier, stack.setting("map-quality-threshold", 0.9),
                                 stack.setting("map-quality-hysteresis", 0.02),
                                 when_stalled=stack.setting("explore-when-stalled", 0.0) > 0.0)

    def _viewpoint(self, goal: str, start: Point, planner: GridPlanner) -> Point | None:
        """Where to look on the way to ``goal`` (module docstring, "explores"): chosen once per
        goal the robot is sent to, kept until the robot has passed it; None when the layer has no
        area, is not mapping, is finding a way round a block, or does not explore this run."""
        from atlas_rap.maps.viewpoints import best_viewpoint

        stack = self.stack
        if (not self.explores or not stack.holds("mapping", "on") or stack.holds("no-route")
                or self.no_route_goal is not None):
            self.viewpoint = None
            return None
        if goal != self.viewpoint_goal:
            self.viewpoint_goal = goal
            found = best_viewpoint(stack.beliefs[GRID].survey, self.area, planner, start, looked_from=self.looked_from)
            self.viewpoint = found[0] if found is not None else None
            if self.viewpoint is not None:
                self.looked_from.append(self.viewpoint)
        return self.viewpoint

    def _via(self, planner: GridPlanner, start: Point, via: Point, target: Point) -> GridPath | None:
        """The path from ``start`` to ``target`` by way of ``via``; the straight one when
        ``via`` cannot be reached or left."""
        from atlas_rap.maps.gridpath import GridPath

        there, on = planner.plan(start, via), planner.plan(via, target)
        if there is None or on is None:
            self.viewpoint = None
            return planner.plan(start, target)
        length = there.length + on.length
        share = (there.unknown_share * there.length + on.unknown_share * on.length) / length if length > 0 else 0.0
        return GridPath(there.waypoints + on.waypoints[1:], length, share)

    def _remap(self) -> None:
        """Every known way cut by a block Layer III assessed (``(route-blocked A B)``): the map is out
        of date round here (seed §5.2: Layer IV "rebuild[s] a new OG map"). The walls it remembers
        within sonar range that the robot cannot see from where it is become doubtful
        (:func:`~atlas_rap.maps.inference.doubt_unseen_walls`): the planner tries the ways they may
        leave, and the sonar decides as the robot goes (Layer IV maps)."""
        blocked = Compound("route-blocked", (Var("a"), Var("b")))
        if next(self.stack.sequencer.memory.facts(blocked), None) is not None:
            self._doubt_unseen_walls()

    def _doubt_unseen_walls(self) -> bool:
        """The walls the grid remembers within sonar range that the robot cannot see from where it
        is become doubtful (:func:`~atlas_rap.maps.inference.doubt_unseen_walls`); whether any did
        (none with a prior map, which is not Layer IV's to doubt, nor without a pose)."""
        from atlas_rap.maps.inference import doubt_unseen_walls

        stack = self.stack
        pose = stack.beliefs.get(POSE)
        if stack.prior_map or pose is None:
            return False
        if not doubt_unseen_walls(stack.beliefs[GRID], pose[:2], stack.robot_radius, self.sonar.max_range):
            return False
        stack.grid_version += 1
        return True

    def _doubt_walls_round(self, goal: Point) -> bool:
        """The walls the grid remembers within sonar range of ``goal`` become doubtful
        (:meth:`~atlas_rap.maps.grid.OccupancyGrid.doubt_walls`; the last try, module docstring);
        whether any did (none with a prior map, which is not Layer IV's to doubt)."""
        stack = self.stack
        if stack.prior_map:
            return False
        reach = stack.robot_radius + self.sonar.max_range
        if not stack.beliefs[GRID].doubt_walls(float(goal[0]), float(goal[1]), reach):
            return False
        stack.grid_version += 1
        return True


GRID_RESOLUTION = 0.05
"""Metres per cell of the grid Layer IV builds when it starts from none."""

OCCUPIED_LOG_ODDS = math.log(0.6 / 0.4)
"""An echo's cell above P(occ) = 0.6 (the planner's obstacle level) blocks the path it is near."""

FAINT_OCCUPIED = 0.9
"""P(occ) under which Layer IV's last try for a way counts a cell the grid holds occupied as unknown
(log-odds 2.2: a wall met head-on goes past it in a few rings). Not a test of what is a wall (about 8
in 10 cells on either side of it lie on a true wall); the last try only lets the robot go and look."""

FOOTPRINT_SPACING = 0.1
"""Metres the robot moves between the footprints it marks free (the disc under it)."""

DRIVEN_RADIUS = FOOTPRINT_SPACING
"""Metres round each footprint's centre that Layer IV marks driven: as far as the next footprint, so
the marks of a way driven join up."""


NEAR_PATH = 0.15
"""Metres beyond the robot's radius from the path within which an echo may block it."""


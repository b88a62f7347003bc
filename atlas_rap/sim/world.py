"""World files: YAML that describes a world for the simulator, read into a :class:`World`.

``load_world("maze")`` reads the shipped ``worlds/maze.yaml``;
``load_world("my/world.yaml")`` reads that file. Every key is optional.
Distances are metres, times seconds; **angles are degrees in the file**
(keys ending in ``_deg``, and the heading in ``robot.start``) and radians in
the model. An example with every key::

    name: lab-corridor-office          # default: the file's name
    description: free text
    walls:                             # segments [x1, y1, x2, y2], or polylines [[x, y], [x, y], ...]
      - [0, 4, 6, 4]
      - [[8, 6], [8, 10], [13, 10]]
    polygons:                          # closed outlines (the last point joins the first)
      - [[0, 0], [8, 0], [8, 4], [0, 4]]
    map: maps/small-office-map.yaml    # a ROS map_server map, relative to this file:
                                       # its occupied cells become walls (atlas_rap.maps.rosmap)
    places:                            # where RAPs can send the robot
      lab: {point: [4, 2], region: [[0, 0], [8, 0], [8, 4], [0, 4]]}
      corner: {point: [1, 1], radius: 0.5}     # a point place (radius default 0.5)
    doors:
      lab-door:
        between: [lab, corridor]       # two places
        segment: [6, 4, 7, 4]          # the leaf across the doorway when closed; omit for an opening
        center: [6.5, 4]               # default: the segment's midpoint (required for an opening)
        open: true                     # at the start (default true)
        openable: false                # can the robot open it (default false)
        schedule: [[30, closed], [90, open]]   # [time, open|closed] changes
    disturbances:
      - {name: visitor, kind: person, start: 10, end: 30, path: [[12, 5.6], [12, 4.4]], size: 0.45, speed: 0.5}
      - {name: crate, kind: box, start: 0, path: [[1.5, 5]], size: 0.6}    # no end: for ever
    objects:                           # coloured things the colour camera sees (atlas_rap.sim.objects)
      red-ball: {colour: red, at: [10.8, 4.6]}                 # kind: object (default), size: 0.25 m
      can-1: {colour: yellow, kind: trash, at: [5.5, 1.0]}     # trash the gripper can pick up
      bin-1: {colour: green, kind: bin, at: [7.3, 0.7], size: 0.4}   # a bin to drop trash into
      blue-box:
        colour: blue
        at: [9, 9.3]
        moves: [{near: 2.0, to: [19, 9]}, {at: 120, to: [9, 9.3]}]   # when the robot comes near / at a time
    robot:
      start: [1.5, 1.5, 0]             # [x, y, heading_deg]
      radius: 0.2
      max_speed: 0.6
      max_turn_rate_deg: 115
      odometry_noise: {alpha1: 0.02, alpha2: 0.005, alpha3: 0.02, alpha4: 0.005}   # the default; see below
      teleports: [{at: 40, to: [4, 2, 90]}]     # kidnaps: at a time, to [x, y, heading_deg] in free space
    sonar: {count: 16, beam_width_deg: 15, max_range: 5, min_range: 0.05, range_noise: 0.01,
            range_noise_per_m: 0.01, specular_angle_deg: 60, specular_dropout: 0.8, rays_per_beam: 3, rate: 10}

The odometry errs as :class:`~atlas_rap.model.OdometryNoise` says, with
AMCL's ``alpha1``-``alpha4`` (rotation from rotation, rotation from
translation, translation from translation, translation from rotation: the
standard deviations after 1 rad turned or 1 m travelled). Without either
key the noise is :data:`~atlas_rap.model.DEFAULT_ODOMETRY_NOISE`, on.
``odometry_noise: {alpha3: 0.05}`` gives some alphas (the others are 0);
``odometry_noise: off`` makes the odometry the true pose (``on`` is the default);
``odometry_drift: d`` is the older shorthand for ``{alpha1: d, alpha3: d}``
(``odometry_drift: 0`` is off). Give one of the two keys, not both. A
teleport moves the robot without telling its odometry (the kidnapped robot:
:meth:`~atlas_rap.sim.physics.Simulation.teleport`); it waits while a box,
a person or a closed door leaf is where the robot would land.

A *variant* of a world changes only its doors, its disturbances, its
objects and its robot's odometry noise and teleports (a ``disturbances``,
``objects`` or ``robot.teleports`` list replaces the base's), and may cut
openings in the base's walls and add walls of its own::

    base: lab-corridor-office          # a shipped world, or a path relative to this file
    name: lab-corridor-office-door-closed
    doors:
      office-door: {open: false}       # open, openable, schedule may be changed
    robot: {odometry_noise: off}       # odometry_noise, odometry_drift, teleports may be changed
    openings:                          # gaps cut in the base's walls: [x1, y1, x2, y2] along a wall
      - [8, 1.5, 8, 2.5]
    walls:                             # walls added to the base's (as ``walls`` above)
      - [[8, 0], [13, 0], [13, 4]]

An opening must lie along at least one of the base's walls (within
:data:`OPENING_TOLERANCE`); every wall it lies along loses the stretch it
covers. The added walls must keep clear of the place points, the robot's
start and its teleport targets, as the base's walls must.

What is checked, with every problem reported at its key's file:line:column:
unknown keys (with the nearest known key as a hint), wrong types and
shapes, doors between places that do not exist, a place point outside its
region or closer than the robot's radius + 0.15 m to a wall, a robot that
starts inside a wall (closer than its radius to a segment, or inside a
polygon that no place is in) or, with a ``map:``, on a cell of the image that
is not free (occupied, unknown, or off the image), a schedule out of time
order, duplicate names; objects: a colour and a name RAPs can use, a kind
(object, trash, bin), a position and moves in free space (at least half the
object's size from walls, outside solid polygons), each move with one of
``at`` (times in order) and ``near``, names that no place or door has;
odometry alphas from 0 to :data:`MAX_ALPHA`; teleports in time order, each to
free space (checked as the start is). A bad start (or teleport target) is
reported at ``robot.start`` (``robot.teleports[i].to``) with the nearest
point where the robot would fit; a variant reports its base's problems,
then the ``base:`` line.

``bounds`` is the box around the walls, the places and the robot's start
and teleport targets, with a margin of :data:`BOUNDS_MARGIN`. Without
``robot.start`` the robot starts at the first place's point, facing east.

Over 25 KB on purpose: the world file format: its reader, its checks and their located
messages, which must agree field by field.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from itertools import pairwise
from pathlib import Path

import numpy as np
from yaml.nodes import MappingNode, Node, ScalarNode

from atlas_rap.errors import AtlasError, SourceError, WorldError, WorldFileError, did_you_mean
from atlas_rap.maps.rosmap import FREE, OCCUPIED, UNKNOWN, RosMap, load_ros_map, wall_segments
from atlas_rap.yamlsource import YamlSource
from atlas_rap.plugins import named_files
from atlas_rap.shipped import resolve_user_path, shipped_root, shipped_worlds
from atlas_rap.model import (
    DEFAULT_ODOMETRY_NOISE,
    NO_ODOMETRY_NOISE,
    OBJECT_KINDS,
    Disturbance,
    Door,
    ObjectMove,
    OdometryNoise,
    Place,
    Point,
    RobotConfig,
    Segment,
    SonarConfig,
    Teleport,
    World,
    WorldObject,
    _inside,
)

TOP_KEYS = ("name", "description", "walls", "polygons", "map", "places", "doors", "disturbances", "objects",
            "robot", "sonar")
VARIANT_KEYS = ("name", "description", "base", "doors", "disturbances", "objects", "robot", "openings", "walls")
VARIANT_DOOR_KEYS = ("open", "openable", "schedule")
VARIANT_ROBOT_KEYS = ("odometry_noise", "odometry_drift", "teleports")
PLACE_KEYS = ("point", "region", "radius")
DOOR_KEYS = ("between", "center", "segment", "open", "openable", "schedule")
DISTURBANCE_KEYS = ("name", "kind", "start", "end", "path", "size", "speed")
ROBOT_KEYS = ("start", "radius", "max_speed", "max_turn_rate_deg", "odometry_noise", "odometry_drift", "teleports")
ALPHA_KEYS = ("alpha1", "alpha2", "alpha3", "alpha4")
TELEPORT_KEYS = ("at", "to")
MAX_ALPHA = 1.0
"""The largest odometry alpha (or ``odometry_drift``) a world may give: 1 m of error per metre driven."""
SONAR_KEYS = ("count", "beam_width_deg", "max_range", "min_range", "range_noise", "range_noise_per_m",
              "specular_angle_deg", "specular_dropout", "rays_per_beam", "rate")
DISTURBANCE_KINDS = ("person", "box")
MAX_TRANSDUCERS = 360
"""The most sonar transducers a world may give its robot (``sonar.count``): one a degree."""
MAX_RAYS_PER_BEAM = 64
"""The most rays a beam is sampled with (``sonar.rays_per_beam``): each costs a ray cast per reading."""
OBJECT_KEYS = ("colour", "kind", "at", "size", "moves")
MOVE_KEYS = ("at", "near", "to")
WALL_CLEARANCE_MARGIN = 0.15  # a place point must be this much more than the robot's radius from walls
FREE_POINT_SEARCH = 5.0  # metres around a bad start searched for a free point to suggest (worlds without a map)
FREE_POINT_STEP = 0.05
BOUNDS_MARGIN = 1.0
"""Metres the bounds reach beyond the walls, the places and the robot's start (``World.margin``)."""
OPENING_TOLERANCE = 1e-6
"""Metres from a wall's line within which an opening's ends lie along the wall."""
NAME_PATTERN = re.compile(r"[a-z][a-z0-9_-]*\Z")


def world_path(name_or_path: str | Path) -> Path:
    """The file a world name or path means: a bare name is a shipped world, else a plugin's world
    (:mod:`atlas_rap.plugins`, the ``atlas_rap.worlds`` entry points and ``--plugin`` files), else a file
    of that name here; anything else a path.

    An unknown bare name raises :class:`WorldError` listing the shipped worlds and the plugins'.
    """
    text = str(name_or_path)
    given = Path(text)
    if given.is_dir():
        raise WorldError(f"{text}: is a directory, not a world file; give a world's .yaml file or a shipped "
                         f"world's name")
    if given.suffix or len(given.parts) != 1:
        return resolve_user_path(given)
    root = shipped_root("worlds")
    candidate = root / f"{text}.yaml" if root is not None else None
    if candidate is not None and candidate.is_file():
        return candidate
    plugin_worlds = named_files("worlds")
    for name, (_, contribution) in plugin_worlds.items():
        if name in shipped_worlds():
            raise WorldError(f"{contribution.plugin}: world '{name}' has the name of a shipped world; rename it")
    if text in plugin_worlds:
        return plugin_worlds[text][0]
    if given.is_file():
        return given
    names = shipped_worlds()

    near = did_you_mean(text.lower(), [*names, *plugin_worlds])  # shipped names are lower-case: MAZE means maze
    message = f"no shipped world named '{text}'"
    message += f"; {near}" if near else ""
    message += f"\n  shipped worlds: {', '.join(names) if names else '(none found)'}"
    if plugin_worlds:
        message += f"\n  plugins' worlds: {', '.join(sorted(plugin_worlds))}"
    message += "\n  or give the path of a world file, e.g. my-world.yaml"
    raise WorldError(message)


def load_world(name_or_path: str | Path) -> World:
    """Read a world: a shipped or a plugin's one by name (``maze``) or a YAML file by path.

    Raises :class:`WorldFileError` with every problem found in the file (and in
    the ROS map it names), or :class:`WorldError` for an unknown name.
    """
    path = world_path(name_or_path)
    return _WorldReader(YamlSource.read(path, _shown(path), "world file", WorldFileError), path).read()


def _shown(path: Path) -> str:
    """How a world file is named in messages: ``worlds/NAME.yaml`` for a shipped one, else its path."""
    root = shipped_root("worlds")
    if root is not None and path.resolve().parent == root.resolve():
        return f"worlds/{path.name}"
    return str(path)


class _WorldReader:
    """Reads one world file's nodes into a World, collecting problems in its YamlSource."""

    def __init__(self, src: YamlSource, path: Path) -> None:
        self.src = src
        self.path = path
        self.wall_nodes: list[tuple[Segment, Node]] = []
        self.start_node: Node | None = None
        self.start_unreadable = False  # robot.start has problems of its own: do not check where it is
        self.teleport_nodes: list[tuple[str, Node]] = []  # each teleport's key path and ``to`` node, in order
        self.polygons: list[tuple[tuple[Point, ...], str, Node]] = []  # (points, key path, node)
        self.rosmap: RosMap | None = None
        self.map_name = ""
        self.declared_places: set[str] = set()

    def read(self) -> World:
        src = self.src
        if isinstance(src.root, MappingNode) and any(getattr(k, "value", None) == "base" for k, _ in src.root.value):
            return self.variant()
        top = src.keys(src.root, "", TOP_KEYS, what=" (a world file)")
        if top is None:
            src.check()
        assert top is not None
        node = {key: value for key, (_, value) in top.items()}
        name = self.path.stem
        if "name" in node:
            name = src.string(node["name"], "name") or name
        if "description" in node:
            src.string(node["description"], "description")
        walls = self.walls(node.get("walls"), node.get("polygons"))
        map_walls = self.map_walls(node["map"]) if "map" in node else []
        sonar = self.sonar(node["sonar"]) if "sonar" in node else SonarConfig()
        places, place_nodes = self.places(node["places"]) if "places" in node else ({}, {})
        self.declared_places = set(place_nodes) | self._place_keys(node.get("places"))
        robot = self.robot(node.get("robot"), places)
        doors = self.doors(node["doors"], places) if "doors" in node else {}
        disturbances = self.disturbances(node["disturbances"]) if "disturbances" in node else ()
        all_walls = tuple(walls) + tuple(map_walls)
        objects = self.objects(node["objects"], places, doors, all_walls) if "objects" in node else {}
        self.check_clearances(all_walls, places, place_nodes, robot)
        src.check()
        return World(name, all_walls, places, doors, disturbances, robot, sonar,
                     _bounds(all_walls, places, robot), src.file, objects, BOUNDS_MARGIN)

    def variant(self) -> World:
        """A world file with ``base: WORLD``: that world with its doors changed (open, openable,
        schedule) and, if given, other disturbances (the list replaces the base's)."""
        src = self.src
        top = src.keys(src.root, "", VARIANT_KEYS,
                       what=" (a world variant: base, name, description, doors, disturbances, objects, robot, "
                                 "openings, walls)")
        src.check()
        assert top is not None
        base_node = top["base"][1]
        base_name = src.string(base_node, "base") or ""
        src.check()
        target = base_name if not _looks_like_path(base_name) else str(self.path.parent / base_name)
        if Path(target).resolve() == self.path.resolve():
            src.error(base_node, "a world cannot be its own base")
            src.check()
        world = self._base_world(base_node, base_name, target)
        robot = self.variant_robot(top["robot"][1], world) if "robot" in top else world.robot
        doors = dict(world.doors)
        entries = src.keys(top["doors"][1], "doors", None) if "doors" in top and _given(top["doors"][1]) else {}
        for name, (key, value) in (entries or {}).items():
            path = f"doors.{name}"
            if name not in doors:
                src.error(key, f"the base world {world.name} has no door '{name}'",
                          did_you_mean(name, doors) or "the doors are: " + ", ".join(doors))
                continue
            fields = src.keys(value, path, VARIANT_DOOR_KEYS, what=" such as {open: false}")
            if not fields:
                continue
            door = doors[name]
            changes: dict = {}
            if "open" in fields:
                changes["open"] = src.boolean(fields["open"][1], f"{path}.open")
            if "openable" in fields:
                changes["openable"] = src.boolean(fields["openable"][1], f"{path}.openable")
            if "schedule" in fields:
                changes["schedule"] = self._schedule(fields["schedule"][1], f"{path}.schedule")
            if door.segment is None and changes:
                src.error(key, f"door '{name}' is an opening: it has no leaf to close")
                continue
            if all(v is not None for v in changes.values()):
                doors[name] = replace(door, **changes)
        walls = world.walls
        if "openings" in top or "walls" in top:
            walls = self.variant_walls(top, world)
        disturbances = self.disturbances(top["disturbances"][1]) if "disturbances" in top else world.disturbances
        objects = self.objects(top["objects"][1], world.places, doors, walls) \
            if "objects" in top else world.objects
        name = src.string(top["name"][1], "name") if "name" in top else self.path.stem
        src.check()
        return replace(world, name=name or self.path.stem, walls=walls, doors=doors, disturbances=disturbances,
                       objects=objects, robot=robot, bounds=_bounds(walls, world.places, robot), source=src.file)

    def variant_walls(self, top: dict[str, tuple[Node, Node]], world: World) -> tuple[Segment, ...]:
        """The base's walls with the variant's ``openings`` cut out and its ``walls`` added; the
        added walls checked against the places, the start and the teleports (problems reported
        at this file's keys)."""
        src = self.src
        walls = list(world.walls)
        node = top["openings"][1] if "openings" in top else None
        for i, item in enumerate(src.items(node, "openings", "each opening is [x1, y1, x2, y2] along a wall") or []
                                 if _given(node) else []):
            values = src.numbers(item, f"openings[{i}]", (4,), "[x1, y1, x2, y2]")
            if values is None:
                continue
            opening = Segment((values[0], values[1]), (values[2], values[3]))
            if opening.length == 0:
                src.error(item, "this opening has no length (its ends are the same point)")
                continue
            cut = [piece for wall in walls for piece in _cut(wall, opening)]
            if len(cut) == len(walls) and all(a == b for a, b in zip(cut, walls)):
                src.error(item, f"the opening {_segment_text(opening)} lies along no wall of {world.name}",
                          "give the two ends of the gap on a wall's line")
                continue
            walls = cut
        self.wall_nodes = []
        added = self.walls(top["walls"][1], None) if "walls" in top else []
        walls = tuple(walls) + tuple(added)
        robot = world.robot
        need = robot.radius + WALL_CLEARANCE_MARGIN
        points = [(f"the point of place '{name}'", place.point, need) for name, place in world.places.items()]
        points += [("the robot's start", robot.start[:2], robot.radius)]
        points += [(f"robot.teleports[{i}].to", t.to[:2], robot.radius) for i, t in enumerate(robot.teleports)]
        for segment, wall_node in self.wall_nodes:  # an opening only makes room: the added walls are checked
            for what, point, room in points:
                gap = nearest_wall([segment], point)[0]
                if gap < room:
                    src.error(wall_node, f"this wall passes {gap:.2f} m from {what}; the robot needs {room:.2f} m")
        return walls

    def _base_world(self, node: Node, name: str, target: str) -> World:
        """The world a variant is based on, read and checked as any world; its problems are raised located."""
        src = self.src
        if _looks_like_path(name) and not Path(target).is_file():
            src.error(node, f"base world file '{name}' not found",
                      f"looked for {target}; the path is relative to this file")
            src.check()
        try:
            path = world_path(target)
            base = _WorldReader(YamlSource.read(path, _shown(path), "world file", WorldFileError), path)
            world = base.read()
        except SourceError as error:
            src.problems += error.problems
            src.error(node, f"the base world '{name}' has problems (above)")
        except AtlasError as error:  # an unknown shipped world's name
            first, *rest = str(error).split("\n")
            src.error(node, first, "; ".join(line.strip() for line in rest) or None)
        else:  # where the base's robot may be: for the teleports a variant gives
            self.rosmap, self.map_name = base.rosmap, base.map_name
            self.polygons = [(points, f"{where} of {base.src.file}", n) for points, where, n in base.polygons]
            return world
        raise WorldFileError(src.problems)  # the base's problems, then this file's base: line

    def variant_robot(self, node: Node, world: World) -> RobotConfig:
        """A variant's ``robot:``: the base's robot with other odometry noise or teleports
        (:data:`VARIANT_ROBOT_KEYS`; its other keys belong to the base world)."""
        src, robot = self.src, world.robot
        if not _given(node):
            return robot
        if isinstance(node, MappingNode):
            kept = []
            for key, value in node.value:
                name = getattr(key, "value", None)
                if name in ROBOT_KEYS and name not in VARIANT_ROBOT_KEYS:
                    src.error(key, f"a variant cannot change robot.{name}",
                              f"a variant may change the robot's {', '.join(VARIANT_ROBOT_KEYS)}; change "
                              f"robot.{name} in the base world, or make a world of its own")
                else:
                    kept.append((key, value))
            node = MappingNode(node.tag, kept, node.start_mark, node.end_mark, node.flow_style)
        fields = src.keys(node, "robot", VARIANT_ROBOT_KEYS, what=" such as {odometry_noise: off}") or {}
        noise = self._odometry_noise(fields, robot.odometry_noise)
        teleports = self._teleports(fields["teleports"][1]) if "teleports" in fields else robot.teleports
        robot = replace(robot, odometry_noise=noise, teleports=teleports)
        if "teleports" in fields:
            self.check_teleports(world.walls, world.places, robot)
        return robot

    # -- geometry -------------------------------------------------------------

    def walls(self, walls: Node | None, polygons: Node | None) -> list[Segment]:
        src, found = self.src, []
        shape = "[x1, y1, x2, y2] or a polyline [[x, y], [x, y], ...]"
        for i, item in enumerate(src.items(walls, "walls", f"each wall is {shape}") or [] if _given(walls) else []):
            path = f"walls[{i}]"
            if item.tag.endswith(":seq") and item.value and item.value[0].tag.endswith(":seq"):
                points = src.points(item, path, 2, "[[x, y], [x, y], ...]")
                found += self._chain(points or [], item, closed=False)
            else:
                values = src.numbers(item, path, (4,), "[x1, y1, x2, y2]")
                if values is not None:
                    found += self._chain([(values[0], values[1]), (values[2], values[3])], item, closed=False)
        for i, item in enumerate(src.items(polygons, "polygons", "each polygon is [[x, y], ...]") or []
                                 if _given(polygons) else []):
            points = src.points(item, f"polygons[{i}]", 3, "[[x, y], [x, y], [x, y], ...]")
            found += self._chain(points or [], item, closed=True)
            if points:
                self.polygons.append((tuple(points), f"polygons[{i}]", item))
        return found

    def _chain(self, points: list[Point], node: Node, closed: bool) -> list[Segment]:
        ring = points + points[:1] if closed and points else points
        segments = [Segment(a, b) for a, b in pairwise(ring) if a != b]
        if points and not segments:
            self.src.error(node, "this wall has no length (its points are all the same)")
        self.wall_nodes += [(s, node) for s in segments]
        return segments

    def map_walls(self, node: Node) -> list[Segment]:
        src = self.src
        name = src.string(node, "map", "name a ROS map_server YAML file, e.g. map: maps/office.yaml")
        if name is None:
            return []
        path = Path(name) if Path(name).is_absolute() else self.path.parent / name
        if not path.is_file():
            src.error(node, f"map file '{name}' not found", f"looked for {path}; the path is relative to the world file")
            return []
        shown = str(Path(src.file).parent / name) if not Path(name).is_absolute() else name
        try:
            rosmap = load_ros_map(path, shown)
        except SourceError as error:
            src.problems += error.problems
            src.error(node, f"the map '{name}' has problems (above)")
            return []
        self.rosmap, self.map_name = rosmap, name
        segments = wall_segments(rosmap)
        self.wall_nodes += [(s, node) for s in segments]
        return segments

    # -- places and doors --------------------------------------------------------

    def places(self, node: Node) -> tuple[dict[str, Place], dict[str, Node]]:
        src = self.src
        entries = src.keys(node, "places", None) if _given(node) else {}
        places: dict[str, Place] = {}
        point_nodes: dict[str, Node] = {}
        for name, (key, value) in (entries or {}).items():
            path = f"places.{name}"
            self._check_name(key, name, "place")
            fields = src.keys(value, path, PLACE_KEYS, ("point",), what=" such as {point: [x, y], radius: 0.5}")
            if fields is None or "point" not in fields:
                continue
            point = src.point(fields["point"][1], f"{path}.point")
            region = None
            if "region" in fields:
                found = src.points(fields["region"][1], f"{path}.region", 3, "[[x, y], [x, y], [x, y], ...]")
                region = tuple(found) if found else None
            radius = 0.5
            if "radius" in fields:
                if "region" in fields:
                    src.error(fields["radius"][0], f"{path} has a region, so its radius is not used",
                              "give a region or a radius, not both")
                radius = src.number(fields["radius"][1], f"{path}.radius", above=0.0) or radius
            if point is None:
                continue
            place = Place(name, point, region, radius)
            if region is not None and not place.contains(*point):
                src.error(fields["point"][1], f"the point of place '{name}' is outside its region",
                          "move the point inside the region: it is where the robot goes to be there")
            places[name] = place
            point_nodes[name] = fields["point"][1]
        return places, point_nodes

    def doors(self, node: Node, places: dict[str, Place]) -> dict[str, Door]:
        src = self.src
        entries = src.keys(node, "doors", None) if _given(node) else {}
        doors: dict[str, Door] = {}
        for name, (key, value) in (entries or {}).items():
            path = f"doors.{name}"
            self._check_name(key, name, "door")
            if name in places:
                self.src.error(key, f"door '{name}' has the name of a place", "give doors and places different names")
            fields = src.keys(value, path, DOOR_KEYS, ("between",), what=" such as {between: [a, b], center: [x, y]}")
            if fields is None:
                continue
            between = self._between(fields["between"][1], f"{path}.between", places) if "between" in fields else None
            segment = None
            if "segment" in fields:
                values = src.numbers(fields["segment"][1], f"{path}.segment", (4,), "[x1, y1, x2, y2]")
                if values is not None:
                    segment = Segment((values[0], values[1]), (values[2], values[3]))
                    if segment.length == 0:
                        src.error(fields["segment"][1], f"the leaf of door '{name}' has no length")
                        segment = None
            center = src.point(fields["center"][1], f"{path}.center") if "center" in fields else None
            if center is None and "center" not in fields:
                if segment is not None:
                    center = segment.midpoint
                elif "segment" not in fields:
                    src.error(value, f"{path} needs a center: [x, y] (an opening has no segment to take it from)",
                              "add center: [x, y], the middle of the doorway")
            if center is not None and segment is not None and "center" in fields:
                gap, _ = nearest_wall([segment], center)
                if gap > 0.1:
                    src.error(fields["center"][1], f"the center of door '{name}' is {gap:.2f} m off its segment",
                              "leave out center: it defaults to the segment's midpoint")
            is_open = src.boolean(fields["open"][1], f"{path}.open") if "open" in fields else True
            openable = src.boolean(fields["openable"][1], f"{path}.openable") if "openable" in fields else False
            schedule = self._schedule(fields["schedule"][1], f"{path}.schedule") if "schedule" in fields else ()
            if segment is None and (is_open is False or schedule or openable) and "segment" not in fields:
                where = fields.get("open", fields.get("schedule", fields.get("openable")))
                src.error(where[0] if where else value,
                          f"door '{name}' has no segment, so it is an opening that cannot close",
                          "add segment: [x1, y1, x2, y2], the door leaf across the doorway")
            if between is None or center is None or is_open is None or openable is None or schedule is None:
                continue
            doors[name] = Door(name, between, center, segment, is_open, openable, schedule)
        return doors

    def _place_keys(self, node: Node | None) -> set[str]:
        """The names under ``places:``, including those of places with problems."""
        if not isinstance(node, MappingNode):
            return set()
        return {str(key.value) for key, _ in node.value if isinstance(key, ScalarNode)}

    def _check_name(self, node: Node, name: str, what: str) -> None:
        if not NAME_PATTERN.match(name):
            suggestion = re.sub(r"[^a-z0-9_-]+", "-", name.lower()).strip("-")
            article = "an" if what[0] in "aeiou" else "a"
            self.src.error(node, f"'{name}' cannot be {article} {what} name: RAPs could not refer to it",
                           f"use lower-case letters, digits, '-' and '_', starting with a letter, "
                           f"e.g. '{suggestion or what + '-1'}'")

    def _between(self, node: Node, path: str, places: dict[str, Place]) -> tuple[str, str] | None:
        src = self.src
        items = src.items(node, path, "write it as [place-a, place-b]")
        if items is None:
            return None
        if len(items) != 2:
            src.error(node, f"{path} must name two places, not {len(items)}", "write it as [place-a, place-b]")
            return None
        names = [src.string(item, f"{path}[{i}]") for i, item in enumerate(items)]
        ok = True
        for item, place in zip(items, names):
            if place is not None and place not in places and place in self.declared_places:
                ok = False  # a place with problems of its own, reported there
            elif place is not None and place not in places:
            
                known = ", ".join(places) or "none yet"
                src.error(item, f"no place named '{place}'",
                          (did_you_mean(place, places, end=" ") or "") + f"places: {known}")
                ok = False
        if names[0] is not None and names[0] == names[1]:
            src.error(items[1], f"a door joins two different places, not '{names[0]}' with itself")
            ok = False
        if not ok or names[0] is None or names[1] is None:
            return None
        return names[0], names[1]

    def _schedule(self, node: Node, path: str) -> tuple[tuple[float, bool], ...] | None:
        src = self.src
        items = src.items(node, path, "write it as [[time, open], [time, closed], ...]")
        if items is None:
            return None
        changes: list[tuple[float, bool]] = []
        last = 0.0
        for i, item in enumerate(items):
            here = f"{path}[{i}]"
            pair = src.items(item, here, "write each change as [time, open] or [time, closed]")
            if pair is None:
                continue
            if len(pair) != 2:
                src.error(item, f"{here} must be [time, open|closed], not a list of {len(pair)}")
                continue
            time = src.number(pair[0], f"{here}[0]", minimum=0.0)
            state = _door_state(pair[1])
            if state is None:
                src.error(pair[1], f"{here}[1] must be open or closed", "write [time, open] or [time, closed]")
            if time is not None and time < last:
                src.error(pair[0], f"{here} at {time:g} s comes before the change above it ({last:g} s)",
                          "list the changes in time order")
            if time is None or state is None:
                continue
            last = time
            changes.append((time, state))
        return tuple(changes)

    # -- disturbances, robot, sonar --------------------------------------------

    def disturbances(self, node: Node) -> tuple[Disturbance, ...]:
        src = self.src
        found: list[Disturbance] = []
        seen: dict[str, int] = {}
        items = src.items(node, "disturbances", "write a list of {kind: person|box, ...}") if _given(node) else []
        for i, item in enumerate(items or []):
            path = f"disturbances[{i}]"
            fields = src.keys(item, path, DISTURBANCE_KEYS, ("kind", "path"),
                              what=" such as {kind: box, path: [[x, y]]}")
            if fields is None:
                continue
            kind = src.string(fields["kind"][1], f"{path}.kind") if "kind" in fields else None
            if kind is not None and kind not in DISTURBANCE_KINDS:
                src.error(fields["kind"][1], f"unknown disturbance kind '{kind}'", "kinds: person, box")
                kind = None
            name = f"{kind or 'disturbance'}-{i + 1}"
            if "name" in fields:
                name = src.string(fields["name"][1], f"{path}.name") or name
                if name in seen:
                    src.error(fields["name"][1], f"two disturbances are named '{name}'", "give each its own name")
            seen[name] = i
            start = src.number(fields["start"][1], f"{path}.start", minimum=0.0) if "start" in fields else 0.0
            end = None
            if "end" in fields and fields["end"][1].tag != "tag:yaml.org,2002:null":
                end = src.number(fields["end"][1], f"{path}.end", minimum=0.0)
                if end is not None and start is not None and end <= start:
                    src.error(fields["end"][1], f"{path}.end ({end:g}) must be after its start ({start:g})")
            at_least = 2 if kind == "person" else 1
            points = src.points(fields["path"][1], f"{path}.path", at_least,
                                "[[x, y], ...] (a person walks along it; a box stands at the first point)") \
                if "path" in fields else None
            size = src.number(fields["size"][1], f"{path}.size", above=0.0) if "size" in fields else 0.5
            speed = src.number(fields["speed"][1], f"{path}.speed", above=0.0) if "speed" in fields else 0.8
            if kind is None or start is None or points is None or size is None or speed is None:
                continue
            found.append(Disturbance(name, kind, start, tuple(points), end, size, speed))
        return tuple(found)

    # -- objects ----------------------------------------------------------------------

    def objects(self, node: Node, places: dict[str, Place], doors: dict[str, Door],
                walls: tuple[Segment, ...]) -> dict[str, WorldObject]:
        """The ``objects:`` mapping: name → {colour, kind, at, size, moves}; see the module docstring."""
        src = self.src
        entries = src.keys(node, "objects", None, what=" such as {red-ball: {colour: red, at: [x, y]}}") \
            if _given(node) else {}
        found: dict[str, WorldObject] = {}
        for name, (key, value) in (entries or {}).items():
            path = f"objects.{name}"
            self._check_name(key, name, "object")
            if name in places or name in doors:
                src.error(key, f"object '{name}' has the name of a {'place' if name in places else 'door'}",
                          "give objects, places and doors different names")
            fields = src.keys(value, path, OBJECT_KEYS, ("colour", "at"),
                              what=" such as {colour: red, at: [x, y]}")
            if fields is None:
                continue
            colour = src.string(fields["colour"][1], f"{path}.colour", "a colour name such as red") \
                if "colour" in fields else None
            if colour is not None and not NAME_PATTERN.match(colour):
                src.error(fields["colour"][1], f"'{colour}' cannot be a colour: RAPs could not refer to it",
                          "use lower-case letters, digits, '-' and '_', starting with a letter, e.g. red")
                colour = None
            kind = "object"
            if "kind" in fields:
                kind = src.string(fields["kind"][1], f"{path}.kind", "kinds: " + ", ".join(OBJECT_KINDS))
                if kind is not None and kind not in OBJECT_KINDS:
                    src.error(fields["kind"][1], f"unknown object kind '{kind}'",
                              (did_you_mean(kind, OBJECT_KINDS, end=" ") or "") + "kinds: " + ", ".join(OBJECT_KINDS))
                    kind = None
            size = src.number(fields["size"][1], f"{path}.size", above=0.0, maximum=2.0) if "size" in fields else 0.25
            at = src.point(fields["at"][1], f"{path}.at") if "at" in fields else None
            if at is not None and size is not None:
                at = self._object_point(fields["at"][1], at, f"the object '{name}'", size, walls, places)
            moves = self._moves(fields["moves"][1], f"{path}.moves", size or 0.25, walls, places) \
                if "moves" in fields else ()
            if colour is None or kind is None or size is None or at is None or moves is None:
                continue
            found[name] = WorldObject(name, colour, at, kind, size, moves)
        return found

    def _moves(self, node: Node, path: str, size: float, walls: tuple[Segment, ...],
               places: dict[str, Place]) -> tuple[ObjectMove, ...] | None:
        """An object's ``moves:`` list: [{at: SECONDS | near: METRES, to: [x, y]}, ...]."""
        src = self.src
        shape = "[{at: SECONDS, to: [x, y]}, {near: METRES, to: [x, y]}, ...]"
        items = src.items(node, path, f"write it as {shape}")
        if items is None:
            return None
        moves: list[ObjectMove] = []
        ok, last = True, 0.0
        for i, item in enumerate(items):
            here = f"{path}[{i}]"
            fields = src.keys(item, here, MOVE_KEYS, ("to",), what=" such as {at: 30, to: [x, y]}")
            if fields is None:
                ok = False
                continue
            if ("at" in fields) == ("near" in fields):
                src.error(fields["near"][0] if "near" in fields else item,
                          f"{here} needs one of at: (a time) and near: (a distance from the robot), "
                          f"not {'both' if 'at' in fields else 'neither'}",
                          "write {at: SECONDS, to: [x, y]} or {near: METRES, to: [x, y]}")
                ok = False
                continue
            at = near = None
            if "at" in fields:
                at = src.number(fields["at"][1], f"{here}.at", minimum=0.0)
                if at is not None and at < last:
                    src.error(fields["at"][1], f"{here} at {at:g} s comes before the move above it ({last:g} s)",
                              "list timed moves in time order")
                    at = None
                if at is not None:
                    last = at
            else:
                near = src.number(fields["near"][1], f"{here}.near", above=0.0)
            to = src.point(fields["to"][1], f"{here}.to") if "to" in fields else None
            if to is not None:
                to = self._object_point(fields["to"][1], to, f"{here}.to", size, walls, places)
            if to is None or (at is None and near is None):
                ok = False
                continue
            moves.append(ObjectMove(to, at, near))
        return tuple(moves) if ok else None

    def _object_point(self, node: Node, point: Point, what: str, size: float, walls: tuple[Segment, ...],
                      places: dict[str, Place]) -> Point | None:
        """``point`` if an object of ``size`` fits there (off the walls, outside solid blocks), else None."""
        gap, wall = nearest_wall(walls, point)
        if gap < size / 2:
            self.src.error(node, f"{what} at ({point[0]:g}, {point[1]:g}) is {gap:.2f} m from a wall "
                                 f"({self._wall_text(wall)}), less than half its size ({size:g} m)",
                           "move it off the wall")
            return None
        solid = self._solid_polygon_at(point, places)
        if solid is not None:
            self.src.error(node, f"{what} at ({point[0]:g}, {point[1]:g}) is inside {solid[0]} "
                                 f"(line {self.src.location(solid[1]).line}), a closed outline with no place in it",
                           "put it where the robot can get to it")
            return None
        return point

    def robot(self, node: Node | None, places: dict[str, Place]) -> RobotConfig:
        src, default = self.src, RobotConfig()
        fields = (src.keys(node, "robot", ROBOT_KEYS) or {}) if _given(node) else {}
        start = default.start
        if places:  # without a start, the robot starts at the first place, facing east
            start = (*next(iter(places.values())).point, 0.0)
        if "start" in fields:
            self.start_node = fields["start"][1]
            values = src.numbers(fields["start"][1], "robot.start", (2, 3), "[x, y] or [x, y, heading_deg]")
            self.start_unreadable = values is None
            if values is not None:
                start = (values[0], values[1], math.radians(values[2]) if len(values) == 3 else 0.0)
        radius = self._number(fields, "robot", "radius", default.radius, above=0.0)
        max_speed = self._number(fields, "robot", "max_speed", default.max_speed, above=0.0)
        turn = self._number(fields, "robot", "max_turn_rate_deg", math.degrees(default.max_turn_rate), above=0.0)
        noise = self._odometry_noise(fields, default.odometry_noise)
        teleports = self._teleports(fields["teleports"][1]) if "teleports" in fields else ()
        return RobotConfig(start, radius, max_speed, math.radians(turn), noise, teleports)

    def _odometry_noise(self, fields: dict[str, tuple[Node, Node]], default: OdometryNoise) -> OdometryNoise:
        """``robot.odometry_noise`` (off, or a mapping of alphas) or ``robot.odometry_drift`` (a number),
        not both; ``default`` without either (or after a problem)."""
        src = self.src
        given = [key for key in fields if key in ("odometry_noise", "odometry_drift")]
        if len(given) == 2:
            first, second = given
            src.error(fields[second][0], f"robot.{second} and robot.{first} (line "
                                         f"{src.location(fields[first][0]).line}) both say how the odometry errs",
                      "keep one: odometry_noise: {alpha1: ..., alpha2: ..., alpha3: ..., alpha4: ...} or off, "
                      "or the shorthand odometry_drift: d (alpha1 = alpha3 = d)")
            return default
        if "odometry_drift" in fields:
            node = fields["odometry_drift"][1]
            if isinstance(node, ScalarNode) and node.tag == "tag:yaml.org,2002:bool":
                src.error(node, f"robot.odometry_drift must be a number, not '{node.value}'",
                          "write odometry_drift: 0 or odometry_noise: off for odometry without noise")
                return default
            drift = self._alpha(node, "robot.odometry_drift")
            return default if drift is None else OdometryNoise.drift(drift)
        if "odometry_noise" not in fields:
            return default
        node = fields["odometry_noise"][1]
        example = "{alpha1: 0.02, alpha2: 0.005, alpha3: 0.02, alpha4: 0.005}"
        if isinstance(node, ScalarNode) and node.tag in ("tag:yaml.org,2002:bool", "tag:yaml.org,2002:str") \
                and str(node.value).strip().lower() in ("off", "false", "no", "on", "true", "yes"):
            return NO_ODOMETRY_NOISE if str(node.value).strip().lower() in ("off", "false", "no") \
                else DEFAULT_ODOMETRY_NOISE
        alphas = src.keys(node, "robot.odometry_noise", ALPHA_KEYS, what=f" (or off) such as {example}")
        if alphas is None:
            return default
        values = {key: self._alpha(value, f"robot.odometry_noise.{key}") for key, (_, value) in alphas.items()}
        if any(v is None for v in values.values()):
            return default
        return OdometryNoise(**values)  # type: ignore[arg-type]

    def _alpha(self, node: Node, path: str) -> float | None:
        """An odometry alpha: a standard deviation per metre or radian, from 0 to :data:`MAX_ALPHA`."""
        value = self.src.number(node, path, minimum=0.0)
        if value is not None and value > MAX_ALPHA:
            self.src.error(node, f"{path} must be at most {MAX_ALPHA:g}, not {value:g}",
                           f"it is a fraction, not a percentage: {value:g} % is {value / 100:g}")
            return None
        return value

    def _teleports(self, node: Node) -> tuple[Teleport, ...]:
        """``robot.teleports``: [{at: SECONDS, to: [x, y, heading_deg]}, ...] in time order; where each
        lands is checked later (:meth:`check_teleports`)."""
        src = self.src
        shape = "[{at: SECONDS, to: [x, y, heading_deg]}, ...]"
        items = src.items(node, "robot.teleports", f"write it as {shape}") if _given(node) else []
        found: list[Teleport] = []
        self.teleport_nodes = []
        last = 0.0
        for i, item in enumerate(items or []):
            here = f"robot.teleports[{i}]"
            fields = src.keys(item, here, TELEPORT_KEYS, TELEPORT_KEYS, what=" such as {at: 40, to: [x, y, 90]}")
            if not fields or "at" not in fields or "to" not in fields:
                continue
            at = src.number(fields["at"][1], f"{here}.at", minimum=0.0)
            if at is not None and at < last:
                src.error(fields["at"][1], f"{here} at {at:g} s comes before the teleport above it ({last:g} s)",
                          "list the teleports in time order")
                at = None
            last = at if at is not None else last
            values = src.numbers(fields["to"][1], f"{here}.to", (2, 3), "[x, y] or [x, y, heading_deg]")
            if at is None or values is None:
                continue
            found.append(Teleport(at, (values[0], values[1], math.radians(values[2]) if len(values) == 3 else 0.0)))
            self.teleport_nodes.append((here, fields["to"][1]))
        return tuple(found)

    def sonar(self, node: Node) -> SonarConfig:
        src, d = self.src, SonarConfig()
        fields = src.keys(node, "sonar", SONAR_KEYS) or {}
        count = self._number(fields, "sonar", "count", d.count, minimum=1, maximum=MAX_TRANSDUCERS, integer=True)
        beam = self._number(fields, "sonar", "beam_width_deg", math.degrees(d.beam_width), above=0.0, maximum=180.0)
        max_range = self._number(fields, "sonar", "max_range", d.max_range, above=0.0)
        min_range = self._number(fields, "sonar", "min_range", d.min_range, minimum=0.0)
        if min_range >= max_range:
            where = fields.get("min_range", fields.get("max_range"))
            src.error(where[1] if where else node,
                      f"sonar.min_range ({min_range:g}) must be less than sonar.max_range ({max_range:g})")
        noise = self._number(fields, "sonar", "range_noise", d.range_noise, minimum=0.0)
        noise_per_m = self._number(fields, "sonar", "range_noise_per_m", d.range_noise_per_m, minimum=0.0)
        specular = self._number(fields, "sonar", "specular_angle_deg", math.degrees(d.specular_angle),
                                minimum=0.0, maximum=90.0)
        dropout = self._number(fields, "sonar", "specular_dropout", d.specular_dropout, minimum=0.0, maximum=1.0)
        rays = self._number(fields, "sonar", "rays_per_beam", d.rays_per_beam, minimum=1, maximum=MAX_RAYS_PER_BEAM,
                            integer=True)
        rate = self._number(fields, "sonar", "rate", d.rate, above=0.0)
        return SonarConfig(int(count), math.radians(beam), max_range, min_range, noise, noise_per_m,
                           math.radians(specular), dropout, int(rays), rate)

    def _number(self, fields: dict[str, tuple[Node, Node]], section: str, key: str, default: float,
                **limits: float | bool) -> float:
        if key not in fields:
            return default
        value = self.src.number(fields[key][1], f"{section}.{key}", **limits)  # type: ignore[arg-type]
        return default if value is None else value

    # -- clearances ----------------------------------------------------------------

    def check_clearances(self, walls: tuple[Segment, ...], places: dict[str, Place], point_nodes: dict[str, Node],
                         robot: RobotConfig) -> None:
        """Place points must leave the robot room; the robot must start and land in free space
        (:meth:`check_start`, :meth:`check_teleports`)."""
        need = robot.radius + WALL_CLEARANCE_MARGIN
        for name, place in places.items() if walls else ():
            gap, wall = nearest_wall(walls, place.point)
            if gap < need:
                self.src.error(point_nodes[name],
                               f"the point of place '{name}' is {gap:.2f} m from a wall "
                               f"({self._wall_text(wall)}); the robot needs {need:.2f} m",
                               "move the point away from the wall: the robot drives to it")
        self.check_start(walls, places, point_nodes, robot)
        self.check_teleports(walls, places, robot)

    # -- where the robot starts ------------------------------------------------------

    def check_start(self, walls: tuple[Segment, ...], places: dict[str, Place], point_nodes: dict[str, Node],
                    robot: RobotConfig) -> None:
        """The robot must start in free space: on a free cell of the map, outside solid polygons, clear of walls.

        Reported at ``robot.start`` (at the first place's point, or the top of
        the file, when the robot starts there for want of a ``robot.start``),
        with the nearest point where the robot would fit as a hint.
        """
        if self.start_unreadable:
            return
        point = robot.start[:2]
        what = self._start_what(point, places)
        problem = self._start_on_map(point, what) or self._start_in_polygon(point, what, places)
        if problem is None and self.start_node is not None:  # a defaulted start is a place point, checked above
            problem = self._start_near_wall(walls, point, robot, "the robot starts")
        if problem is None:
            return
        where = self.start_node or next((point_nodes[n] for n in places if n in point_nodes), self.src.root)
        free = self._free_point_near(walls, point, robot, places)
        move = "move robot.start into free space" if self.start_node is not None \
            else "add robot.start: [x, y, heading_deg] in free space"
        kind = "cell" if self.rosmap is not None else "point"
        found = f"the nearest free {kind} with room for the robot is at ({free[0]:.2f}, {free[1]:.2f})" \
            if free is not None else f"no free {kind} with room for the robot (radius {robot.radius:g} m) is near it"
        self.src.error(where, problem, f"{move}; {found}")

    def check_teleports(self, walls: tuple[Segment, ...], places: dict[str, Place], robot: RobotConfig) -> None:
        """Each teleport must land the robot in free space, as :meth:`check_start` checks the start;
        reported at its ``to``, with the nearest point where the robot would fit as a hint."""
        for teleport, (here, node) in zip(robot.teleports, self.teleport_nodes):
            point = teleport.to[:2]
            what = f"{here}.to ({point[0]:g}, {point[1]:g})"
            problem = self._start_on_map(point, what) or self._start_in_polygon(point, what, places) \
                or self._start_near_wall(walls, point, robot, f"{what} puts the robot")
            if problem is None:
                continue
            free = self._free_point_near(walls, point, robot, places)
            kind = "cell" if self.rosmap is not None else "point"
            found = f"the nearest free {kind} with room for the robot is at ({free[0]:.2f}, {free[1]:.2f})" \
                if free is not None else f"no free {kind} with room for the robot is near it"
            self.src.error(node, problem, f"move {here}.to into free space; {found}")

    def _start_what(self, point: Point, places: dict[str, Place]) -> str:
        """How messages name the start: robot.start (x, y), or where the robot starts without one."""
        at = f"({point[0]:g}, {point[1]:g})"
        if self.start_node is not None:
            return f"robot.start {at}"
        if places:
            at = f"the point of place '{next(iter(places))}' {at}"
        return f"the robot starts at {at} (there is no robot.start), which"

    def _start_on_map(self, point: Point, what: str) -> str | None:
        """What is wrong with the map cell the robot starts on (occupied, unknown, off the map), if anything."""
        rosmap = self.rosmap
        if rosmap is None:
            return None
        label = rosmap.label_at(*point)
        if label == FREE:
            return None
        name = f"the map '{self.map_name}'"
        if label is None:
            xmin, ymin, xmax, ymax = rosmap.extent
            return (f"{what} is outside {name}, which covers x {xmin:g} to {xmax:g}, y {ymin:g} to {ymax:g} m: "
                    f"nothing is known there")
        row, col = rosmap.world_to_cell(*point)
        cell = {OCCUPIED: "an occupied cell", UNKNOWN: "an unknown cell"}.get(label, f"a cell that is not free "
                                                                               f"(value {label} of 100)")
        return f"{what} is on {cell} of {name} (pixel x={col}, y={row} of {Path(rosmap.image).name})"

    def _start_in_polygon(self, point: Point, what: str, places: dict[str, Place]) -> str | None:
        """A polygon the robot starts inside although no place is in it: a solid block, not a room."""
        solid = self._solid_polygon_at(point, places)
        if solid is None:
            return None
        path, node = solid
        return (f"{what} is inside {path} (line {self.src.location(node).line}), a closed outline "
                f"with no place in it: a solid block the robot could not leave")

    def _solid_polygon_at(self, point: Point, places: dict[str, Place]) -> tuple[str, Node] | None:
        """The key path and node of a polygon that contains ``point`` but no place's point (none without places)."""
        if not places:
            return None
        for points, path, node in self.polygons:
            if _inside(points, *point) and not any(_inside(points, *p.point) for p in places.values()):
                return path, node
        return None

    def _start_near_wall(self, walls: tuple[Segment, ...], point: Point, robot: RobotConfig,
                         subject: str) -> str | None:
        """A wall closer to ``point`` than the robot's radius: the robot would be inside it (``subject``
        says how it gets there: "the robot starts")."""
        gap, wall = nearest_wall(walls, point)
        if gap >= robot.radius:
            return None
        return (f"{subject} {gap:.2f} m from a wall ({self._wall_text(wall)}), "
                f"less than its radius {robot.radius:g} m")

    def _free_point_near(self, walls: tuple[Segment, ...], point: Point, robot: RobotConfig,
                         places: dict[str, Place]) -> Point | None:
        """The nearest point to ``point`` where the robot would start clear of everything, or None.

        On a map world the candidates are the map's free cells with room for
        the robot; elsewhere points on rings around ``point``. Each must also
        keep radius + :data:`WALL_CLEARANCE_MARGIN` from every wall and lie
        outside the solid polygons.
        """
        need = robot.radius + WALL_CLEARANCE_MARGIN
        if self.rosmap is not None:
            candidates = self.rosmap.free_points_near(*point, need)
        else:
            candidates = _ring_points(point, FREE_POINT_SEARCH, FREE_POINT_STEP)
        for candidate in candidates:
            if nearest_wall(walls, candidate)[0] >= need and self._solid_polygon_at(candidate, places) is None:
                return candidate
        return None

    def _wall_text(self, wall: Segment | None) -> str:
        """A wall for messages: its ends and the line of the file that made it."""
        node = next((n for s, n in self.wall_nodes if s == wall), None)
        line = f" from line {self.src.location(node).line}" if node is not None else ""
        return _segment_text(wall) + line


def _ring_points(center: Point, reach: float, step: float) -> list[Point]:
    """Points on rings of radius ``step``, ``2 step`` ... ``reach`` around ``center``, nearest rings first."""
    found: list[Point] = []
    for k in range(1, int(round(reach / step)) + 1):
        r = k * step
        count = max(8, int(math.pi * r / step))  # points about two steps apart
        angles = (2 * math.pi * i / count for i in range(count))
        found += [(center[0] + r * math.cos(a), center[1] + r * math.sin(a)) for a in angles]
    return found


def _cut(wall: Segment, opening: Segment) -> list[Segment]:
    """``wall`` without the stretch ``opening`` covers: the wall itself when the opening does not lie
    along it (both ends on its line, within :data:`OPENING_TOLERANCE`), else the pieces left (0-2)."""
    (ax, ay), (bx, by) = wall.a, wall.b
    length = wall.length
    if length == 0:
        return [wall]
    ux, uy = (bx - ax) / length, (by - ay) / length

    def along(point: Point) -> float | None:
        dx, dy = point[0] - ax, point[1] - ay
        return dx * ux + dy * uy if abs(dx * uy - dy * ux) <= OPENING_TOLERANCE else None

    s, t = along(opening.a), along(opening.b)
    if s is None or t is None:
        return [wall]
    s, t = sorted((s, t))
    if t <= 0 or s >= length:
        return [wall]
    pieces = []
    if s > 0:
        pieces.append(Segment(wall.a, (ax + ux * s, ay + uy * s)))
    if t < length:
        pieces.append(Segment((ax + ux * t, ay + uy * t), wall.b))
    return pieces


def _looks_like_path(text: str) -> bool:
    return "/" in text or text.endswith((".yaml", ".yml"))


def _given(node: Node | None) -> bool:
    """Whether a section is there and not empty (``walls:`` with nothing after it is no walls)."""
    return node is not None and node.tag != "tag:yaml.org,2002:null"


def _door_state(node: Node) -> bool | None:
    """open/closed (or true/false) as a bool; None for anything else."""
    value = getattr(node, "value", None)
    if not isinstance(value, str):
        return None
    word = value.strip().lower()
    if word in ("open", "true", "yes", "on"):
        return True
    if word in ("closed", "close", "false", "no", "off"):
        return False
    return None


def nearest_wall(walls: tuple[Segment, ...] | list[Segment], point: Point) -> tuple[float, Segment | None]:
    """Distance from ``point`` to the nearest wall segment, and that segment (inf, None without walls)."""
    if not walls:
        return math.inf, None
    ends = np.array([(s.a[0], s.a[1], s.b[0], s.b[1]) for s in walls], dtype=float)
    distances = _point_segment_distances(np.asarray(point, dtype=float), ends)
    index = int(np.argmin(distances))
    return float(distances[index]), walls[index]


def _point_segment_distances(p: np.ndarray, ends: np.ndarray) -> np.ndarray:
    a, b = ends[:, :2], ends[:, 2:]
    ab = b - a
    length2 = np.maximum((ab * ab).sum(axis=1), 1e-18)
    t = np.clip(((p - a) * ab).sum(axis=1) / length2, 0.0, 1.0)
    closest = a + t[:, None] * ab
    return np.hypot(*(p - closest).T)


def _segment_text(segment: Segment | None) -> str:
    if segment is None:
        return "none"
    (ax, ay), (bx, by) = segment.a, segment.b
    return f"[{ax:g}, {ay:g}, {bx:g}, {by:g}]"


def _bounds(walls: tuple[Segment, ...], places: dict[str, Place], robot: RobotConfig) -> tuple[float, float, float, float]:
    xs: list[float] = [robot.start[0]] + [t.to[0] for t in robot.teleports]
    ys: list[float] = [robot.start[1]] + [t.to[1] for t in robot.teleports]
    for wall in walls:
        xs += (wall.a[0], wall.b[0])
        ys += (wall.a[1], wall.b[1])
    for place in places.values():
        xs.append(place.point[0])
        ys.append(place.point[1])
        for x, y in place.region or ():
            xs.append(x)
            ys.append(y)
    m = BOUNDS_MARGIN
    return min(xs) - m, min(ys) - m, max(xs) + m, max(ys) + m


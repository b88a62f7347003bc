"""Our things as Foxglove's well-known messages: poses, the sonar ring, the grid, scenes, log lines.

Pure functions from atlas-rap values (poses, a world, an
:class:`~atlas_rap.maps.grid.OccupancyGrid`, a
:class:`~atlas_rap.maps.topology.Topology`, a followed route, the
localiser's :class:`~atlas_rap.skills.beliefs.PoseEstimate`, a trace
record) to ``foxglove.messages`` objects, for :mod:`atlas_rap.views.recording`.
Everything is in the ``map`` frame (the world's metres, z = 0) except
what is said otherwise; ``t`` is simulated seconds.

Import it only once the Foxglove SDK is known to be installed
(:func:`atlas_rap.views.recording.require_foxglove`): it imports
``foxglove.messages`` at the top.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from foxglove.messages import (
    Color,
    CubePrimitive,
    CylinderPrimitive,
    FrameTransform,
    Grid,
    LaserScan,
    LinePrimitive,
    LinePrimitiveLineType,
    Log,
    LogLevel,
    PackedElementField,
    PackedElementFieldNumericType,
    Point3,
    Pose,
    PoseInFrame,
    PosesInFrame,
    Quaternion,
    SceneEntity,
    SceneEntityDeletion,
    SceneUpdate,
    SpherePrimitive,
    TextPrimitive,
    Timestamp,
    Vector2,
    Vector3,
)

from atlas_rap.trace_events import Event

MAP_FRAME = "map"
"""The world's frame: x, y in metres as in the world file."""

ROBOT_FRAME = "base_link"
"""The robot's frame (``/tf`` places it in ``map`` at every pose sample)."""

_WALL = Color(r=0.2, g=0.2, b=0.2, a=1.0)
_DOOR_OPEN = Color(r=0.2, g=0.65, b=0.3, a=1.0)
_DOOR_SHUT = Color(r=0.85, g=0.15, b=0.15, a=1.0)
_PLACE = Color(r=0.25, g=0.45, b=0.85, a=0.8)
_OBSTACLE = Color(r=0.9, g=0.55, b=0.1, a=0.9)
_TOPOLOGY = Color(r=0.55, g=0.2, b=0.7, a=0.9)
_ROUTE = Color(r=0.95, g=0.75, b=0.05, a=1.0)
_TEXT = Color(r=0.1, g=0.1, b=0.1, a=1.0)
_BELIEF = Color(r=0.84, g=0.07, b=0.48, a=0.35)  # the estimate's ellipse (the picture's believed-path magenta)
_LOST = Color(r=0.85, g=0.15, b=0.15, a=0.35)
_NO_ROTATION = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)

_ERROR_EVENTS = frozenset({Event.TASK_FAILED, Event.PLAN_ABANDONED, Event.MEMORY_ERROR})
_WARNING_EVENTS = frozenset({Event.PLAN_STEP_FAILED, Event.SKILL_PREEMPTED, Event.TASK_HALTED})


def nanoseconds(t: float) -> int:
    """Simulated seconds as the integer nanoseconds of an MCAP log time."""
    return round(t * 1e9)


_last_stamp: list = [None, None]  # (t, Timestamp) of the last call: a sample stamps several messages alike


def timestamp(t: float) -> Timestamp:
    """Simulated seconds as a Foxglove timestamp (seconds since 0: the run's start)."""
    if _last_stamp[0] != t:
        sec, nsec = divmod(nanoseconds(t), 1_000_000_000)
        _last_stamp[:] = [t, Timestamp(sec, nsec)]
    return _last_stamp[1]


def pose(x: float, y: float, heading: float) -> Pose:
    """A planar pose: (x, y) on the floor, ``heading`` a rotation about z."""
    return Pose(position=Vector3(x=x, y=y, z=0.0),
                orientation=Quaternion(x=0.0, y=0.0, z=math.sin(heading / 2), w=math.cos(heading / 2)))


def pose_in_frame(t: float, where: Pose) -> PoseInFrame:
    """The robot's pose at ``t`` in ``map``."""
    return PoseInFrame(timestamp=timestamp(t), frame_id=MAP_FRAME, pose=where)


def robot_transform(t: float, x: float, y: float, heading: float) -> FrameTransform:
    """``map`` → ``base_link``: where the robot is, so a 3D panel can follow it."""
    return FrameTransform(timestamp=timestamp(t), parent_frame_id=MAP_FRAME, child_frame_id=ROBOT_FRAME,
                          translation=Vector3(x=x, y=y, z=0.0),
                          rotation=Quaternion(x=0.0, y=0.0, z=math.sin(heading / 2), w=math.cos(heading / 2)))


def path(t: float, poses: list[Pose]) -> PosesInFrame:
    """The robot's path so far, at ``t``, in ``map``."""
    return PosesInFrame(timestamp=timestamp(t), frame_id=MAP_FRAME, poses=poses)


def particles(t: float, cloud: Any, limit: int = 500) -> PosesInFrame:
    """The particle cloud (n x 3: x, y, heading) at ``t`` as poses in ``map``, like nav2's
    ``/particle_cloud``: every ``ceil(n / limit)``-th particle, so at most ``limit`` of them."""
    cloud = np.asarray(cloud, dtype=float).reshape(-1, 3)
    kept = cloud[::max(1, math.ceil(len(cloud) / limit))]
    half = kept[:, 2] / 2
    return PosesInFrame(timestamp=timestamp(t), frame_id=MAP_FRAME, poses=[
        Pose(position=Vector3(x=x, y=y, z=0.0), orientation=Quaternion(x=0.0, y=0.0, z=sz, w=cz))
        for x, y, sz, cz in zip(kept[:, 0].tolist(), kept[:, 1].tolist(), np.sin(half).tolist(), np.cos(half).tolist())])


def covariance_record(estimate: Any) -> dict[str, Any]:
    """The localiser's estimate as a JSON message (schema ``atlas.PoseCovariance``): the ``pose``
    (x, y, heading), its 3 x 3 ``covariance`` row-major (m², rad²: ROS's ``PoseWithCovariance`` in
    the plane), the standard deviations ``sigma_x``, ``sigma_y`` (m) and ``sigma_heading`` (rad),
    whether the robot counts as ``localised``, and how many ``particles`` the belief has."""
    covariance = np.asarray(estimate.covariance, dtype=float).reshape(3, 3)
    sigma = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    cloud = estimate.particles
    return {"x": float(estimate.pose[0]), "y": float(estimate.pose[1]), "heading": float(estimate.pose[2]),
            "covariance": covariance.ravel().tolist(), "sigma_x": float(sigma[0]), "sigma_y": float(sigma[1]),
            "sigma_heading": float(sigma[2]), "localised": bool(estimate.localised),
            "particles": 0 if cloud is None else int(len(cloud))}


def estimate_entity(t: float, estimate: Any, sigmas: float = 2.0) -> SceneEntity:
    """The estimate's uncertainty in x and y: a flat disc (a cylinder 2 cm tall) the size of its
    ``sigmas``-sigma ellipse, turned to the ellipse's axes, at the estimated position; magenta while
    the robot counts as localised, red and named "lost" when not."""
    from atlas_rap.views.pose_error import covariance_ellipse

    width, height, angle = covariance_ellipse(estimate.covariance, sigmas)
    yaw = math.radians(angle)
    x, y = float(estimate.pose[0]), float(estimate.pose[1])
    disc = CylinderPrimitive(pose=Pose(position=Vector3(x=x, y=y, z=0.01),
                                       orientation=Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))),
                             size=Vector3(x=max(width, 0.005), y=max(height, 0.005), z=0.02), bottom_scale=1.0,
                             top_scale=1.0, color=_BELIEF if estimate.localised else _LOST)
    texts = [] if estimate.localised else [_label((x, y), "lost", 0.3)]
    return entity(t, "estimate", cylinders=[disc], texts=texts)


def sonar_scan(t: float, where: Pose, ranges: Any, angles: Any, radius: float, max_range: float) -> LaserScan:
    """The sonar ring as a laser scan from the robot's centre (``where``, in ``map``).

    A reading is measured from the rim, so ``radius`` is added; a reading at
    ``max_range`` (no echo) is NaN, which Foxglove does not draw, with
    intensity 0 (an echo has intensity 1). The transducers are evenly spaced
    counter-clockwise from the heading, so ``start_angle`` is the first one's
    and ``end_angle`` the last one's.
    """
    readings = ranges.tolist() if hasattr(ranges, "tolist") else list(ranges)
    return LaserScan(timestamp=timestamp(t), frame_id=MAP_FRAME, pose=where,
                     start_angle=float(angles[0]), end_angle=float(angles[-1]),
                     ranges=[r + radius if r < max_range else math.nan for r in readings],
                     intensities=[1.0 if r < max_range else 0.0 for r in readings])


def occupancy_grid(t: float, grid: Any) -> Grid:
    """An occupancy grid as a ``foxglove.Grid`` with one ``uint8`` field ``occupancy``: P(occupied) × 100
    (50 where nothing is known). Our row 0 is the top row; Foxglove's is the bottom one, so rows flip."""
    frame = grid.frame
    p = 1.0 / (1.0 + np.exp(-grid.log_odds))
    cells = np.flipud(np.rint(p * 100.0).astype(np.uint8))
    ox, oy, yaw = frame.origin
    return Grid(timestamp=timestamp(t), frame_id=MAP_FRAME, pose=pose(ox, oy, yaw), column_count=frame.width,
                cell_size=Vector2(x=frame.resolution, y=frame.resolution), row_stride=frame.width, cell_stride=1,
                fields=[PackedElementField(name="occupancy", offset=0, type=PackedElementFieldNumericType.Uint8)],
                data=np.ascontiguousarray(cells).tobytes())


def _point(xy: Sequence[float]) -> Point3:
    return Point3(x=float(xy[0]), y=float(xy[1]), z=0.0)


def _segments(pairs: list[tuple[Sequence[float], Sequence[float]]], color: Color, thickness: float) -> LinePrimitive:
    return LinePrimitive(type=LinePrimitiveLineType.LineList, thickness=thickness, color=color,
                         points=[_point(end) for pair in pairs for end in pair])


def _label(xy: Sequence[float], text: str, size: float = 0.35) -> TextPrimitive:
    return TextPrimitive(pose=Pose(position=Vector3(x=float(xy[0]), y=float(xy[1]), z=0.3), orientation=_NO_ROTATION),
                         billboard=True, font_size=size, color=_TEXT, text=text)


def _sphere(xy: Sequence[float], size: float, color: Color) -> SpherePrimitive:
    return SpherePrimitive(pose=Pose(position=Vector3(x=float(xy[0]), y=float(xy[1]), z=0.0),
                                     orientation=_NO_ROTATION),
                           size=Vector3(x=size, y=size, z=size), color=color)


def entity(t: float, name: str, **primitives: Any) -> SceneEntity:
    """A scene entity ``name`` in ``map``; ``primitives`` as SceneEntity takes them (``lines=[...]``)."""
    return SceneEntity(timestamp=timestamp(t), frame_id=MAP_FRAME, id=name, **primitives)


def scene(*entities: SceneEntity, deleted: Sequence[tuple[float, str]] = ()) -> SceneUpdate:
    """A scene update: these entities (each replacing the one of its id) and deletions (t, id)."""
    return SceneUpdate(entities=list(entities),
                       deletions=[SceneEntityDeletion(timestamp=timestamp(t), id=name) for t, name in deleted])


def walls_entity(t: float, world: Any) -> SceneEntity:
    """The world's walls, as line segments."""
    return entity(t, "walls", lines=[_segments([(w.a, w.b) for w in world.walls], _WALL, 0.05)])


def places_entity(t: float, world: Any) -> SceneEntity:
    """The world's places: a region's outline, or a point place's circle; each named at its point."""
    outlines, spheres = [], []
    for place in world.places.values():
        if place.region is not None:
            outlines.append(LinePrimitive(type=LinePrimitiveLineType.LineLoop, thickness=0.02, color=_PLACE,
                                          points=[_point(p) for p in place.region]))
        else:
            spheres.append(_sphere(place.point, 0.2, _PLACE))
    texts = [_label(place.point, name) for name, place in world.places.items()]
    return entity(t, "places", lines=outlines, spheres=spheres, texts=texts)


def doors_entity(t: float, world: Any, doors_open: Mapping[str, bool]) -> SceneEntity:
    """The doors as they are now: a leaf green when open, red when shut; an opening as a green dot."""
    lines, spheres, texts = [], [], []
    for name, door in world.doors.items():
        color = _DOOR_OPEN if doors_open.get(name, True) else _DOOR_SHUT
        if door.segment is not None:
            lines.append(_segments([(door.segment.a, door.segment.b)], color, 0.08))
        else:
            spheres.append(_sphere(door.center, 0.15, color))
        texts.append(_label(door.center, name, 0.2))
    return entity(t, "doors", lines=lines, spheres=spheres, texts=texts)


def obstacles_entity(t: float, obstacles: Sequence[tuple[str, tuple[float, float], float]]) -> SceneEntity:
    """The disturbances present now: a box as a cube, a person as a cylinder."""
    cubes, cylinders = [], []
    for kind, (x, y), size in obstacles:
        where = Pose(position=Vector3(x=x, y=y, z=0.25), orientation=_NO_ROTATION)
        if kind == "box":
            cubes.append(CubePrimitive(pose=where, size=Vector3(x=size, y=size, z=0.5), color=_OBSTACLE))
        else:
            cylinders.append(CylinderPrimitive(pose=where, size=Vector3(x=size, y=size, z=0.5), bottom_scale=1.0,
                                               top_scale=1.0, color=_OBSTACLE))
    return entity(t, "obstacles", cubes=cubes, cylinders=cylinders)


def prior_topology_entity(t: float, world: Any) -> SceneEntity:
    """The prior map as a graph (what routes are planned on without a built topology): a node per
    place at its point, an edge through each door's centre between the places it joins."""
    pairs = []
    for door in world.doors.values():
        a, b = (world.places[name].point for name in door.between)
        pairs += [(a, door.center), (door.center, b)]
    return entity(t, "topology", lines=[_segments(pairs, _TOPOLOGY, 0.04)] if pairs else [],
                  spheres=[_sphere(place.point, 0.25, _TOPOLOGY) for place in world.places.values()])


def topology_entity(t: float, topology: Any, every: int = 3) -> SceneEntity:
    """A topology built from the grid (Layer III): each edge along its skeleton cells (every
    ``every``-th cell), each node a sphere named by its place or its kind (X, T, L)."""
    frame = topology.frame
    pairs = []
    for u, v, data in topology.graph.edges(data=True):
        cells = np.asarray(data["cells"], dtype=float).reshape(-1, 2)
        if len(cells):
            keep = np.unique(np.r_[np.arange(0, len(cells), every), len(cells) - 1])
            xs, ys = frame.cell_to_world(cells[keep, 0], cells[keep, 1])
            line = [topology.graph.nodes[data["head"]]["xy"], *zip(np.atleast_1d(xs), np.atleast_1d(ys))]
            other = v if data["head"] == u else u
            line.append(topology.graph.nodes[other]["xy"])
        else:
            line = [topology.graph.nodes[u]["xy"], topology.graph.nodes[v]["xy"]]
        pairs += list(zip(line[:-1], line[1:]))
    spheres, texts = [], []
    for _, data in topology.graph.nodes(data=True):
        spheres.append(_sphere(data["xy"], 0.25, _TOPOLOGY))
        texts.append(_label(data["xy"], topology.place_name(data["place"]) if data.get("place") else data["kind"],
                            0.25))
    return entity(t, "topology", lines=[_segments(pairs, _TOPOLOGY, 0.04)] if pairs else [], spheres=spheres,
                  texts=texts)


def route_entity(t: float, route: Any) -> SceneEntity:
    """The route ``navigate-to`` is driving: its waypoints as a line, the ones still ahead as dots,
    named ``route to GOAL (by WHO)``."""
    points = [_point(p) for p in route.waypoints]
    ahead = route.waypoints[route.index:]
    label = f"route to {route.goal}" + (f" (by {route.by})" if route.by else "")
    return entity(t, "route",
                  lines=[LinePrimitive(type=LinePrimitiveLineType.LineStrip, thickness=0.06, color=_ROUTE,
                                       points=points)],
                  spheres=[_sphere(p, 0.15, _ROUTE) for p in ahead],
                  texts=[_label(route.waypoints[-1], label, 0.3)])


def log_line(record: Mapping[str, Any]) -> Log:
    """A trace record as a Foxglove log line: ``name`` the event, ``message`` the record's other
    fields as compact JSON (what ``--trace`` writes, less ``t`` and ``event``); failures are
    errors, preemptions, halts and failed plan steps warnings, the rest info."""
    event = record["event"]
    rest = {key: value for key, value in record.items() if key not in ("t", "event")}
    level = (LogLevel.Error if event in _ERROR_EVENTS else
             LogLevel.Warning if event in _WARNING_EVENTS else LogLevel.Info)
    return Log(timestamp=timestamp(record["t"]), level=level, name=event,
               message=json.dumps(rest, separators=(",", ":"), default=str))

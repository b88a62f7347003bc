"""Beliefs: the named, typed state that skills and the ATLAS layers share.

A data flow between skills goes through the skill manager's wires (a
skill's outputs to the inputs of the same name). What is not a data flow,
but something the robot *believes* (the doors it saw closed, the
occupancy grid it is building, the topology made from it, the route it is
following, the place it is going to) lives in :class:`Beliefs`, under a
:class:`Belief` key that names it and says its type. A key is a module
constant, so a reader finds every producer and consumer by searching for
it, and a wrong value is refused where it is written, not where it is read:

    from atlas_rap.skills.beliefs import GRID
    context.beliefs[GRID] = OccupancyGrid.covering(bounds)   # checked
    grid = context.beliefs.get(GRID)                          # OccupancyGrid | None

The keys the toolkit uses are declared here with the small value types that
have no other home (:class:`Goal`, :class:`FollowedRoute`,
:class:`PlannedRoute`, :class:`RouteSource`, :class:`Sighting`,
:class:`ObjectDevices`). This is ROS's parameter /
blackboard idea with a type per key, like BehaviorTree.CPP's typed ports.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Generic, Protocol, TypeVar

from atlas_rap.model import Point

T = TypeVar("T")


@dataclass(frozen=True, slots=True, eq=False)
class Belief(Generic[T]):
    """The key of one belief: its name (for messages) and the type its value must have."""

    name: str
    kind: type | tuple[type, ...] | str
    doc: str = ""

    def admits(self, value: object) -> bool:
        """Whether ``value`` has the belief's type (a ``"module:Class"`` kind is matched by
        name, so declaring it does not import a heavy module)."""
        if isinstance(self.kind, str):
            return any(f"{k.__module__}:{k.__qualname__}" == self.kind for k in type(value).__mro__)
        return isinstance(value, self.kind)

    def __repr__(self) -> str:
        return f"<Belief {self.name}>"


class Beliefs:
    """The beliefs of one robot: :class:`Belief` key → value, type-checked on write."""

    def __init__(self) -> None:
        self._values: dict[Belief[Any], Any] = {}

    def __getitem__(self, key: Belief[T]) -> T:
        try:
            return self._values[key]
        except KeyError:
            raise KeyError(f"no belief {key.name} yet") from None

    def get(self, key: Belief[T], default: T | None = None) -> T | None:
        return self._values.get(key, default)

    def __setitem__(self, key: Belief[T], value: T) -> None:
        if not isinstance(key, Belief):
            raise TypeError(f"beliefs are keyed by Belief constants, not {key!r}")
        if value is not None and not key.admits(value):
            raise TypeError(f"belief {key.name} holds {_kind_name(key.kind)}, not {type(value).__name__}")
        self._values[key] = value

    def setdefault(self, key: Belief[T], value: T) -> T:
        if key not in self._values:
            self[key] = value
        return self._values[key]

    def pop(self, key: Belief[T], default: T | None = None) -> T | None:
        return self._values.pop(key, default)

    def __contains__(self, key: object) -> bool:
        return key in self._values

    def __repr__(self) -> str:
        return f"<Beliefs {', '.join(key.name for key in self._values)}>"


def _kind_name(kind: type | tuple[type, ...] | str) -> str:
    if isinstance(kind, str):
        return kind.rpartition(":")[2]
    kinds = kind if isinstance(kind, tuple) else (kind,)
    return " or ".join(k.__name__ for k in kinds)


# -- values -----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Goal:
    """Where the robot is going: a named place and its point (set by ``navigate-to``)."""

    place: str
    point: Point


@dataclass(frozen=True, slots=True)
class PlannedRoute:
    """A route a planner made: waypoints to drive, the doors on it (door → index of the
    last waypoint before it, for routes on the prior map) and who planned it."""

    waypoints: tuple[Point, ...]
    doors: dict[str, int] = field(default_factory=dict)
    by: str = ""


@dataclass(slots=True)
class FollowedRoute:
    """The route being driven now and the index of the waypoint being driven to."""

    goal: str
    waypoints: tuple[Point, ...]
    index: int = 0
    by: str = ""
    doors: dict[str, int] = field(default_factory=dict)

    @property
    def next_point(self) -> Point:
        return self.waypoints[min(self.index, len(self.waypoints) - 1)]


class RouteSource(Protocol):
    """Who plans routes for ``navigate-to``: the prior map, a topology, or the ATLAS layers.

    ``revision`` grows whenever the source has a better route than it gave
    before (a re-plan on a new grid, a re-route round a block): the skill
    then asks again. :meth:`route` returns a route, or the reason there is none.
    """

    revision: int

    def route(self, goal: str, start: Point, closed: set[str]) -> PlannedRoute | str:
        """A route from ``start`` to the place ``goal`` avoiding ``closed`` doors, or why not."""


@dataclass(frozen=True, slots=True)
class Sighting:
    """An object as the colour camera last saw it: its colour and kind, where it was on the
    robot's map (``x``, ``y``, from the believed pose, and the ``place`` there), its bearing
    (radians from the heading, counter-clockwise) and range (metres) then, and when (``time``)."""

    name: str
    colour: str
    kind: str
    x: float
    y: float
    place: str | None
    bearing: float
    range: float
    time: float


@dataclass(frozen=True, eq=False)
class PoseEstimate:
    """Where the robot believes it is, as the localiser (:mod:`atlas_rap.skills.localising`) has it at
    ``time``: the ``pose`` (x, y, heading), its 3 x 3 ``covariance`` (m², rad²; ROS's
    ``PoseWithCovariance`` in the plane), the ``particles`` (n x 3; None when the pose is not
    estimated: odometry without noise is the pose) and whether the robot counts as ``localised``."""

    time: float
    pose: tuple[float, float, float]
    covariance: Any
    particles: Any = None
    localised: bool = True


class ObjectDevices(Protocol):
    """The robot's colour camera and gripper on the world's objects (in a simulated world,
    :class:`atlas_rap.sim.objects.ObjectSim`): what the camera skill looks with and the
    handling skills pick up and drop with. Refusals come back as the reason, in words."""

    def look(self, fov: float, max_range: float) -> list:
        """What the camera sees now: views with ``name``, ``colour``, ``kind``, ``bearing``, ``range``."""

    def why_not_pick_up(self, name: str, reach: float) -> str | None:
        """Why the gripper cannot pick up ``name`` now (None: it can)."""

    def pick_up(self, name: str, reach: float) -> str | None:
        """Take ``name`` into the gripper; None when done, else why not."""

    def why_not_drop(self, name: str, bin_name: str, reach: float) -> str | None:
        """Why the gripper cannot drop ``name`` into ``bin_name`` now (None: it can)."""

    def drop(self, name: str, bin_name: str, reach: float) -> str | None:
        """Drop ``name`` into the bin ``bin_name``; None when done, else why not."""


# -- the keys ---------------------------------------------------------------------------

POSE: Belief[tuple] = Belief("pose", tuple, "(x, y, heading) the robot believes it has (the localiser's estimate)")
POSE_ESTIMATE: Belief[PoseEstimate] = Belief("pose-estimate", PoseEstimate,
                                             "the localiser's belief: pose, covariance, particles, localised or not")
LOCALISATION: Belief[str] = Belief("localisation", str, "how the localiser knows the pose: 'mcl' (default: the "
                                                        "filter on a prior map, or without one the odometry "
                                                        "corrected against the grid) or 'odometry' (dead "
                                                        "reckoning; atlas run --localisation)")
POSE_TRACK: Belief[list] = Belief("pose-track", list, "the believed poses (t, x, y, heading) so far, every period of the localiser")
SONAR: Belief[tuple] = Belief("sonar", tuple, "the latest sonar ring: (ranges from the rim, body-frame angles)")
BUMP: Belief[tuple] = Belief("bump", tuple, "the latest contact the bumper felt: (time, body-frame angle)")
CLOSED_DOORS: Belief[set] = Belief("closed-doors", set, "door names seen closed (door monitor); routes avoid them")
GRID: Belief[Any] = Belief("grid", "atlas_rap.maps.grid:OccupancyGrid", "the occupancy grid built from sonar (Layer IV)")
POSES: Belief[list] = Belief("poses", list, "the believed poses the grid was built from")
TOPOLOGY: Belief[Any] = Belief("topology", "atlas_rap.maps.topology:Topology", "the topological map (Layer III, or atlas run --map)")
GOAL: Belief[Goal] = Belief("goal", Goal, "where navigate-to is taking the robot")
ROUTE: Belief[FollowedRoute] = Belief("route", FollowedRoute, "the route navigate-to is driving")
ROUTES: Belief[Any] = Belief("routes", object, "the RouteSource navigate-to asks (default: the prior map)")
OBSTACLE: Belief[tuple] = Belief("obstacle", tuple, "(x, y) of the obstacle in the robot's way (Layer I)")
REFLEXES: Belief[bool] = Belief("reflexes", bool, "False when Layer I is not enabled: no slowing, stopping, backing off")
HOLD: Belief[str] = Belief("hold", str, "why Layer I holds the robot still (absent: not held)")
SPEED_LIMIT: Belief[float] = Belief("speed-limit", float, "the fraction of top speed motion skills may use")
OBJECTS: Belief[Any] = Belief("objects", object, "the camera and gripper on the world's objects (ObjectDevices; "
                                                 "absent in a world without objects)")
SIGHTINGS: Belief[dict] = Belief("sightings", dict, "object name → its latest Sighting by the colour camera")

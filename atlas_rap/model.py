"""What a world is: walls, named places, doors, disturbances, objects, the robot and its sonar.

These frozen dataclasses are the contract between the world files
(``sim.world`` reads YAML into them), the physics (``sim.physics`` builds a
pymunk space from them), the skills (which plan routes over places and
doors) and the pictures (``views.world_render``). Units are SI: metres, seconds,
radians; angles are counter-clockwise from the +x axis.

The robot's *prior map* is the places and doors with their connections
(:meth:`World.facts` puts it in RAP memory); the walls are only known to
the physics and, through the sonar, to the maps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

Point = tuple[float, float]


@dataclass(frozen=True, slots=True)
class Segment:
    """A wall segment from ``a`` to ``b``."""

    a: Point
    b: Point

    @property
    def length(self) -> float:
        return math.dist(self.a, self.b)

    @property
    def midpoint(self) -> Point:
        return ((self.a[0] + self.b[0]) / 2, (self.a[1] + self.b[1]) / 2)


@dataclass(frozen=True, slots=True)
class Place:
    """A named place RAPs refer to, e.g. ``office``.

    ``point`` is where the robot goes when told to go there; ``region`` (a
    polygon, counter-clockwise or not) is the area that counts as being
    there. A place without a region is a point place: within ``radius``
    of ``point`` counts.
    """

    name: str
    point: Point
    region: tuple[Point, ...] | None = None
    radius: float = 0.5

    def contains(self, x: float, y: float) -> bool:
        """Whether (x, y) is in this place."""
        if self.region is None:
            return math.dist((x, y), self.point) <= self.radius
        return _inside(self.region, x, y)


@dataclass(frozen=True, slots=True)
class Door:
    """A doorway between two places: a door that can be open or closed, or a plain opening.

    ``center`` is the middle of the doorway; ``segment`` the door leaf that
    blocks it when closed (None for an opening that is always open).
    ``openable`` doors can be opened by the robot (an automatic door with a
    button); others only by the world's ``schedule``, a tuple of
    ``(time, is_open)`` changes.
    """

    name: str
    between: tuple[str, str]
    center: Point
    segment: Segment | None = None
    open: bool = True
    openable: bool = False
    schedule: tuple[tuple[float, bool], ...] = ()

    def side_points(self, clearance: float = 0.7) -> tuple[Point, Point]:
        """Two points ``clearance`` metres either side of the doorway, on its normal.

        Which is which: the first is on the side of ``between[0]`` when the
        world file's places say so (the route planner sorts that out); for
        an opening without a segment both are the centre.
        """
        if self.segment is None:
            return self.center, self.center
        (ax, ay), (bx, by) = self.segment.a, self.segment.b
        length = math.hypot(bx - ax, by - ay) or 1.0
        nx, ny = -(by - ay) / length, (bx - ax) / length
        cx, cy = self.center
        return (cx + nx * clearance, cy + ny * clearance), (cx - nx * clearance, cy - ny * clearance)


@dataclass(frozen=True, slots=True)
class Disturbance:
    """Something the world does to the robot at a time: a person crossing, a box left behind.

    ``kind`` is ``person`` (a moving disc along ``path`` at ``speed``,
    present from ``start`` to ``end``: short-lived) or ``box`` (a square of
    side ``size`` at ``path[0]`` from ``start``, until ``end`` or for ever
    when ``end`` is None: long-lived).
    """

    name: str
    kind: str
    start: float
    path: tuple[Point, ...]
    end: float | None = None
    size: float = 0.5
    speed: float = 0.8


OBJECT_KINDS = ("object", "trash", "bin")
"""What an object can be: a thing to find (``object``), a piece of ``trash`` the gripper can pick
up, or a ``bin`` trash is dropped into (bins stay where they are)."""


@dataclass(frozen=True, slots=True)
class ObjectMove:
    """The world moving an object (someone picks it up and puts it elsewhere): the object is
    at ``to`` from time ``at``, or from the moment the robot first comes within ``near``
    metres of it. Exactly one of ``at`` and ``near`` is given. A move happens only to an
    object lying on the floor: not to one in the robot's gripper or in a bin.
    """

    to: Point
    at: float | None = None
    near: float | None = None


@dataclass(frozen=True, slots=True)
class WorldObject:
    """A coloured object on the floor, seen by the colour camera: a ball to find, trash, a bin.

    ``position`` is where it starts; ``size`` its width (for pictures and reach);
    ``moves`` the world's changes to where it is, in order. Objects are not
    bodies of the physics: the robot drives over them and the sonar does not
    see them; walls and closed doors hide them from the camera.
    """

    name: str
    colour: str
    position: Point
    kind: str = "object"
    size: float = 0.25
    moves: tuple[ObjectMove, ...] = ()


@dataclass(frozen=True, slots=True)
class OdometryNoise:
    """How the robot's odometry errs: the four noise parameters of a differential-drive motion
    model, named and ordered as AMCL's ``alpha1``-``alpha4`` (Thrun, Burgard and Fox,
    *Probabilistic Robotics*, odometry motion model): which motion makes which error.

    Here each is the standard deviation of a random walk after one unit of motion (1 rad
    turned, 1 m travelled), growing with the square root of the motion, because the
    simulator adds the errors step by step and variances add. AMCL scales its alphas by
    each update's whole motion instead, so its numbers do not carry over unchanged. The
    simulator's odometry (:class:`~atlas_rap.sim.sensors.Odometry`) draws each step's errors
    from these; all four zero (:attr:`off`): the odometry is the true pose.
    """

    alpha1: float = 0.0  # rotation noise from rotation: std (rad) after 1 rad turned, growing with sqrt
    alpha2: float = 0.0  # rotation noise from translation: std (rad) after 1 m travelled
    alpha3: float = 0.0  # translation noise from translation: std (m) after 1 m travelled
    alpha4: float = 0.0  # translation noise from rotation: std (m) after 1 rad turned

    @property
    def off(self) -> bool:
        """All four zero: odometry is the true pose (and the simulator draws no random numbers for it)."""
        return not (self.alpha1 or self.alpha2 or self.alpha3 or self.alpha4)

    @classmethod
    def drift(cls, d: float) -> OdometryNoise:
        """The old single-number model (``odometry_drift: d``): ``d`` of turn per radian turned and of
        travel per metre travelled, no cross terms (alpha1 = alpha3 = d, alpha2 = alpha4 = 0)."""
        return cls(alpha1=float(d), alpha3=float(d))


DEFAULT_ODOMETRY_NOISE = OdometryNoise(alpha1=0.02, alpha2=0.005, alpha3=0.02, alpha4=0.005)
"""The robot's odometry noise when a world says nothing: about 2 cm per metre driven and 1 degree
per radian turned (after 1 m or 1 rad), a well-calibrated differential drive on a good floor."""

NO_ODOMETRY_NOISE = OdometryNoise()
"""Odometry that is the true pose (``odometry_noise: off`` in a world file)."""


@dataclass(frozen=True, slots=True)
class Teleport:
    """A kidnap: at time ``at`` the world puts the robot at ``to`` = (x, y, heading), without telling
    its odometry (which goes on from where it believed it was)."""

    at: float
    to: tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class RobotConfig:
    """The robot: a disc of ``radius`` starting at ``start`` = (x, y, heading), its odometry erring by
    ``odometry_noise`` (:data:`DEFAULT_ODOMETRY_NOISE` unless a world says otherwise), and the world's
    ``teleports`` of it, in time order."""

    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 0.2
    max_speed: float = 0.6
    max_turn_rate: float = 2.0
    odometry_noise: OdometryNoise = DEFAULT_ODOMETRY_NOISE
    teleports: tuple[Teleport, ...] = ()


@dataclass(frozen=True, slots=True)
class SonarConfig:
    """The sonar ring: ``count`` transducers evenly spaced around the robot, the first facing forward."""

    count: int = 16
    beam_width: float = math.radians(15.0)
    max_range: float = 5.0
    min_range: float = 0.05
    range_noise: float = 0.01  # std in metres, plus ``range_noise_per_m`` per metre of range
    range_noise_per_m: float = 0.01
    specular_angle: float = math.radians(60.0)  # beyond this angle between beam and wall normal...
    specular_dropout: float = 0.8  # ...a reading is lost (max range) with this probability
    rays_per_beam: int = 3
    rate: float = 10.0  # readings per second


@dataclass(frozen=True, slots=True)
class World:
    """A whole world: geometry, named places and doors, disturbances, robot and sonar settings.

    ``bounds`` is (xmin, ymin, xmax, ymax) around everything, ``margin``
    metres of it beyond the walls, places and start (the room a grid over the
    bounds leaves for the sonar's cones past the outer walls; nothing stands
    there): :attr:`extent` is the box they lie in. ``source`` is the file it
    was read from (for messages and pictures). ``objects`` are the coloured
    things on the floor (the simulation's truth, not the prior map).
    """

    name: str
    walls: tuple[Segment, ...]
    places: dict[str, Place]
    doors: dict[str, Door] = field(default_factory=dict)
    disturbances: tuple[Disturbance, ...] = ()
    robot: RobotConfig = RobotConfig()
    sonar: SonarConfig = SonarConfig()
    bounds: tuple[float, float, float, float] = (0.0, 0.0, 10.0, 10.0)
    source: str = ""
    objects: dict[str, WorldObject] = field(default_factory=dict)
    margin: float = 0.0

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the area itself: the bounds less their ``margin``."""
        xmin, ymin, xmax, ymax = self.bounds
        m = self.margin
        return xmin + m, ymin + m, xmax - m, ymax - m

    def place_shapes(self) -> dict[str, tuple[Point, ...] | Point]:
        """Each place's region (a polygon), or its point when it has none: what names a map's places."""
        return {name: place.region if place.region is not None else place.point for name, place in self.places.items()}

    def without_map(self) -> World:
        """What a robot with no prior map knows of this world: the names and points of its
        places (as point places), the extent of the area, its own body and sonar; no walls,
        no doors, no regions, no objects (``atlas run --no-prior-map``)."""
        places = {name: Place(name, place.point, None, place.radius) for name, place in self.places.items()}
        return World(self.name, (), places, {}, (), self.robot, self.sonar, self.bounds, self.source,
                     margin=self.margin)

    def place_at(self, x: float, y: float) -> str | None:
        """The first place (in file order) that contains (x, y), or None."""
        for place in self.places.values():
            if place.contains(x, y):
                return place.name
        return None


def _inside(polygon: tuple[Point, ...], x: float, y: float) -> bool:
    """Even-odd rule point-in-polygon test."""
    inside = False
    n = len(polygon)
    for i in range(n):
        (x1, y1), (x2, y2) = polygon[i], polygon[(i + 1) % n]
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside

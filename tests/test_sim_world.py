"""World files: the shipped worlds load and can be driven; bad world files get located, helpful errors."""

from __future__ import annotations

import math
import re
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest

from atlas_rap.errors import AtlasError, Problem, SourceError
from atlas_rap.maps.rosmap import FREE, OCCUPIED, UNKNOWN, write_ros_map
from atlas_rap.model import Door, Segment, World
from atlas_rap.sim.world import load_world, shipped_worlds

SHIPPED = ("lab-corridor-office", "office-building", "maze", "small-office-map")
ROUTE_MARGIN = 0.15  # what routes must keep from walls beyond the robot's radius
SIDE = 0.7  # how far in front of a door the route planner puts its waypoints


# -- geometry, in plain numpy ---------------------------------------------------

def _as_array(segments: list[Segment]) -> np.ndarray:
    return np.array([(s.a[0], s.a[1], s.b[0], s.b[1]) for s in segments], dtype=float).reshape(-1, 4)


def _point_distances(p: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Distances from point ``p`` to each segment row (x1, y1, x2, y2) of ``ends``."""
    a, b = ends[:, :2], ends[:, 2:]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(axis=1) / np.maximum((ab * ab).sum(axis=1), 1e-18), 0.0, 1.0)
    return np.hypot(*(p - (a + t[:, None] * ab)).T)


def segment_clearance(p: tuple[float, float], q: tuple[float, float], ends: np.ndarray) -> tuple[float, int]:
    """Smallest distance between segment p-q and the segments ``ends``, and the index of the nearest."""
    if len(ends) == 0:
        return math.inf, -1
    p_, q_ = np.asarray(p, float), np.asarray(q, float)
    a, b = ends[:, :2], ends[:, 2:]

    def cross(o: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return (u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1]) - (u[..., 1] - o[..., 1]) * (v[..., 0] - o[..., 0])

    d1, d2 = cross(a, b, p_), cross(a, b, q_)
    d3, d4 = cross(p_, q_, a), cross(p_, q_, b)
    crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
    pq = np.array([[*p_, *q_]])
    distances = np.minimum.reduce([
        _point_distances(p_, ends), _point_distances(q_, ends),
        np.array([_point_distances(x, pq)[0] for x in a]), np.array([_point_distances(x, pq)[0] for x in b]),
    ])
    distances[crossing] = 0.0
    index = int(np.argmin(distances))
    return float(distances[index]), index


def oriented_side_points(world: World, door: Door, place: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """The door's side points as (on ``place``'s side, on the other side): the one in or nearer the place first."""
    a, b = door.side_points(SIDE)
    here = world.places[place]
    if here.contains(*b) and not here.contains(*a):
        return b, a
    if not here.contains(*a) and math.dist(b, here.point) < math.dist(a, here.point):
        return b, a
    return a, b


def route_problems(world: World) -> list[str]:
    """Every place of the routes through doors that comes closer than radius + margin to a wall or another leaf.

    Checked: for each door D between A and B, A.point -> D's side point on A's
    side -> D.center -> side point on B's side -> B.point (the brief); for each
    place, the straight lines between its doors' side points and from the
    robot's start to its place's doors (what the route planner drives).
    """
    need = world.robot.radius + ROUTE_MARGIN
    walls = list(world.walls)
    leaves = {d.name: d.segment for d in world.doors.values() if d.segment is not None}
    problems: list[str] = []

    def check(p, q, what: str, own: set[str]) -> None:
        obstacles = walls + [leaf for name, leaf in leaves.items() if name not in own]
        gap, index = segment_clearance(p, q, _as_array(obstacles))
        if gap < need - 1e-9:
            problems.append(f"{what}: {p} -> {q} passes {gap:.3f} m from {obstacles[index]} (needs {need:.2f})")

    for door in world.doors.values():
        a, b = door.between
        side_a, _ = oriented_side_points(world, door, a)
        side_b, _ = oriented_side_points(world, door, b)
        path = [world.places[a].point, side_a, door.center, side_b, world.places[b].point]
        for p, q in pairwise(path):
            check(p, q, f"door {door.name}", {door.name})
    start = world.robot.start[:2]
    start_place = world.place_at(*start)
    for place in world.places:
        sides = [(d.name, oriented_side_points(world, d, place)[0]) for d in world.doors.values() if place in d.between]
        for i, (name1, p) in enumerate(sides):
            for name2, q in sides[i + 1:]:
                check(p, q, f"across {place} from {name1} to {name2}", set())
            if place == start_place:
                check(start, p, f"from the start to {name1}", set())
    return problems


def unreachable(world: World) -> set[str]:
    """Places that cannot be reached from the first place through doors and openings."""
    if not world.places:
        return set()
    first = next(iter(world.places))
    seen, todo = {first}, [first]
    while todo:
        here = todo.pop()
        for door in world.doors.values():
            if here in door.between:
                other = door.between[1] if door.between[0] == here else door.between[0]
                if other not in seen:
                    seen.add(other)
                    todo.append(other)
    return set(world.places) - seen


# -- the shipped worlds ------------------------------------------------------------

@pytest.fixture(scope="module", params=SHIPPED)
def shipped(request) -> World:
    return load_world(request.param)


def test_every_shipped_world_is_listed() -> None:
    assert set(SHIPPED) <= set(shipped_worlds())


def test_shipped_world_loads_with_places_walls_and_doors(shipped: World) -> None:
    assert shipped.walls and shipped.places and shipped.doors
    xmin, ymin, xmax, ymax = shipped.bounds
    for wall in shipped.walls:
        for x, y in (wall.a, wall.b):
            assert xmin < x < xmax and ymin < y < ymax
    for place in shipped.places.values():
        assert place.contains(*place.point), place.name
    assert shipped.place_at(*shipped.robot.start[:2]) is not None, "the robot starts in a place"


def test_shipped_world_routes_keep_clear_of_walls(shipped: World) -> None:
    problems = route_problems(shipped)
    assert not problems, "\n".join(problems)


def test_shipped_world_places_are_all_connected(shipped: World) -> None:
    assert not unreachable(shipped)


def test_shipped_world_door_side_points_are_in_their_places(shipped: World) -> None:
    for door in shipped.doors.values():
        if door.segment is None:
            continue
        for place in door.between:
            mine, other = oriented_side_points(shipped, door, place)
            region = shipped.places[place]
            assert region.contains(*mine), f"{door.name}: side point {mine} is not in {place}"
            assert not region.contains(*other), f"{door.name}: both side points are in {place}"


def test_default_world_is_the_seeds_lab_corridor_office() -> None:
    world = load_world("lab-corridor-office")
    assert {"lab", "corridor", "office"} <= set(world.places)
    assert world.doors["lab-door"].between == ("lab", "corridor") and world.doors["lab-door"].open
    assert world.doors["office-door"].between == ("corridor", "office") and world.doors["office-door"].open
    assert world.place_at(*world.robot.start[:2]) == "lab"
    assert {d.kind for d in world.disturbances} == {"person", "box"}
    person = next(d for d in world.disturbances if d.kind == "person")
    assert person.end is not None and person.end - person.start < 60


def test_lab_corridor_office_has_a_second_way_into_the_office() -> None:
    world = load_world("lab-corridor-office")
    without = World(world.name, world.walls, world.places,
                    {n: d for n, d in world.doors.items() if n != "office-door"})
    assert not unreachable(without)


def test_office_building_has_a_door_on_a_schedule() -> None:
    world = load_world("office-building")
    assert len(world.places) >= 6
    assert any(d.schedule for d in world.doors.values())
    assert "elevator-lobby" in world.places


def test_maze_delivers_coffee_from_kitchen_to_office_through_openings() -> None:
    world = load_world("maze")
    assert {"kitchen", "office"} <= set(world.places)
    assert any(d.segment is None for d in world.doors.values())


def test_angles_are_degrees_in_the_file_and_radians_in_the_model(tmp_path: Path) -> None:
    world = write_and_load(tmp_path, """
robot: {start: [1, 1, 90], max_turn_rate_deg: 90}
sonar: {beam_width_deg: 30, specular_angle_deg: 45, count: 8}
""")
    assert world.robot.start == pytest.approx((1, 1, math.pi / 2))
    assert world.robot.max_turn_rate == pytest.approx(math.pi / 2)
    assert world.sonar.beam_width == pytest.approx(math.radians(30))
    assert world.sonar.specular_angle == pytest.approx(math.pi / 4)
    assert world.sonar.count == 8


def test_a_world_file_by_path_with_polygons_polylines_and_a_computed_door_center(tmp_path: Path) -> None:
    world = write_and_load(tmp_path, """
name: box
polygons: [[[0, 0], [4, 0], [4, 4], [0, 4]]]
walls:
  - [2, 0, 2, 1.5]
  - [[2, 2.5], [2, 4]]
places:
  west: {point: [1, 2], region: [[0, 0], [2, 0], [2, 4], [0, 4]]}
  east: {point: [3, 2]}
doors:
  gap: {between: [west, east], segment: [2, 1.5, 2, 2.5], schedule: [[10, closed], [20, open]]}
""")
    assert world.name == "box"
    assert len(world.walls) == 4 + 1 + 1
    door = world.doors["gap"]
    assert door.center == (2.0, 2.0) and door.schedule == ((10.0, False), (20.0, True))
    assert world.places["east"].region is None and world.places["east"].radius == 0.5
    assert world.bounds == (-1.0, -1.0, 5.0, 5.0)


def test_unknown_world_name_lists_the_shipped_worlds() -> None:
    with pytest.raises(AtlasError) as caught:
        load_world("mazee")
    text = str(caught.value)
    assert "no shipped world named 'mazee'" in text and "did you mean 'maze'" in text
    for name in SHIPPED:
        assert name in text


def test_a_missing_world_file_is_a_located_error(tmp_path: Path) -> None:
    with pytest.raises(SourceError) as caught:
        load_world(tmp_path / "nowhere.yaml")
    assert "no such file" in str(caught.value)


# -- errors in world files ----------------------------------------------------------

def write_and_load(tmp_path: Path, text: str, name: str = "world.yaml") -> World:
    path = tmp_path / name
    path.write_text(text.lstrip("\n"), encoding="utf-8")
    return load_world(path)


def problems_of(tmp_path: Path, text: str) -> list[Problem]:
    with pytest.raises(SourceError) as caught:
        write_and_load(tmp_path, text)
    print(caught.value)  # shown when a test fails
    return caught.value.problems


def at(problem: Problem) -> tuple[int, int]:
    return problem.location.line, problem.location.column


ROOMS = """
walls: [[0, 0, 6, 0], [6, 0, 6, 4], [6, 4, 0, 4], [0, 4, 0, 0], [3, 0, 3, 1.5], [3, 2.5, 3, 4]]
places:
  office: {point: [1.5, 2], region: [[0, 0], [3, 0], [3, 4], [0, 4]]}
  lab: {point: [4.5, 2], region: [[3, 0], [6, 0], [6, 4], [3, 4]]}
"""


def test_unknown_key_is_located_with_a_hint(tmp_path: Path) -> None:
    [problem] = problems_of(tmp_path, ROOMS + """doors:
  office-door:
    betwen: [office, lab]
    segment: [3, 1.5, 3, 2.5]
""")
    assert "unknown key 'betwen' in doors.office-door" in problem.message
    assert at(problem) == (7, 5)
    assert "did you mean 'between'?" in problem.hint
    assert problem.location.file.endswith("world.yaml")
    assert "^" in problem.render() and "betwen: [office, lab]" in problem.render()


def test_unknown_top_level_key_suggests_the_right_one(tmp_path: Path) -> None:
    [problem] = problems_of(tmp_path, "place:\n  a: {point: [0, 0]}\n")
    assert "unknown key 'place'" in problem.message and "'places'" in problem.hint
    assert at(problem) == (1, 1)


def test_door_between_an_unknown_place_names_the_key_path(tmp_path: Path) -> None:
    [problem] = problems_of(tmp_path, ROOMS + """doors:
  office-door: {between: [ofice, lab], segment: [3, 1.5, 3, 2.5]}
""")
    assert problem.message == "no place named 'ofice'"
    assert at(problem) == (6, 27)
    assert "did you mean 'office'?" in problem.hint


def test_wall_with_three_numbers(tmp_path: Path) -> None:
    [problem] = problems_of(tmp_path, "walls:\n  - [0, 0, 4, 0]\n  - [0, 0, 4]\n")
    assert "walls[1] must be [x1, y1, x2, y2]" in problem.message and "not 3" in problem.message
    assert at(problem) == (3, 5)


def test_bad_yaml_syntax_is_a_located_source_error_not_a_traceback(tmp_path: Path) -> None:
    [problem] = problems_of(tmp_path, "places:\n  lab: {point: [1, 2]\n  office: {point: [3, 4]}\n")
    assert problem.message.startswith("YAML syntax:")
    assert problem.location.line in (2, 3)
    assert problem.source_line is not None


def test_bad_indentation_is_a_located_source_error(tmp_path: Path) -> None:
    [problem] = problems_of(tmp_path, "robot:\n  radius: 0.2\n max_speed: 0.5\n")
    assert problem.message.startswith("YAML syntax:") and problem.location.line == 3


def test_every_problem_is_reported_not_only_the_first(tmp_path: Path) -> None:
    problems = problems_of(tmp_path, ROOMS + """doors:
  d1: {between: [office, attic], segment: [3, 1.5, 3, 2.5]}
robot: {radius: -1, max_sped: 2}
sonar: {count: 2.5}
""")
    messages = [p.message for p in problems]
    assert any("no place named 'attic'" in m for m in messages)
    assert any("robot.radius must be more than 0" in m for m in messages)
    assert any("unknown key 'max_sped'" in m for m in messages)
    assert any("sonar.count must be a whole number" in m for m in messages)
    assert len(problems) == 4


def test_wrong_types_and_shapes(tmp_path: Path) -> None:
    problems = problems_of(tmp_path, """
places:
  lab: {point: [1, two]}
  hall: [1, 2]
doors: [a, b]
disturbances:
  - {kind: cat, path: [[1, 1]]}
  - {kind: person, path: [[1, 1]], start: 5, end: 2}
""")
    text = "\n".join(p.render() for p in problems)
    assert "places.lab.point[1] must be a number, not 'two'" in text
    assert "places.hall must be a mapping" in text
    assert "doors must be a mapping" in text
    assert "unknown disturbance kind 'cat'" in text
    assert "disturbances[1].path needs at least 2 points" in text
    assert "disturbances[1].end (2) must be after its start (5)" in text


def test_place_point_too_close_to_a_wall(tmp_path: Path) -> None:
    [problem] = problems_of(tmp_path, """
walls: [[0, 0, 4, 0]]
places:
  nook: {point: [1, 0.2]}
""")
    assert "the point of place 'nook' is 0.20 m from a wall" in problem.message
    assert "[0, 0, 4, 0] from line 1" in problem.message
    assert at(problem) == (3, 17)


def test_place_point_outside_its_region_and_a_bad_place_name(tmp_path: Path) -> None:
    problems = problems_of(tmp_path, """
places:
  Lab Room: {point: [5, 5], region: [[0, 0], [1, 0], [1, 1]]}
""")
    text = "\n".join(p.render() for p in problems)
    assert "'Lab Room' cannot be a place name" in text and "'lab-room'" in text
    assert "outside its region" in text


def test_door_schedule_must_be_in_time_order_and_say_open_or_closed(tmp_path: Path) -> None:
    problems = problems_of(tmp_path, ROOMS + """doors:
  d: {between: [office, lab], segment: [3, 1.5, 3, 2.5], schedule: [[20, closed], [10, ajar]]}
""")
    text = "\n".join(p.message for p in problems)
    assert "doors.d.schedule[1][1] must be open or closed" in text
    assert "comes before the change above it" in text


def test_an_opening_needs_a_center_and_cannot_close(tmp_path: Path) -> None:
    problems = problems_of(tmp_path, ROOMS + """doors:
  gap: {between: [office, lab]}
  arch: {between: [office, lab], center: [3, 2], open: false}
""")
    text = "\n".join(p.message for p in problems)
    assert "doors.gap needs a center" in text
    assert "door 'arch' has no segment" in text


def test_robot_starting_inside_a_wall(tmp_path: Path) -> None:
    [problem] = problems_of(tmp_path, "walls: [[0, 0, 4, 0]]\nrobot:\n  start: [1, 0.1]\n")
    assert "the robot starts 0.10 m from a wall" in problem.message
    assert at(problem) == (3, 10)
    x, y = suggested_point(problem)
    assert y >= 0.2 + 0.15 and abs(x - 1) < 0.5
    write_and_load(tmp_path, f"walls: [[0, 0, 4, 0]]\nrobot:\n  start: [{x}, {y}]\n")  # the hint works


def test_duplicate_keys_are_reported(tmp_path: Path) -> None:
    [problem] = problems_of(tmp_path, "places:\n  a: {point: [0, 0]}\n  a: {point: [1, 1]}\n")
    assert "key 'a' appears twice in places (first at line 2)" in problem.message
    assert at(problem) == (3, 3)


@pytest.mark.parametrize("text, expected", [
    ("", "file is empty"),
    ("- just\n- a list\n", "the file must be a mapping"),
    ("walls: [[0, 0, 1, 1]]\nwalls: []\n", "appears twice"),
    ("robot: {start: !!python/object:os.system [1, 2]}\n", "unsupported YAML tag"),
    ("places: {a: {point: [.nan, 0]}}\n", "finite"),
    ("\ttabs: 1\n", "YAML syntax"),
    ('name: "a\x01b"\n', "is not allowed here"),
    ("name: a\n---\nname: b\n", "YAML syntax"),
])
def test_files_that_are_not_worlds_never_give_a_traceback(tmp_path: Path, text: str, expected: str) -> None:
    problems = problems_of(tmp_path, text) if text else None
    if problems is None:
        (tmp_path / "world.yaml").write_text("")
        with pytest.raises(SourceError) as caught:
            load_world(tmp_path / "world.yaml")
        problems = caught.value.problems
    assert any(expected in p.message for p in problems), [p.message for p in problems]


# -- worlds from ROS maps -----------------------------------------------------------

def test_a_world_whose_walls_come_from_a_ros_map(tmp_path: Path) -> None:
    grid = np.zeros((40, 60), dtype=np.int8)  # 3 m x 2 m at 0.05 m; row 0 at the top
    grid[:, :2] = grid[:, -2:] = grid[:2, :] = grid[-2:, :] = 100  # outer walls
    grid[:, 29:31] = 100  # a dividing wall at x = 1.5 m ...
    grid[14:26, 29:31] = 0  # ... with a doorway from y = 0.7 to 1.3
    (tmp_path / "maps").mkdir()
    write_ros_map(tmp_path / "maps" / "two-rooms.yaml", grid, 0.05, (0.0, 0.0, 0.0))
    world = write_and_load(tmp_path, """
map: maps/two-rooms.yaml
places:
  west: {point: [0.75, 1.0], region: [[0, 0], [1.5, 0], [1.5, 2], [0, 2]]}
  east: {point: [2.25, 1.0], region: [[1.5, 0], [3, 0], [3, 2], [1.5, 2]]}
doors:
  doorway: {between: [west, east], center: [1.5, 1.0]}
robot: {start: [0.5, 0.5, 0]}
""")
    ends = np.array([(*w.a, *w.b) for w in world.walls])
    # The outlines run along the occupied cells' outer edges: the map's edges here.
    assert ends[:, [0, 2]].min() == pytest.approx(0.0) and ends[:, [0, 2]].max() == pytest.approx(3.0)
    assert ends[:, [1, 3]].min() == pytest.approx(0.0) and ends[:, [1, 3]].max() == pytest.approx(2.0)
    # Every wall vertex is on the outline of an occupied cell ...
    for x, y in ends.reshape(-1, 2):
        row, col = round(39.5 - y / 0.05), round(x / 0.05 - 0.5)
        near = grid[max(row - 1, 0):row + 2, max(col - 1, 0):col + 2]
        assert (near == 100).any(), (x, y)
    # ... the doorway is free (nothing near the way through it) and the dividing wall is not.
    gap, _ = segment_clearance((1.0, 1.0), (2.0, 1.0), ends)
    assert gap >= 0.25
    gap, _ = segment_clearance((1.0, 0.4), (2.0, 0.4), ends)
    assert gap == 0.0


def test_a_world_whose_map_is_missing_or_broken(tmp_path: Path) -> None:
    problems = problems_of(tmp_path, "map: nowhere.yaml\n")
    assert problems[0].message == "map file 'nowhere.yaml' not found" and at(problems[0]) == (1, 6)
    (tmp_path / "bad.yaml").write_text("image: bad.pgm\nresolution: 0\norigin: [0, 0, 0]\n"
                                       "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    problems = problems_of(tmp_path, "map: bad.yaml\n")
    rendered = "\n".join(p.render() for p in problems)
    assert "bad.yaml:2:13: error: resolution must be more than 0" in rendered
    assert "image file 'bad.pgm' not found" in rendered
    assert "world.yaml:1:6: error: the map 'bad.yaml' has problems" in rendered


TURTLEBOT = Path(__file__).resolve().parents[2] / "shared" / "data" / "maps" / "turtlebot3_world.yaml"


def test_a_world_on_the_turtlebot3_map(tmp_path: Path) -> None:
    if not TURTLEBOT.is_file():
        pytest.skip(f"optional data not here: {TURTLEBOT}")
    world = write_and_load(tmp_path, f"map: {TURTLEBOT}\nplaces:\n  start: {{point: [-2.0, -0.5]}}\n"
                                     "robot: {start: [-2.0, -0.5, 0]}\n")
    assert len(world.walls) > 50
    xmin, ymin, xmax, ymax = world.bounds
    assert -10 <= xmin < xmax <= 10.5 and -10 <= ymin < ymax <= 10.5


def test_the_route_check_catches_an_opening_whose_routes_cut_a_corner(tmp_path: Path) -> None:
    # Two doorways in the same wall as openings: the route between them runs along the wall.
    world = write_and_load(tmp_path, """
walls: [[0, 0, 6, 0], [6, 0, 6, 6], [6, 6, 0, 6], [0, 6, 0, 0], [0, 3, 1, 3], [2, 3, 4, 3], [5, 3, 6, 3]]
places:
  south: {point: [3, 1.5], region: [[0, 0], [6, 0], [6, 3], [0, 3]]}
  north: {point: [3, 4.5], region: [[0, 3], [6, 3], [6, 6], [0, 6]]}
doors:
  west-gap: {between: [south, north], center: [1.5, 3]}
  east-gap: {between: [south, north], center: [4.5, 3]}
""")
    problems = route_problems(world)
    assert any("across south from west-gap to east-gap" in p for p in problems), problems
    assert not unreachable(world)


# -- where the robot starts -----------------------------------------------------------

SMALL_OFFICE = Path(__file__).resolve().parents[1] / "worlds" / "small-office-map.yaml"


def suggested_point(problem: Problem) -> tuple[float, float]:
    """The (x, y) that a start problem's hint proposes."""
    found = re.search(r"with room for the robot is at \((-?[\d.]+), (-?[\d.]+)\)", problem.hint or "")
    assert found, problem.hint
    return float(found.group(1)), float(found.group(2))


def small_office_starting_at(start: str) -> str:
    """The shipped small-office-map world with another robot.start, its map named by absolute path."""
    text = SMALL_OFFICE.read_text(encoding="utf-8")
    assert "  start: [1.5, 1.5, 0]\n" in text and "map: maps/small-office-map.yaml\n" in text
    text = text.replace("  start: [1.5, 1.5, 0]\n", f"  start: {start}\n")
    return text.replace("map: maps/small-office-map.yaml", f"map: {SMALL_OFFICE.parent / 'maps/small-office-map.yaml'}")


def start_line(text: str) -> int:
    return next(i for i, line in enumerate(text.split("\n"), 1) if line.strip().startswith("start:"))


def test_a_robot_starting_in_the_unknown_outside_a_map_building_is_refused_at_robot_start(tmp_path: Path) -> None:
    # West of the building's outer wall (x = 0) the image is unknown grey; 0.25 m from the wall outline,
    # more than the robot's radius, so the wall check alone let it through.
    text = small_office_starting_at("[-0.3, 4, 0]")
    [problem] = problems_of(tmp_path, text)
    assert problem.location.file.endswith("world.yaml") and at(problem) == (start_line(text), 10)
    assert "robot.start (-0.3, 4) is on an unknown cell of the map" in problem.message
    assert "small-office-map.pgm" in problem.message
    assert "^" in problem.render() and "start: [-0.3, 4, 0]" in problem.render()
    assert problem.hint.startswith("move robot.start into free space; the nearest free cell")
    x, y = suggested_point(problem)
    assert 0 < x < 1 and 3 < y < 5  # just inside, in hall-west
    world = write_and_load(tmp_path, small_office_starting_at(f"[{x}, {y}, 0]"))
    assert world.place_at(x, y) == "hall-west"


def thick_walled_map(tmp_path: Path) -> Path:
    """A 4 m x 3 m room (free) with a 1 m x 1 m solid pillar, inside a 5 m x 3 m image whose east metre is unknown."""
    grid = np.full((60, 100), UNKNOWN, dtype=np.int8)  # 0.05 m cells; row 0 at the top (y = 3)
    grid[:, :80] = OCCUPIED
    grid[2:58, 2:78] = FREE  # walls 0.1 m thick round x 0..4, y 0..3
    grid[20:40, 50:70] = OCCUPIED  # the pillar: x 2.5..3.5, y 1..2
    (tmp_path / "maps").mkdir(exist_ok=True)
    write_ros_map(tmp_path / "maps" / "pillar.yaml", grid, 0.05, (0.0, 0.0, 0.0))
    return tmp_path / "maps" / "pillar.yaml"


PILLAR_WORLD = """
map: maps/pillar.yaml
places:
  room: {point: [1, 1.5], region: [[0, 0], [4, 0], [4, 3], [0, 3]]}
"""


def test_a_robot_starting_inside_a_thick_wall_of_the_map_image_is_refused(tmp_path: Path) -> None:
    thick_walled_map(tmp_path)
    [problem] = problems_of(tmp_path, PILLAR_WORLD + "robot: {start: [3, 1.5, 90]}\n")
    assert at(problem) == (4, 16)
    assert "robot.start (3, 1.5) is on an occupied cell of the map 'maps/pillar.yaml'" in problem.message
    assert "(pixel x=60, y=29 of pillar.pgm)" in problem.message
    x, y = suggested_point(problem)
    assert math.dist((x, y), (3, 1.5)) < 1.0
    world = write_and_load(tmp_path, PILLAR_WORLD + f"robot: {{start: [{x}, {y}, 90]}}\n")
    assert world.robot.start[:2] == (x, y)


def test_a_robot_starting_on_an_unknown_cell_or_off_the_map_is_refused(tmp_path: Path) -> None:
    thick_walled_map(tmp_path)
    [problem] = problems_of(tmp_path, PILLAR_WORLD + "robot: {start: [4.6, 1.5]}\n")
    assert "robot.start (4.6, 1.5) is on an unknown cell" in problem.message and at(problem) == (4, 16)
    [problem] = problems_of(tmp_path, PILLAR_WORLD + "robot: {start: [12, 1.5]}\n")
    assert "robot.start (12, 1.5) is outside the map 'maps/pillar.yaml', which covers x 0 to 5, y 0 to 3" \
        in problem.message
    x, y = suggested_point(problem)
    assert 3.5 < x < 4 and 0 < y < 3


def test_without_robot_start_the_first_place_must_be_in_free_space(tmp_path: Path) -> None:
    thick_walled_map(tmp_path)
    [problem] = problems_of(tmp_path, "map: maps/pillar.yaml\nplaces:\n  porch: {point: [4.6, 1.5]}\n")
    assert at(problem) == (3, 18)  # the point the robot starts at
    assert "the robot starts at the point of place 'porch' (4.6, 1.5) (there is no robot.start), " \
           "which is on an unknown cell" in problem.message
    assert problem.hint.startswith("add robot.start: [x, y, heading_deg] in free space")


def test_a_robot_starting_inside_a_solid_polygon_is_refused(tmp_path: Path) -> None:
    # The pillar's edges are 1 m from the start: no wall is closer than the robot's radius.
    world = """
polygons:
  - [[0, 0], [8, 0], [8, 4], [0, 4]]     # the room: the places are in it
  - [[5, 1], [7, 1], [7, 3], [5, 3]]     # a pillar: nothing is
places:
  lab: {point: [2, 2]}
"""
    [problem] = problems_of(tmp_path, world + "robot: {start: [6, 2, 0]}\n")
    assert at(problem) == (6, 16)
    assert "robot.start (6, 2) is inside polygons[1] (line 3), a closed outline with no place in it" \
        in problem.message
    x, y = suggested_point(problem)
    assert not (5 < x < 7 and 1 < y < 3)
    assert write_and_load(tmp_path, world + f"robot: {{start: [{x}, {y}, 0]}}\n").robot.start[:2] == (x, y)
    assert write_and_load(tmp_path, world + "robot: {start: [3, 2, 0]}\n")  # in the room, outside the pillar


def test_a_variant_of_a_world_whose_robot_starts_off_the_free_space_is_refused(tmp_path: Path) -> None:
    thick_walled_map(tmp_path)
    (tmp_path / "base.yaml").write_text(PILLAR_WORLD.lstrip("\n") + "robot: {start: [3, 1.5]}\n")
    (tmp_path / "variant.yaml").write_text("base: base.yaml\nname: pillar-variant\n")
    with pytest.raises(SourceError) as caught:
        load_world(tmp_path / "variant.yaml")
    print(caught.value)
    first, last = caught.value.problems
    assert first.location.file.endswith("base.yaml") and at(first) == (4, 16)
    assert "is on an occupied cell of the map 'maps/pillar.yaml'" in first.message
    assert last.location.file.endswith("variant.yaml") and at(last) == (1, 7)
    assert last.message == "the base world 'base.yaml' has problems (above)"


def test_a_variant_whose_base_is_unknown_or_missing_is_located_at_base(tmp_path: Path) -> None:
    [problem] = problems_of(tmp_path, "base: mazee\n")
    assert problem.message == "no shipped world named 'mazee'; did you mean 'maze'?" and at(problem) == (1, 7)
    assert "small-office-map" in problem.hint
    [problem] = problems_of(tmp_path, "base: nowhere.yaml\n")
    assert problem.message == "base world file 'nowhere.yaml' not found" and at(problem) == (1, 7)


def test_a_world_whose_map_names_a_world_file_says_so(tmp_path: Path) -> None:
    problems = problems_of(tmp_path, f"map: {SMALL_OFFICE}\n")
    rendered = "\n".join(p.render() for p in problems)
    assert "small-office-map.yaml:22:1: error: this is a world file, not a ROS map YAML" in rendered
    assert "world.yaml:1:6: error: the map" in rendered


def test_shipped_worlds_start_the_robot_on_a_free_cell_of_their_maps() -> None:
    from atlas_rap.maps.rosmap import load_ros_map

    world = load_world("small-office-map")
    rosmap = load_ros_map(SMALL_OFFICE.parent / "maps" / "small-office-map.yaml")
    assert rosmap.label_at(*world.robot.start[:2]) == FREE


# -- variants that cut openings and add walls ------------------------------------------------------


def test_a_variant_cuts_openings_in_its_base_walls_and_adds_walls_of_its_own(tmp_path: Path) -> None:
    (tmp_path / "rooms.yaml").write_text(ROOMS.lstrip("\n"))
    (tmp_path / "variant.yaml").write_text(
        "base: rooms.yaml\nname: rooms-opened\n"
        "openings: [[6, 1, 6, 2], [0.5, 0, 1.5, 0]]\n"   # two gaps: the east wall and the south wall
        "walls: [[[6, 1], [8, 1], [8, 2], [6, 2]]]\n")   # a closet beyond the east gap
    base, world = load_world(tmp_path / "rooms.yaml"), load_world(tmp_path / "variant.yaml")
    segments = {(s.a, s.b) for s in world.walls}
    assert ((6.0, 0.0), (6.0, 1.0)) in segments and ((6.0, 2.0), (6.0, 4.0)) in segments
    assert ((0.0, 0.0), (0.5, 0.0)) in segments and ((1.5, 0.0), (6.0, 0.0)) in segments
    assert ((8.0, 1.0), (8.0, 2.0)) in segments
    assert len(world.walls) == len(base.walls) + 2 + 3  # two walls cut in two, three walls added
    assert world.bounds[2] == 8 + 1.0  # the added walls widen the box round the world
    assert world.places == base.places and world.doors == base.doors


def test_an_opening_along_no_wall_and_an_added_wall_through_a_place_are_refused(tmp_path: Path) -> None:
    (tmp_path / "rooms.yaml").write_text(ROOMS.lstrip("\n"))
    problems = problems_of(tmp_path, "base: rooms.yaml\nopenings: [[2, 2, 2.5, 2]]\nwalls: [[1.3, 1.9, 1.3, 2.1]]\n")
    messages = [p.message for p in problems]
    assert "the opening [2, 2, 2.5, 2] lies along no wall of rooms" in messages[0] and at(problems[0]) == (2, 12)
    assert messages[1].startswith("this wall passes 0.20 m from the point of place 'office'") and at(problems[1]) == (3, 9)

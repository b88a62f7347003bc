"""ROS map_server maps: nav2's conventions, round trips through write_ros_map, wall outlines, bad maps."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from atlas_rap.errors import SourceError
from atlas_rap.maps.rosmap import FREE, OCCUPIED, UNKNOWN, RosMap, load_ros_map, wall_segments, write_ros_map

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "maps"


def map_yaml(tmp_path: Path, image: str = "map.pgm", **keys: object) -> Path:
    """A map YAML with the usual keys, overridden (or removed, with None) by ``keys``."""
    fields: dict[str, object] = {"image": image, "resolution": 0.1, "origin": "[0.0, 0.0, 0.0]", "negate": 0,
                                 "occupied_thresh": 0.65, "free_thresh": 0.196}
    fields.update(keys)
    path = tmp_path / "map.yaml"
    path.write_text("".join(f"{k}: {v}\n" for k, v in fields.items() if v is not None))
    return path


def p2(tmp_path: Path, rows: list[list[int]], maxval: int = 255, name: str = "map.pgm") -> None:
    """An ASCII PGM with a comment in its header."""
    body = "\n".join(" ".join(str(v) for v in row) for row in rows)
    (tmp_path / name).write_text(f"P2\n# made by a test\n{len(rows[0])} {len(rows)}\n{maxval}\n{body}\n")


# -- nav2's conventions -----------------------------------------------------------------

def test_pixel_shades_become_probabilities_and_trinary_labels(tmp_path: Path) -> None:
    p2(tmp_path, [[0, 254, 205], [255, 100, 170]])
    rosmap = load_ros_map(map_yaml(tmp_path))
    # occupancy = (255 - p) / 255: 1.0, 0.004, 0.196 (unknown), 0.0, 0.608 (unknown), 0.333 (unknown)
    assert rosmap.labels.tolist() == [[OCCUPIED, FREE, UNKNOWN], [FREE, UNKNOWN, UNKNOWN]]
    assert rosmap.occupancy.dtype == np.float32 and rosmap.labels.dtype == np.int8
    assert rosmap.occupancy[0, 0] == pytest.approx(1.0) and rosmap.occupancy[0, 1] == pytest.approx(1 / 255)
    assert rosmap.occupancy[1, 0] == 0.0
    assert np.isnan(rosmap.occupancy[0, 2]) and np.isnan(rosmap.occupancy[1, 1])


def test_negate_swaps_black_and_white(tmp_path: Path) -> None:
    p2(tmp_path, [[0, 255, 128]])
    rosmap = load_ros_map(map_yaml(tmp_path, negate=1))
    assert rosmap.labels.tolist() == [[FREE, OCCUPIED, UNKNOWN]]
    assert rosmap.occupancy[0, 1] == pytest.approx(1.0) and rosmap.negate


def test_thresholds_are_strict_as_in_nav2(tmp_path: Path) -> None:
    # With a maximum value of 4 the occupancies 1, 0.75, 0.5, 0.25, 0 are exact.
    p2(tmp_path, [[0, 1, 2, 3, 4]], maxval=4)
    rosmap = load_ros_map(map_yaml(tmp_path, occupied_thresh=0.75, free_thresh=0.25))
    assert rosmap.labels.tolist() == [[OCCUPIED, UNKNOWN, UNKNOWN, UNKNOWN, FREE]]


def test_scale_and_raw_modes(tmp_path: Path) -> None:
    p2(tmp_path, [[0, 254, 128, 255]])
    scale = load_ros_map(map_yaml(tmp_path, mode="scale", occupied_thresh=0.9, free_thresh=0.1))
    occupancy = (255 - 128) / 255
    assert scale.labels.tolist() == [[OCCUPIED, FREE, round((occupancy - 0.1) / 0.8 * 100), FREE]]
    assert scale.occupancy[0, 2] == pytest.approx(occupancy)
    p2(tmp_path, [[0, 42, 100, 101, 255]])
    raw = load_ros_map(map_yaml(tmp_path, mode="raw"))
    assert raw.labels.tolist() == [[0, 42, 100, UNKNOWN, UNKNOWN]]
    assert raw.occupancy[0, 1] == pytest.approx(0.42) and np.isnan(raw.occupancy[0, 3])


def test_sixteen_bit_and_binary_pgm(tmp_path: Path) -> None:
    p2(tmp_path, [[0, 65535]], maxval=65535)
    assert load_ros_map(map_yaml(tmp_path)).labels.tolist() == [[OCCUPIED, FREE]]
    (tmp_path / "map.pgm").write_bytes(b"P5 3 1 255\n" + bytes([0, 254, 205]))
    assert load_ros_map(map_yaml(tmp_path)).labels.tolist() == [[OCCUPIED, FREE, UNKNOWN]]


def test_a_single_occupied_pixel_at_the_bottom_left_lands_at_the_origin(tmp_path: Path) -> None:
    grid = np.zeros((4, 5), dtype=np.int8)
    grid[-1, 0] = OCCUPIED  # the last row is the bottom of the image
    write_ros_map(tmp_path / "map.yaml", grid, 0.5, (-2.0, 3.0, 0.0))
    rosmap = load_ros_map(tmp_path / "map.yaml")
    assert rosmap.origin == (-2.0, 3.0, 0.0)
    assert rosmap.cell_to_world(3, 0) == pytest.approx((-1.75, 3.25))
    assert rosmap.cell_to_world(0, 4) == pytest.approx((0.25, 4.75))  # top right
    assert rosmap.world_to_cell(-1.9, 3.1) == (3, 0)
    assert rosmap.world_to_cell(0.2, 4.9) == (0, 4)
    assert not rosmap.contains_cell(*rosmap.world_to_cell(-2.1, 3.1))
    assert rosmap.extent == pytest.approx((-2.0, 3.0, 0.5, 5.0))
    ends = np.array([(*s.a, *s.b) for s in wall_segments(rosmap)]).reshape(-1, 2)
    assert len(ends) >= 6
    assert ends[:, 0].min() == pytest.approx(-2.0) and ends[:, 0].max() == pytest.approx(-1.5)
    assert ends[:, 1].min() == pytest.approx(3.0) and ends[:, 1].max() == pytest.approx(3.5)


def test_cell_to_world_and_back_with_a_yawed_origin() -> None:
    labels = np.zeros((3, 4), dtype=np.int8)
    rosmap = RosMap(labels.astype(np.float32), labels, 1.0, (10.0, 0.0, math.pi / 2))
    # Yaw 90 degrees: the image's columns run up +y, its rows (upwards) run along -x.
    assert rosmap.cell_to_world(2, 0) == pytest.approx((9.5, 0.5))
    assert rosmap.cell_to_world(2, 3) == pytest.approx((9.5, 3.5))
    assert rosmap.cell_to_world(0, 0) == pytest.approx((7.5, 0.5))
    rows, cols = np.mgrid[0:3, 0:4]
    xs, ys = rosmap.cell_to_world(rows, cols)
    back_rows, back_cols = rosmap.world_to_cell(xs, ys)
    assert (back_rows == rows).all() and (back_cols == cols).all()


# -- writing ---------------------------------------------------------------------

@pytest.mark.parametrize("image_format", ["pgm", "png"])
def test_labels_read_back_identically(tmp_path: Path, image_format: str) -> None:
    rng = np.random.default_rng(7)
    labels = rng.choice(np.array([FREE, OCCUPIED, UNKNOWN], dtype=np.int8), size=(23, 31))
    image = write_ros_map(tmp_path / "lab.yaml", labels, 0.05, (1.0, -2.0), image_format=image_format)
    assert image == tmp_path / f"lab.{image_format}" and image.is_file()
    rosmap = load_ros_map(tmp_path / "lab.yaml")
    assert np.array_equal(rosmap.labels, labels)
    assert rosmap.resolution == 0.05 and rosmap.origin == (1.0, -2.0, 0.0)
    assert (rosmap.occupancy[labels == OCCUPIED] == 1.0).all()
    assert np.isnan(rosmap.occupancy[labels == UNKNOWN]).all()


def test_probabilities_read_back_to_within_a_grey_level(tmp_path: Path) -> None:
    probabilities = np.array([[0.0, 0.1, 0.9, 1.0], [np.nan, 0.05, 0.99, 0.4]])
    write_ros_map(tmp_path / "p.yaml", probabilities, 0.1, (0.0, 0.0, 0.0))
    rosmap = load_ros_map(tmp_path / "p.yaml")
    assert rosmap.labels.tolist() == [[FREE, FREE, OCCUPIED, OCCUPIED], [UNKNOWN, FREE, OCCUPIED, UNKNOWN]]
    known = rosmap.labels != UNKNOWN
    assert np.abs(rosmap.occupancy[known] - probabilities[known]).max() <= 0.5 / 255 + 1e-6


def test_writing_rejects_what_is_not_a_map(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="labels must be 0, 100 or -1"):
        write_ros_map(tmp_path / "m.yaml", np.array([[0, 50]]), 0.1, (0, 0))
    with pytest.raises(ValueError, match="2-D"):
        write_ros_map(tmp_path / "m.yaml", np.zeros(4), 0.1, (0, 0))
    with pytest.raises(ValueError, match="resolution"):
        write_ros_map(tmp_path / "m.yaml", np.zeros((2, 2), dtype=bool), 0.0, (0, 0))


def test_wall_segments_outline_occupied_blocks(tmp_path: Path) -> None:
    grid = np.zeros((20, 20), dtype=bool)
    grid[5:10, 4:16] = True  # a 1.2 m x 0.5 m block at 0.1 m per cell
    write_ros_map(tmp_path / "m.yaml", grid, 0.1, (0.0, 0.0, 0.0))
    segments = wall_segments(load_ros_map(tmp_path / "m.yaml"))
    ends = np.array([(*s.a, *s.b) for s in segments]).reshape(-1, 2)
    assert ends[:, 0].min() == pytest.approx(0.4) and ends[:, 0].max() == pytest.approx(1.6)
    assert ends[:, 1].min() == pytest.approx(1.0) and ends[:, 1].max() == pytest.approx(1.5)
    # The outline follows the cells' edges, its corners cut by half a cell at 45 degrees.
    assert sum(s.length for s in segments) == pytest.approx(2 * (1.2 + 0.5) - 4 * (0.1 - 0.05 * math.sqrt(2)))
    assert len(wall_segments(load_ros_map(tmp_path / "m.yaml"), tolerance=0.2)) <= len(segments)
    empty = np.zeros((3, 3), dtype=bool)
    write_ros_map(tmp_path / "e.yaml", empty, 0.1, (0, 0))
    assert wall_segments(load_ros_map(tmp_path / "e.yaml")) == []


# -- maps that are not maps --------------------------------------------------------

def only(caught: pytest.ExceptionInfo[SourceError]) -> list[tuple[str, int, int]]:
    print(caught.value)
    return [(p.message, p.location.line, p.location.column) for p in caught.value.problems]


def test_a_yaml_that_is_not_a_mapping(tmp_path: Path) -> None:
    (tmp_path / "map.yaml").write_text("- image\n- resolution\n")
    with pytest.raises(SourceError) as caught:
        load_ros_map(tmp_path / "map.yaml")
    [(message, line, column)] = only(caught)
    assert "must be a mapping" in message and (line, column) == (1, 1)


def test_missing_keys_and_bad_values_are_located(tmp_path: Path) -> None:
    p2(tmp_path, [[0]])
    path = map_yaml(tmp_path, resolution=-0.1, free_thresh=0.7, origin="[0, 0]", occupied_thresh=None, mode="binary")
    with pytest.raises(SourceError) as caught:
        load_ros_map(path)
    found = only(caught)
    assert ("resolution must be more than 0, not -0.1", 2, 13) in found
    assert any(m.startswith("origin must be [x, y, yaw]") and (line, col) == (3, 9) for m, line, col in found)
    assert any("missing the key 'occupied_thresh'" in m and line == 1 for m, line, _ in found)
    assert any("unknown mode 'binary'" in m for m, _, _ in found)
    text = str(caught.value)
    assert "map.yaml:2:13: error:" in text and "    resolution: -0.1" in text


def test_thresholds_out_of_order(tmp_path: Path) -> None:
    p2(tmp_path, [[0]])
    with pytest.raises(SourceError) as caught:
        load_ros_map(map_yaml(tmp_path, occupied_thresh=0.3, free_thresh=0.6))
    [(message, line, column)] = only(caught)
    assert "free_thresh (0.6) must be less than occupied_thresh (0.3)" in message and (line, column) == (6, 14)
    assert "0.196" in caught.value.problem.hint


def test_missing_or_unreadable_image(tmp_path: Path) -> None:
    with pytest.raises(SourceError) as caught:
        load_ros_map(map_yaml(tmp_path, image="nowhere.pgm"))
    [(message, line, column)] = only(caught)
    assert "image file 'nowhere.pgm' not found" in message and (line, column) == (1, 8)
    (tmp_path / "junk.png").write_bytes(b"this is not a picture")
    with pytest.raises(SourceError) as caught:
        load_ros_map(map_yaml(tmp_path, image="junk.png"))
    assert "cannot read image 'junk.png'" in only(caught)[0][0]
    (tmp_path / "short.pgm").write_bytes(b"P5 10 10 255\n" + bytes(5))
    with pytest.raises(SourceError) as caught:
        load_ros_map(map_yaml(tmp_path, image="short.pgm"))
    assert "truncated" in only(caught)[0][0]


def test_yaml_syntax_error_in_a_map(tmp_path: Path) -> None:
    (tmp_path / "map.yaml").write_text("image: map.pgm\norigin: [0, 0, 0\nresolution: 0.1\n")
    with pytest.raises(SourceError) as caught:
        load_ros_map(tmp_path / "map.yaml")
    [(message, line, _)] = only(caught)
    assert message.startswith("YAML syntax") and line in (2, 3)


# -- real maps (optional data) -------------------------------------------------------

def test_the_turtlebot3_world_map() -> None:
    if not (DATA / "turtlebot3_world.yaml").is_file():
        pytest.skip(f"optional data not here: {DATA}")
    rosmap = load_ros_map(DATA / "turtlebot3_world.yaml")
    assert rosmap.labels.shape == (384, 384) and rosmap.resolution == 0.05
    assert rosmap.origin == (-10.0, -10.0, 0.0)
    assert set(np.unique(rosmap.labels)) == {FREE, OCCUPIED, UNKNOWN}
    segments = wall_segments(rosmap)
    assert len(segments) > 50
    xs = [x for s in segments for x in (s.a[0], s.b[0])]
    assert -10 <= min(xs) < max(xs) <= 10 - 10 + 384 * 0.05


def test_the_willow_garage_map_loads_its_soft_walls_as_unknown() -> None:
    if not (DATA / "willow-2010-02-18-0.10.yaml").is_file():
        pytest.skip(f"optional data not here: {DATA}")
    rosmap = load_ros_map(DATA / "willow-2010-02-18-0.10.yaml")
    assert rosmap.labels.shape == (608, 566)
    assert (rosmap.labels == UNKNOWN).sum() > (rosmap.labels == OCCUPIED).sum()


# -- a world file, or some other YAML, where a map was wanted ----------------------------

WORLDS = Path(__file__).resolve().parents[1] / "worlds"


def test_a_world_file_with_a_map_image_points_to_its_map(tmp_path: Path) -> None:
    (tmp_path / "maps").mkdir()
    write_ros_map(tmp_path / "maps" / "floor.yaml", np.zeros((10, 10), dtype=np.int8), 0.1, (0, 0, 0))
    (tmp_path / "world.yaml").write_text("name: floor\n# the walls\nmap: maps/floor.yaml\nrobot: {start: [0.5, 0.5]}\n")
    with pytest.raises(SourceError) as caught:
        load_ros_map(tmp_path / "world.yaml", "world.yaml")
    [(message, line, column)] = only(caught)
    assert message == "this is a world file, not a ROS map YAML; the map it names is 'maps/floor.yaml'"
    assert (line, column) == (3, 1)
    hint = caught.value.problem.hint
    assert hint == "give that map instead: maps/floor.yaml"
    assert load_ros_map(tmp_path / hint.split(": ")[1]).labels.shape == (10, 10)  # and that is the map


def test_the_shipped_map_world_points_to_its_map() -> None:
    with pytest.raises(SourceError) as caught:
        load_ros_map(WORLDS / "small-office-map.yaml")
    assert "this is a world file" in caught.value.problem.message
    map_yaml = Path(caught.value.problem.hint.split(": ")[1])
    assert map_yaml == WORLDS / "maps" / "small-office-map.yaml" and load_ros_map(map_yaml).width == 220


def test_a_world_file_without_a_map_image_says_how_to_build_one() -> None:
    with pytest.raises(SourceError) as caught:
        load_ros_map(WORLDS / "maze.yaml", "worlds/maze.yaml")
    problem = caught.value.problem
    assert problem.message == "this is a world file, not a ROS map YAML, and it names no map image (no map: key)"
    assert problem.hint == ("build a map of it with `atlas map build --world worlds/maze.yaml --out maze-map`, "
                            "then give maze-map/occupancy.yaml")
    assert len(caught.value.problems) == 1  # not one "missing the key" per map key


def test_a_world_variant_says_whose_variant_it_is(tmp_path: Path) -> None:
    (tmp_path / "closed.yaml").write_text("name: closed\nbase: lab-corridor-office\ndoors: {lab-door: {open: false}}\n")
    with pytest.raises(SourceError) as caught:
        load_ros_map(tmp_path / "closed.yaml")
    [(message, line, column)] = only(caught)
    assert message == "this is a world file (a variant of 'lab-corridor-office'), not a ROS map YAML"
    assert (line, column) == (2, 1) and "atlas map build --world" in caught.value.problem.hint


def test_a_yaml_that_is_neither_a_map_nor_a_world_says_what_a_map_needs(tmp_path: Path) -> None:
    (tmp_path / "notes.yaml").write_text("title: floor plan\nscale: 1\n")
    with pytest.raises(SourceError) as caught:
        load_ros_map(tmp_path / "notes.yaml")
    [(message, line, column)] = only(caught)
    assert message == "this is not a ROS map_server map YAML: it has none of a map's keys (it has title, scale)"
    assert (line, column) == (1, 1)
    for key in ("image:", "resolution:", "origin: [x, y, yaw]", "occupied_thresh:", "free_thresh:"):
        assert key in caught.value.problem.hint


def test_the_world_keys_it_recognises_are_those_of_world_files() -> None:
    from atlas_rap.maps.rosmap import MAP_KEYS, WORLD_KEYS
    from atlas_rap.sim.world import TOP_KEYS, VARIANT_KEYS

    assert (set(TOP_KEYS) | set(VARIANT_KEYS)) - {"name", "description"} == set(WORLD_KEYS)
    assert not set(WORLD_KEYS) & set(MAP_KEYS)


def test_label_at_and_free_points_near(tmp_path: Path) -> None:
    grid = np.full((10, 10), FREE, dtype=np.int8)  # 1 m x 1 m at 0.1 m
    grid[:, 0] = OCCUPIED  # x 0..0.1
    grid[0, :] = UNKNOWN  # y 0.9..1
    write_ros_map(tmp_path / "map.yaml", grid, 0.1, (0, 0, 0))
    rosmap = load_ros_map(tmp_path / "map.yaml")
    assert rosmap.label_at(0.05, 0.5) == OCCUPIED and rosmap.label_at(0.5, 0.95) == UNKNOWN
    assert rosmap.label_at(0.5, 0.5) == FREE and rosmap.label_at(1.5, 0.5) is None
    points = rosmap.free_points_near(0.05, 0.45, 0.2)
    # Cell centres 0.2 m or more from the cells' edges next to the wall, the unknown row and the map's edges.
    room = {(round(x, 2), round(y, 2)) for x in (0.35, 0.45, 0.55, 0.65, 0.75) for y in (0.25, 0.35, 0.45, 0.55, 0.65)}
    assert {(round(x, 2), round(y, 2)) for x, y in points} == room and len(points) == len(room)
    assert points[0] == pytest.approx((0.35, 0.45))
    distances = [math.dist(p, (0.05, 0.45)) for p in points]
    assert distances == sorted(distances)
    assert len(rosmap.free_points_near(0.05, 0.45, 0.2, count=3)) == 3
    assert rosmap.free_points_near(0.5, 0.5, 2.0) == []

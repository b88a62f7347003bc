"""Pictures of runs (views.world_render): the PNG exists, decodes, shows the path, and is reproducible."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from matplotlib.image import imread

from atlas_rap.model import Door, Place, RobotConfig, Segment, World
from atlas_rap.views.world_render import TaskMark, render_run


def _world() -> World:
    walls = (
        Segment((0, 0), (8, 0)), Segment((8, 0), (8, 5)), Segment((8, 5), (0, 5)), Segment((0, 5), (0, 0)),
        Segment((4, 0), (4, 2)), Segment((4, 3), (4, 5)),  # between the rooms, doorway from y=2 to 3
        Segment((6, 5), (6, 4.2)),
    )
    places = {
        "hall": Place("hall", (2, 2.5), region=((0, 0), (4, 0), (4, 5), (0, 5))),
        "office": Place("office", (6, 2.5), region=((4, 0), (8, 0), (8, 5), (4, 5))),
        "dock": Place("dock", (1, 1), radius=0.4),
    }
    doors = {
        "d1": Door("d1", ("hall", "office"), (4, 2.5), Segment((4, 2), (4, 3)), open=True),
        "d2": Door("d2", ("office", "office"), (7, 5), Segment((6.5, 5), (7.5, 5)), open=False),
        "gap": Door("gap", ("hall", "hall"), (2, 5)),
    }
    return World("test-rooms", walls, places, doors, robot=RobotConfig(start=(1, 1, 0)), bounds=(0, 0, 8, 5))


def _path() -> list[tuple[float, float, float, float]]:
    """From the dock along y = 1 to x = 6, then up to the office point: 0.1 m steps, 0.5 m/s."""
    pts = [(1 + 0.1 * i, 1.0) for i in range(51)] + [(6.0, 1 + 0.1 * i) for i in range(1, 16)]
    out, t = [], 0.0
    for i, (x, y) in enumerate(pts):
        if i:
            t += math.dist(pts[i - 1], (x, y)) / 0.5
        heading = 0.0 if i <= 50 else math.pi / 2
        out.append((t, x, y, heading))
    return out


MARKS = (
    TaskMark(0.0, 1.0, 1.0, "go-to office", "started"),
    TaskMark(13.0, 6.0, 2.5, "go-to office", "succeeded"),
    TaskMark(13.1, 6.0, 2.5, "(open d2)", "failed"),
)


@pytest.fixture(scope="module")
def pictures(tmp_path_factory):
    """The same run drawn with and without its path (rendered once for the module: keeps it fast)."""
    d = tmp_path_factory.mktemp("render")
    world = _world()
    common = {"doors_open": {"d1": True}, "task_marks": MARKS, "title": "deliver.rap, seed 0",
              "obstacles": [("box", (2.5, 4.0), 0.5), ("person", (5.0, 3.8), 0.5)]}
    with_path = render_run(world, d / "with.png", path=_path(), **common)
    without = render_run(world, d / "without.png", **common)
    return world, d, with_path, without


def test_png_exists_decodes_and_is_a_sensible_size(pictures):
    _, _, png, _ = pictures
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = imread(png)
    h, w = img.shape[:2]
    assert 300 <= w <= 3000 and 200 <= h <= 3000
    assert w > h  # the world is wider than tall, and the legend goes beside it
    assert img[..., :3].std() > 0.05  # not a blank canvas


def test_returns_the_path_it_wrote_and_creates_directories(tmp_path):
    out = render_run(_world(), str(tmp_path / "deep" / "er" / "run.png"))
    assert out == tmp_path / "deep" / "er" / "run.png" and out.is_file()


def test_the_path_shows(pictures):
    """The two pictures have the same layout except the colorbar; they differ along the path."""
    _, _, with_path, without = pictures
    a, b = imread(with_path)[..., :3], imread(without)[..., :3]
    # The colorbar makes the picture with the path taller at the bottom; the map part lines up at the top.
    # (the legends may differ in width: compare the common top-left part)
    h, w = min(a.shape[0], b.shape[0]), min(a.shape[1], b.shape[1])
    a, b = a[:h, :w], b[:h, :w]
    diff = np.abs(a - b).sum(axis=2) > 0.1
    assert diff.any()
    # The map: find it from the wall colour (dark) in the path-less picture, then look at the path's
    # straight stretch along y = 1 in metres: between its ends, 20% of the height from the bottom wall.
    dark = b.max(axis=2) < 0.25
    rows, cols = np.nonzero(dark)
    # the outer walls are the longest dark runs: the map box spans these rows and columns
    row_counts = np.bincount(rows, minlength=h)
    col_counts = np.bincount(cols, minlength=w)
    wall_rows = np.nonzero(row_counts > 0.5 * row_counts.max())[0]
    wall_cols = np.nonzero(col_counts > 0.5 * col_counts.max())[0]
    top, bottom = wall_rows.min(), wall_rows.max()
    left, right = wall_cols.min(), wall_cols.max()
    px_per_m = (right - left) / 8.0
    assert abs((bottom - top) / px_per_m - 5.0) < 0.2  # equal aspect: 8 m by 5 m
    y_row = round(bottom - 1.0 * px_per_m)
    x0, x1 = int(left + 2.0 * px_per_m), int(left + 3.5 * px_per_m)  # clear of markers, doors and walls
    band = diff[y_row - 3:y_row + 4, x0:x1]
    assert band.any(axis=0).mean() > 0.9  # the path line runs along the whole stretch
    # and far from the path (the middle of the hall's upper part, away from labels) nothing changes
    quiet = diff[int(top + 0.5 * px_per_m):int(top + 1.5 * px_per_m), int(left + 0.5 * px_per_m):int(left + 1.5 * px_per_m)]
    assert not quiet.any()


def test_rendering_twice_gives_identical_bytes(pictures, tmp_path):
    world, _, first, _ = pictures
    again = render_run(world, tmp_path / "again.png", path=_path(), doors_open={"d1": True}, task_marks=MARKS,
                       title="deliver.rap, seed 0",
                       obstacles=[("box", (2.5, 4.0), 0.5), ("person", (5.0, 3.8), 0.5)])
    assert again.read_bytes() == first.read_bytes()
    assert b"matplotlib" not in first.read_bytes().lower()  # no software version in the file


def test_empty_path_and_nothing_else(tmp_path):
    out = render_run(_world(), tmp_path / "bare.png", path=[])
    img = imread(out)
    assert img.ndim == 3 and img.shape[0] > 100


def test_closed_door_from_doors_open_changes_the_picture(tmp_path):
    world = _world()
    opened = render_run(world, tmp_path / "open.png", doors_open={"d1": True})
    closed = render_run(world, tmp_path / "closed.png", doors_open={"d1": False})
    assert opened.read_bytes() != closed.read_bytes()
    a, b = imread(opened)[..., :3], imread(closed)[..., :3]
    assert a.shape == b.shape
    # a closed door is drawn red: there are more strongly red pixels
    def red(img):
        return ((img[..., 0] > 0.7) & (img[..., 1] < 0.35) & (img[..., 2] < 0.35)).sum()
    assert red(b) > red(a)


def test_awkward_inputs(tmp_path):
    """One-point path, many marks at one spot, labels with $ and parentheses, an empty world."""
    world = _world()
    marks = [TaskMark(float(i), 3.0, 3.0, f"(task-{i} $x$ " + "long " * 20 + ")", kind)
             for i, kind in enumerate(["started", "succeeded", "failed", "other"] * 11)]
    render_run(world, tmp_path / "a.png", path=[(2.0, 3.0, 3.0, 1.0)], task_marks=marks, title="50% $cost$")
    empty = World("nothing", (), {}, bounds=(0, 0, 1, 1))
    render_run(empty, tmp_path / "b.png")
    tall = World("tall", (Segment((0, 0), (0, 50)),), {}, bounds=(0, 0, 0.5, 50))
    img = imread(render_run(tall, tmp_path / "c.png"))
    assert img.shape[1] >= 250  # a thin world still gets a readable width
    assert (tmp_path / "a.png").stat().st_size > 0 and (tmp_path / "b.png").stat().st_size > 0


def test_importing_the_module_does_not_import_matplotlib():
    code = "import sys, atlas_rap.views.world_render; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"

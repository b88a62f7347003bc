"""Pictures of map levels (views.map_render): each writes a decodable, reproducible PNG that shows what it should."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from matplotlib.image import imread
from scipy import ndimage

from atlas_rap.maps.frame import GridFrame
from atlas_rap.views.map_render import (
    MapSheet,
    render_distance_transform,
    render_edges,
    render_grid,
    render_places,
    render_polygons,
    render_route,
    render_stochastic_sdt,
    render_topology,
)

nx = pytest.importorskip("networkx")

# A two-room map, 6 m × 10 m at 0.1 m, its lower-left corner at (-1, -2): rows 0..59, columns 0..99.
FRAME = GridFrame(60, 100, 0.1, (-1.0, -2.0, 0.0))
UNKNOWN_ROWS, UNKNOWN_COLS = slice(40, 57), slice(78, 97)  # an unexplored patch in the right room


def two_rooms() -> np.ndarray:
    p = np.full(FRAME.shape, 0.05)
    p[:2, :] = p[-2:, :] = p[:, :2] = p[:, -2:] = 0.95  # outer walls
    p[:, 49:51] = 0.95  # the wall between the rooms...
    p[24:36, 49:51] = 0.1  # ...with a doorway
    p[10:16, 20:26] = 0.9  # a cupboard in the left room
    p[44:54, 10:30] = np.linspace(0.2, 0.7, 20)  # an uncertain stretch
    p[UNKNOWN_ROWS, UNKNOWN_COLS] = np.nan
    return p


def distance_transform(p: np.ndarray) -> np.ndarray:
    dt = ndimage.distance_transform_edt(~(p >= 0.5)) * FRAME.resolution
    dt[np.isnan(p)] = np.nan
    return dt


def place_labels(p: np.ndarray) -> np.ndarray:
    labels = np.zeros(FRAME.shape, dtype=int)
    labels[2:-2, 2:49] = 1
    labels[2:-2, 51:-2] = 2
    labels[24:36, 49:51] = 3
    labels[p >= 0.5] = 0
    return labels


# The skeleton: a corridor along row 30 and two cross corridors at columns 25 and 75.
SKELETON_LINES = {
    ("c", "a"): [(r, 25) for r in range(5, 31)],
    ("a", "d"): [(r, 25) for r in range(30, 56)],
    ("a", "b"): [(30, c) for c in range(25, 76)],
    ("b", "e"): [(r, 75) for r in range(30, 4, -1)],
    ("b", "f"): [(30, c) for c in range(75, 96)],
}


def skeleton_probability() -> np.ndarray:
    prob = np.full(FRAME.shape, np.nan)
    for cells in SKELETON_LINES.values():
        for r, c in cells:
            prob[r, c] = 0.95
    prob[30, 40:60] = np.linspace(0.9, 0.2, 20)  # less sure through the doorway
    prob[5:12, 75] = 0.45
    return prob


def graph(frame: GridFrame = FRAME):
    g = nx.Graph()
    kinds = {"a": "X", "b": "T", "c": "L", "d": "L", "e": "L", "f": "L"}
    cells_of = {"a": (30, 25), "b": (30, 75), "c": (5, 25), "d": (55, 25), "e": (5, 75), "f": (30, 95)}
    for node, kind in kinds.items():
        g.add_node(node, xy=frame.cell_to_world(*cells_of[node]), kind=kind)
    probabilities = {("c", "a"): 0.9, ("a", "d"): 0.8, ("a", "b"): 0.35, ("b", "e"): 0.55}
    for (u, v), cells in SKELETON_LINES.items():
        attrs = {"cells": cells}
        if (u, v) in probabilities:
            attrs["probability"] = probabilities[(u, v)]
        g.add_edge(u, v, **attrs)  # b-f has no probability
    g.add_node("g", xy=frame.cell_to_world(35, 85), kind="L")
    g.add_edge("f", "g")  # no cells: a straight line
    return g


ROUTE = ["c", "a", "b", "e"]
WAYPOINTS = [(0.0, -1.0), (0.5, 0.8), (4.0, 1.0), (6.0, 1.2), (7.5, 3.0)]


def edge_masks(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    occupied, unknown = p >= 0.5, np.isnan(p)
    free = ~occupied & ~unknown
    occupied_edges = occupied & ndimage.binary_dilation(free)
    empty_edges = free & ndimage.binary_dilation(unknown | occupied)
    return occupied_edges, empty_edges


def polygons() -> list[np.ndarray]:
    room = np.array([[-0.8, -1.8], [3.9, -1.8], [3.9, 3.8], [-0.8, 3.8]])
    return [room, room + [4.9, 0.0], np.array([[4.0, 0.4], [4.2, 0.4], [4.2, 1.6], [4.0, 1.6]]),
            np.array([[1.0, 0.0], [2.5, 0.0], [1.5, 2.0]])]


def _path() -> np.ndarray:
    """A robot path in metres: up the left room's column 10 to row 30, then along row 30 to the right room."""
    return np.array([FRAME.cell_to_world(r, 10) for r in range(50, 29, -1)]
                    + [FRAME.cell_to_world(30, c) for c in range(11, 90)])


def render_all(d) -> dict[str, object]:
    """Every picture of the synthetic map, into the folder d (the tests and the example script use this)."""
    p = two_rooms()
    occupied_edges, empty_edges = edge_masks(p)
    g = graph()
    path = _path()
    return {
        "grid": render_grid(p, FRAME, d / "grid.png", title="two rooms", path_xy=path),
        "grid_bare": render_grid(p, FRAME, d / "grid_bare.png", title="two rooms"),
        "edges": render_edges(occupied_edges, empty_edges, FRAME, d / "edges.png"),
        "polygons": render_polygons(polygons(), FRAME, d / "polygons.png", background=p),
        "dt": render_distance_transform(distance_transform(p), FRAME, d / "dt.png"),
        "places": render_places(place_labels(p), FRAME, d / "places.png",
                                names={1: "hall", 2: "office", 3: "door"}, background=p),
        "sdt": render_stochastic_sdt(skeleton_probability(), FRAME, d / "sdt.png", background=p),
        "topology": render_topology(g, FRAME, d / "topology.png", background=p),
        "topology_route": render_topology(g, FRAME, d / "topology_route.png", background=p, route=ROUTE),
        "route": render_route(p, FRAME, WAYPOINTS, d / "route.png"),
    }


@pytest.fixture(scope="module")
def pictures(tmp_path_factory):
    return render_all(tmp_path_factory.mktemp("map_render"))


def _rgb(png) -> np.ndarray:
    return imread(png)[..., :3]


def _map_box(img: np.ndarray) -> tuple[int, int, int, int]:
    """(top, bottom, left, right) pixel rows / columns of the drawn map: the outer walls in the bare grid."""
    dark = img.max(axis=2) < 0.2
    rows, cols = np.nonzero(dark)
    row_counts, col_counts = np.bincount(rows), np.bincount(cols)
    wall_rows = np.nonzero(row_counts > 0.6 * row_counts.max())[0]
    wall_cols = np.nonzero(col_counts > 0.6 * col_counts.max())[0]
    return wall_rows.min(), wall_rows.max(), wall_cols.min(), wall_cols.max()


def _pixel(img: np.ndarray, box, row: float, col: float) -> np.ndarray:
    """The colour at the centre of grid cell (row, col), given the map's pixel box."""
    top, bottom, left, right = box
    y = top + (row + 0.5) / FRAME.height * (bottom - top)
    x = left + (col + 0.5) / FRAME.width * (right - left)
    return img[int(round(y)), int(round(x))]


def test_every_picture_decodes_and_is_sensible(pictures):
    for name, png in pictures.items():
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
        img = _rgb(png)
        h, w = img.shape[:2]
        assert 300 <= w <= 2000 and 250 <= h <= 2000, (name, img.shape)
        assert img.std() > 0.05, name  # not a blank canvas


def test_same_inputs_same_bytes(pictures, tmp_path):
    p = two_rooms()
    again = {
        "grid": render_grid(p, FRAME, tmp_path / "grid.png", title="two rooms", path_xy=_path()),
        "sdt": render_stochastic_sdt(skeleton_probability(), FRAME, tmp_path / "sdt.png", background=p),
        "topology_route": render_topology(graph(), FRAME, tmp_path / "t.png", background=p, route=ROUTE),
    }
    for name, png in again.items():
        assert png.read_bytes() == pictures[name].read_bytes(), name
    assert b"matplotlib" not in pictures["grid"].read_bytes().lower()


def test_pictures_on_one_sheet_are_the_pictures_drawn_alone(pictures, tmp_path):
    """A shared MapSheet (as write_levels uses) changes nothing: same bytes, in any order, drawn twice."""
    p = two_rooms()
    occupied_edges, empty_edges = edge_masks(p)
    with MapSheet(FRAME) as sheet:
        for round_ in range(2):
            d = tmp_path / str(round_)
            again = {
                "topology_route": render_topology(graph(), FRAME, d / "t.png", background=p, route=ROUTE,
                                                  sheet=sheet),
                "places": render_places(place_labels(p), FRAME, d / "p.png", names={1: "hall", 2: "office", 3: "door"},
                                        background=p, sheet=sheet),
                "edges": render_edges(occupied_edges, empty_edges, FRAME, d / "e.png", sheet=sheet),
                "grid": render_grid(p, FRAME, d / "g.png", title="two rooms", path_xy=_path(), sheet=sheet),
                "dt": render_distance_transform(distance_transform(p), FRAME, d / "d.png", sheet=sheet),
                "sdt": render_stochastic_sdt(skeleton_probability(), FRAME, d / "s.png", background=p, sheet=sheet),
                "polygons": render_polygons(polygons(), FRAME, d / "y.png", background=p, sheet=sheet),
                "route": render_route(p, FRAME, WAYPOINTS, d / "r.png", sheet=sheet),
            }
            for name, png in again.items():
                assert png.read_bytes() == pictures[name].read_bytes(), (round_, name)
    with MapSheet(GridFrame(10, 10, 0.1)) as other, pytest.raises(ValueError, match="sheet is for"):
        render_grid(p, FRAME, tmp_path / "x.png", sheet=other)
    with pytest.raises(RuntimeError, match="closed"):
        render_grid(p, FRAME, tmp_path / "x.png", sheet=sheet)


def test_a_title_longer_than_the_sheet_still_shows_whole(pictures, tmp_path):
    title = "a title that runs on and on " * 12
    out = render_grid(two_rooms(), FRAME, tmp_path / "long.png", title=title)
    img, usual = _rgb(out), _rgb(pictures["grid_bare"])
    assert img.shape[1] > usual.shape[1] + 800  # the picture grew to hold it...
    assert (img[:60, -60:].min(axis=2) < 0.5).any()  # ...and its end is drawn near the right edge


def test_a_picture_draws_few_artists_however_big_the_graph(tmp_path, monkeypatch):
    """Nodes, edges, letters and names go in a handful of collections, not one artist each."""
    frame = GridFrame(200, 200, 0.05)
    g = nx.Graph()
    for i in range(20):
        for j in range(20):
            g.add_node((i, j), xy=frame.cell_to_world(5 + 10 * i, 5 + 10 * j), kind="XTL"[(i + j) % 3])
            if i:
                g.add_edge((i - 1, j), (i, j), probability=0.5, cells=[(5 + 10 * i - 5, 5 + 10 * j)])
            if j:
                g.add_edge((i, j - 1), (i, j))
    labels = np.repeat(np.repeat(np.arange(1, 101).reshape(10, 10), 20, axis=0), 20, axis=1)
    counts = []
    end = MapSheet._end

    def counting(sheet):  # the picture's own artists, just drawn
        counts.append(len([a for a in sheet.ax.get_children() if a not in sheet._static]))
        end(sheet)

    monkeypatch.setattr(MapSheet, "_end", counting)
    render_topology(g, frame, tmp_path / "big_graph.png", background=np.zeros(frame.shape))
    render_places(labels, frame, tmp_path / "many_places.png")
    assert g.number_of_nodes() == 400
    # 2 titles, 2 edge collections, 3 node kinds, 2 letter collections, the legend; titles, names (2), no legend
    assert counts == [10, 4]


def test_grid_is_upright_in_metres_and_unknown_is_not_free(pictures):
    img = _rgb(pictures["grid_bare"])
    box = _map_box(img)
    top, bottom, left, right = box
    assert abs((right - left) / (bottom - top) - 10 / 6) < 0.05  # equal aspect: 10 m by 6 m
    free = _pixel(img, box, 30, 70)
    unknown = _pixel(img, box, 48, 87)
    cupboard = _pixel(img, box, 13, 23)  # upper left: row 0 is the top
    assert free.min() > 0.85  # free is (nearly) white
    assert cupboard.max() < 0.3  # occupied is dark
    assert np.abs(unknown - free).max() > 0.1  # unknown is not drawn as free...
    assert unknown[2] - unknown[0] > 0.05  # ...but in a blue tint, unlike any grey probability


def test_grid_path_shows_only_along_the_path(pictures):
    a, b = _rgb(pictures["grid"]), _rgb(pictures["grid_bare"])
    h, w = min(a.shape[0], b.shape[0]), min(a.shape[1], b.shape[1])
    diff = np.abs(a[:h, :w] - b[:h, :w]).sum(axis=2) > 0.1
    box = _map_box(b)
    top, bottom, left, right = box
    px = (right - left) / FRAME.width  # pixels per cell
    y, x0, x1 = int(round(top + 30.5 * px)), int(left + 30 * px), int(left + 45 * px)
    assert diff[y - 2:y + 3, x0:x1].any(axis=0).all()  # the path along row 30
    assert not diff[int(top + 5 * px):int(top + 20 * px), int(left + 60 * px):int(left + 90 * px)].any()


def test_topology_route_is_highlighted(pictures):
    with_route, without = pictures["topology_route"], pictures["topology"]
    assert with_route.read_bytes() != without.read_bytes()
    a, b = _rgb(with_route), _rgb(without)
    h, w = min(a.shape[0], b.shape[0]), min(a.shape[1], b.shape[1])

    def blue(img):
        return ((img[..., 2] > 0.6) & (img[..., 0] < 0.6) & (img[..., 2] - img[..., 0] > 0.25)).sum()

    assert blue(a[:h, :w]) > blue(b[:h, :w]) + 1000  # a wide blue band


def test_topology_nodes_by_kind(pictures, tmp_path):
    g = graph()
    for node in ("a", "c"):
        g.nodes[node]["kind"] = "T"
    changed = render_topology(g, FRAME, tmp_path / "b.png", background=two_rooms())
    assert changed.read_bytes() != pictures["topology"].read_bytes()
    with pytest.raises(ValueError, match="xy"):
        g.add_node("nowhere")
        render_topology(g, FRAME, tmp_path / "c.png")


def test_topology_route_errors_and_waypoints(pictures, tmp_path):
    g = graph()
    with pytest.raises(ValueError, match="not in the graph"):
        render_topology(g, FRAME, tmp_path / "x.png", route=["c", "zz"])
    waypoints = np.array([[0.0, 0.0], [4.0, 1.0], [8.0, 1.0]])
    out = render_topology(g, FRAME, tmp_path / "w.png", route=waypoints, background=two_rooms())
    assert out.read_bytes() != pictures["topology"].read_bytes()
    multi = nx.MultiGraph(g)
    render_topology(multi, FRAME, tmp_path / "m.png", route=ROUTE)


def test_places_each_get_their_own_colour(pictures):
    img = _rgb(pictures["places"])
    box = _map_box(_rgb(pictures["grid_bare"]))  # the same layout: no colorbar in either... almost
    hall, office = _pixel(img, box, 50, 40), _pixel(img, box, 15, 65)
    assert np.abs(hall - office).max() > 0.15
    assert np.abs(hall - 1.0).max() > 0.1 and np.abs(office - 1.0).max() > 0.1  # coloured, not white


def test_many_places_neighbours_differ(tmp_path):
    labels = np.repeat(np.repeat(np.arange(1, 31).reshape(5, 6), 12, axis=0), 17, axis=1)[:60, :100]
    out = render_places(labels, FRAME, tmp_path / "many.png")
    assert _rgb(out).std() > 0.05


def test_polygon_holes_stay_unfilled(pictures, tmp_path):
    def square(x0, y0, x1, y1):
        return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]])  # closed, as find_contours gives

    outer, hole, island = square(-0.5, -1.5, 8.5, 3.5), square(0.5, -0.5, 7.5, 2.5), square(3.0, 0.5, 5.0, 1.5)
    out = render_polygons([hole, outer, island], FRAME, tmp_path / "holes.png")  # any order
    img = _rgb(out)
    box = _map_box(_rgb(pictures["grid_bare"]))  # same layout from the top left
    band, in_hole, on_island = _pixel(img, box, 8, 50), _pixel(img, box, 20, 20), _pixel(img, box, 25, 50)
    assert band.min() < 0.9 and on_island.min() < 0.9  # filled
    assert in_hole.min() > 0.97  # not filled


def test_sdt_shows_red_and_green(pictures):
    img = _rgb(pictures["sdt"])
    green = (img[..., 1] > img[..., 0] + 0.25) & (img[..., 1] > img[..., 2] + 0.2)
    red = (img[..., 0] > 0.6) & (img[..., 1] < 0.3) & (img[..., 2] < 0.3)
    assert green.sum() > 500 and red.sum() > 50


def test_thin_skeleton_survives_a_big_grid(tmp_path):
    """1200 × 1200 cells: reduced 1:2 for display, yet a one-cell line is still drawn, and wall cells too."""
    frame = GridFrame(1200, 1200, 0.05)
    prob = np.full(frame.shape, np.nan)
    prob[600, 100:1100] = 0.0  # red
    p = np.zeros(frame.shape)
    p[:, 500] = 1.0  # a one-cell wall
    out = render_stochastic_sdt(prob, frame, tmp_path / "big.png", background=p)
    img = _rgb(out)
    red = (img[..., 0] > 0.6) & (img[..., 1] < 0.3)
    rows = np.nonzero(red.any(axis=1))[0]
    assert red.sum() > 1000 and 2 <= len(rows) <= 15  # a line a few pixels thick
    grid = render_grid(p, frame, tmp_path / "big_grid.png")
    dark_cols = (_rgb(grid).max(axis=2) < 0.3).sum(axis=0)
    assert (dark_cols > 400).sum() >= 1  # the one-cell wall is a dark column (the axes frame is grey)


def test_edges_masks_and_lines(pictures, tmp_path):
    img = _rgb(pictures["edges"])
    red = (img[..., 0] > 0.6) & (img[..., 1] < 0.35) & (img[..., 2] < 0.35)
    blue = (img[..., 2] > 0.7) & (img[..., 0] < 0.4)
    assert red.sum() > 1000 and blue.sum() > 100
    lines = [np.array([[0.0, 0.0], [3.0, 2.0]]), np.array([[5.0, 1.0], [6.0, 1.0], [6.0, 3.0]])]
    render_edges(lines, None, FRAME, tmp_path / "lines.png", title="lines", background=two_rooms())


def test_distance_transform_obstacles_dark_far_bright(pictures):
    img = _rgb(pictures["dt"])
    box = _map_box(_rgb(pictures["grid_bare"]))
    # the dt picture has a colorbar under the map; the map itself is laid out the same from the top
    wall, middle = _pixel(img, box, 0.5, 40), _pixel(img, box, 30, 70)
    assert wall.max() < 0.15 and middle.mean() > wall.mean() + 0.3


def test_bad_inputs(tmp_path):
    with pytest.raises(ValueError, match="shape"):
        render_grid(np.zeros((3, 3)), FRAME, tmp_path / "x.png")
    with pytest.raises(ValueError, match="N, 2"):
        render_grid(two_rooms(), FRAME, tmp_path / "x.png", path_xy=[1, 2, 3])
    with pytest.raises(ValueError, match="integers"):
        render_places(np.zeros(FRAME.shape), FRAME, tmp_path / "x.png")
    with pytest.raises(TypeError, match="GridFrame"):
        render_grid(two_rooms(), (60, 100), tmp_path / "x.png")


def test_rotated_frame_and_nested_folders(tmp_path):
    frame = GridFrame(60, 100, 0.1, (1.0, 2.0, 0.5))
    out = render_topology(graph(frame), frame, tmp_path / "deep" / "er" / "rot.png", background=two_rooms(),
                          route=ROUTE)
    assert out == tmp_path / "deep" / "er" / "rot.png" and out.is_file()
    render_places(place_labels(two_rooms()), frame, tmp_path / "rot_places.png")


def test_importing_the_module_does_not_import_matplotlib():
    code = "import sys, atlas_rap.views.map_render; print('matplotlib' in sys.modules, 'scipy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False False"

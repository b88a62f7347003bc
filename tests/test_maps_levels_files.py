"""Writing every level of a map (views.map_levels.write_levels) is cheap, and what it writes reads back the same.

Issue 13, part 4: writing the levels used to cost ten to twenty times the
abstraction. The pictures share one MapSheet and draw few artists (see
tests/test_maps_render.py); here: the data files are written without
per-element Python (and stay what they were). How long writing takes
beside the abstraction is measured by benchmarks/bench_places.py, not here.
"""

from __future__ import annotations

import json
import zipfile

import networkx as nx
import numpy as np

from atlas_rap.maps import topology as topology_module
from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.abstraction import abstract_map
from atlas_rap.views.map_levels import save_npz, write_levels
from atlas_rap.maps.topology import Topology

DATA = ("grid.npz", "topology.json", "topology.graphml")
PICTURES = ("grid.png", "edges.png", "polygons.png", "distance-transform.png", "places.png", "stochastic-sdt.png",
            "topology.png", "route.png")


def offices(rows: int = 3, cols: int = 5, room: int = 60, wall: int = 4, seed: int = 0) -> tuple[np.ndarray, GridFrame]:
    """Bands of rooms between corridors, a corridor down the left joining them, doors everywhere; at 0.05 m.

    Noisy probabilities, as a sonar map has.
    """
    corridor = 36
    h = rows * room + (rows - 1) * (2 * wall + corridor) + 2 * wall
    w = corridor + cols * (room + wall) + 3 * wall
    occ = np.zeros((h, w), dtype=bool)
    occ[:wall] = occ[-wall:] = True
    occ[:, :wall] = occ[:, -wall:] = True
    left = wall + corridor  # the rooms start right of the corridor down the left
    doors = [left + wall + c * (room + wall) + room // 2 for c in range(cols)]
    y = wall
    for band in range(rows):
        for c in range(cols + 1):  # the walls between the rooms of this band
            occ[y:y + room, left + c * (room + wall):left + c * (room + wall) + wall] = True
        y += room
        if band == rows - 1:
            break
        for _ in range(2):  # the walls under this band and over the next, a corridor between them
            occ[y:y + wall, left:] = True
            for x in doors:
                occ[y:y + wall, x - 9:x + 9] = False
            y += wall + corridor
        y -= corridor
    rng = np.random.default_rng(seed)
    p = np.where(occ, rng.uniform(0.7, 0.95, occ.shape), rng.uniform(0.0, 0.05, occ.shape)).astype(np.float32)
    return p, GridFrame(h, w, 0.05, (-1.0, -2.0, 0.0))


def test_every_level_is_written_and_pictures_can_be_left_out(tmp_path):
    p, frame = offices()
    result = abstract_map(p, frame)
    written = write_levels(p, result, tmp_path / "all", title="offices")
    assert [f.name for f in written] == ["grid.npz", "grid.png", "edges.png", "polygons.png", "distance-transform.png",
                                         "places.png", "stochastic-sdt.png", "topology.json", "topology.graphml",
                                         "topology.png", "route.png"]
    data = write_levels(p, result, tmp_path / "data", title="offices", pictures=False)
    assert [f.name for f in data] == list(DATA)
    assert sorted(f.name for f in (tmp_path / "data").iterdir()) == sorted(DATA)
    for name in DATA:  # the same data either way, byte for byte
        assert (tmp_path / "data" / name).read_bytes() == (tmp_path / "all" / name).read_bytes(), name


def test_grid_npz_reads_back_every_array_and_is_the_same_every_time(tmp_path):
    p, frame = offices()
    arrays = {"p_occ": p, "dt": np.linspace(0, 3, p.size).reshape(p.shape), "skeleton": p < 0.01,
              "places": (np.arange(p.size) // 5000).reshape(p.shape).astype(np.int32), "frame": frame.to_array()}
    a = save_npz(tmp_path / "a.npz", **arrays)
    b = save_npz(tmp_path / "b.npz", **arrays)
    assert a.read_bytes() == b.read_bytes()  # no time stamps
    with np.load(a) as loaded:
        assert sorted(loaded.files) == sorted(arrays)
        for name, value in arrays.items():
            assert loaded[name].dtype == value.dtype and np.array_equal(loaded[name], value), name
    with zipfile.ZipFile(a) as archive:
        kinds = {info.filename: info.compress_type for info in archive.infolist()}
    assert kinds["p_occ.npy"] == zipfile.ZIP_STORED  # noise: not worth squeezing
    assert kinds["places.npy"] == kinds["skeleton.npy"] == zipfile.ZIP_DEFLATED


def test_topology_files_are_what_they_were(tmp_path, monkeypatch):
    """JSON: the text json.dumps(to_dict()) gives; GraphML: the bytes networkx.write_graphml gives."""
    p, frame = offices()
    topo = abstract_map(p, frame).topology
    topo.place_names[1] = 'the "big" <room> & co'
    text = topo.to_json(tmp_path / "t.json").read_text(encoding="utf-8")
    assert text == json.dumps(topo.to_dict(), separators=(",", ":"))
    assert Topology.from_json(tmp_path / "t.json") == topo
    ours = topo.to_graphml(tmp_path / "ours.graphml").read_bytes()

    def with_networkx(graph, out):
        nx.write_graphml(graph, out)
        return out

    monkeypatch.setattr(topology_module, "_write_graphml", with_networkx)
    assert topo.to_graphml(tmp_path / "networkx.graphml").read_bytes() == ours
    read = nx.read_graphml(tmp_path / "networkx.graphml")
    assert read.number_of_nodes() == topo.graph.number_of_nodes()
    assert any(d["name"] == 'the "big" <room> & co' for _, d in read.nodes(data=True))

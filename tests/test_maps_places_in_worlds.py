"""Places on the maps of the shipped worlds: named after the world's places, one per room on a
map built from sonar where the sonar saw the walls, and no topology outside the space the robot
could reach."""

from __future__ import annotations

import json

import numpy as np
from cli_process import REPO, assert_no_traceback, atlas
from floorplans import world_rooms

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.inference import InferenceGrid
from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.sim.world import load_world

SMALL_MAP = REPO / "worlds" / "maps" / "small-office-map.yaml"


def ious(places: np.ndarray, rooms: np.ndarray) -> list[float]:
    """For each ground-truth room, the IoU of the place that covers most of it."""
    out = []
    for room in range(1, int(rooms.max()) + 1):
        region = rooms == room
        counts = np.bincount(places[region], minlength=int(places.max()) + 1)
        counts[0] = 0
        best = int(np.argmax(counts))
        out.append(counts[best] / (region.sum() + ((places == best) & ~region).sum()))
    return out


def test_places_of_a_world_map_take_the_names_of_its_places(tmp_path):
    done = atlas("map", "abstract", str(SMALL_MAP), "--world", "small-office-map", "--out", "levels", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    topology = json.loads((tmp_path / "levels" / "topology.json").read_text(encoding="utf-8"))
    names = set(topology["place_names"].values())
    # the four rooms and the meeting room by their doors; the hall's two halves meet in an opening as wide
    # as the hall, so they are one place, named after the half that covers most of it
    assert {"room-a", "room-b", "room-c", "meeting-room"} <= names
    assert len(names & {"hall-west", "hall-east"}) == 1 and len(names) == 5


def test_a_map_built_from_sonar_has_one_place_per_room_and_no_topology_outside_the_reachable_space(tmp_path):
    world = "lab-corridor-office-door-closed"
    done = atlas("map", "build", "--world", world, "--out", "built", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    with np.load(tmp_path / "built" / "grid.npz") as data:
        places, frame = data["places"], GridFrame.from_array(data["frame"])
    scores = ious(places, world_rooms(load_world(world), frame))
    assert min(scores) >= 0.5, scores  # lab, corridor, storeroom and office each a place of its own
    topology = json.loads((tmp_path / "built" / "topology.json").read_text(encoding="utf-8"))
    assert set(topology["place_names"].values()) == {"lab", "corridor", "storeroom", "office"}
    grid = OccupancyGrid.load_npz(tmp_path / "built" / "occupancy.npz")
    start = load_world(world).robot.start
    reachable = InferenceGrid(grid, start[:2], 0.2, 5.0).reachable
    cells = [tuple(node["cell"]) for node in topology["nodes"]]
    assert cells and all(reachable[cell] for cell in cells)

"""Places on the maps of the shipped worlds: named after the world's places, one per room on a
map built from sonar where the sonar saw the walls, and no topology outside the space the robot
could reach."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from cli_process import REPO, assert_no_traceback, atlas
from floorplans import best_places, built_world_scores, world_rooms

from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.inference import InferenceGrid
from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.sim.world import load_world

SMALL_MAP = REPO / "worlds" / "maps" / "small-office-map.yaml"


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
    # with exact odometry: at the default noise the corridor's west end can come out as a place of its
    # own (IoU 0.42 for the corridor with seed 0), a regression of issue 27 named in its note
    world = str(Path(__file__).resolve().parent / "worlds" / "lab-corridor-office-door-closed-exact.yaml")
    done = atlas("map", "build", "--world", world, "--out", "built", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    with np.load(tmp_path / "built" / "grid.npz") as data:
        places, frame = data["places"], GridFrame.from_array(data["frame"])
    scores = [iou for _, iou in best_places(places, world_rooms(load_world(world), frame))]
    assert min(scores) >= 0.5, scores  # lab, corridor, storeroom and office each a place of its own
    topology = json.loads((tmp_path / "built" / "topology.json").read_text(encoding="utf-8"))
    assert set(topology["place_names"].values()) == {"lab", "corridor", "storeroom", "office"}
    grid = OccupancyGrid.load_npz(tmp_path / "built" / "occupancy.npz")
    start = load_world(world).robot.start
    reachable = InferenceGrid(grid, start[:2], 0.2, 5.0).reachable
    cells = [tuple(node["cell"]) for node in topology["nodes"]]
    assert cells and all(reachable[cell] for cell in cells)


def _built_places(world: str, tmp_path) -> tuple[dict[str, float], dict[str, str]]:
    """Map ``world`` from sonar with ``atlas map build``: for each of the world's named regions, the
    IoU of the place that covers most of it, and the name that place took."""
    done = atlas("map", "build", "--world", world, "--out", "built", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    found = built_world_scores(tmp_path / "built", world)
    return {name: iou for name, (iou, _) in found.items()}, {name: place for name, (_, place) in found.items()}


def test_the_sonar_built_lab_corridor_office_has_a_place_named_after_each_of_its_four_rooms(tmp_path):
    """With exact odometry. At the default noise, localised on the prior map, the corridor's west end
    can come out as a place of its own (IoU 0.42 for the corridor with seed 0): a known regression of
    issue 27, named in its note; the office building's rooms (the next test) still come out at the
    default noise."""
    exact = Path(__file__).resolve().parent / "worlds" / "lab-corridor-office-exact.yaml"
    scores, names = _built_places(str(exact), tmp_path)
    assert set(scores) == {"lab", "corridor", "storeroom", "office"}
    assert all(score >= 0.5 and names[room] == room for room, score in scores.items()), (scores, names)


def test_the_sonar_built_office_building_has_a_place_named_after_each_room_off_its_hall(tmp_path):
    """Five offices and the conference room, each behind a door of 1 m, get places of their own.
    What it does not get (issue 25): the hall's two halves and the elevator lobby meet through
    openings as wide as the hall, with no narrowing between them, so they are one place; and the
    kitchen's door is shut, so the robot never maps the kitchen."""
    scores, names = _built_places("office-building", tmp_path)
    rooms = [f"office-{i}" for i in range(1, 6)] + ["conference-room"]
    assert all(scores[room] >= 0.5 and names[room] == room for room in rooms), (scores, names)

"""The JSC colour-search demo (seed 003 §4): the colour camera, the search RAPs, the mission, the world's objects."""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path
from types import SimpleNamespace

import pytest

from atlas_rap.errors import SourceError
from atlas_rap.lang import parse_term
from atlas_rap.model import Door, ObjectMove, Place, Segment, World, WorldObject
from atlas_rap.sequencer import Sequencer
from atlas_rap.sim.objects import ObjectSim
from atlas_rap.sim.world import load_world
from atlas_rap.skills import SkillManager
from atlas_rap.skills.beliefs import OBJECTS, SIGHTINGS
from atlas_rap.skills.camera import ColourCamera
from cli_process import assert_no_traceback, atlas
from world_runs import REPO, run_in_world

MISSION = REPO / "rap_library" / "missions" / "colour-search.rap"


# -- a small world and a stand-in for the simulated robot -------------------------------------

class Body:
    """What ObjectSim reads of the simulation: time, true pose, radius, doors, obstacles."""

    def __init__(self, pose=(0.0, 0.0, 0.0), doors_open=None, obstacles=()):
        self.time = 0.0
        self.pose = pose
        self.radius = 0.2
        self.doors_open = dict(doors_open or {})
        self._obstacles = list(obstacles)

    def obstacles(self):
        return list(self._obstacles)


def room(*objects: WorldObject, walls=(), doors=None) -> World:
    places = {"room": Place("room", (0.0, 0.0), ((-10, -10), (10, -10), (10, 10), (-10, 10)))}
    return World("room", tuple(walls), places, doors or {}, objects={o.name: o for o in objects})


def seen(sim: ObjectSim) -> list[str]:
    return sorted(view.name for view in sim.look(math.radians(60), 5.0))


# -- the camera: field of view, range, occlusion ------------------------------------------------

def test_the_camera_sees_within_its_field_of_view_and_no_wider():
    inside = WorldObject("inside", "red", (3 * math.cos(math.radians(28)), 3 * math.sin(math.radians(28))))
    outside = WorldObject("outside", "red", (3 * math.cos(math.radians(32)), -3 * math.sin(math.radians(32))))
    behind = WorldObject("behind", "red", (-2.0, 0.0))
    sim = ObjectSim(room(inside, outside, behind), Body())
    assert seen(sim) == ["inside"]
    (view,) = sim.look(math.radians(60), 5.0)
    assert view.colour == "red" and view.kind == "object"
    assert view.bearing == pytest.approx(math.radians(28)) and view.range == pytest.approx(3.0)
    sim.body.pose = (0.0, 0.0, math.pi)  # turned round: only what is behind
    assert seen(sim) == ["behind"]


def test_the_camera_sees_within_its_range_and_no_further():
    near = WorldObject("near", "blue", (4.9, 0.0))
    far = WorldObject("far", "blue", (0.0, 5.1))
    sim = ObjectSim(room(near, far), Body())
    assert seen(sim) == ["near"]
    sim.body.pose = (0.0, 0.0, math.pi / 2)
    assert seen(sim) == []


def test_walls_closed_doors_boxes_and_people_hide_things():
    ball = WorldObject("ball", "red", (4.0, 0.0))
    wall = Segment((2.0, -1.0), (2.0, 1.0))
    sim = ObjectSim(room(ball, walls=[wall]), Body())
    assert seen(sim) == []
    sim.body.pose = (3.0, 0.0, 0.0)  # past the wall
    assert seen(sim) == ["ball"]
    assert not sim.clear_line((0.0, 0.0), (4.0, 0.0)) and sim.clear_line((3.0, 0.0), (4.0, 0.0))

    leaf = Door("door", ("room", "room"), (2.0, 0.0), Segment((2.0, -0.5), (2.0, 0.5)))
    sim = ObjectSim(room(ball, doors={"door": leaf}), Body(doors_open={"door": True}))
    assert seen(sim) == ["ball"]
    sim.body.doors_open["door"] = False
    assert seen(sim) == []

    sim = ObjectSim(room(ball), Body(obstacles=[("box", (2.0, 0.2), 0.5)]))
    assert seen(sim) == []
    sim = ObjectSim(room(ball), Body(obstacles=[("person", (2.0, 0.1), 0.45)]))
    assert seen(sim) == []
    sim = ObjectSim(room(ball), Body(obstacles=[("person", (2.0, 0.5), 0.45)]))  # beside the line of sight
    assert seen(sim) == ["ball"]


def test_the_world_moves_an_object_at_a_time_or_when_the_robot_comes_near():
    timed = WorldObject("timed", "red", (3.0, 0.0), moves=(ObjectMove((3.0, 0.6), at=10.0),))
    shy = WorldObject("shy", "red", (3.0, -0.5), moves=(ObjectMove((-5.0, -5.0), near=2.0),))
    body = Body()
    sim = ObjectSim(room(timed, shy), body)
    assert seen(sim) == ["shy", "timed"]
    body.time = 10.0
    assert sim.position("timed") == (3.0, 0.0)  # queries move things only through update (look does it)
    assert seen(sim) == ["shy", "timed"] and sim.position("timed") == (3.0, 0.6)
    body.pose = (1.5, 0.0, 0.0)  # within 2 m of shy: it is taken away
    assert seen(sim) == ["timed"] and sim.position("shy") == (-5.0, -5.0)
    assert [(name, to) for _, name, to in sim.moved] == [("timed", (3.0, 0.6)), ("shy", (-5.0, -5.0))]


# -- the camera skill's facts ---------------------------------------------------------------------

def test_the_camera_skill_posts_in_view_seen_and_is_a_only_when_they_change():
    ball = WorldObject("ball", "red", (3.0, 0.5))
    body = Body()
    world = room(ball)
    manager = SkillManager([ColourCamera()], world=world, robot=body)
    manager.context.beliefs[OBJECTS] = ObjectSim(world, body)
    seq = Sequencer(skills=manager)

    def tick(t: float, pose=None) -> None:
        body.time = t
        if pose is not None:
            body.pose = pose
        manager.data["pose"] = body.pose
        manager.tick(t)

    for step in range(5):
        tick(step * 0.1)
    memory = seq.memory
    assert memory.holds(parse_term("(and (in-view ball red) (seen ball red room) (is-a ball object))"))
    sighting = manager.context.beliefs[SIGHTINGS]["ball"]
    assert (sighting.x, sighting.y, sighting.place) == (pytest.approx(3.0), pytest.approx(0.5), "room")
    changes = len(list(memory.facts()))
    tick(0.5, (0.0, 0.0, math.pi))  # looking away: still in view for out_of_view_after seconds...
    tick(1.3)
    assert memory.holds(parse_term("(in-view ball red)")) and len(list(memory.facts())) == changes
    tick(1.6)  # ...then no longer; where it was seen is remembered
    assert not memory.holds(parse_term("(in-view ball red)"))
    assert memory.holds(parse_term("(seen ball red room)"))


# -- the mission -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def run():
    return run_in_world(MISSION)


def test_the_mission_finds_the_red_and_the_blue_things(run):
    assert run.result.ok, run.explain()
    memory = run.mission.sequencer.memory
    assert memory.holds(parse_term("(and (found red red-ball) (found blue blue-box))"))
    x, y, _ = run.mission.simulation.pose
    blue = run.mission.manager.context.beliefs[OBJECTS].position("blue-box")
    assert math.dist((x, y), blue) <= 0.6


def test_no_place_is_searched_twice(run):
    searched = Counter(f for f in run.facts("fact-asserted") if f.startswith("(searched "))
    assert searched and max(searched.values()) == 1, searched
    finished = [r["task"] for r in run.records if r["event"] == "task-succeeded"
                and r["task"].startswith("(search-place ")]
    assert len(finished) == len(set(finished)), finished
    looked = run.facts("fact-asserted").count("(done (look-around) :succeed)")
    assert looked == len(searched) == len(finished)  # every full look round is one place searched


def test_losing_the_colour_sends_the_search_back_to_where_it_was_seen(run):
    records = run.records
    objects = run.mission.manager.context.beliefs[OBJECTS]
    assert [(name, to) for _, name, to in objects.moved] == [("red-ball", (19.2, 9.4))]

    def first(predicate) -> int:
        return next(i for i, r in enumerate(records) if predicate(r))

    spotted = first(lambda r: r.get("fact") == "(seen red-ball red corridor-west)")
    lost = first(lambda r: r["event"] == "step-outcome" and r.get("step") == "step t2 (approach red-ball)"
                 and r["outcome"] == ":fail")
    assert "lost sight of red-ball" in records[lost]["reason"]
    assert first(lambda r: r.get("fact") == "(lost red-ball red corridor-west)") < lost
    recover = first(lambda r: r["event"] == "method-selected" and r["task"] == "(find-colour red)"
                    and r["method"] == "search-where-lost")
    searched_again = first(lambda r: r.get("fact") == "(searched corridor-west)")
    found = first(lambda r: r.get("fact") == "(found red red-ball)")
    assert spotted < lost < recover < searched_again < found
    assert objects.moved[0][0] < records[lost]["t"]


def test_the_blue_box_seen_on_the_way_is_found_from_memory_without_a_search(run):
    methods = [r["method"] for r in run.records if r["event"] == "method-selected"
               and r["task"] == "(find-colour blue)"]
    assert methods == ["go-get-it"]
    asserted = run.facts("fact-asserted")
    assert asserted.index("(seen blue-box blue storeroom)") < asserted.index("(found red red-ball)")


def test_the_demo_is_one_command_and_the_same_seed_gives_the_same_trace(tmp_path):
    done = [atlas("run", str(MISSION), "--quiet", "--trace", f"t{i}.jsonl", "--render", f"r{i}.png", cwd=tmp_path)
            for i in (1, 2)]
    for each in done:
        assert_no_traceback(each)
        assert each.returncode == 0, each.stdout + each.stderr
    assert (tmp_path / "t1.jsonl").read_bytes() == (tmp_path / "t2.jsonl").read_bytes()
    assert (tmp_path / "r1.png").stat().st_size > 0


def test_atlas_check_finds_the_mission_and_the_search_raps_clean(tmp_path):
    done = atlas("check", str(MISSION), str(REPO / "rap_library" / "search.rap"), cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warning" not in done.stdout + done.stderr


# -- objects in world files -----------------------------------------------------------------------

def test_the_shipped_demo_worlds_have_their_objects():
    world = load_world("colour-search")
    assert {name: (o.colour, o.kind) for name, o in world.objects.items()} == {
        "green-cone": ("green", "object"), "red-ball": ("red", "object"), "blue-box": ("blue", "object")}
    assert world.objects["red-ball"].moves == (ObjectMove((19.2, 9.4), near=2.0),)
    kinds = Counter(o.kind for o in load_world("trash").objects.values())
    assert kinds == {"trash": 4, "bin": 2}


BAD_OBJECTS = """\
base: lab-corridor-office
objects:
  ball: {colour: red, at: [10, 5]}
  lab: {colour: red, at: [3, 3]}
  cone: {color: green, at: [3, 3]}
  bin-1: {colour: green, kind: bim, at: [3, 2]}
  box: {colour: Blue, at: [0.05, 2]}
  shy: {colour: red, at: [3, 1], moves: [{near: 2}, {at: 5, near: 1, to: [2, 2]}]}
"""


def test_bad_objects_in_a_world_file_get_located_errors(tmp_path: Path):
    path = tmp_path / "bad.yaml"
    path.write_text(BAD_OBJECTS, encoding="utf-8")
    with pytest.raises(SourceError) as caught:
        load_world(path)
    found = [(p.location.line, p.location.column, p.message) for p in caught.value.problems]
    lines = sorted({line for line, _, _ in found})
    assert lines == [4, 5, 6, 7, 8], found
    text = str(caught.value)
    assert "object 'lab' has the name of a place" in text
    assert "unknown key 'color' in objects.cone" in text and "did you mean 'colour'?" in text
    assert "unknown object kind 'bim'" in text and "did you mean 'bin'?" in text
    assert "'Blue' cannot be a colour" in text and "from a wall" in text
    assert "objects.shy.moves[0] is missing the key 'to'" in text
    assert "needs one of at: (a time) and near:" in text


def test_a_bad_object_given_to_atlas_run_is_a_located_error_not_a_traceback(tmp_path: Path):
    (tmp_path / "bad.yaml").write_text(BAD_OBJECTS, encoding="utf-8")
    done = atlas("run", str(MISSION), "--world", "bad.yaml", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "bad.yaml:6:32: error: unknown object kind 'bim'" in done.stderr, done.stderr
    assert "^" in done.stderr

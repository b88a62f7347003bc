"""Chip's trash demo (seed 003 §4): the gripper's reach rules, the handling skills, the mission and its counts."""

from __future__ import annotations

import math
import re
from collections import Counter

import pytest

from atlas_rap.lang import parse_term
from atlas_rap.model import ObjectMove, Place, World, WorldObject
from atlas_rap.sequencer import Sequencer
from atlas_rap.sim.objects import CARRY_GAP, ObjectSim
from atlas_rap.skills import SkillManager
from atlas_rap.skills.beliefs import OBJECTS
from atlas_rap.skills.handling import Drop, PickUp
from cli_process import assert_no_traceback, atlas
from world_runs import REPO, run_in_world

MISSION = REPO / "rap_library" / "missions" / "trash.rap"


class Body:
    """What ObjectSim reads of the simulation: time, true pose, radius, doors, obstacles."""

    def __init__(self, pose=(0.0, 0.0, 0.0)):
        self.time = 0.0
        self.pose = pose
        self.radius = 0.2
        self.doors_open: dict[str, bool] = {}

    def obstacles(self):
        return []


def floor(*objects: WorldObject) -> World:
    places = {"room": Place("room", (0.0, 0.0), ((-10, -10), (10, -10), (10, 10), (-10, 10)))}
    return World("room", (), places, objects={o.name: o for o in objects})


CAN = WorldObject("can", "yellow", (1.0, 0.0), "trash", 0.15)
CUP = WorldObject("cup", "red", (0.0, 0.5), "trash", 0.15)
BIN = WorldObject("bin", "green", (3.0, 0.0), "bin", 0.4)


# -- the gripper's rules ----------------------------------------------------------------------

def test_pick_up_needs_the_item_within_reach_and_an_empty_gripper():
    body = Body()
    sim = ObjectSim(floor(CAN, CUP, BIN), body)
    assert sim.pick_up("can", 0.6) == "can is 1.00 m from the robot; the gripper reaches 0.6 m"
    body.pose = (0.5, 0.0, 0.0)
    assert sim.pick_up("can", 0.6) is None and sim.carried == "can"
    assert sim.pick_up("cup", 0.6) == "the gripper is holding can"
    assert sim.pick_up("bin", 0.6) == "bin is a bin: bins stay where they are"
    assert sim.pick_up("nothing", 0.6) == "there is no object named nothing"


def test_a_carried_item_moves_with_the_robot_and_the_camera_does_not_see_it():
    body = Body((0.5, 0.0, 0.0))
    sim = ObjectSim(floor(CAN, BIN), body)
    assert sim.pick_up("can", 0.6) is None
    body.pose = (2.0, 1.0, math.pi / 2)
    assert sim.position("can") == pytest.approx((2.0, 1.0 + 0.2 + CARRY_GAP))
    assert [v.name for v in sim.look(math.radians(60), 5.0)] == []
    body.pose = (2.0, 1.0, -0.5)
    assert [v.name for v in sim.look(math.radians(60), 5.0)] == ["bin"]


def test_drop_needs_the_item_in_the_gripper_and_a_bin_within_reach():
    body = Body((0.5, 0.0, 0.0))
    sim = ObjectSim(floor(CAN, CUP, BIN), body)
    assert sim.drop("can", "bin", 0.8) == "the gripper is not holding can (it is empty)"
    sim.pick_up("can", 0.6)
    assert sim.drop("cup", "bin", 0.8) == "the gripper is not holding cup (it holds can)"
    assert sim.drop("can", "cup", 0.8) == "cup is not a bin"
    assert sim.drop("can", "bin", 0.8) == "bin is 2.50 m from the robot; the gripper reaches 0.8 m"
    body.pose = (2.3, 0.0, 0.0)
    assert sim.drop("can", "bin", 0.8) is None
    assert sim.carried is None and sim.in_bin == {"can": "bin"} and sim.position("can") == (3.0, 0.0)
    assert sim.pick_up("can", 5.0) == "can is in bin"
    assert [v.name for v in sim.look(math.radians(60), 5.0)] == ["bin"]  # what is in a bin is not seen


def test_the_world_does_not_move_what_the_robot_holds():
    shy = WorldObject("shy", "red", (0.4, 0.0), "trash", moves=(ObjectMove((5.0, 5.0), at=1.0),))
    body = Body()
    sim = ObjectSim(floor(shy), body)
    assert sim.pick_up("shy", 0.6) is None
    body.time = 2.0
    sim.update()
    assert sim.moved == [] and sim.position("shy") != (5.0, 5.0)


# -- the handling skills ------------------------------------------------------------------------

def run_skill(call: str, sim: ObjectSim, seconds: float = 2.0):
    """Enable one handling skill on ``sim`` under a bare sequencer; tick it; return memory."""
    manager = SkillManager([PickUp(), Drop()], world=sim.world, robot=sim.body)
    manager.context.beliefs[OBJECTS] = sim
    seq = Sequencer(skills=manager)
    manager.enable(parse_term(call))
    for step in range(int(seconds * 20) + 1):
        sim.body.time = step * 0.05
        manager.tick(step * 0.05)
    return seq.memory


def test_the_pick_up_skill_posts_holding_or_says_why_not():
    sim = ObjectSim(floor(CAN, BIN), Body())
    memory = run_skill("(pick-up can)", sim)
    assert memory.holds(parse_term("(done (pick-up can) :fail)"))
    assert memory.holds(parse_term('(why (pick-up can) "can is 1.00 m from the robot; the gripper reaches 0.6 m")'))
    sim.body.pose = (0.6, 0.0, 0.0)
    memory = run_skill("(pick-up can)", sim)
    assert memory.holds(parse_term("(and (done (pick-up can) :succeed) (holding robot can))"))
    assert sim.carried == "can"


def test_the_drop_skill_posts_in_bin_or_says_why_not():
    sim = ObjectSim(floor(CAN, BIN), Body((0.6, 0.0, 0.0)))
    sim.pick_up("can", 0.6)
    memory = run_skill("(drop can bin)", sim)
    assert memory.holds(parse_term('(why (drop can bin) "bin is 2.40 m from the robot; the gripper reaches 0.8 m")'))
    sim.body.pose = (2.4, 0.0, 0.0)
    memory = run_skill("(drop can bin)", sim)
    assert memory.holds(parse_term("(and (done (drop can bin) :succeed) (in-bin can bin))"))
    assert sim.in_bin == {"can": "bin"}


# -- the mission ------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def run():
    return run_in_world(MISSION)


def test_chip_bins_every_piece_of_trash_and_memory_counts_them(run):
    assert run.result.ok, run.explain()
    objects = run.mission.manager.context.beliefs[OBJECTS]
    trash = {name for name, o in objects.objects.items() if o.kind == "trash"}
    bins = {name for name, o in objects.objects.items() if o.kind == "bin"}
    assert set(objects.in_bin) == trash and objects.carried is None
    memory = run.mission.sequencer.memory
    in_bin = {str(f.args[0]): str(f.args[1]) for f in memory.facts(parse_term("(in-bin ?item ?bin)"))}
    assert in_bin == objects.in_bin
    counts = {str(f.args[0]): f.args[1] for f in memory.facts(parse_term("(bin-count ?bin ?n)"))}
    assert set(counts) == bins
    assert counts == Counter(in_bin.values())
    assert [f.args[0] for f in memory.facts(parse_term("(trash-left ?n)"))] == [0]
    assert sum(counts.values()) == len(trash) == 4


def test_the_counts_go_down_and_up_by_one_at_each_drop(run):
    lefts = [int(m.group(1)) for f in run.facts("fact-asserted") if (m := re.fullmatch(r"\(trash-left (\d+)\)", f))]
    assert lefts == [4, 3, 2, 1, 0]
    drops = [f for f in run.facts("fact-asserted") if f.startswith("(in-bin ")]
    assert len(drops) == 4


def test_no_place_is_searched_twice_while_cleaning_up(run):
    searched = Counter(f for f in run.facts("fact-asserted") if f.startswith("(searched "))
    assert set(searched) == {f"(searched {p})" for p in run.mission.world.places}
    assert max(searched.values()) == 1


def test_the_demo_is_one_command_and_the_same_seed_gives_the_same_trace(tmp_path):
    done = [atlas("run", str(MISSION), "--quiet", "--trace", f"t{i}.jsonl", cwd=tmp_path) for i in (1, 2)]
    for each in done:
        assert_no_traceback(each)
        assert each.returncode == 0, each.stdout + each.stderr
    assert (tmp_path / "t1.jsonl").read_bytes() == (tmp_path / "t2.jsonl").read_bytes()


def test_atlas_check_finds_the_mission_and_the_trash_raps_clean(tmp_path):
    done = atlas("check", str(MISSION), str(REPO / "rap_library" / "trash.rap"), cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warning" not in done.stdout + done.stderr

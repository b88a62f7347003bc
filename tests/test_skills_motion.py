"""The stock motion skills and the safety reflex driving the simulated robot, enabled by RAPs."""

from __future__ import annotations

import math

import numpy as np

from world_runs import run_in_world

ROOM = """
walls:
  - [[0, 0], [6, 0], [6, 4], [0, 4], [0, 0]]
  - [4, 0, 4, 3]        # an inner wall, open at the top
places:
  west: {point: [2, 2], region: [[0, 0], [4, 0], [4, 4], [0, 4]]}
  east: {point: [5, 1], region: [[4, 0], [6, 0], [6, 4], [4, 4]]}
robot: {start: [1, 1, 0]}
"""


def mission(tmp_path, body: str, extra: str = "") -> str:
    (tmp_path / "room.yaml").write_text(ROOM, encoding="utf-8")
    path = tmp_path / "m.rap"
    path.write_text(f'(world "room.yaml")\n{extra}\n(define-rap (job) (retries 1) (method {body}))\n(post (job))\n',
                    encoding="utf-8")
    return path


def test_move_to_a_point_in_free_space_gets_there(tmp_path):
    run = run_in_world(mission(tmp_path, "(task-net (move-to 3 3))"))
    assert run.result.ok, run.explain()
    x, y, _ = run.mission.simulation.pose
    assert math.dist((x, y), (3, 3)) < 0.25


def test_move_to_a_point_behind_a_wall_stops_short_of_it_and_reports_blocked(tmp_path):
    # (5, 1) is behind the inner wall; steering straight at it runs into the wall
    run = run_in_world(mission(tmp_path, "(task-net (move-to 5 1))"))
    sim = run.mission.simulation
    assert not run.result.ok
    assert "(blocked robot move-to)" in run.facts("fact-asserted")
    assert "no progress toward (5, 1)" in run.result.tasks[0].failure.root().reason
    assert sim.bump_steps == 0  # never touched the wall
    assert sim.pose[0] < 4 - 0.2


def test_follow_route_passes_each_waypoint_round_the_wall(tmp_path):
    run = run_in_world(mission(tmp_path, "(task-net (t1 (follow-route ((3 3.5) (5 3.5) (5 1)))))"))
    assert run.result.ok, run.explain()
    assert run.mission.world.place_at(*run.mission.simulation.pose[:2]) == "east"
    assert "(at robot east)" in run.facts("fact-asserted")


def test_turn_to_faces_the_heading(tmp_path):
    run = run_in_world(mission(tmp_path, "(task-net (turn-to 90))"))
    assert run.result.ok, run.explain()
    assert abs(math.degrees(run.mission.simulation.pose[2]) - 90) < 5


def turned(path) -> float:
    """Radians turned along a simulated path of (t, x, y, heading), whichever way."""
    return sum(abs(math.remainder(b[3] - a[3], 2 * math.pi)) for a, b in zip(path, path[1:]))


def test_look_around_turns_on_the_spot_once_all_the_way_round_each_time_it_is_enabled(tmp_path):
    run = run_in_world(mission(tmp_path, "(task-net (look-around))"))
    assert run.result.ok, run.explain()
    sim = run.mission.simulation
    assert 2 * math.pi - 0.1 <= turned(sim.path) < 2 * math.pi + 0.5  # to within a period's turn (0.1 rad)
    assert math.dist(sim.path[0][1:3], sim.pose[:2]) < 0.05  # on the spot
    run = run_in_world(mission(tmp_path, "(task-net (sequence (t1 (look-around)) (t2 (look-around))))"))
    assert run.result.ok, run.explain()
    assert 4 * math.pi - 0.2 <= turned(run.mission.simulation.path) < 4 * math.pi + 1.0  # a full turn again


def test_wander_and_wall_follow_keep_moving_until_disabled_and_stop_then(tmp_path):
    body = """(task-net (parallel (t1 (wander) (until-end t2)) (t2 (pause))))"""
    extra = "(define-virtual-skill (pause) (after 20 (finish :succeed)))"
    run = run_in_world(mission(tmp_path, body, extra))
    assert run.result.ok, run.explain()
    sim = run.mission.simulation
    travelled = sum(math.dist(a[1:3], b[1:3]) for a, b in zip(sim.path, sim.path[1:]))
    assert travelled > 3.0
    assert sim.commanded == (0.0, 0.0)  # disabled: no skill commands the wheels any more
    body = """(task-net (parallel (t1 (wall-follow left) (until-end t2)) (t2 (pause))))"""
    run = run_in_world(mission(tmp_path, body, extra))
    assert run.result.ok, run.explain()
    assert run.mission.simulation.commanded == (0.0, 0.0)


def reflex_output(command, front_range: float, bump=None, now: float = 0.0):
    from atlas_rap.skills import SkillManager
    from atlas_rap.skills.safety import SafetyReflex

    manager = SkillManager([SafetyReflex()])
    manager.connect(None)  # no sequencer needed: the reflex posts no facts
    angles = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    ranges = np.full(16, 4.0)
    ranges[0] = front_range
    manager.data.update({"command": command, "sonar": (ranges, angles), "bump": bump})
    manager.tick(now)
    return manager


def test_the_safety_reflex_slows_near_an_obstacle_stops_before_it_and_backs_off_after_a_bump():
    assert reflex_output((0.5, 0.1), 3.0).data["safe-command"] == (0.5, 0.1)
    v, omega = reflex_output((0.5, 0.1), 0.36).data["safe-command"]
    assert 0 < v < 0.5 and omega == 0.1
    assert reflex_output((0.5, 0.1), 0.1).data["safe-command"] == (0.0, 0.1)
    assert reflex_output((-0.2, 0.0), 0.1).data["safe-command"] == (-0.2, 0.0)  # reversing away is allowed
    manager = reflex_output((0.5, 0.0), 3.0, bump=0.3)
    v, omega = manager.data["safe-command"]
    assert v < 0 and omega < 0  # backs off, turning away from a bump on its left
    manager.data["bump"] = None
    manager.tick(0.3)
    assert manager.data["safe-command"][0] < 0  # still backing off
    manager.tick(0.7)
    assert manager.data["safe-command"] == (0.5, 0.0)

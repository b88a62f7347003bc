"""Skills are resources: a skill instance belongs to the task that enabled it, and a second
live task takes it (the holder's step ends :preempted) or is refused (:busy) by priority.

A stock skill is one instance whatever its arguments (one robot base); a virtual skill is
one instance per call (scripts share nothing), so these tests contest the same call."""

from __future__ import annotations

from scenario import run
from world_runs import go_to_mission, run_in_world

CAMERAS = """
(define-virtual-skill (camera ?what) (after 10 (assert (seen ?what)) (finish :succeed)))
(define-virtual-skill (spare-camera ?what) (after 20 (assert (seen ?what)) (finish :succeed)))
(define-rap (look-at ?what)
  (succeed (seen ?what))
  (method main (task-net (t1 (camera ?what))))
  (method spare (task-net (t1 (spare-camera ?what)))))
"""


def test_a_newer_task_takes_the_skill_and_the_holder_recovers_with_its_other_method(tmp_path):
    mission = CAMERAS + "(post (look-at pump))\n(at-time 3 (assert (go)))\n" \
        "(define-rap (watch ?x) (method (task-net (sequence (wait-for (go)) (t1 (camera ?x))))))\n" \
        "(post (watch pump))\n"
    with run(tmp_path, mission) as s:
        assert s.result.ok
        (contest,) = s.events("skill-preempted")
        assert contest == {"t": 3.0, "event": "skill-preempted", "skill": "(camera pump)", "outcome": ":preempted",
                           "id": 1, "task": "(look-at pump)", "winner_id": 2, "winner": "(watch pump)"}
        step = s.events("step-outcome", task="(look-at pump)", outcome=":preempted")
        assert step and step[0]["t"] == 3.0  # at once, not at a timeout
        assert "preempted by [2] (watch pump)" in step[0]["reason"]
        assert s.field("method", "method-selected", task="(look-at pump)") == ["main", "spare"]
        assert s.times("task-succeeded", task="(look-at pump)") == [23.0]  # the spare camera, 20 s from t=3
        assert s.times("task-succeeded", task="(watch pump)") == [13.0]
        disabled = s.events("skill-disabled", skill="(camera pump)", id=1)
        assert [r["t"] for r in disabled] == [3.0]  # the holder's enable is matched by its disable


def test_a_holder_of_higher_priority_keeps_the_skill_and_the_newcomer_is_busy(tmp_path):
    mission = CAMERAS + "(post (look-at pump) :priority 5)\n" \
        "(define-rap (glance ?x) (retries 1) (method (task-net (t1 (camera ?x)))))\n" \
        "(at-time 1 (assert (go)))\n" \
        "(define-rap (later ?x) (retries 1) (method (task-net (sequence (wait-for (go)) (t1 (glance ?x))))))\n" \
        "(post (later pump))\n"
    with run(tmp_path, mission) as s:
        (contest,) = s.events("skill-preempted")
        assert contest["outcome"] == ":busy" and contest["task"] == "(glance pump)"
        assert contest["winner"] == "(look-at pump)"
        assert s.task("(look-at pump)").status == "succeeded"
        assert s.times("task-succeeded", task="(look-at pump)") == [10.0]  # never interrupted
        glance = s.task("(glance pump)")
        assert glance.status == "failed" and glance.ended == 1.0
        root = glance.failure.root()
        assert root.reason.startswith("skill (camera pump) is held by [1] (look-at pump), whose priority 5")


def test_a_task_that_enables_a_skill_it_holds_restarts_it_without_a_contest(tmp_path):
    mission = """
(define-virtual-skill (beep ?n) (after 1 (finish :succeed)))
(define-rap (twice) (method (primitive (enable (beep 1)) (enable (beep 1)) (wait-for (done (beep 1) ?o)))))
(post (twice))
"""
    with run(tmp_path, mission) as s:
        assert s.result.ok
        assert s.events("skill-preempted") == []


def test_two_go_tos_in_a_world_end_at_once_instead_of_one_hanging_until_its_timeout(tmp_path):
    """The defect: (go-to office) and (go-to storeroom) together left the first task waiting
    600 s for a navigate-to that the second had taken over."""
    path = tmp_path / "two.rap"
    navigation = go_to_mission(tmp_path, "office").read_text(encoding="utf-8").splitlines()[0]
    path.write_text(f"{navigation}\n(post (go-to office))\n(post (go-to storeroom))\n", encoding="utf-8")
    done = run_in_world(path, "lab-corridor-office")
    office, storeroom = done.result.tasks
    assert storeroom.status == "succeeded", done.explain()
    assert office.status == "failed" and office.ended == 0.0, done.explain()
    assert "preempted by [2] (go-to storeroom)" in office.failure.root().reason
    contests = [r for r in done.records if r["event"] == "skill-preempted"]
    assert contests and {(r["task"], r["winner"]) for r in contests} == {
        ("(go-to office)", "(go-to storeroom)"), ("(go-to storeroom)", "(go-to office)")}
    assert done.mission.manager.running() == []  # nothing left enabled at the end


def test_always_on_skills_belong_to_no_task(tmp_path):
    done = run_in_world(go_to_mission(tmp_path, "corridor"), "lab-corridor-office")
    assert done.result.ok, done.explain()
    manager = done.mission.manager
    always_on = {name for name, skill in manager.catalog.items() if skill.always_on}
    assert {"safety-reflex", "sonar-ring", "place-monitor"} <= always_on
    assert not always_on & set(done.mission.skills.skills())  # tasks cannot enable them
    enabled = {r["skill"].strip("()").split()[0] for r in done.records if r["event"] == "skill-enabled"}
    assert enabled and not enabled & always_on


def test_mapping_is_layer_ivs_and_no_task_can_take_it():
    from atlas_rap.layers import MissionEngine

    engine = MissionEngine("lab-corridor-office", mapping=True)
    engine.start()
    assert "map-builder" not in engine.skills.skills()
    engine.advance(1.0)  # no task posted: Layer IV maps all the same
    assert engine.grid is not None and engine.grid.updated.sum() > 500

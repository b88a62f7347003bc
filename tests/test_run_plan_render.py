"""The picture of a run with a plan (views.world_render): where each plan step started and how it
ended, re-plans and abandoned plans, read from the plan executive's trace records. A unit
test of the renderer: a small world, a hand-made path and hand-made records."""

from __future__ import annotations


import numpy as np
from matplotlib.image import imread

from plan_records import ended as _ended
from plan_records import started as _started
from atlas_rap.model import Door, Place, RobotConfig, Segment, World
from atlas_rap.views.world_render import PLAN_EVENTS, plan_legend_rows, plan_marks, render_run


def _world() -> World:
    walls = (
        Segment((0, 0), (8, 0)), Segment((8, 0), (8, 5)), Segment((8, 5), (0, 5)), Segment((0, 5), (0, 0)),
        Segment((4, 0), (4, 2)), Segment((4, 3), (4, 5)),
    )
    places = {
        "hall": Place("hall", (2, 2.5), region=((0, 0), (4, 0), (4, 5), (0, 5))),
        "office": Place("office", (6, 2.5), region=((4, 0), (8, 0), (8, 5), (4, 5))),
    }
    doors = {"d1": Door("d1", ("hall", "office"), (4, 2.5), Segment((4, 2), (4, 3)), open=True)}
    return World("two-rooms", walls, places, doors, robot=RobotConfig(start=(1, 1, 0)), bounds=(0, 0, 8, 5))


def _path() -> list[tuple[float, float, float, float]]:
    """1 m/s from (1, 1) along y = 1 to (7, 1): x = 1 + t, for t in 0..6, every 0.5 s."""
    return [(0.5 * i, 1 + 0.5 * i, 1.0, 0.0) for i in range(13)]




RECORDS = [
    {"t": 0.0, "event": "plan-ready", "plan": 1, "version": 1, "id": 1, "steps": 3, "makespan": 9,
     "goals": ["(at robot office)"]},
    {"t": 0.0, "event": "task-selected", "id": 1, "task": "(errand)"},  # not the plan's: ignored
    _started(0.0, 1, "(go-to hall)", 10),
    _started(0.0, 2, "(open d1)", 11, agent="arm"),
    _ended(2.0, "plan-step-done", 1, "(go-to hall)", 10),
    _ended(2.5, "plan-step-failed", 2, "(open d1)", 11, agent="arm", reason="the door is locked"),
    {"t": 2.5, "event": "plan-ready", "plan": 1, "version": 2, "id": 1, "steps": 2, "makespan": 6,
     "goals": ["(at robot office)"]},
    {"t": 2.5, "event": "replanned", "plan": 1, "version": 2, "id": 1,
     "cause": "step s2 (open d1) failed: the door is locked", "done": ["(go-to hall)"], "kept": [],
     "new": ["(unlock d1)", "(go-to office)"], "halted": [], "reassigned": []},
    _started(3.0, 1, "(unlock d1)", 12, version=2),
    _ended(4.0, "plan-step-done", 1, "(unlock d1)", 12, version=2),
    _started(4.0, 2, "(go-to office)", 13, version=2),
    _ended(6.0, "plan-step-done", 2, "(go-to office)", 13, version=2),
    {"t": 6.0, "event": "plan-done", "plan": 1, "version": 2, "id": 1, "goals": ["(at robot office)"],
     "abandoned": []},
]


# ============================================================================= reading the records

def test_steps_are_placed_where_the_robot_was_when_they_started() -> None:
    steps, notes = plan_marks(RECORDS, _path())
    assert [(m.version, m.step, m.action, m.outcome) for m in steps] == [
        (1, 1, "(go-to hall)", "done"), (1, 2, "(open d1)", "failed"),
        (2, 1, "(unlock d1)", "done"), (2, 2, "(go-to office)", "done")]
    assert [(m.x, m.y) for m in steps] == [(1.0, 1.0), (1.0, 1.0), (4.0, 1.0), (5.0, 1.0)]
    assert steps[1].end == 2.5 and steps[1].reason == "the door is locked" and steps[1].agent == "arm"
    assert [(n.kind, n.version, n.x) for n in notes] == [
        ("ready", 1, 1.0), ("ready", 2, 3.5), ("replanned", 2, 3.5), ("finished", 2, 7.0)]


def test_without_a_path_steps_are_at_the_start() -> None:
    steps, _ = plan_marks(RECORDS, (), start=(1.5, 2.0))
    assert {(m.x, m.y) for m in steps} == {(1.5, 2.0)}


def test_the_legend_lists_the_steps_in_time_order() -> None:
    rows = plan_legend_rows(*plan_marks(RECORDS, _path()))
    assert rows == [
        ("ready", "plan 1 at 0.0 s: 3 steps, makespan 9, for (at robot office)"),
        ("done", "v1 s1 (go-to hall) [robot] \u2713 0.0\u20132.0 s"),
        ("failed", "v1 s2 (open d1) [arm] \u2717 0.0\u20132.5 s: the door is locked"),
        ("replanned", "re-planned at 2.5 s (plan 1 v2; 2 new): step s2 (open d1) failed: the door is locked"),
        ("done", "v2 s1 (unlock d1) [robot] \u2713 3.0\u20134.0 s"),
        ("done", "v2 s2 (go-to office) [robot] \u2713 4.0\u20136.0 s"),
        ("finished", "plan 1 done at 6.0 s"),
    ]


def test_one_plan_of_one_version_is_numbered_plainly() -> None:
    records = [_started(0.0, 3, "(go-to office)", 7), _ended(5.0, "plan-step-done", 3, "(go-to office)", 7)]
    assert plan_legend_rows(*plan_marks(records, _path())) == [
        ("done", "s3 (go-to office) [robot] \u2713 0.0\u20135.0 s")]


def test_halted_abandoned_running_and_several_plans() -> None:
    records = [
        _started(0.0, 1, "(go-to hall)", 10),
        _started(0.0, 2, "(wave)", 11, agent=None),
        {"t": 1.0, "event": "replanned", "plan": 1, "version": 2, "cause": "a hall is blocked", "kept": ["(wave)"],
         "new": [], "halted": ["(go-to hall)"], "reassigned": []},
        {"t": 3.0, "event": "plan-abandoned", "plan": 1, "version": 2, "scope": "plan", "goals": ["(at robot hall)"],
         "reason": "no plan meets the deadline"},
        _started(4.0, 1, "(go-to office)", 20, plan=2),
        _started(4.0, 1, "(go-to office)", 20, plan=2),  # started twice: the first counts
    ]
    steps, notes = plan_marks(records, _path())
    assert [(m.plan, m.step, m.outcome, m.end) for m in steps] == [
        (1, 1, "halted", 1.0), (1, 2, "halted", 3.0), (2, 1, "running", None)]
    rows = plan_legend_rows(steps, notes)
    texts = [text for _, text in rows]
    assert texts[0] == "p1 v1 s1 (go-to hall) [robot] halted 0.0\u20131.0 s: re-plan v2 dropped it"
    assert texts[1] == "p1 v1 s2 (wave) halted 0.0\u20133.0 s: the plan was abandoned"
    assert "re-planned at 1.0 s (plan 1 v2; 1 kept, 1 halted): a hall is blocked" in texts
    assert "plan 1 abandoned at 3.0 s: no plan meets the deadline" in texts
    assert texts[-1] == "p2 s1 (go-to office) [robot] running from 4.0 s"


def test_records_that_are_not_the_plans_are_ignored() -> None:
    assert plan_marks([{"t": 0.0, "event": "task-selected", "id": 1, "task": "(x)"}], _path()) == ([], [])
    assert "plan-step-started" in PLAN_EVENTS and "task-selected" not in PLAN_EVENTS


# ============================================================================= the picture

def test_the_picture_is_written_the_same_twice_and_shows_the_plan(tmp_path) -> None:
    world = _world()
    first = render_run(world, tmp_path / "a.png", path=_path(), plan_events=RECORDS, title="errand, seed 0")
    again = render_run(world, tmp_path / "b.png", path=_path(), plan_events=RECORDS, title="errand, seed 0")
    data = first.read_bytes()
    assert data.startswith(b"\x89PNG\r\n\x1a\n") and data == again.read_bytes()
    without = render_run(world, tmp_path / "c.png", path=_path(), title="errand, seed 0")
    a, c = imread(first)[..., :3], imread(without)[..., :3]
    assert a.shape != c.shape or not np.array_equal(a, c)
    # the failed step's red square and the re-plan's purple star are there
    red = (a[..., 0] > 0.75) & (a[..., 1] < 0.3) & (a[..., 2] < 0.3)
    purple = (a[..., 0] > 0.5) & (a[..., 1] < 0.35) & (a[..., 2] > 0.6)
    assert red.sum() > ((c[..., 0] > 0.75) & (c[..., 1] < 0.3) & (c[..., 2] < 0.3)).sum()
    assert purple.sum() > 10


def test_a_plan_alone_without_a_path_or_task_marks(tmp_path) -> None:
    out = render_run(_world(), tmp_path / "plan-only.png", plan_events=RECORDS[:3])
    assert imread(out).shape[0] > 100

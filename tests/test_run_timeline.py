"""The timeline of a run with no world (views.timeline, ``atlas run --render`` in ``(world none)``):
plan steps in a lane per agent, re-plans and abandons as lines, tasks below; read from trace records."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from matplotlib.image import imread

from plan_records import ended as _ended
from plan_records import started as _started
from atlas_rap.views.timeline import (NO_AGENT, OUTCOME_COLOURS, lanes, method_changes, pack_rows, plan_lines,
                                       render_timeline, short_action, short_cause, stack_labels, step_bars,
                                       task_bars)
from cli_process import REPO, assert_no_traceback, atlas




def _posted(t, tid, text, parent=None):
    record = {"t": t, "event": "task-posted", "id": tid, "task": text, "priority": 0}
    if parent is not None:
        record["parent"] = parent
    return record


def _task(t, event, tid, text, **more):
    return {"t": t, "event": event, "id": tid, "task": text, **more}


# A plan of two agents (the arm first used later), a failed step, a re-plan that halts one
# step and hands a running one from left-arm to right-arm, a goal given up, and the plan abandoned.
RECORDS = [
    _posted(0.0, 1, "(service-station)"),
    _task(0.0, "task-selected", 1, "(service-station)"),
    {"t": 0.0, "event": "method-selected", "id": 1, "task": "(service-station)", "method": "carry-out", "attempt": 1},
    {"t": 0.0, "event": "plan-requested", "plan": 1, "id": 1, "goals": ["(repaired site-b)"]},
    {"t": 0.2, "event": "plan-ready", "plan": 1, "version": 1, "id": 1, "steps": 4, "makespan": 50},
    _posted(0.2, 2, "(fly-to evahr site-b)", parent=1),
    _started(0.2, 1, "(fly-to evahr site-b)", 2, agent="evahr"),
    _task(0.2, "task-selected", 2, "(fly-to evahr site-b)"),
    _task(30.2, "task-succeeded", 2, "(fly-to evahr site-b)"),
    _ended(30.2, "plan-step-done", 1, "(fly-to evahr site-b)", 2, agent="evahr"),
    _posted(30.2, 3, "(inspect-site left-arm site-b)", parent=1),
    _started(30.2, 2, "(inspect-site left-arm site-b)", 3, agent="left-arm"),
    _posted(30.2, 4, "(log-data)", parent=1),
    _started(30.2, 3, "(log-data)", 4, agent=None),
    _task(30.2, "task-selected", 3, "(inspect-site left-arm site-b)"),
    {"t": 30.2, "event": "method-selected", "id": 3, "task": "(inspect-site left-arm site-b)",
     "method": "own-arm", "attempt": 1},
    {"t": 35.0, "event": "method-selected", "id": 3, "task": "(inspect-site left-arm site-b)",
     "method": "other-arm", "attempt": 2},
    {"t": 40.0, "event": "replanned", "plan": 1, "version": 2, "id": 1,
     "cause": "agent left-arm was lost ((agent-failed left-arm))", "kept": ["(inspect-site right-arm site-b)"],
     "new": [], "halted": ["(log-data)"],
     "reassigned": [{"step": "s1", "action": "(inspect-site right-arm site-b)", "from": "left-arm",
                     "to": "right-arm", "running": True}]},
    _task(40.0, "task-halted", 4, "(log-data)", reason="a re-plan dropped it"),
    {"t": 40.0, "event": "plan-ready", "plan": 1, "version": 2, "id": 1, "steps": 2, "makespan": 20},
    _task(50.0, "task-failed", 3, "(inspect-site left-arm site-b)", reason="no image"),
    _ended(50.0, "plan-step-failed", 1, "(inspect-site right-arm site-b)", 3, agent="right-arm", version=2,
           reason="skill (camera-scan right-arm site-b): finished :fail: no image"),
    {"t": 50.0, "event": "plan-abandoned", "plan": 1, "version": 2, "id": 1, "scope": "goal",
     "goals": ["(repaired site-b)"], "reason": "3 failures; the last: step s1 (inspect-site right-arm site-b) "
                                               "failed: skill (camera-scan right-arm site-b): finished :fail: no image"},
    _posted(50.2, 5, "(log-data)", parent=1),
    _started(50.2, 1, "(log-data)", 5, agent=None, version=3),
    {"t": 55.0, "event": "plan-abandoned", "plan": 1, "version": 3, "id": 1, "scope": "plan",
     "goals": ["(repaired site-b)"], "reason": "no plan meets the deadline: the plan takes 60 s and 5 s are left"},
    {"t": 55.0, "event": "method-selected", "id": 1, "task": "(service-station)", "method": "give-up",
     "attempt": 2},
    _posted(55.0, 6, "(return-to-dock evahr)", parent=1),
    _task(55.0, "task-selected", 6, "(return-to-dock evahr)"),
    _posted(55.0, 7, "(dock evahr)", parent=6),  # two levels below: not drawn
    _task(55.0, "task-selected", 7, "(dock evahr)"),
    _task(60.0, "task-succeeded", 7, "(dock evahr)"),
]


# ============================================================================= reading the records

def test_step_bars_outcomes_agents_and_labels() -> None:
    bars = step_bars(RECORDS)
    assert [(b.lane, b.start, b.end, b.outcome) for b in bars] == [
        ("evahr", 0.2, 30.2, "done"),
        ("left-arm", 30.2, 40.0, "handed-over"),
        (NO_AGENT, 30.2, 40.0, "halted"),
        ("right-arm", 40.0, 50.0, "failed"),
        (NO_AGENT, 50.2, 55.0, "halted"),
    ]
    # the agent is the lane's name, so the label leaves it out; v2 after a re-plan
    assert bars[0].label == "v1 s1 fly-to site-b"
    assert bars[1].label == "v1 s2 inspect-site site-b \u2192 other-arm"  # the RAP's other method, on the bar
    assert bars[1].ticks == ((35.0, "other-arm", 2, "own-arm"),) and bars[3].ticks == ()
    assert bars[3].label == "v2 s1 inspect-site site-b (from left-arm)"
    assert bars[3].from_agent == "left-arm" and bars[3].task == 3
    assert bars[2].label == "v1 s3 log-data" and "re-plan v2 dropped it" in bars[2].reason
    assert bars[4].reason == "the plan was abandoned"
    assert "no image" in bars[3].reason


def test_a_step_with_no_end_is_still_running_and_one_plan_of_one_version_is_plain() -> None:
    records = [_started(0.0, 1, "(go-to robot hall)", 10), _started(0.0, 2, "(open arm d1)", 11, agent="arm"),
               _ended(3.0, "plan-step-done", 1, "(go-to robot hall)", 10)]
    bars = step_bars(records)
    assert [(b.label, b.outcome, b.end) for b in bars] == [("s1 go-to hall", "done", 3.0),
                                                           ("s2 open d1", "running", None)]


def test_several_plans_are_told_apart() -> None:
    records = [_started(0.0, 1, "(go robot a)", 10), _ended(1.0, "plan-step-done", 1, "(go robot a)", 10),
               _started(2.0, 1, "(go robot b)", 11, plan=2), _ended(3.0, "plan-step-done", 1, "(go robot b)", 11, plan=2)]
    assert [b.label for b in step_bars(records)] == ["p1 s1 go a", "p2 s1 go b"]


def test_a_step_that_ends_with_another_agent_is_cut_at_the_last_replan() -> None:
    """With no ``reassigned`` entry (an older trace), a change of agent is still shown."""
    records = [_started(0.0, 1, "(scan left-arm x)", 10, agent="left-arm"),
               {"t": 4.0, "event": "replanned", "plan": 1, "version": 2, "cause": "agent left-arm was lost"},
               _ended(9.0, "plan-step-done", 1, "(scan right-arm x)", 10, agent="right-arm", version=2)]
    bars = step_bars(records)
    assert [(b.lane, b.start, b.end, b.outcome) for b in bars] == [
        ("left-arm", 0.0, 4.0, "handed-over"), ("right-arm", 4.0, 9.0, "done")]


def test_lanes_are_agents_by_first_use_and_no_agent_last() -> None:
    assert lanes(step_bars(RECORDS)) == ["evahr", "left-arm", "right-arm", NO_AGENT]
    records = [_started(5.0, 1, "(a arm)", 10, agent="arm"), _started(1.0, 2, "(b base)", 11, agent="base"),
               _started(0.0, 3, "(c)", 12, agent=None), _started(5.0, 4, "(d cam)", 13, agent="cam")]
    assert lanes(step_bars(records)) == ["base", "arm", "cam", NO_AGENT]


def test_plan_lines_say_what_happened_briefly() -> None:
    lines = plan_lines(RECORDS)
    assert [(n.time, n.kind, n.label) for n in lines] == [
        (40.0, "replanned", "re-plan v2: agent left-arm was lost"),
        (50.0, "abandoned", "abandoned (repaired site-b): 3 failures"),
        (55.0, "abandoned", "plan abandoned: no plan meets the deadline: the plan takes 60 s and 5 s are left"),
    ]
    assert all(len(line) <= 40 for n in lines for line in n.lines)  # wrapped
    cause = ("step s3 (repair-site left-arm site-b) failed: skill (swap-orbital-unit left-arm site-b): "
             "finished :fail: the arm's tool is jammed")
    assert short_cause(cause) == "s3 (repair-site left-arm site-b) failed: the arm's tool is jammed"
    long = plan_lines([{"t": 1.0, "event": "replanned", "plan": 1, "version": 2, "cause": "x " * 200}])[0]
    assert len(long.lines) == 3 and long.lines[-1].endswith("\u2026")


def test_tasks_posted_and_one_level_below_in_tree_order_without_the_plan_steps() -> None:
    steps = {b.task for b in step_bars(RECORDS)}
    tasks = task_bars(RECORDS, skip=steps)
    assert [(t.task, t.depth, t.start, t.end, t.outcome) for t in tasks] == [
        (1, 0, 0.0, None, "running"), (6, 1, 55.0, None, "running")]
    assert tasks[0].ticks == ((55.0, "give-up", 2, "carry-out"),)
    everything = task_bars(RECORDS)
    assert [t.task for t in everything] == [1, 2, 3, 4, 5, 6]  # (dock evahr) is two levels down
    assert [t.outcome for t in everything] == ["running", "done", "failed", "halted", "running", "running"]
    assert everything[2].reason == "no image"
    assert method_changes(RECORDS) == {3: [(35.0, "other-arm", 2, "own-arm")], 1: [(55.0, "give-up", 2, "carry-out")]}


def test_a_retry_of_the_same_method_is_a_tick_but_no_change() -> None:
    records = [_started(0.0, 1, "(repair-site arm x)", 10, agent="arm"),
               {"t": 0.0, "event": "method-selected", "id": 10, "method": "own-arm", "attempt": 1},
               {"t": 4.0, "event": "method-selected", "id": 10, "method": "own-arm", "attempt": 2},
               {"t": 6.0, "event": "method-selected", "id": 10, "method": "spare", "attempt": 3},
               _ended(9.0, "plan-step-failed", 1, "(repair-site arm x)", 10, agent="arm")]
    changes = method_changes(records)[10]
    assert [(c.t, c.changed) for c in changes] == [(4.0, False), (6.0, True)]
    bar, = step_bars(records)
    assert bar.label == "s1 repair-site x \u2192 spare" and len(bar.ticks) == 2


def test_short_actions_leave_the_agent_out() -> None:
    assert short_action("(repair-site left-arm site-b)", "left-arm") == "repair-site site-b"
    assert short_action("(dock evahr)", "evahr") == "dock"
    assert short_action("(put arm arm-tool)", "arm") == "put arm-tool"
    assert short_action("(go-to hall)") == "go-to hall"
    assert len(short_action("(" + "x" * 80 + ")")) == 30


def test_labels_are_stacked_so_that_no_line_crosses_one() -> None:
    items = [(0.0, 30.0, 1.0), (10.0, 30.0, 2.0), (12.0, 5.0, 1.0), (50.0, 10.0, 1.0), (100.0, 40.0, 1.0)]
    bottoms = stack_labels(items)
    for i, (x, w, h) in enumerate(items):
        for j, (xj, _, hj) in enumerate(items):
            if j != i and x <= xj < x + w and (xj, j) > (x, i):  # line j under label i reaches below it
                assert bottoms[j] + hj <= bottoms[i]
    assert bottoms[3] == bottoms[4] == 0.0  # alone: on the chart
    assert bottoms[0] > bottoms[1] > bottoms[2] == 0.0


def test_rows_are_packed_first_fit() -> None:
    assert pack_rows([(0, 10), (5, 8), (8, 12), (10, 11), (12, 20)]) == [0, 1, 1, 0, 0]
    assert pack_rows([]) == []


# ============================================================================= the picture

def test_the_timeline_is_written_the_same_twice_and_shows_outcomes(tmp_path) -> None:
    first = render_timeline(RECORDS, tmp_path / "deep" / "t.png", "mission.rap, seed 0", end=60.0)
    again = render_timeline(RECORDS, tmp_path / "t2.png", "mission.rap, seed 0", end=60.0)
    assert first == tmp_path / "deep" / "t.png" and first.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert first.read_bytes() == again.read_bytes()
    img = imread(first)[..., :3]
    h, w = img.shape[:2]
    assert 600 <= w <= 2500 and 250 <= h <= 2000
    for outcome in ("done", "failed", "halted", "handed-over"):
        colour = np.array([int(OUTCOME_COLOURS[outcome][i:i + 2], 16) / 255 for i in (1, 3, 5)])
        assert (np.abs(img - colour).max(axis=2) < 0.02).sum() > 50, outcome


def test_a_timeline_of_nothing_and_of_tasks_alone(tmp_path) -> None:
    assert imread(render_timeline([], tmp_path / "empty.png", "repl")).shape[0] > 50
    only_tasks = [r for r in RECORDS if not r["event"].startswith("plan-") and r["event"] != "replanned"]
    assert imread(render_timeline(only_tasks, tmp_path / "tasks.png", "tasks")).shape[0] > 50


def test_importing_the_module_does_not_import_matplotlib() -> None:
    code = "import sys, atlas_rap.views.timeline; print('matplotlib' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO)
    assert done.stdout.strip() == "False", done.stderr


# ============================================================================= atlas run --render, no world

def test_atlas_run_render_with_no_world_draws_the_timeline(tmp_path) -> None:
    mission = str(REPO / "rap_library" / "missions" / "evahr.rap")
    done = atlas("run", mission, "-q", "--render", "t.png", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout + done.stderr
    png = tmp_path / "t.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and "picture written to t.png" in done.stdout
    again = atlas("run", mission, "-q", "--render", "t2.png", cwd=tmp_path)
    assert again.returncode == 0 and (tmp_path / "t2.png").read_bytes() == png.read_bytes()


def test_atlas_run_render_a_run_without_plans(tmp_path) -> None:
    done = atlas("run", str(REPO / "rap_library" / "missions" / "site-visit.rap"), "-q", "--render", "s.png",
                 cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout + done.stderr
    assert imread(tmp_path / "s.png").shape[0] > 100


def test_the_run_picture_keeps_what_the_timeline_needs() -> None:
    """RunPicture keeps tasks at most one level down (first selection, method changes, end) and the plan
    steps' tasks' method changes, not every record."""
    from atlas_rap.layers import MissionEngine, RunOptions
    from atlas_rap.views import RunPicture

    engine = MissionEngine(RunOptions(world="none", seed=0))
    picture = RunPicture(engine)
    engine.load_file(REPO / "rap_library" / "missions" / "evahr.rap", require_post=True)
    assert engine.run_mission().ok
    kept = picture.timeline
    assert {r["event"] for r in kept} <= {"task-posted", "task-selected", "method-selected", "task-succeeded",
                                           "task-failed", "task-halted", "plan-requested", "plan-ready",
                                           "plan-step-started", "plan-step-done", "plan-step-failed", "replanned",
                                           "plan-abandoned", "plan-done"}
    posted = {r["id"] for r in kept if r["event"] == "task-posted"}
    assert all(r["id"] in posted for r in kept if r["event"].startswith("task-") or r["event"] == "method-selected")
    selected = [r["id"] for r in kept if r["event"] == "task-selected"]
    assert len(selected) == len(set(selected))
    bars = step_bars(kept)
    assert ("right-arm", "done") in {(b.lane, b.outcome) for b in bars}
    assert any(b.outcome == "handed-over" for b in bars)  # left-arm was lost while inspecting site-c
    assert [c.method for c in method_changes(kept)[3]] == ["handrail"]  # attach-at: grapple, then handrail


def test_the_run_picture_leaves_out_tasks_two_levels_down() -> None:
    from atlas_rap.layers import MissionEngine, RunOptions
    from atlas_rap.views import RunPicture

    engine = MissionEngine(RunOptions(world="none", seed=0))
    picture = RunPicture(engine)
    engine.load_file(REPO / "rap_library" / "missions" / "site-visit.rap", require_post=True)
    assert engine.run_mission().ok
    shown = {r["task"] for r in picture.timeline if r["event"] == "task-posted"}
    assert shown == {"(service-round)", "(report-fault hull-7)", "(visit-site hull-3 spare-pump)",
                     "(visit-site hull-7 filter)"}
    assert all(r.get("task") in shown for r in picture.timeline)

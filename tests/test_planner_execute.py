"""`(plan GOAL ...)` in a mission: planned from memory when its task runs (the planner's
latency charged in simulated time), carried out by RAPs in the plan's partial order, and a
plan no RAP can execute abandoned before any of its steps runs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cli_process import REPO, assert_no_traceback, atlas

LIFT = """\
(world none)
(operator fetch :purpose (have ?x) :agent ?arm :preconditions ((on-shelf ?x)) :constraints ((arm ?arm))
  :plot (take ?arm ?x) :effects ((have ?x) (not (on-shelf ?x))))
(operator pack :purpose (packed ?x) :agent ?arm :preconditions ((have ?x)) :constraints ((arm ?arm))
  :plot (put-in-box ?arm ?x) :effects ((packed ?x)))
(agents (controlled arm-1))
(initial (arm arm-1) (on-shelf cup))
(define-virtual-skill (take-skill ?arm ?x) (after 2 (assert (have ?x)) (finish :succeed)))
(define-virtual-skill (box-skill ?arm ?x) (after 3 (assert (packed ?x)) (finish :succeed)))
(define-rap (take ?arm ?x) (succeed (have ?x))
  (method (primitive (enable (take-skill ?arm ?x)) (wait-for (have ?x) :succeed) (disable :above))))
{pack_rap}
(plan (packed cup))
"""

PACK_RAP = """(define-rap (put-in-box ?arm ?x) (succeed (packed ?x))
  (method (primitive (enable (box-skill ?arm ?x)) (wait-for (packed ?x) :succeed) (disable :above))))"""


def trace_of(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


def test_a_plan_in_a_mission_is_carried_out_by_raps_in_its_order(tmp_path: Path) -> None:
    (tmp_path / "lift.rap").write_text(LIFT.format(pack_rap=PACK_RAP), encoding="utf-8")
    done = atlas("run", "lift.rap", "--trace", "t.jsonl", "--quiet", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    ends = {r["task"]: r["t"] for r in trace_of(tmp_path / "t.jsonl") if r["event"] == "task-succeeded"}
    starts = {r["task"]: r["t"] for r in trace_of(tmp_path / "t.jsonl") if r["event"] == "task-selected"}
    ready = next(r["t"] for r in trace_of(tmp_path / "t.jsonl") if r["event"] == "plan-ready")
    assert ready > 0  # the planner's latency is charged in simulated time
    assert ends["(take arm-1 cup)"] == pytest.approx(ready + 2)
    assert starts["(put-in-box arm-1 cup)"] >= ends["(take arm-1 cup)"]  # packing waits for the fetch
    assert ends["(carry-out-plan-1)"] == pytest.approx(ready + 5)


def test_a_plan_with_a_step_no_rap_can_execute_is_abandoned_before_any_step_runs(tmp_path: Path) -> None:
    (tmp_path / "lift.rap").write_text(LIFT.format(pack_rap=""), encoding="utf-8")
    done = atlas("run", "lift.rap", "--trace", "t.jsonl", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "plan step s2 (put-in-box arm-1 cup): no RAP can execute it" in done.stdout
    records = trace_of(tmp_path / "t.jsonl")
    abandoned = [r for r in records if r["event"] == "plan-abandoned"]
    assert len(abandoned) == 1 and "no RAP can execute it" in abandoned[0]["reason"]
    assert not [r for r in records if r["event"] == "plan-step-started"]


def test_a_goal_with_no_plan_fails_the_mission_naming_it(tmp_path: Path) -> None:
    text = LIFT.format(pack_rap=PACK_RAP).replace("(initial (arm arm-1) (on-shelf cup))", "(initial (arm arm-1))")
    (tmp_path / "lift.rap").write_text(text, encoding="utf-8")
    done = atlas("run", "lift.rap", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "plan 1 abandoned: no plan for (packed cup): unsolvable" in done.stdout


def test_the_shipped_plan_mission_lifts_the_crate_with_two_robots_at_once(tmp_path: Path) -> None:
    done = atlas("run", str(REPO / "rap_library/missions/plan-bulky.rap"), "--trace", "t.jsonl", "--quiet",
                 cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stderr
    selected = {r["task"]: r["t"] for r in trace_of(tmp_path / "t.jsonl") if r["event"] == "task-selected"}
    assert selected["(grip robot-a crate-1)"] == selected["(grip robot-b crate-1)"]

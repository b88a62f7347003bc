"""The MITRE office demo (seed 003): a robot re-plans round a blocked hallway on one floor
with a loop of halls (rap_library/missions/office-replan.rap), and gives the errand up and
comes back when the way round breaks the deadline (office-replan-late.rap). Virtual skills,
simulated time: each mission runs once per module, as a user would run it."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import pytest

from cli_process import REPO, assert_no_traceback, atlas

MISSIONS = REPO / "rap_library" / "missions"
MAIN = MISSIONS / "office-replan.rap"
LATE = MISSIONS / "office-replan-late.rap"
BLOCKED = "(passage west-hall north-hall-west)"


@dataclass
class Run:
    returncode: int
    stdout: str
    stderr: str
    records: list[dict]

    def events(self, event: str) -> list[dict]:
        return [r for r in self.records if r["event"] == event]

    def facts(self, event: str) -> list[str]:
        return [r["fact"] for r in self.events(event)]

    def robot_at_end(self) -> str:
        """Where memory has the robot when the run ends (a memory rule keeps one robot-at)."""
        alive: set[str] = set()
        for r in self.records:
            if r.get("fact", "").startswith("(robot-at robot "):
                (alive.add if r["event"] == "fact-asserted" else alive.discard)(r["fact"])
        assert len(alive) == 1, alive
        return alive.pop()


def run_mission(mission: Path, cwd: Path, trace: str = "t.jsonl", *extra: str) -> Run:
    done = atlas("run", str(mission), "--quiet", "--trace", trace, *extra, cwd=cwd)
    assert_no_traceback(done)
    lines = (cwd / trace).read_text(encoding="utf-8").splitlines()
    return Run(done.returncode, done.stdout, done.stderr, [json.loads(line) for line in lines])


@pytest.fixture(scope="module")
def main_run(tmp_path_factory) -> Run:
    return run_mission(MAIN, tmp_path_factory.mktemp("office-replan"))


@pytest.fixture(scope="module")
def late_run(tmp_path_factory) -> Run:
    return run_mission(LATE, tmp_path_factory.mktemp("office-replan-late"))


# -- the way round: re-planned round the blocked hallway, in time --------------------------------

def test_both_missions_and_their_files_pass_atlas_check(tmp_path):
    done = atlas("check", str(MAIN), str(LATE), str(REPO / "operators" / "office-replan.ap"), cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warning" not in done.stdout + done.stderr


def test_the_first_plan_goes_west_and_needs_the_hallway_that_gets_blocked(main_run):
    first = main_run.events("plan-ready")[0]
    assert first["version"] == 1 and first["makespan"] == 50
    assert "s4 (follow-hall robot north-hall-west) [robot]" in first["actions"]
    assert any("(follow-hall robot west-hall)" in action for action in first["actions"])


def test_blocking_the_hallway_ahead_of_the_robot_makes_it_replan_naming_the_passage(main_run):
    (replanned,) = main_run.events("replanned")
    assert BLOCKED in replanned["cause"] and "retracted" in replanned["cause"]
    assert replanned["t"] > 15  # after the at-time event, plus the planner's latency
    retracted = next(r for r in main_run.events("fact-retracted") if r["fact"] == BLOCKED)
    assert retracted["t"] == 15
    # the robot was driving into the south hall then: the blocked hallway was ahead of it
    assert replanned["kept"] == ["(follow-hall robot south-hall-west)"]
    assert replanned["halted"] == []


def test_the_steps_done_before_the_replan_stay_done_and_are_not_started_again(main_run):
    (replanned,) = main_run.events("replanned")
    assert replanned["done"] == ["(follow-hall robot entrance-hall)"]
    started_after = [r["action"] for r in main_run.events("plan-step-started") if r["t"] >= replanned["t"]]
    assert not set(replanned["done"]) & set(started_after)
    # the kept step is not started again either: it ran on, and finished for the new plan
    assert "(follow-hall robot south-hall-west)" not in started_after
    done_v2 = [r["action"] for r in main_run.events("plan-step-done") if r["version"] == 2]
    assert done_v2[0] == "(follow-hall robot south-hall-west)"


def test_the_new_steps_go_round_by_the_east_hall_and_never_through_the_west_hall(main_run):
    (replanned,) = main_run.events("replanned")
    assert replanned["new"][:4] == ["(follow-hall robot south-hall-east)", "(follow-hall robot east-hall)",
                                    "(follow-hall robot north-hall-east)", "(follow-hall robot north-hall-west)"]
    started_after = [r["action"] for r in main_run.events("plan-step-started") if r["t"] >= replanned["t"]]
    assert "(follow-hall robot east-hall)" in started_after
    assert "(follow-hall robot west-hall)" not in started_after
    assert [r["action"] for r in main_run.events("plan-step-started")].count("(follow-hall robot west-hall)") == 0


def test_the_robot_reaches_office_a_before_the_deadline_and_reports_it(main_run):
    assert main_run.returncode == 0, main_run.stdout + main_run.stderr
    (requested,) = main_run.events("plan-requested")
    (plan_done,) = main_run.events("plan-done")
    assert plan_done["goals"] == ["(robot-at robot office-a)"] and plan_done["abandoned"] == []
    assert plan_done["t"] < requested["deadline"] == 80
    arrived = next(r for r in main_run.events("fact-asserted") if r["fact"] == "(robot-at robot office-a)")
    assert arrived["t"] == pytest.approx(plan_done["t"])
    assert "(reported arrived office-a)" in main_run.facts("fact-asserted")
    assert main_run.robot_at_end() == "(robot-at robot office-a)"
    assert not main_run.events("plan-abandoned")


def test_a_hallway_blocked_under_the_robot_fails_the_hop_and_the_plan_goes_round(tmp_path):
    text = MAIN.read_text(encoding="utf-8")
    text = text.replace('"../../operators/', f'"{REPO}/operators/').replace('"../plan_steps/',
                                                                          f'"{MISSIONS.parent}/plan_steps/')
    event = ("(at-time 15\n  (retract (passage west-hall north-hall-west))\n"
             "  (retract (passage north-hall-west west-hall))\n  (assert (hall-blocked west-hall north-hall-west)))")
    assert event in text
    text = text.replace(event, "(at-time 25\n  (retract (passage south-hall-west west-hall))\n"
                               "  (retract (passage west-hall south-hall-west))\n"
                               "  (assert (hall-blocked south-hall-west west-hall)))")
    (tmp_path / "under.rap").write_text(text, encoding="utf-8")
    run = run_mission(tmp_path / "under.rap", tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    (failed,) = run.events("plan-step-failed")
    assert failed["action"] == "(follow-hall robot west-hall)" and failed["t"] == 25  # at once, mid-hop
    (replanned,) = run.events("replanned")
    assert replanned["cause"].startswith("step s3 (follow-hall robot west-hall) failed")
    assert replanned["done"] == ["(follow-hall robot entrance-hall)", "(follow-hall robot south-hall-west)"]
    assert "(follow-hall robot east-hall)" in replanned["new"]
    assert "(robot-at robot office-a)" in run.facts("fact-asserted")


# -- the late variant: the way round breaks the deadline -------------------------------------------

def test_the_late_variant_detects_that_the_way_round_breaks_the_deadline(late_run):
    (abandoned,) = late_run.events("plan-abandoned")
    assert abandoned["scope"] == "plan" and abandoned["plan"] == 1
    assert abandoned["goals"] == ["(robot-at robot office-a)"]
    assert abandoned["reason"].startswith("no plan meets the deadline: the plan takes 60 s and ")
    assert abandoned["reason"].endswith(" s are left")
    (requested,) = [r for r in late_run.events("plan-requested") if r["plan"] == 1]
    assert abandoned["makespan"] == 60 and abandoned["t"] > 15
    assert abandoned["t"] + abandoned["makespan"] > requested["deadline"] == 65  # the way round is too late
    assert abandoned["left"] == pytest.approx(requested["deadline"] - abandoned["t"], abs=1e-3)
    assert not late_run.events("replanned")  # the new plan was not adopted
    halted = [r["task"] for r in late_run.events("task-halted")]
    assert "(follow-hall robot south-hall-west)" in halted  # the hop being driven is stopped


def test_the_late_variant_gives_the_goal_up_and_the_robot_comes_back_to_report(late_run):
    assert "(goal-abandoned (robot-at robot office-a))" in late_run.facts("fact-asserted")
    methods = [r["method"] for r in late_run.events("method-selected") if r["task"] == "(errand office-a)"]
    assert methods == ["go-there", "come-back"]
    back = [r for r in late_run.events("plan-done") if r["goals"] == ["(robot-at robot lobby)"]]
    assert len(back) == 1
    assert late_run.robot_at_end() == "(robot-at robot lobby)"
    asserted = late_run.facts("fact-asserted")
    assert "(reported gave-up office-a)" in asserted and "(reported arrived office-a)" not in asserted
    assert "(robot-at robot office-a)" not in asserted
    # the errand recovered by its other method, so the mission exits 0 (the file's header says so)
    assert late_run.returncode == 0, late_run.stdout + late_run.stderr


# -- determinism ------------------------------------------------------------------------------

@pytest.mark.parametrize("mission", [MAIN, LATE], ids=["office-replan", "office-replan-late"])
def test_the_same_seed_gives_the_same_trace_twice(mission, tmp_path):
    first = run_mission(mission, tmp_path, "1.jsonl", "--seed", "7")
    second = run_mission(mission, tmp_path, "2.jsonl", "--seed", "7")
    assert first.returncode == second.returncode == 0
    assert (tmp_path / "1.jsonl").read_bytes() == (tmp_path / "2.jsonl").read_bytes()
    assert any(r["event"] == "plan-ready" for r in first.records)

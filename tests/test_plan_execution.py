"""The three tiers together: a RAP asks for a plan in its task net, the planner plans from
RAP memory beside the running robot, and the plan executive carries the plan out step by
step, repairs it when a step fails or the situation changes, and gives up with a reason.

The EVAHR demos (rap_library/missions/evahr*.rap) show the paper's recoveries; smaller
missions written here show each rule on its own."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import pytest
from cli_process import REPO, assert_no_traceback, atlas

from atlas_rap.lang import load_text, parse_term
from atlas_rap.layers import MissionEngine, RunOptions
from atlas_rap.layers.deliberation import Deliberation, charged_latency, plan_for
from atlas_rap.planner.problem import PlanningProblem
from atlas_rap.sequencer import Trace
from atlas_rap.skillbus import Timers

MISSIONS = REPO / "rap_library" / "missions"

PACKING = """\
(world none)
(operator fetch :purpose (have ?x) :agent ?arm :preconditions ((on-shelf ?x)) :constraints ((arm ?arm))
  :plot (take ?arm ?x) :effects ((have ?x) (not (on-shelf ?x))) :duration 2)
(operator pack :purpose (packed ?x) :agent ?arm :preconditions ((have ?x)) :constraints ((arm ?arm))
  :plot (put-in-box ?arm ?x) :effects ((packed ?x)) :duration 3)
(agents (controlled arm-1 arm-2))
(initial (arm arm-1) (arm arm-2))
(define-virtual-skill (take-skill ?arm ?x)
  (when (broken ?arm) (after 1 (finish :fail)))
  (when (not (broken ?arm)) (after 2 (assert (have ?x)) (retract (on-shelf ?x)) (finish :succeed))))
(define-virtual-skill (box-skill ?arm ?x) (after 3 (assert (packed ?x)) (finish :succeed)))
(define-rap (take ?arm ?x) (succeed (have ?x)) (retries 1) (method (task-net (t1 (take-skill ?arm ?x)))))
(define-rap (put-in-box ?arm ?x) (succeed (packed ?x)) (method (task-net (t1 (box-skill ?arm ?x)))))
"""


def run_text(text: str, until: float = 600.0) -> tuple[MissionEngine, list[dict]]:
    """Load ``text`` as a mission into a fresh engine, run it, and return the engine and its trace."""
    engine = MissionEngine(trace=Trace(keep=True))
    engine.load(load_text(text, "<mission>"), require_post=True)
    engine.run_mission(until)
    return engine, engine.trace.records


def events(records: list[dict], name: str) -> list[dict]:
    return [r for r in records if r["event"] == name]


def holds(engine: MissionEngine, fact: str) -> bool:
    return parse_term(fact) in engine.sequencer.memory


# -- a RAP's (plan ...) step -----------------------------------------------------------------------

def test_a_raps_plan_step_succeeds_when_the_plan_is_carried_out_and_the_net_goes_on() -> None:
    engine, records = run_text(PACKING + """
(define-rap (ship ?x)
  (method (task-net (sequence (assert (on-shelf ?x)) (plan (packed ?x)) (assert (shipped ?x))))))
(post (ship cup))
""")
    assert [t.status for t in engine.sequencer.roots] == ["succeeded"]
    done = events(records, "plan-done")[0]
    shipped = next(r for r in records if r["event"] == "fact-asserted" and r["fact"] == "(shipped cup)")
    assert shipped["t"] == done["t"]  # the step after the plan runs once the plan is carried out
    started = [r["action"] for r in events(records, "plan-step-started")]
    assert started == ["(take arm-1 cup)", "(put-in-box arm-1 cup)"]


def test_a_labelled_plan_step_orders_other_steps_after_it() -> None:
    engine, records = run_text(PACKING + """
(initial (on-shelf cup))
(define-rap (ship ?x)
  (method (task-net (p1 (plan (packed ?x)) (for t2)) (t2 (announce ?x)))))
(define-virtual-skill (announce ?x) (after 1 (assert (announced ?x)) (finish :succeed)))
(post (ship cup))
""")
    assert [t.status for t in engine.sequencer.roots] == ["succeeded"]
    announced = next(r for r in records if r["event"] == "skill-enabled" and r["skill"] == "(announce cup)")
    assert announced["t"] >= events(records, "plan-done")[0]["t"]


def test_the_planner_plans_from_rap_memory_as_it_is_when_the_step_runs() -> None:
    # (on-shelf cup) is asserted by the RAP's own first step: no plan exists without it
    engine, records = run_text(PACKING + """
(define-rap (ship ?x) (method (task-net (sequence (assert (on-shelf ?x)) (plan (packed ?x))))))
(post (ship cup))
""")
    assert engine.sequencer.roots[0].status == "succeeded"
    engine, records = run_text(PACKING + """
(define-rap (ship ?x) (method (task-net (plan (packed ?x)))))
(post (ship cup))
""")
    assert engine.sequencer.roots[0].status == "failed"
    assert "no plan for (packed cup): unsolvable" in events(records, "plan-abandoned")[0]["reason"]


def test_the_planner_sees_the_prior_map_of_a_world_and_raps_drive_the_plan(tmp_path: Path) -> None:
    records = run_demo("plan-errand.rap", tmp_path)
    ready = events(records, "plan-ready")[0]
    # (connected lab corridor) and (connected corridor storeroom) come from the world's prior map
    assert ready["actions"] == ["s1 (travel-to robot corridor) [robot]", "s2 (travel-to robot storeroom) [robot]"]
    arrived = [r["t"] for r in records if r["event"] == "fact-asserted" and r["fact"] == "(at robot storeroom)"]
    assert arrived and arrived[0] <= events(records, "plan-done")[0]["t"]


def test_the_planners_latency_is_charged_in_simulated_time_by_its_own_count() -> None:
    engine, records = run_text(PACKING + "(initial (on-shelf cup))\n(plan (packed cup))\n")
    requested, ready = events(records, "plan-requested")[0], events(records, "plan-ready")[0]
    assert ready["t"] - requested["t"] == pytest.approx(ready["latency"])
    assert ready["latency"] > 0


# -- repair ----------------------------------------------------------------------------------------

def test_a_failed_step_is_tried_with_another_agent_before_the_same_one_again() -> None:
    engine, records = run_text(PACKING + """
(initial (on-shelf cup))
(initial-memory (broken arm-1))
(plan (packed cup))
""")
    assert engine.sequencer.roots[0].status == "succeeded"
    failed = events(records, "plan-step-failed")
    assert [r["action"] for r in failed] == ["(take arm-1 cup)"]
    replanned = events(records, "replanned")[0]
    assert replanned["reassigned"][0]["from"] == "arm-1" and replanned["reassigned"][0]["to"] == "arm-2"
    assert holds(engine, "(packed cup)")


def test_a_goal_is_abandoned_after_max_failures_with_the_reason() -> None:
    engine, records = run_text(PACKING + """
(initial (on-shelf cup))
(initial-memory (broken arm-1) (broken arm-2))
(plan (packed cup) :max-failures 2)
""")
    assert engine.sequencer.roots[0].status == "failed"
    assert len(events(records, "plan-step-failed")) == 2
    abandoned = events(records, "plan-abandoned")
    assert len(abandoned) == 1 and abandoned[0]["scope"] == "plan"
    assert "gave up after 2 failures" in abandoned[0]["reason"]
    assert holds(engine, "(goal-abandoned (packed cup))")


def test_a_plan_whose_makespan_breaks_the_deadline_is_reported_and_not_carried_out() -> None:
    engine, records = run_text(PACKING + "(initial (on-shelf cup))\n(plan (packed cup) :deadline 4)\n")
    abandoned = events(records, "plan-abandoned")[0]
    assert abandoned["reason"].startswith("no plan meets the deadline: the plan takes 5 s")
    assert not events(records, "plan-step-started")
    assert engine.sequencer.roots[0].status == "failed"


def test_a_deadline_written_in_ap_binds_the_plan_too() -> None:
    engine, records = run_text(PACKING + "(initial (on-shelf cup))\n(deadline (packed cup) 4)\n"
                                         "(plan (packed cup))\n")
    assert events(records, "plan-requested")[0]["deadline"] == 4
    assert "no plan meets the deadline" in events(records, "plan-abandoned")[0]["reason"]


def test_a_broken_causal_link_is_repaired_keeping_the_steps_done_and_the_running_one() -> None:
    # one arm takes the cup, then the mug, then packs both; the cup is taken from it meanwhile
    engine, records = run_text(PACKING.replace("(agents (controlled arm-1 arm-2))", "(agents (controlled arm-1))") + """
(initial (on-shelf cup) (on-shelf mug) (in-store cup))
(operator restock :purpose (on-shelf ?x) :agent ?arm :preconditions ((in-store ?x)) :constraints ((arm ?arm))
  :plot (restock ?arm ?x) :effects ((on-shelf ?x)) :duration 4)
(define-virtual-skill (restock-skill ?arm ?x) (after 4 (assert (on-shelf ?x)) (finish :succeed)))
(define-rap (restock ?arm ?x) (succeed (on-shelf ?x)) (method (task-net (t1 (restock-skill ?arm ?x)))))
(at-time 3 (retract (have cup)))
(plan (packed cup) (packed mug))
""")
    assert engine.sequencer.roots[0].status == "succeeded"
    first = events(records, "plan-ready")[0]["actions"]
    assert first[:2] == ["s1 (take arm-1 cup) [arm-1]", "s2 (take arm-1 mug) [arm-1]"]
    replanned = events(records, "replanned")
    assert len(replanned) == 1 and 3 < replanned[0]["t"] < 4  # the repair is planned from t=3
    assert "(have cup) was retracted, which step s3 needs" in replanned[0]["cause"]
    assert replanned[0]["done"] == ["(take arm-1 cup)"]
    assert replanned[0]["kept"] == ["(take arm-1 mug)"] and replanned[0]["halted"] == []
    mug_takes = [r for r in records if r["event"] == "plan-step-started" and r["action"] == "(take arm-1 mug)"]
    assert len(mug_takes) == 1  # the running step went on: it was not started again
    assert "(restock arm-1 cup)" in replanned[0]["new"]  # memory says the cup's taking was undone
    assert holds(engine, "(packed cup)") and holds(engine, "(packed mug)")


# -- the EVAHR demos ---------------------------------------------------------------------------

def run_demo(name: str, cwd: Path) -> list[dict]:
    """Run a shipped mission with ``atlas run``; it must end well; its trace records."""
    done = atlas("run", str(MISSIONS / name), "--quiet", "--trace", "t.jsonl", cwd=cwd)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout
    return [json.loads(line) for line in (cwd / "t.jsonl").read_text(encoding="utf-8").splitlines()]


@pytest.fixture(scope="module")
def evahr(tmp_path_factory) -> list[dict]:
    return run_demo("evahr.rap", tmp_path_factory.mktemp("evahr"))


@pytest.fixture(scope="module")
def evahr_failures(tmp_path_factory) -> list[dict]:
    return run_demo("evahr-failures.rap", tmp_path_factory.mktemp("evahr-failures"))


def test_evahr_attaches_at_the_handrail_when_the_grapple_fixture_fails(evahr) -> None:
    methods = [r["method"] for r in evahr if r["event"] == "method-selected" and r["task"] == "(attach-at evahr fx-b)"]
    assert methods == ["grapple", "handrail"]
    assert any(r["event"] == "fact-asserted" and r["fact"] == "(attached evahr hr-b)" for r in evahr)


def test_evahr_leaves_out_the_move_the_handrail_makes_needless(evahr) -> None:
    first = events(evahr, "plan-ready")[0]["actions"]
    assert any("(fly-to evahr site-c)" in action for action in first)  # the first plan flies to site-c
    replanned = events(evahr, "replanned")[0]
    assert "(attached evahr fx-b) does not hold" in replanned["cause"]
    later = [r["action"] for r in evahr if r["event"] == "plan-step-started" and r["t"] > replanned["t"]]
    assert "(inspect-site left-arm site-c)" in later
    assert not [a for a in later if a.startswith(("(fly-to", "(attach-at", "(detach-from"))]
    assert not [r for r in evahr if r["event"] == "skill-enabled" and r["skill"] == "(thrusters evahr site-c)"]


def test_evahr_substitutes_the_other_arm_and_the_planner_reassigns_later_steps(evahr) -> None:
    lost = next(r for r in evahr if r["event"] == "replanned" and "agent left-arm was lost" in r["cause"])
    assert lost["halted"] == []  # the running step goes on: its RAP is substituting the arm already
    assert lost["kept"] == ["(inspect-site right-arm site-c)"]
    assert {(r["from"], r["to"]) for r in lost["reassigned"]} == {("left-arm", "right-arm")}
    assert any(r["action"] == "(repair-site right-arm site-b)" for r in lost["reassigned"])
    substituted = [r for r in evahr if r["event"] == "method-selected"
                   and r["task"] == "(inspect-site left-arm site-c)"]
    assert [r["method"] for r in substituted] == ["own-arm", "other-arm"]
    enabled = [r["skill"] for r in evahr if r["event"] == "skill-enabled" and r["t"] >= lost["t"]]
    assert "(swap-orbital-unit right-arm site-b)" in enabled
    assert not [s for s in enabled if "left-arm" in s]
    assert events(evahr, "plan-done") and any(r["fact"] == "(docked evahr)" for r in events(evahr, "fact-asserted"))


def test_evahr_abandons_the_site_then_the_plan_and_docks(evahr_failures) -> None:
    abandoned = events(evahr_failures, "plan-abandoned")
    assert [(r["scope"], r["goals"]) for r in abandoned] == [
        ("goal", ["(repaired site-b)"]), ("plan", ["(inspected site-c)"])]
    assert "the arm's tool is jammed" in abandoned[0]["reason"]
    assert "no image from the arm's camera" in abandoned[1]["reason"]
    docked = next(r for r in events(evahr_failures, "fact-asserted") if r["fact"] == "(docked evahr)")
    assert docked["t"] > abandoned[1]["t"]
    give_up = [r for r in evahr_failures if r["event"] == "method-selected" and r["method"] == "give-up"]
    assert give_up and give_up[0]["t"] == abandoned[1]["t"]


def test_evahr_gives_the_same_trace_twice(tmp_path: Path) -> None:
    for name in ("1.jsonl", "2.jsonl"):
        done = atlas("run", str(MISSIONS / "evahr.rap"), "--quiet", "--trace", name, cwd=tmp_path)
        assert done.returncode == 0
    assert (tmp_path / "1.jsonl").read_bytes() == (tmp_path / "2.jsonl").read_bytes()


# -- deliberation beside action -------------------------------------------------------------------

def test_on_a_worker_the_clock_keeps_ticking_while_the_planner_works() -> None:
    """A unit test of Deliberation: the planner is held until the test lets it go, and
    the timers (the sequencer's clock) go on meanwhile; then the plan is delivered."""
    release = threading.Event()
    real_plan = []

    def held_planner(problem: PlanningProblem, timeout: float):
        assert release.wait(60), "the test never let the planner go"
        plan = plan_for(problem, timeout)
        real_plan.append(plan)
        return plan

    program = load_text(PACKING + "(initial (on-shelf cup))\n", "<packing>")
    engine = MissionEngine(RunOptions(world="none"))
    engine.load(program)
    timers = Timers()
    deliberation = Deliberation(engine.planning_problem, timers, worker=True, planner=held_planner)
    delivered = []
    ticks = 0
    deliberation.request((parse_term("(packed cup)"),), frozenset(), frozenset(),
                         lambda plan, latency: delivered.append((plan, latency, timers.now)))
    while ticks < 20:  # the clock ticks while the planner is held: nothing is delivered yet
        timers.fire_due(timers.now + 0.05)
        ticks += 1
    assert not delivered
    release.set()
    while not delivered:
        timers.fire_due(timers.now + 0.05)
        ticks += 1
        assert ticks < 100_000, "the plan was never delivered"
    plan, latency, at = delivered[0]
    assert plan is real_plan[0] and plan.status == "solved"
    assert at >= 1.0 and latency == pytest.approx(at)  # simulated time passed while it planned


def test_in_simulated_time_the_latency_is_a_count_and_the_clock_is_not_held() -> None:
    program = load_text(PACKING + "(initial (on-shelf cup))\n", "<packing>")
    engine = MissionEngine(RunOptions(world="none"))
    engine.load(program)
    timers = Timers()
    deliberation = Deliberation(engine.planning_problem, timers)
    delivered = []
    deliberation.request((parse_term("(packed cup)"),), frozenset(), frozenset(),
                         lambda plan, latency: delivered.append((plan, timers.now)))
    assert not delivered  # never from inside the request
    while not delivered and timers.now < 10:
        timers.fire_due(timers.now + 0.001)
    plan, at = delivered[0]
    assert at == pytest.approx(charged_latency(plan), abs=0.001)


def test_atlas_run_realtime_plans_on_a_worker_while_time_goes_on(tmp_path: Path) -> None:
    mission = PACKING + "(initial (on-shelf cup))\n(at-time 0.05 (assert (tick)))\n(plan (packed cup))\n"
    (tmp_path / "m.rap").write_text(mission, encoding="utf-8")
    done = atlas("run", "m.rap", "--realtime", "--quiet", "--trace", "t.jsonl", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout
    records = [json.loads(line) for line in (tmp_path / "t.jsonl").read_text(encoding="utf-8").splitlines()]
    ready = events(records, "plan-ready")[0]
    assert ready["t"] > 0 and ready["latency"] == pytest.approx(ready["t"] - events(records, "plan-requested")[0]["t"])

"""Scenarios for the RAP sequencer (docs/language/rap.md), checked on the trace as a user would.

Each test writes a small mission on virtual skills (``(world none)``,
simulated seconds), runs it and asserts on what the trace says happened
and when. A failing assertion prints the task tree and the end of the trace
(see ``scenario.py``).
"""

from __future__ import annotations

import json

import pytest

from paper_examples import ATTACH_AT_SITE
from scenario import INCLUDE_LIBRARY, run

# ---------------------------------------------------------------------------
# 1. method choice by context (the 3T attach-at-site)


ATTACH_SKILLS = """
(define-virtual-skill (approach-site ?site)
  (after 2.0 (assert (near robot ?site)))
  (after 2.5 (finish :succeed)))
(define-virtual-skill (magnetically-attach ?site)
  (after 1.0 (assert (docked ?site)) (finish :succeed)))
(define-virtual-skill (grip-attach ?site)
  (when (not (gripper-ok)) (after 0.5 (finish :fail)))
  (after 1.0 (assert (docked ?site)) (finish :succeed)))
"""

ATTACH = ATTACH_AT_SITE + ATTACH_SKILLS + """
(world none)
(initial-memory (ferrous-hull hull-3) {gripper})
(post (attach-at-site {site}))
"""

ATTACH_CASES = pytest.mark.parametrize("site, method, skill, other", [
    ("hull-3", "1", "(magnetically-attach hull-3)", "(grip-attach hull-3)"),
    ("hull-7", "2", "(grip-attach hull-7)", "(magnetically-attach hull-7)"),
])


@ATTACH_CASES
def test_method_chosen_by_context(tmp_path, site, method, skill, other):
    with run(tmp_path, ATTACH.format(site=site, gripper="(gripper-ok)")) as s:
        task = f"(attach-at-site {site})"
        assert s.field("method", "method-selected", task=task) == [method]
        assert s.field("attempt", "method-selected", task=task) == [1]
        enabled = s.field("skill", "skill-enabled")
        assert enabled == [f"(approach-site {site})", skill]
        assert other not in enabled
        # approach 2.5 s, then the attach skill 1.0 s: docked at 3.5 s
        assert s.times("skill-enabled", skill=skill) == [2.5]
        assert s.times("fact-asserted", fact=f"(docked {site})") == [3.5]
        assert s.times("task-succeeded", task=task) == [3.5]
        assert s.result.ok and s.result.ended_by == "done"


@ATTACH_CASES
def test_method_chosen_by_context_with_the_shipped_library(tmp_path, site, method, skill, other):
    text = INCLUDE_LIBRARY + f"""
    (world none)
    (initial-memory (ferrous-hull hull-3) (gripper-ok))
    (post (attach-at-site {site}))
    """
    with run(tmp_path, text) as s:
        assert s.field("method", "method-selected") == [method]
        assert skill in s.field("skill", "skill-enabled")
        assert other not in s.field("skill", "skill-enabled")
        assert s.result.ok and s.holds(f"(docked {site})")


# ---------------------------------------------------------------------------
# 2. the second method is tried after the first fails

FASTEN = """
(world none)
(define-rap (fasten ?x)
  (succeed (fastened ?x))
  {retries}
  (method (task-net (t1 (bolt ?x))))
  (method (task-net (t1 (glue ?x)))))
(define-virtual-skill (bolt ?x) (after 1 (finish :fail)))
(define-virtual-skill (glue ?x) (after 2 {glue}))
(post (fasten panel))
"""


def test_second_method_after_first_fails(tmp_path):
    text = FASTEN.format(retries="", glue="(assert (fastened ?x)) (finish :succeed)")
    with run(tmp_path, text) as s:
        chosen = [(r["method"], r["attempt"], r["t"]) for r in s.events("method-selected")]
        assert chosen == [("1", 1, 0.0), ("2", 2, 1.0)]
        assert [(r["t"], r["outcome"]) for r in s.events("step-outcome", step="step t1 (bolt panel)")] \
            == [(1.0, ":fail")]
        assert s.times("skill-disabled", skill="(bolt panel)") == [1.0]
        assert s.times("skill-enabled", skill="(glue panel)") == [1.0]
        assert s.times("task-succeeded", task="(fasten panel)") == [3.0]
        assert s.events("task-failed") == []
        assert s.result.ok


def test_untried_methods_are_preferred_before_repeating_one(tmp_path):
    # both methods always fail; the default 3 attempts go 1, 2 at once (untried: another way), then 1
    # again after the 1 s back-off (repeating a method waits for a change)
    text = FASTEN.format(retries="", glue="(finish :fail)")
    with run(tmp_path, text) as s:
        chosen = [(r["method"], r["attempt"], r["t"]) for r in s.events("method-selected")]
        assert chosen == [("1", 1, 0.0), ("2", 2, 1.0), ("1", 3, 4.0)]
        assert s.times("task-resumed", task="(fasten panel)") == [4.0]
        assert s.times("task-failed", task="(fasten panel)") == [5.0]
        assert s.task("(fasten panel)").status == "failed"


# ---------------------------------------------------------------------------
# 3. retries exhausted

def test_retries_exhausted(tmp_path):
    text = """
    (world none)
    (define-rap (open-hatch ?h)
      (retries 2)
      (method (task-net (t1 (crank ?h)))))
    (define-virtual-skill (crank ?h) (after 1 (finish :fail)))
    (post (open-hatch h1))
    """
    with run(tmp_path, text) as s:
        assert s.field("attempt", "method-selected") == [1, 2]
        assert s.times("method-selected") == [0.0, 2.0]  # the retry waits the 1 s back-off
        assert s.times("skill-enabled", skill="(crank h1)") == [0.0, 2.0]
        assert s.times("skill-disabled", skill="(crank h1)") == [1.0, 3.0]
        [failed] = s.events("task-failed")
        assert failed["t"] == 3.0 and failed["task"] == "(open-hatch h1)"
        assert "2 attempts" in failed["reason"]
        assert "(crank h1)" in failed["because"]
        task = s.task("(open-hatch h1)")
        assert task.status == "failed"
        assert "(crank h1)" in task.failure.root().what
        assert not s.result.ok


# ---------------------------------------------------------------------------
# 4. a wait-for that times out

WAIT_SIGNAL = """
(world none)
(define-rap (await-signal)
  (retries 2)
  (method
    (task-net
      (sequence
        (wait-for (signal) :timeout 2)
        (assert (got-signal))))))
(at-time {when} (assert (signal)))
(post (await-signal))
"""


def test_wait_for_times_out(tmp_path):
    with run(tmp_path, WAIT_SIGNAL.format(when=10)) as s:
        outcomes = [(r["t"], r["step"], r["outcome"]) for r in s.events("step-outcome")]
        assert outcomes == [(2.0, "(wait-for (signal))", ":timeout"),
                            (5.0, "(wait-for (signal))", ":timeout")]
        assert s.times("method-selected") == [0.0, 3.0]  # the retry waits the 1 s back-off
        assert s.times("task-failed", task="(await-signal)") == [5.0]
        assert s.events("fact-asserted", fact="(got-signal)") == []
        assert s.result.time == 5.0


def test_wait_for_matching_before_its_timeout_succeeds(tmp_path):
    with run(tmp_path, WAIT_SIGNAL.format(when=1.5)) as s:
        assert s.field("outcome", "step-outcome") == [":succeed"]
        assert s.times("fact-asserted", fact="(got-signal)") == [1.5]
        assert s.times("task-succeeded") == [1.5]
        assert s.result.ok


# ---------------------------------------------------------------------------
# 5. multi-outcome steps, with a custom outcome keyword

GO_STEP = """
    (task-net
      (sequence
        (t1 (drive ?x) (wait-for (arrived ?x) :arrived) (wait-for (stuck ?x) :fail))
        (assert (went ?x))))"""
GO_PRIMITIVE = """
    (primitive
      (enable (drive ?x))
      (wait-for (arrived ?x) :arrived)
      (wait-for (stuck ?x) :fail)
      (disable :above)
      (assert (went ?x)))"""
GO = """
(world none)
(define-rap (go ?x)
  (retries 1)
  (method {body}))
(define-virtual-skill (drive ?x) (after 100 (finish :succeed)))
(at-time 3 (assert ({event} rover)))
(post (go rover))
"""


@pytest.mark.parametrize("body, step", [(GO_STEP, "step t1 (drive rover)"), (GO_PRIMITIVE, "primitive")],
                         ids=["step", "primitive"])
@pytest.mark.parametrize("event, outcome, status", [
    ("arrived", ":arrived", "succeeded"),
    ("stuck", ":fail", "failed"),
])
def test_multi_outcome_step(tmp_path, body, step, event, outcome, status):
    with run(tmp_path, GO.format(body=body, event=event)) as s:
        assert [(r["t"], r["step"], r["outcome"]) for r in s.events("step-outcome")] == [(3.0, step, outcome)]
        assert s.times("skill-enabled", skill="(drive rover)") == [0.0]
        assert s.times("skill-disabled", skill="(drive rover)") == [3.0]
        assert s.task("(go rover)").status == status
        assert s.times(f"task-{status}", task="(go rover)") == [3.0]
        # :arrived counts as success, so the method goes on to its next step
        went = s.times("fact-asserted", fact="(went rover)")
        assert went == ([3.0] if status == "succeeded" else [])
        assert s.result.time == 3.0  # the drive skill's finish at t=100 was cancelled


# ---------------------------------------------------------------------------
# 6. parallel ends when all its parts have ended

def test_parallel_ends_when_the_slowest_part_ends(tmp_path):
    text = """
    (world none)
    (define-rap (prepare)
      (method
        (task-net
          (sequence
            (parallel
              (t1 (heat-up))
              (t2 (pressurize))
              (wait-for (crew-aboard)))
            (assert (prepared))))))
    (define-virtual-skill (heat-up) (after 5 (finish :succeed)))
    (define-virtual-skill (pressurize) (after 1 (finish :succeed)))
    (at-time 3 (assert (crew-aboard)))
    (post (prepare))
    """
    with run(tmp_path, text) as s:
        assert s.times("skill-enabled") == [0.0, 0.0]
        ends = [(r["t"], r["step"]) for r in s.events("step-outcome")]
        assert ends == [(1.0, "step t2 (pressurize)"), (3.0, "(wait-for (crew-aboard))"),
                        (5.0, "step t1 (heat-up)")]
        assert s.times("fact-asserted", fact="(prepared)") == [5.0]
        assert s.times("task-succeeded", task="(prepare)") == [5.0]


# ---------------------------------------------------------------------------
# 7. until-end halts a monitor

def test_until_end_halts_the_monitor(tmp_path):
    text = """
    (world none)
    (define-rap (inspect ?x)
      (method
        (task-net
          (t1 (track ?x) (until-end t2))
          (t2 (scan ?x)))))
    (define-rap (track ?x)
      (method
        (primitive
          (enable (camera ?x))
          (wait-for (lost ?x) :fail)
          (disable :above))))
    (define-virtual-skill (camera ?x) (after 1 (assert (tracking ?x))))
    (define-virtual-skill (scan ?x) (after 4 (assert (scanned ?x)) (finish :succeed)))
    (post (inspect pump))
    """
    with run(tmp_path, text) as s:
        assert s.times("skill-enabled", skill="(camera pump)") == [0.0]
        assert s.times("skill-enabled", skill="(scan pump)") == [0.0]
        assert s.times("task-halted", task="(track pump)") == [4.0]
        assert s.times("skill-disabled", skill="(camera pump)") == [4.0]
        assert s.events("step-outcome", task="(inspect pump)", step="step t1 (track pump)")[0]["outcome"] \
            == ":halted"
        assert s.times("task-succeeded", task="(inspect pump)") == [4.0]
        assert s.events("task-failed") == []
        assert s.task("(track pump)").status == "halted"
        assert s.result.ok


def test_until_end_monitor_as_a_skill_step(tmp_path):
    text = """
    (world none)
    (define-rap (inspect ?x)
      (method
        (task-net
          (t1 (camera ?x) (until-end t2))
          (t2 (scan ?x)))))
    (define-virtual-skill (camera ?x) (after 1 (assert (tracking ?x))))
    (define-virtual-skill (scan ?x) (after 4 (assert (scanned ?x)) (finish :succeed)))
    (post (inspect pump))
    """
    with run(tmp_path, text) as s:
        assert s.times("skill-disabled", skill="(camera pump)") == [4.0]
        assert s.times("task-succeeded", task="(inspect pump)") == [4.0]
        assert s.result.ok


# ---------------------------------------------------------------------------
# 8. (for L) orderings between unordered nets

@pytest.mark.parametrize("nets", [
    "(t1 (warm-up oven) (for t3)) (t2 (fetch flour)) (t3 (mix flour))",
    "(t1 (warm-up oven) (for t3)) (sequence (t2 (fetch flour)) (t3 (mix flour)))",
], ids=["three-nets", "net-and-sequence"])
def test_for_orders_unordered_nets(tmp_path, nets):
    text = f"""
    (world none)
    (define-rap (bake)
      (method (task-net {nets})))
    (define-virtual-skill (warm-up ?o) (after 3 (finish :succeed)))
    (define-virtual-skill (fetch ?x) (after 1 (finish :succeed)))
    (define-virtual-skill (mix ?x) (after 1 (finish :succeed)))
    (post (bake))
    """
    with run(tmp_path, text) as s:
        assert s.times("skill-enabled", skill="(warm-up oven)") == [0.0]
        assert s.times("skill-enabled", skill="(fetch flour)") == [0.0]
        assert s.times("step-outcome", step="step t1 (warm-up oven)") == [3.0]
        assert s.times("skill-enabled", skill="(mix flour)") == [3.0]
        assert s.times("task-succeeded", task="(bake)") == [4.0]


def test_for_successor_never_starts_when_its_predecessor_fails(tmp_path):
    text = """
    (world none)
    (define-rap (bake)
      (retries 1)
      (method (task-net (t1 (warm-up oven) (for t3)) (t2 (fetch flour)) (t3 (mix flour)))))
    (define-virtual-skill (warm-up ?o) (after 3 (finish :fail)))
    (define-virtual-skill (fetch ?x) (after 1 (finish :succeed)))
    (define-virtual-skill (mix ?x) (after 1 (finish :succeed)))
    (post (bake))
    """
    with run(tmp_path, text) as s:
        assert s.events("skill-enabled", skill="(mix flour)") == []
        assert s.times("task-failed", task="(bake)") == [3.0]


# ---------------------------------------------------------------------------
# 9. repeats

def test_repeat_until_a_fact_arrives(tmp_path):
    text = """
    (world none)
    (define-rap (pump)
      (repeat-until (full tank))
      (method (task-net (t1 (stroke)))))
    (define-virtual-skill (stroke) (after 1 (finish :succeed)))
    (at-time 3.5 (assert (full tank)))
    (post (pump))
    """
    with run(tmp_path, text) as s:
        # strokes end at 1, 2, 3 (not full yet) and 4 (full since 3.5)
        assert s.times("skill-enabled", skill="(stroke)") == [0.0, 1.0, 2.0, 3.0]
        assert s.field("attempt", "method-selected") == [1, 1, 1, 1]
        assert s.times("task-succeeded", task="(pump)") == [4.0]
        assert s.result.ok


def test_repeat_while_a_counter_is_low(tmp_path):
    text = """
    (world none)
    (initial-memory (count 0))
    (define-rap (count-up)
      (repeat-while (and (count ?n) (< ?n 3)))
      (method
        (context (and (count ?n) (= ?m (+ ?n 1))))
        (task-net
          (sequence
            (t1 (tick))
            (retract (count ?n))
            (assert (count ?m))))))
    (define-virtual-skill (tick) (after 1 (finish :succeed)))
    (post (count-up))
    """
    with run(tmp_path, text) as s:
        assert len(s.events("method-selected")) == 3
        assert s.field("fact", "fact-asserted", by="task 1") == ["(count 1)", "(count 2)", "(count 3)"]
        assert s.times("fact-asserted", by="task 1") == [1.0, 2.0, 3.0]
        assert s.times("task-succeeded", task="(count-up)") == [3.0]
        assert s.facts("count") == ["(count 3)"]


# ---------------------------------------------------------------------------
# 10. a deadline

def test_deadline_missed(tmp_path):
    text = """
    (world none)
    (define-rap (overhaul)
      (method (task-net (parallel (t1 (grind)) (t2 (polish-part))))))
    (define-rap (polish-part)
      (method (primitive (enable (polish)) (wait-for (polished) :succeed) (disable :above))))
    (define-virtual-skill (grind) (after 10 (assert (ground)) (finish :succeed)))
    (define-virtual-skill (polish) (after 10 (assert (polished))))
    (post (overhaul) :deadline 5)
    """
    with run(tmp_path, text) as s:
        assert s.events("task-posted", task="(overhaul)")[0]["deadline"] == 5.0
        [failed] = s.events("task-failed")
        assert failed["t"] == 5.0 and failed["task"] == "(overhaul)"
        assert "deadline" in failed["reason"]
        assert s.times("skill-disabled", skill="(grind)") == [5.0]
        assert s.times("skill-disabled", skill="(polish)") == [5.0]
        assert s.times("task-halted", task="(polish-part)") == [5.0]
        assert s.events("fact-asserted", fact="(ground)") == []
        assert s.result.time == 5.0 and s.result.ended_by == "done"


# ---------------------------------------------------------------------------
# 11. a parent fails cleanly when a child fails

FAILING_CHILD = """
(world none)
(define-rap (repair ?x)
  (retries 1)
  (method
    (task-net
      (t1 (watch ?x))
      (t2 (light ?x))
      (t3 (replace-part ?x)))))
(define-rap (watch ?x)
  (method (primitive (enable (camera ?x)) (wait-for (lost ?x) :fail))))
(define-rap (replace-part ?x)
  (retries 1)
  (method
    (task-net
      (parallel
        (t1 (spin-fan ?x))
        (sequence (t2 (unscrew ?x)) (t3 (break-seal ?x)))))))
(define-virtual-skill (camera ?x) (after 0.5 (assert (watching ?x))))
(define-virtual-skill (light ?x) (after 50 (finish :succeed)))
(define-virtual-skill (spin-fan ?x) (after 50 (finish :succeed)))
(define-virtual-skill (unscrew ?x) (after 1 (finish :succeed)))
(define-virtual-skill (break-seal ?x) (after 1 (finish :fail)))
(post (repair pump))
"""


def test_parent_fails_cleanly_when_a_child_fails(tmp_path):
    with run(tmp_path, FAILING_CHILD) as s:
        assert s.times("task-failed", task="(replace-part pump)") == [2.0]
        assert s.times("task-halted", task="(watch pump)") == [2.0]
        assert s.times("task-failed", task="(repair pump)") == [2.0]
        assert s.result.time == 2.0
        # every skill enabled is disabled afterwards, by the same task
        enabled = s.events("skill-enabled")
        assert {r["skill"] for r in enabled} == {
            "(camera pump)", "(light pump)", "(spin-fan pump)", "(unscrew pump)", "(break-seal pump)"}
        for on in enabled:
            later = [r for r in s.records[s.records.index(on):]
                     if r["event"] == "skill-disabled" and r["skill"] == on["skill"]]
            assert later and later[0]["id"] == on["id"], f"{on['skill']} was never disabled"
        assert not s.mission.virtual.running() and not s.mission.sequencer.holders
        for task in s.all_tasks():
            assert task.status in ("failed", "halted"), task
        assert "running" not in s.tree and "pending" not in s.tree
        # the failure explains itself down to the skill
        repair = s.task("(repair pump)")
        assert "(break-seal pump)" in repair.failure.root().what
        assert "(replace-part pump)" in repair.failure.explain()
        assert "(break-seal pump)" in s.events("task-failed", task="(repair pump)")[0]["because"]


# ---------------------------------------------------------------------------
# 12. a memory rule keeps (at ?x ?place) unique

def test_memory_rule_keeps_at_unique(tmp_path):
    text = """
    (world none)
    (initial-memory (at robot dock) (at cart dock))
    (define-memory-rule at-is-unique
      (on (at ?thing ?new))
      (when (and (at ?thing ?old) (/= ?old ?new)))
      (retract (at ?thing ?old)))
    (define-rap (tour)
      (method (task-net (sequence (t1 (move-to lab)) (t2 (move-to airlock)) (t3 (move-to lab))))))
    (define-virtual-skill (move-to ?p) (after 1 (assert (at robot ?p)) (finish :succeed)))
    (post (tour))
    """
    with run(tmp_path, text) as s:
        assert s.facts("at") == ["(at cart dock)", "(at robot lab)"]
        by_rule = [(r["t"], r["fact"]) for r in s.events("fact-retracted", by="memory rule")]
        assert by_rule == [(1.0, "(at robot dock)"), (2.0, "(at robot lab)"), (3.0, "(at robot airlock)")]
        assert s.result.ok


# ---------------------------------------------------------------------------
# 13. two top-level tasks interleave by priority

def test_priority_orders_selection_and_work_interleaves(tmp_path):
    text = """
    (world none)
    (define-rap (chore ?x)
      (method (task-net (sequence (t1 (sweep ?x)) (t2 (mop ?x))))))
    (define-rap (alarm)
      (priority 9)
      (method (task-net (t1 (beep)))))
    (define-virtual-skill (sweep ?x) (after 2 (finish :succeed)))
    (define-virtual-skill (mop ?x) (after 1 (finish :succeed)))
    (define-virtual-skill (beep) (after 1 (finish :succeed)))
    (post (chore low) :priority 1)
    (post (chore high) :priority 5)
    (post (alarm))
    """
    with run(tmp_path, text) as s:
        at_start = [r["task"] for r in s.events("task-selected") if r["t"] == 0.0]
        assert at_start[:3] == ["(alarm)", "(chore high)", "(chore low)"]
        assert s.events("task-posted", task="(alarm)")[0]["priority"] == 9
        # the work of both chores overlaps in time
        assert s.times("skill-enabled", skill="(sweep high)") == [0.0]
        assert s.times("skill-enabled", skill="(sweep low)") == [0.0]
        assert s.times("skill-enabled", skill="(mop high)") == [2.0]
        assert s.times("skill-enabled", skill="(mop low)") == [2.0]
        assert s.times("task-succeeded", task="(chore high)") == [3.0]
        assert s.times("task-succeeded", task="(chore low)") == [3.0]
        # at the same instant the higher-priority task goes first
        enabled_at_2 = s.field("skill", "skill-enabled")[3:]
        assert enabled_at_2 == ["(mop high)", "(mop low)"]
        assert s.result.ok


# ---------------------------------------------------------------------------
# 14. the same mission run twice gives the same trace

def test_same_mission_same_trace(tmp_path):
    text = FAILING_CHILD + INCLUDE_LIBRARY + """
    (initial-memory (ferrous-hull hull-3) (gripper-ok) (holding robot filter) (at robot dock))
    (post (visit-site hull-7 filter) :priority 2 :deadline 60)
    (post (visit-site hull-3 filter))
    """
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    first = run(tmp_path / "a", text)
    second = run(tmp_path / "b", text)
    with first:
        assert len(first.records) > 50
        assert json.dumps(first.records) == json.dumps(second.records)
        assert first.tree == second.tree


# ---------------------------------------------------------------------------
# 15. a RAP that recurses without end fails cleanly

def test_endless_recursion_fails_at_the_depth_bound(tmp_path):
    text = """
    (world none)
    (define-rap (dig ?n)
      (method
        (context (= ?m (+ ?n 1)))
        (task-net (t1 (dig ?m)))))
    (post (dig 0))
    """
    with run(tmp_path, text) as s:
        assert s.result.ended_by == "done"
        [root_failed] = s.events("task-failed", task="(dig 0)")
        assert "deeper than 64" in root_failed["because"]
        assert "deeper than 64" in s.task("(dig 0)").failure.root().reason
        # a depth bound is not retried: one method per task, and every task failed
        posted = s.events("task-posted")
        assert len(posted) == len(s.events("task-failed")) == 66
        assert len(s.events("method-selected")) == 65
        assert s.times("task-failed") == [0.0] * 66


@pytest.mark.parametrize("steps", [600, 1500])
def test_a_long_sequence_of_instant_steps_runs(tmp_path, steps):
    # steps that end at once (memory operations, wait-fors that already hold)
    # must not nest Python calls one per step: no RecursionError, at run or at load
    body = " ".join(f"(assert (log {i}))" for i in range(steps))
    text = f"""
    (world none)
    (define-rap (write-log) (method (task-net (sequence {body} (wait-for (log 0))))))
    (post (write-log))
    """
    with run(tmp_path, text) as s:
        assert s.result.ok
        assert len(s.events("fact-asserted", by="task 1")) == steps
        assert s.times("task-succeeded") == [0.0]


# ---------------------------------------------------------------------------
# 16-17. succeed already true; constraints false

def test_succeed_already_true_does_nothing(tmp_path):
    text = """
    (world none)
    (initial-memory (open door))
    (define-rap (open-door)
      (succeed (open door))
      (repeat-until (locked door))
      (method (task-net (t1 (push door)))))
    (define-virtual-skill (push ?d) (after 1 (assert (open ?d)) (finish :succeed)))
    (post (open-door))
    """
    with run(tmp_path, text) as s:
        assert s.times("task-selected") == [0.0]
        assert s.times("task-succeeded", task="(open-door)") == [0.0]
        assert s.events("method-selected") == []
        assert s.events("skill-enabled") == []
        assert s.result.ok


def test_constraints_false_fails_without_a_method(tmp_path):
    text = """
    (world none)
    (initial-memory (holding robot filter))
    (define-rap (unload-at-site ?thesite ?item)
      (succeed (delivered ?item ?thesite))
      (constraints (docked ?thesite))
      (method (task-net (sequence (t1 (release-item ?item)) (assert (delivered ?item ?thesite))))))
    (define-virtual-skill (release-item ?item) (after 1.5 (retract (holding robot ?item)) (finish :succeed)))
    (post (unload-at-site hull-3 filter))
    """
    with run(tmp_path, text) as s:
        [failed] = s.events("task-failed")
        assert failed["t"] == 0.0 and failed["task"] == "(unload-at-site hull-3 filter)"
        assert "constraints" in failed["reason"] and "(docked hull-3)" in failed["reason"]
        assert s.events("method-selected") == []
        assert s.events("skill-enabled") == []
        assert s.holds("(holding robot filter)")


# ---------------------------------------------------------------------------
# 18. waiting for something that never comes

def test_waiting_for_what_never_comes_stalls(tmp_path):
    text = """
    (world none)
    (define-rap (launch)
      (method (task-net (sequence (t1 (fuel-up)) (t2 (crew-check))))))
    (define-rap (crew-check)
      (method (task-net (wait-for (crew-ready)))))
    (define-virtual-skill (fuel-up) (after 1 (finish :succeed)))
    (post (launch))
    """
    with run(tmp_path, text) as s:
        assert s.result.ended_by == "stalled"
        assert s.result.time == 1.0
        [failed] = s.events("task-failed", task="(launch)")
        assert failed["t"] == 1.0
        assert "(crew-ready)" in failed["reason"]
        assert s.task("(crew-check)").status in ("failed", "halted")
        assert not s.result.ok


def test_waiting_for_a_skill_that_never_finishes_stalls(tmp_path):
    text = """
    (world none)
    (define-rap (launch)
      (method (task-net (t1 (count-down)))))
    (define-virtual-skill (count-down) (after 2 (assert (counting))))
    (post (launch))
    """
    with run(tmp_path, text) as s:
        assert s.result.ended_by == "stalled"
        [failed] = s.events("task-failed", task="(launch)")
        assert failed["t"] == 2.0 and "(count-down)" in failed["reason"]
        assert s.times("skill-disabled", skill="(count-down)") == [2.0]


# ---------------------------------------------------------------------------
# 19. wait-for bindings flow to later steps

def test_wait_for_bindings_flow_to_later_steps(tmp_path):
    text = """
    (world none)
    (define-rap (find-robot)
      (method
        (task-net
          (sequence
            (wait-for (at robot ?where))
            (assert (visited ?where))
            (t1 (photograph ?where))))))
    (define-virtual-skill (photograph ?p) (after 1 (assert (photo ?p)) (finish :succeed)))
    (at-time 2 (assert (at robot lab)))
    (post (find-robot))
    """
    with run(tmp_path, text) as s:
        assert s.times("fact-asserted", fact="(visited lab)") == [2.0]
        assert s.times("skill-enabled", skill="(photograph lab)") == [2.0]
        assert s.times("task-succeeded", task="(find-robot)") == [3.0]
        assert s.holds("(photo lab)")


def test_step_wait_for_bindings_flow_to_later_steps(tmp_path):
    text = """
    (world none)
    (define-rap (fetch-tool)
      (method
        (task-net
          (sequence
            (t1 (scan-shelf) (wait-for (seen ?tool) :found))
            (t2 (grab ?tool))))))
    (define-virtual-skill (scan-shelf) (after 1.5 (assert (seen wrench))) (after 9 (finish :succeed)))
    (define-virtual-skill (grab ?t) (after 1 (assert (holding ?t)) (finish :succeed)))
    (post (fetch-tool))
    """
    with run(tmp_path, text) as s:
        assert [(r["t"], r["outcome"]) for r in s.events("step-outcome", step="step t1 (scan-shelf)")] \
            == [(1.5, ":found")]
        assert s.times("skill-disabled", skill="(scan-shelf)") == [1.5]
        assert s.times("skill-enabled", skill="(grab wrench)") == [1.5]
        assert s.times("task-succeeded", task="(fetch-tool)") == [2.5]
        assert s.holds("(holding wrench)")


# ---------------------------------------------------------------------------
# the timeout clause

def test_timeout_clause_fails_the_task_with_outcome_timeout_and_disables_its_skills(tmp_path):
    # docs/language/rap.md: the task fails with :timeout if it is not done in time;
    # the step of the parent's net that ran it ends with that outcome
    text = """
    (world none)
    (define-rap (outer)
      (retries 1)
      (method (task-net (t1 (slow-job)))))
    (define-rap (slow-job)
      (timeout 3)
      (method (task-net (t1 (crawl)))))
    (define-virtual-skill (crawl) (after 10 (finish :succeed)))
    (post (outer))
    """
    with run(tmp_path, text) as s:
        [failed] = s.events("task-failed", task="(slow-job)")
        assert failed["t"] == 3.0 and "timed out" in failed["reason"]
        assert s.times("skill-disabled", skill="(crawl)") == [3.0]
        assert [(r["t"], r["outcome"]) for r in s.events("step-outcome", step="step t1 (slow-job)")] \
            == [(3.0, ":timeout")]
        assert s.times("task-failed", task="(outer)") == [3.0]


# ---------------------------------------------------------------------------
# more of the contract around the scenarios above

def test_3t_attach_with_a_broken_gripper_retries_then_fails(tmp_path):
    # hull-7 is not ferrous, so only method 2 applies; without (gripper-ok) the
    # grip fails 0.5 s after the 2.5 s approach, three times (the default retries), each retry after
    # the 1 s back-off
    with run(tmp_path, ATTACH.format(site="hull-7", gripper="")) as s:
        chosen = [(r["method"], r["attempt"], r["t"]) for r in s.events("method-selected")]
        assert chosen == [("2", 1, 0.0), ("2", 2, 4.0), ("2", 3, 8.0)]
        assert s.times("skill-disabled", skill="(grip-attach hull-7)") == [3.0, 7.0, 11.0]
        [failed] = s.events("task-failed")
        assert failed["t"] == 11.0 and "3 attempts" in failed["reason"]
        assert s.events("fact-asserted", fact="(docked hull-7)") == []  # the cancelled script line


def test_named_method_is_traced_by_name(tmp_path):
    text = """
    (world none)
    (define-rap (navigate ?p)
      (method direct (context (clear-route ?p)) (task-net (t1 (fly-to ?p))))
      (method around (task-net (t1 (fly-around ?p)))))
    (define-virtual-skill (fly-to ?p) (after 3 (finish :fail)))
    (define-virtual-skill (fly-around ?p) (after 5 (finish :succeed)))
    (initial-memory (clear-route hull-3))
    (post (navigate hull-3))
    """
    with run(tmp_path, text) as s:
        chosen = [(r["method"], r["attempt"], r["t"]) for r in s.events("method-selected")]
        assert chosen == [("direct", 1, 0.0), ("around", 2, 3.0)]
        assert s.times("task-succeeded", task="(navigate hull-3)") == [8.0]
        assert "method around" in s.tree


def test_method_ending_with_succeed_still_false_is_retried(tmp_path):
    text = """
    (world none)
    (define-rap (charge)
      (succeed (charged))
      (retries 2)
      (method (task-net (t1 (plug-in)))))
    (define-virtual-skill (plug-in) (after 1 (finish :succeed)))
    (post (charge))
    """
    with run(tmp_path, text) as s:
        assert s.field("outcome", "step-outcome") == [":succeed", ":succeed"]
        assert s.times("method-selected") == [0.0, 2.0]  # the retry waits the 1 s back-off
        [failed] = s.events("task-failed")
        assert failed["t"] == 3.0 and "(charged)" in failed["because"]


def test_equal_priority_earlier_deadline_is_selected_first(tmp_path):
    text = """
    (world none)
    (define-rap (job ?x) (method (task-net (t1 (work ?x)))))
    (define-virtual-skill (work ?x) (after 1 (finish :succeed)))
    (post (job relaxed))
    (post (job urgent) :deadline 50)
    (post (job later) :deadline 80)
    """
    with run(tmp_path, text) as s:
        assert s.field("task", "task-selected")[:3] == ["(job urgent)", "(job later)", "(job relaxed)"]
        assert s.result.ok


def test_repeat_without_time_passing_fails_as_a_runaway(tmp_path):
    text = """
    (world none)
    (initial-memory (forever))
    (define-rap (spin)
      (repeat-while (forever))
      (method (task-net (assert (turned)))))
    (post (spin))
    """
    with run(tmp_path, text) as s:
        [failed] = s.events("task-failed")
        assert failed["t"] == 0.0 and "without simulated time passing" in failed["reason"]
        assert s.result.ended_by == "done"


def test_time_limit_fails_what_is_still_running(tmp_path):
    text = """
    (world none)
    (define-rap (survey) (method (task-net (t1 (orbit)))))
    (define-virtual-skill (orbit) (after 5000 (finish :succeed)))
    (post (survey))
    """
    with run(tmp_path, text, until=100) as s:
        assert s.result.ended_by == "time-limit"
        [failed] = s.events("task-failed")
        assert failed["t"] == 100.0 and "time limit" in failed["reason"] and "(orbit)" in failed["reason"]
        assert s.times("skill-disabled", skill="(orbit)") == [100.0]


# ---------------------------------------------------------------------------
# the helper: a failing scenario shows the task tree and the end of the trace

def test_a_failing_scenario_shows_the_task_tree(tmp_path):
    text = """
    (world none)
    (define-rap (launch) (method (task-net (t1 (count-down)))))
    (define-virtual-skill (count-down) (after 2 (finish :succeed)))
    (post (launch))
    """
    with pytest.raises(AssertionError) as failure:
        with run(tmp_path, text) as s:
            assert s.times("task-succeeded") == [99.0]
    message = str(failure.value)
    assert "--- task tree (run ended by done at t=2) ---" in message
    assert "✓ [1] (launch) succeeded method 1 (attempt 1)" in message
    assert "t=2 task-succeeded id=1 task=(launch)" in message

"""Skills are resources: a task that needs a skill another task holds waits its turn, a task of
higher priority takes it and the holder resumes, and nothing spends its retries in one instant.

A stock skill is one instance whatever its arguments (one robot base); a virtual skill is
one instance per call (scripts share nothing), so the virtual-skill tests contest the same call."""

from __future__ import annotations

from scenario import run
from world_runs import NAVIGATION, REPO, run_in_world

CAMERA = """
(define-virtual-skill (camera ?what) (after 10 (finish :succeed)))
(define-rap (look-at ?what)
  (method (task-net (sequence (t1 (camera ?what)) (assert (looked-at ?what))))))
(define-rap (watch ?x) (method (task-net (sequence (wait-for (go)) (t1 (camera ?x))))))
"""


def test_a_task_that_needs_a_held_skill_waits_for_it_and_takes_it_when_it_is_let_go(tmp_path):
    mission = CAMERA + "(post (look-at pump))\n(at-time 3 (assert (go)))\n(post (watch pump))\n"
    with run(tmp_path, mission) as s:
        assert s.result.ok
        assert s.events("skill-preempted") == []
        (waiting,) = s.events("task-waiting")
        assert waiting == {"t": 3.0, "event": "task-waiting", "id": 2, "task": "(watch pump)",
                           "skill": "(camera pump)", "holder_id": 1, "holder": "(look-at pump)"}
        (resumed,) = s.events("task-resumed")
        assert resumed["t"] == 10.0 and resumed["id"] == 2 and resumed["waited"] == 7.0
        assert s.times("task-succeeded", task="(look-at pump)") == [10.0]  # never interrupted
        assert s.times("task-succeeded", task="(watch pump)") == [20.0]  # 10 s of camera once it had it
        assert s.field("attempt", "method-selected", task="(watch pump)") == [1]  # waiting cost no retry


def test_a_task_of_higher_priority_takes_the_skill_and_the_holder_resumes_uncharged(tmp_path):
    mission = CAMERA + "(post (look-at pump))\n(at-time 3 (assert (go)))\n(post (watch pump) :priority 5)\n"
    with run(tmp_path, mission) as s:
        assert s.result.ok
        (contest,) = s.events("skill-preempted")
        assert contest == {"t": 3.0, "event": "skill-preempted", "skill": "(camera pump)", "outcome": ":halted",
                           "id": 1, "task": "(look-at pump)", "winner_id": 2, "winner": "(watch pump)"}
        assert s.events("step-outcome", outcome=":preempted") == []  # halted, not failed
        assert s.times("task-waiting", task="(look-at pump)") == [3.0]
        assert s.times("task-succeeded", task="(watch pump)") == [13.0]
        assert s.times("task-resumed", task="(look-at pump)") == [13.0]
        # the halted step runs again from its start (10 s of camera), on the same attempt
        assert s.times("task-succeeded", task="(look-at pump)") == [23.0]
        assert s.field("attempt", "method-selected", task="(look-at pump)") == [1]
        on = [r["t"] for r in s.events("skill-enabled", id=1)]
        off = [r["t"] for r in s.events("skill-disabled", id=1)]
        assert on == [0.0, 13.0] and off == [3.0, 23.0]  # each enable matched by its disable


def test_on_preempt_fail_fails_the_holders_step_as_a_behaviour_tree_action_that_cannot_resume(tmp_path):
    mission = CAMERA.replace("(method (task-net (sequence (t1 (camera ?what))",
                             "(retries 1) (method (on-preempt fail) (task-net (sequence (t1 (camera ?what))") \
        + "(post (look-at pump))\n(at-time 3 (assert (go)))\n(post (watch pump) :priority 5)\n"
    with run(tmp_path, mission) as s:
        (contest,) = s.events("skill-preempted")
        assert contest["outcome"] == ":preempted" and contest["task"] == "(look-at pump)"
        look = s.task("(look-at pump)")
        assert look.status == "failed" and look.ended == 3.0
        assert "preempted by [2] (watch pump)" in look.failure.root().reason
        assert s.task("(watch pump)").status == "succeeded"


def test_waiters_are_served_in_agenda_order_priority_then_deadline_then_age(tmp_path):
    mission = CAMERA + """
(define-rap (snap ?who) (method (task-net (sequence (wait-for (go)) (t1 (camera pump)) (assert (snapped ?who))))))
(post (look-at pump) :priority 3)
(post (snap old))
(post (snap urgent) :deadline 100)
(post (snap important) :priority 2)
(post (snap young))
(at-time 1 (assert (go)))
"""
    with run(tmp_path, mission) as s:
        assert s.result.ok
        served = [r["task"] for r in s.events("task-resumed")]
        assert served == ["(snap important)", "(snap urgent)", "(snap old)", "(snap young)"]
        assert s.times("task-resumed") == [10.0, 20.0, 30.0, 40.0]


def test_a_deadline_that_passes_while_a_task_waits_says_what_it_waited_for(tmp_path):
    mission = CAMERA + "(post (look-at pump))\n(at-time 3 (assert (go)))\n(post (watch pump) :deadline 6)\n"
    with run(tmp_path, mission) as s:
        watch = s.task("(watch pump)")
        assert watch.status == "failed" and watch.ended == 6.0
        assert watch.failure.reason == ("missed its deadline at t=6 s: it waited for (camera pump) "
                                        "held by [1] (look-at pump) since t=3 s")
        assert s.task("(look-at pump)").status == "succeeded"
        assert s.events("task-resumed") == []  # its claim left the queue with it


def test_a_halted_holder_whose_context_changed_chooses_its_method_again_uncharged(tmp_path):
    mission = """
(define-virtual-skill (drive ?to) (after 10 (assert (at robot ?to)) (finish :succeed)))
(define-virtual-skill (dock) (after 1 (assert (docked)) (finish :succeed)))
(define-rap (go-home)
  (succeed (docked))
  (method by-road (context (road-open)) (task-net (sequence (t1 (drive home)) (t2 (dock)))))
  (method by-air (task-net (t1 (dock)))))
(define-rap (rush) (method (task-net (sequence (wait-for (go)) (t1 (drive home))))))
(initial-memory (road-open))
(post (go-home))
(at-time 2 (assert (go)) (retract (road-open)))
(post (rush) :priority 5)
"""
    with run(tmp_path, mission) as s:
        assert s.result.ok
        (resumed,) = s.events("task-resumed", task="(go-home)")
        assert resumed["t"] == 12.0
        assert resumed["rechoose"] == "the context of method by-road no longer holds: (road-open)"
        assert s.field("method", "method-selected", task="(go-home)") == ["by-road", "by-air"]
        assert s.field("attempt", "method-selected", task="(go-home)") == [1, 1]  # the halted one is refunded
        assert s.times("task-succeeded", task="(go-home)") == [13.0]


def test_a_primitive_whose_skill_is_taken_enables_it_again_and_waits_again_where_it_waited(tmp_path):
    mission = CAMERA + """
(define-rap (film ?x)
  (method (primitive (assert (filming ?x)) (enable (camera ?x)) (wait-for (done (camera ?x) ?o))
                     (assert (filmed ?x)))))
(post (film pump))
(at-time 3 (assert (go)))
(post (watch pump) :priority 5)
"""
    with run(tmp_path, mission) as s:
        assert s.result.ok
        assert s.times("task-succeeded", task="(watch pump)") == [13.0]
        assert s.times("fact-asserted", fact="(filmed pump)") == [23.0]
        assert s.times("fact-asserted", fact="(filming pump)") == [0.0]  # not run again from the top
        assert s.events("skill-enabled", id=1)[-1]["t"] == 13.0


def test_two_primitives_each_holding_what_the_other_needs_do_not_wait_for_each_other_for_ever(tmp_path):
    mission = """
(define-virtual-skill (arm) (after 5 (finish :succeed)))
(define-virtual-skill (cam) (after 5 (finish :succeed)))
(define-rap (a) (method (primitive (enable (arm)) (wait-for (go)) (enable (cam)) (wait-for (done (cam) ?o))
                                   (disable :above) (assert (done-a)))))
(define-rap (b) (method (primitive (enable (cam)) (wait-for (go)) (enable (arm)) (wait-for (done (arm) ?o))
                                   (disable :above) (assert (done-b)))))
(post (a))
(post (b))
(at-time 1 (assert (go)))
"""
    with run(tmp_path, mission) as s:
        assert s.result.ok and s.result.time < 30
        assert [(r["id"], r["skill"]) for r in s.events("task-waiting")] == [(1, "(cam)"), (1, "(arm)")]
        (contest,) = s.events("skill-preempted")  # b's wait would close the circle: b takes the arm
        assert (contest["t"], contest["task"], contest["winner"], contest["outcome"]) == (1.0, "(a)", "(b)", ":halted")
        assert s.times("fact-asserted", fact="(done-b)") == [6.0]
        assert s.times("fact-asserted", fact="(done-a)") == [11.0]  # arm back, then cam, 5 s
        assert [t.attempts for t in s.result.tasks] == [1, 1]


def test_a_failed_attempt_waits_for_the_back_off_instead_of_retrying_in_the_same_instant(tmp_path):
    mission = """
(define-virtual-skill (grab ?x) (after 0.5 (finish :fail)))
(define-rap (pick ?x) (succeed (held ?x)) (retries 3) (method (task-net (t1 (grab ?x)))))
(post (pick cup))
"""
    with run(tmp_path, mission) as s:
        assert s.times("method-selected", task="(pick cup)") == [0.0, 1.5, 3.0]  # 0.5 s grab + 1 s back-off
        assert [r["by"] for r in s.events("task-resumed")] == ["the back-off", "the back-off"]
        assert s.events("task-waiting")[0]["watching"] == ["(held cup)"]
        assert s.task("(pick cup)").ended == 3.5  # the last failure is final at once


def test_a_change_the_rap_reads_ends_the_back_off_early_and_retry_backoff_sets_it(tmp_path):
    mission = """
(define-virtual-skill (grab ?x) (after 0.5 (finish :fail)))
(define-virtual-skill (grab-gently ?x) (after 0.5 (assert (held ?x)) (finish :succeed)))
(define-rap (pick ?x) (succeed (held ?x)) (retry-backoff 30)
  (method gently (context (slippery ?x)) (task-net (t1 (grab-gently ?x))))
  (method (task-net (t1 (grab ?x)))))
(post (pick cup))
(at-time 4 (assert (slippery cup)))
"""
    with run(tmp_path, mission) as s:
        assert s.result.ok
        (resumed,) = s.events("task-resumed")
        assert resumed["t"] == 4.0 and resumed["by"] == "a change"
        assert s.events("task-waiting")[0]["until"] == 30.5
        assert s.field("method", "method-selected") == ["2", "gently"]


def test_retry_backoff_zero_retries_at_once_as_before(tmp_path):
    mission = """
(define-virtual-skill (grab ?x) (after 0.5 (finish :fail)))
(define-rap (pick ?x) (succeed (held ?x)) (retries 3) (retry-backoff 0) (method (task-net (t1 (grab ?x)))))
(post (pick cup))
"""
    with run(tmp_path, mission) as s:
        assert s.times("method-selected") == [0.0, 0.5, 1.0]
        assert s.events("task-waiting") == []


# -- in the simulated world ---------------------------------------------------------------


def _two_go_tos(tmp_path, *, later: str = ""):
    """(go-to office) and (go-to storeroom) posted together, or the storeroom one when ``later``
    (a priority) a few seconds on, by a RAP of that priority."""
    path = tmp_path / "two.rap"
    storeroom = "(post (go-to storeroom))" if not later else (
        f"(define-rap (errand) (priority {later}) (method (task-net (sequence (wait-for (go)) "
        "(t1 (go-to storeroom))))))\n(at-time 5 (assert (go)))\n(post (errand))")
    path.write_text(f'(include "{NAVIGATION}")\n(world "lab-corridor-office")\n'
                    f"(post (go-to office))\n{storeroom}\n", encoding="utf-8")
    return run_in_world(path)


def test_two_go_tos_posted_together_both_arrive_one_after_the_other(tmp_path):
    done = _two_go_tos(tmp_path)
    assert done.result.ok, done.explain()
    office, storeroom = done.result.tasks
    assert office.ended < storeroom.ended, done.explain()
    assert [r["t"] for r in done.records if r["event"] == "task-waiting" and r["id"] == 2] == [0.0]
    (resumed,) = [r for r in done.records if r["event"] == "task-resumed"]
    assert resumed["id"] == 2 and resumed["t"] <= office.ended
    arrived = [r["fact"] for r in done.records if r["event"] == "fact-asserted"
               and r["fact"] in ("(at robot office)", "(at robot storeroom)")]
    assert arrived == ["(at robot office)", "(at robot storeroom)"]
    assert [t.attempts for t in done.result.tasks] == [1, 1]
    assert done.mission.manager.running() == []  # nothing left enabled at the end


def test_a_go_to_of_higher_priority_drives_first_and_the_other_resumes(tmp_path):
    done = _two_go_tos(tmp_path, later="5")
    assert done.result.ok, done.explain()
    office, errand = done.result.tasks
    assert errand.ended < office.ended, done.explain()
    contests = [r for r in done.records if r["event"] == "skill-preempted"]
    assert [(r["task"], r["winner"], r["outcome"]) for r in contests] == [
        ("(go-to office)", "(go-to storeroom)", ":halted")]
    assert [t.attempts for t in done.result.tasks] == [1, 1]
    (resumed,) = [r for r in done.records if r["event"] == "task-resumed"]
    assert resumed["task"] == "(go-to office)" and resumed["t"] <= errand.ended


def test_always_on_skills_belong_to_no_task(tmp_path):
    from world_runs import go_to_mission

    done = run_in_world(go_to_mission(tmp_path, "corridor"), "lab-corridor-office")
    assert done.result.ok, done.explain()
    manager = done.mission.manager
    always_on = {name for name, skill in manager.catalog.items() if skill.always_on}
    assert {"safety-reflex", "sonar-ring", "place-monitor"} <= always_on
    assert not always_on & set(done.mission.skills.skills())  # tasks cannot enable them
    enabled = {r["skill"].strip("()").split()[0] for r in done.records if r["event"] == "skill-enabled"}
    assert enabled and not enabled & always_on


def test_mapping_is_layer_ivs_and_no_task_can_take_it():
    from atlas_rap.layers import MissionEngine, RunOptions

    engine = MissionEngine(RunOptions(world="lab-corridor-office", mapping=True))
    engine.start()
    assert "map-builder" not in engine.skills.skills()
    engine.advance(1.0)  # no task posted: Layer IV maps all the same
    assert engine.grid is not None and engine.grid.updated.sum() > 500


# -- plans share the robot ----------------------------------------------------------------

POLISHING = """
(operator polish :purpose (polished ?x) :agent ?arm :preconditions ((dull ?x)) :constraints ((arm ?arm))
  :plot (polish ?arm ?x) :effects ((polished ?x)) :duration 5)
(agents (controlled arm-1))
(initial (arm arm-1) (dull vase))
(define-virtual-skill (buff ?arm) (after 5 (finish :succeed)))
(define-rap (polish ?arm ?x) (succeed (polished ?x))
  (method (task-net (sequence (t1 (buff ?arm)) (assert (polished ?x))))))
(define-rap (hog) (priority 5) (method (task-net (t1 (buff arm-1)))))
(post (hog))
"""


def test_a_plan_step_that_finds_its_agent_busy_waits_and_the_plan_goes_on(tmp_path):
    with run(tmp_path, POLISHING + "(plan (polished vase) :deadline 12)\n") as s:
        assert s.result.ok
        (waiting,) = s.events("task-waiting", task="(polish arm-1 vase)")
        assert waiting["holder"] == "(hog)"
        assert s.events("replanned") == [] and s.events("plan-abandoned") == []  # waiting is no failure
        assert s.times("plan-done") == [10.0]


def test_a_wait_that_endangers_the_plans_deadline_repairs_it_and_a_plan_that_cannot_fit_is_abandoned(tmp_path):
    with run(tmp_path, POLISHING + "(plan (polished vase) :deadline 8)\n") as s:
        (abandoned,) = s.events("plan-abandoned")
        assert 3.0 < abandoned["t"] < 3.5  # 5 s of plan left, 8 s deadline: it had to start by t=3; then the repair
        assert abandoned["cause"] == ("step s1 (polish arm-1 vase) waits for (buff arm-1) held by [1] (hog), and the "
                                      "5 s of plan left from it no longer fit before the deadline at t=8 s")
        assert abandoned["reason"].startswith("no plan meets the deadline")
        assert s.task("(hog)").status == "succeeded"
        assert not s.holds("(polished vase)")


# -- in the REPL, as the issue tried it ----------------------------------------------------

def _repl_errand(tmp_path, *lines: str, shown: list[str] | None = None) -> list[dict]:
    """`atlas repl deliver.rap` fed ``lines`` through a pipe; the trace records (and the lines it
    printed, into ``shown``)."""
    import json
    import subprocess

    from cli_process import ENV, REPO, assert_no_traceback, atlas_command

    trace = tmp_path / "trace.jsonl"
    done = subprocess.run(atlas_command("repl", "deliver.rap", "--trace", str(trace)), input="\n".join(lines) + "\n",
                          cwd=REPO / "rap_library" / "missions", capture_output=True, text=True, env=ENV, timeout=120)
    assert_no_traceback(done)
    assert done.returncode == 0, done.stdout + done.stderr
    if shown is not None:
        shown += [line.strip() for line in done.stdout.splitlines()]
    return [json.loads(line) for line in trace.read_text(encoding="utf-8").splitlines()]


def _arrivals(records: list[dict]) -> list[str]:
    return [r["fact"] for r in records if r["event"] == "fact-asserted" and r["fact"].startswith("(at robot ")]


def test_repl_a_go_to_posted_while_deliver_drives_waits_and_the_mail_is_delivered_first(tmp_path):
    records = _repl_errand(tmp_path, ":run 12", "(post (go-to storeroom))", ":run 200")
    assert [r["task"] for r in records if r["event"] == "task-failed"] == []
    succeeded = [r["task"] for r in records if r["event"] == "task-succeeded" and r["task"] in (
        "(deliver mail office lab)", "(go-to storeroom)")]
    assert succeeded == ["(go-to storeroom)", "(deliver mail office lab)"]
    delivered = next(r["t"] for r in records if r["event"] == "fact-asserted" and r["fact"] == "(delivered mail office)")
    storeroom = next(r["t"] for r in records if r["event"] == "fact-asserted" and r["fact"] == "(at robot storeroom)")
    assert delivered < storeroom
    assert _arrivals(records)[-3:] == ["(at robot storeroom)", "(at robot corridor)", "(at robot lab)"]
    assert {r["attempt"] for r in records if r["event"] == "method-selected"} == {1}  # nobody retried


def test_repl_a_go_to_of_higher_priority_goes_first_and_the_errand_resumes_uncharged(tmp_path):
    shown: list[str] = []
    records = _repl_errand(tmp_path, ":run 12", "(post (go-to storeroom) :priority 5)", ":run 200", shown=shown)
    assert [r["task"] for r in records if r["event"] == "task-failed"] == []
    (contest,) = [r for r in records if r["event"] == "skill-preempted"]
    assert (contest["t"], contest["task"], contest["winner"], contest["outcome"]) == (
        12.0, "(go-to office)", "(go-to storeroom)", ":halted")
    storeroom = next(r["t"] for r in records if r["event"] == "fact-asserted" and r["fact"] == "(at robot storeroom)")
    delivered = next(r["t"] for r in records if r["event"] == "fact-asserted" and r["fact"] == "(delivered mail office)")
    assert storeroom < delivered
    assert records[-1]["event"] != "task-failed"
    assert any(r["event"] == "task-succeeded" and r["task"] == "(deliver mail office lab)" for r in records)
    assert {r["attempt"] for r in records if r["event"] == "method-selected"} == {1}  # the errand paid no retry
    page = (REPO / "docs" / "explanation" / "sharing.md").read_text(encoding="utf-8")
    example = page.split("# Tasks share the robot")[1].split("```\n12.00")[1].split("```")[0]
    for line in ("12.00" + example).strip().splitlines():  # the page shows what the REPL prints
        assert line.strip() in shown


def test_repl_a_plan_posted_mid_errand_and_the_errand_both_complete(tmp_path):
    records = _repl_errand(tmp_path, '(include "../plan_steps/places-steps.rap")', '(include "../../operators/places.ap")',
                           ":run 12", "(plan (at robot storeroom))", ":run 300")
    assert [r["task"] for r in records if r["event"] == "task-failed"] == []
    assert [r["event"] for r in records if r["event"] in ("plan-done", "plan-abandoned")] == ["plan-done"]
    assert any(r["event"] == "task-succeeded" and r["task"] == "(deliver mail office lab)" for r in records)
    assert any(r["event"] == "task-waiting" for r in records)  # they did share the robot

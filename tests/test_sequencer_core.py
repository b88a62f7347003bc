"""The sequencer's parts on their own: timers, the wait index, reloading, halting, the task tree."""

from __future__ import annotations

import pytest

from atlas_rap.lang import parse_term, parse_text
from atlas_rap.sequencer import Sequencer, Trace, agenda_tree, tree_text
from atlas_rap.skillbus import Timers
from atlas_rap.sequencer.waiting import Waiter, WaitIndex
from atlas_rap.skills.virtual import VirtualSkills


def term(text: str):
    return parse_term(text)


def forms(text: str):
    return parse_text(text, "t.rap").forms


def test_timers_fire_in_time_order_then_in_the_order_scheduled():
    timers, fired = Timers(), []
    timers.at(2.0, lambda: fired.append("b"))
    timers.at(1.0, lambda: fired.append("a"))
    timers.at(2.0, lambda: fired.append("c"))
    timers.at(1.5, lambda: fired.append("never")).cancel()
    assert timers.next_time() == 1.0
    timers.fire_due(2.0)
    assert fired == ["a", "b", "c"]
    assert timers.next_time() is None and timers.now == 2.0


def test_a_timer_scheduled_for_now_by_a_firing_timer_fires_in_the_same_call():
    timers, fired = Timers(), []
    timers.at(1.0, lambda: timers.after(0.0, lambda: fired.append("echo")))
    timers.fire_due(1.0)
    assert fired == ["echo"]


class Owner:
    def woken(self, waiter, answer):
        pass

    def broken(self, waiter, message):
        pass


def candidates(index: WaitIndex, kind: str, fact: str) -> list[str]:
    from atlas_rap.logic import term_to_str

    return [term_to_str(w.query) for w in index.candidates([(kind, term(fact))])]


def test_the_wait_index_wakes_only_waiters_whose_predicate_and_first_argument_match():
    index = WaitIndex()
    for query in ("(ev 1 ?step)", "(ev 2 ?step)", "(ev ?who 3)", "(at robot ?where)"):
        index.add(Waiter(term(query), Owner()))
    assert candidates(index, "assert", "(ev 2 5)") == ["(ev 2 ?step)", "(ev ?who 3)"]
    assert candidates(index, "assert", "(at box lab)") == []
    assert candidates(index, "retract", "(ev 1 1)") == []


def test_a_negated_pattern_is_woken_by_retraction_and_a_conjunction_by_either_part():
    index = WaitIndex()
    index.add(Waiter(term("(and (at robot ?p) (not (blocked robot)))"), Owner()))
    assert len(index.candidates([("assert", term("(at robot lab)"))])) == 1
    assert len(index.candidates([("retract", term("(blocked robot)"))])) == 1
    assert index.candidates([("assert", term("(blocked robot)"))]) == []


def test_ten_thousand_waiting_tasks_cost_nothing_when_an_event_concerns_one_of_them():
    seq = Sequencer(forms("(define-rap (worker ?i) (method (task-net (wait-for (ev ?i)))))"))
    for i in range(10_000):
        seq.post(term(f"(worker {i})"))
    seq.settle()
    assert seq.waits.size == 10_000
    assert len(seq.waits.candidates([("assert", term("(ev 4242)"))])) == 1
    seq.assert_fact(term("(ev 4242)"))
    seq.settle()
    assert [t.text for t in seq.roots if t.status == "succeeded"] == ["(worker 4242)"]
    assert seq.waits.size == 9_999


RELOADABLE = """
(define-rap (greet)
  (succeed (greeted))
  (method old (task-net (sequence (wait-for (go)) (assert (said hello))))))
"""


def test_a_reload_keeps_the_running_method_and_the_next_choice_uses_the_new_definition():
    trace = Trace(keep=True)
    seq = Sequencer(forms(RELOADABLE), trace=trace)
    task = seq.post(term("(greet)"))
    seq.settle()
    seq.define(forms("(define-rap (greet) (succeed (greeted)) "
                     "(method new (task-net (sequence (assert (said bonjour)) (assert (greeted))))))"))
    seq.assert_fact(term("(go)"))  # the old method's net ends; (greeted) is still false
    seq.settle()
    assert task.status == "pending" and task.backoff is not None  # its attempt failed: it waits a while
    seq.advance_to(1.0)
    assert task.status == "succeeded"
    methods = [r["method"] for r in trace.records if r["event"] == "method-selected"]
    assert methods == ["old", "new"]
    assert seq.memory.holds(term("(and (said hello) (said bonjour))"))


SKILLED = """
(define-virtual-skill (hum ?tune) (after 100 (finish :succeed)))
(define-rap (sing ?tune) (method (task-net (t1 (hum ?tune)))))
(define-rap (concert) (method (task-net (parallel (sing a) (sing b)))))
"""


def test_cancelling_a_task_halts_its_subtasks_and_disables_every_skill_they_enabled():
    program = forms(SKILLED)
    skills = VirtualSkills([f for f in program if type(f).__name__ == "VirtualSkillDef"])
    seq = Sequencer([f for f in program if type(f).__name__ == "RapDef"], skills=skills)
    concert = seq.post(term("(concert)"))
    seq.settle()
    assert [str(c) for c in map(str, skills.running())] == ["(hum a)", "(hum b)"]
    text = tree_text(agenda_tree(seq))
    assert "▶ [1] (concert) running method 1 (attempt 1)" in text
    assert "waiting for skill (hum a)" in text
    seq.cancel(concert, "the audience left")
    assert skills.running() == []
    assert [c.status for c in concert.children] == ["halted", "halted"]
    assert concert.failure.reason == "the audience left"
    assert seq.timers.next_time() is None  # the skills' scripts were cancelled too


def test_reloading_a_file_replaces_raps_rules_and_skills_and_a_bad_file_changes_nothing(tmp_path):
    from scenario import load_mission

    from atlas_rap.errors import SourceError

    mission_file = tmp_path / "m.rap"
    mission_file.write_text(
        "(define-virtual-skill (beep) (after 1 (finish :fail)))\n"
        "(define-rap (alarm) (method loud (task-net (beep))))\n"
        "(post (alarm))\n", encoding="utf-8")
    mission = load_mission(mission_file)
    fixed = tmp_path / "fixed.rap"
    fixed.write_text("(define-virtual-skill (beep) (after 1 (finish :succeed)))\n"
                     "(define-rap (alarm) (method quiet (task-net (beep))))\n", encoding="utf-8")
    broken = tmp_path / "broken.rap"
    broken.write_text("(define-rap (alarm) (method (task-net (boop))))\n", encoding="utf-8")
    mission.sequencer.settle()  # the alarm runs its first method with the failing beep
    with pytest.raises(SourceError, match="'boop' is neither a RAP nor a skill"):
        mission.reload(broken)
    assert mission.reload(fixed).names == ["alarm", "beep"]
    result = mission.run_mission()
    assert result.ok
    (alarm,) = result.tasks
    assert alarm.last_method == "quiet" and alarm.attempts == 2


def test_the_succeed_test_comes_before_the_constraints_so_a_method_may_end_its_own_constraint():
    """Releasing a thing needs it gripped (constraint) and ends with it not gripped
    (succeed): when the method is done the task succeeds, it does not fail."""
    program = forms("""
        (define-rap (release ?thing)
          (succeed (not (gripping ?thing)))
          (constraints (gripping ?thing))
          (method (task-net (retract (gripping ?thing)))))
        (define-rap (release-twice ?thing)
          (constraints (gripping ?thing))
          (method (task-net (t1 (release ?thing)))))""")
    seq = Sequencer(program)
    seq.assert_fact(term("(gripping box)"))
    task = seq.post(term("(release box)"))
    seq.settle()
    assert task.status == "succeeded"
    other = seq.post(term("(release-twice box)"))  # nothing gripped now: its constraints fail it
    seq.settle()
    assert other.status == "failed" and "constraints do not hold" in other.failure.reason

"""Bad RAP programs are caught by the load-time checks, each with file, line, column and a hint."""

from __future__ import annotations

import pytest
from scenario import load_mission
from source_problems import at

from atlas_rap.errors import SourceError

SKILL = "(define-virtual-skill (beep ?n) (after 1 (finish :succeed)))\n"


def load_problems(tmp_path, text: str):
    path = tmp_path / "m.rap"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(SourceError) as caught:
        load_mission(path)
    return caught.value.problems


def only(problems):
    assert len(problems) == 1, "\n".join(p.render() for p in problems)
    return problems[0]


def test_a_step_that_names_no_rap_or_skill_is_an_error_with_the_nearest_name(tmp_path):
    problem = only(load_problems(tmp_path, SKILL + (
        "(define-rap (go)\n"
        "  (method (task-net (sequence (t1 (bep 1))))))\n"
        "(post (go))\n")))
    assert "'bep' is neither a RAP nor a skill" in problem.message
    assert at(problem) == (3, 31)
    assert problem.hint == "did you mean 'beep'?"
    assert problem.location.file.endswith("m.rap")
    assert "^" in problem.render()


def test_a_call_with_the_wrong_number_of_arguments_says_how_many(tmp_path):
    problem = only(load_problems(tmp_path, SKILL + (
        "(define-rap (go)\n  (method (task-net (beep 1 2))))\n(post (go))\n")))
    assert problem.message == "beep takes 1 argument, not 2"
    assert at(problem) == (3, 21)


def test_enabling_an_unknown_skill_in_a_primitive_is_an_error(tmp_path):
    problem = only(load_problems(tmp_path, SKILL + (
        "(define-rap (go)\n  (method (primitive (enable (beeps 1)) (wait-for (done (beeps 1) :succeed)))))\n"
        "(post (go))\n")))
    assert problem.message == "cannot enable unknown skill 'beeps'"
    assert problem.hint == "did you mean 'beep'?"
    assert at(problem) == (3, 22)


def test_enabling_a_rap_as_a_skill_is_an_error(tmp_path):
    problem = only(load_problems(tmp_path, (
        "(define-rap (go) (method (primitive (enable (go)))))\n(post (go))\n")))
    assert problem.message == "cannot enable go: it is a RAP, not a skill"


def test_posting_an_unknown_task_is_an_error_at_the_post(tmp_path):
    problem = only(load_problems(tmp_path, SKILL + "(define-rap (go) (method (task-net (beep 1))))\n(post (goo))\n"))
    assert "'goo' is neither a RAP nor a skill" in problem.message
    assert at(problem) == (3, 1)
    assert problem.hint == "did you mean 'go'?"


def test_posting_a_skill_is_an_error_that_says_to_wrap_it(tmp_path):
    problem = only(load_problems(tmp_path, SKILL + "(post (beep 1))\n"))
    assert "only RAPs go on the agenda" in problem.message


def test_a_step_label_used_twice_is_an_error(tmp_path):
    problem = only(load_problems(tmp_path, SKILL + (
        "(define-rap (go)\n  (method (task-net (sequence (t1 (beep 1)) (t1 (beep 2))))))\n(post (go))\n")))
    assert "step label 't1' used twice" in problem.message
    assert at(problem) == (3, 45)


def test_an_ordering_to_a_missing_label_is_an_error(tmp_path):
    problem = only(load_problems(tmp_path, SKILL + (
        "(define-rap (go)\n  (method (task-net (t1 (beep 1) (for t2)) (t3 (beep 3)))))\n(post (go))\n")))
    assert problem.message == "no step labelled 't2' in this method"
    assert at(problem) == (3, 21)


def test_steps_ordered_in_a_circle_are_an_error(tmp_path):
    problem = only(load_problems(tmp_path, SKILL + (
        "(define-rap (go)\n"
        "  (method (task-net (sequence (t1 (beep 1)) (t2 (beep 2) (for t1))))))\n"
        "(post (go))\n")))
    assert "wait for each other for ever: t1 -> t2 -> t1" in problem.message


def test_a_monitor_that_must_end_before_its_target_starts_is_an_error(tmp_path):
    problem = only(load_problems(tmp_path, SKILL + (
        "(define-rap (go)\n"
        "  (method (task-net (sequence (t1 (beep 1) (until-end t2)) (t2 (beep 2))))))\n"
        "(post (go))\n")))
    assert "keeps it running until t2 ends" in problem.message
    assert at(problem) == (3, 31)


def test_a_mission_with_no_post_is_an_error_that_suggests_one(tmp_path):
    problem = only(load_problems(tmp_path, SKILL + "(define-rap (go) (method (task-net (beep 1))))\n"))
    assert problem.message == "this mission posts no task, so there is nothing to run"
    assert at(problem) == (1, 1)
    assert problem.hint.endswith("e.g. (post (go))")


def test_every_problem_is_reported_not_only_the_first(tmp_path):
    problems = load_problems(tmp_path, (
        "(define-rap (go)\n  (method (task-net (sequence (t1 (fly 1)) (t2 (swim 2))))))\n(post (run))\n"))
    assert [p.message.split("'")[1] for p in problems] == ["fly", "swim", "run"]


def test_a_wait_for_that_nothing_can_produce_is_a_warning_not_an_error(tmp_path):
    path = tmp_path / "m.rap"
    path.write_text(SKILL + (
        "(define-rap (go)\n  (method (task-net (sequence (beep 1) (wait-for (dokced hull-3))))))\n"
        "(define-rap (unused) (method (task-net (wait-for (never-posted)))))\n"
        "(post (go))\n"), encoding="utf-8")
    mission = load_mission(path)
    (warning,) = mission.library.warnings
    assert warning.severity == "warning"
    assert "this wait-for can never match: nothing asserts dokced facts" in warning.message
    assert at(warning) == (3, 40)


def test_a_wait_for_on_a_fact_that_a_skill_script_asserts_is_not_warned(tmp_path):
    path = tmp_path / "m.rap"
    path.write_text(
        "(define-virtual-skill (dock ?s) (after 1 (assert (docked ?s)) (finish :succeed)))\n"
        "(define-rap (go) (method (task-net\n"
        "  (sequence (dock h) (wait-for (docked h)) (wait-for (or (x) (docked h)))))))\n"
        "(post (go))\n", encoding="utf-8")
    assert load_mission(path).library.warnings == []


# -- memory: arithmetic in facts, rules that trigger each other --------------------

POST_GO = SKILL + "(define-rap (go) (method (task-net (beep 1))))\n(post (go))\n"


def test_arithmetic_without_a_value_in_initial_memory_is_an_error_under_the_fact(tmp_path):
    problem = only(load_problems(tmp_path, POST_GO + (
        "(initial-memory (level (+ 1 2)) (ok)\n"
        "                (level (/ 1 0)))\n")))
    assert problem.severity == "error"
    assert problem.message == ("cannot evaluate the arithmetic in the fact (level (/ 1 0)): "
                               "division by zero in (/ 1 0)")
    assert at(problem) == (5, 17)
    assert problem.render().splitlines()[1:3] == ["                    (level (/ 1 0)))",
                                                  "                    ^"]
    assert "arithmetic in a fact is evaluated when the fact is asserted" in problem.hint


def test_arithmetic_on_a_symbol_in_an_at_time_fact_is_an_error_under_the_fact(tmp_path):
    problem = only(load_problems(tmp_path, POST_GO + (
        "(at-time 2 (assert (door open))\n"
        "  (retract   (fuel (- full 1))))\n")))
    assert problem.message == ("cannot evaluate the arithmetic in the fact (fuel (- full 1)): "
                               "full is not a number, in (- full 1)")
    assert at(problem) == (5, 14)


def test_arithmetic_with_a_value_in_initial_memory_and_at_time_is_fine(tmp_path):
    path = tmp_path / "m.rap"
    path.write_text(POST_GO + "(initial-memory (level (+ 1 2)))\n(at-time 2 (assert (level (* 2 (- 3)))))\n",
                    encoding="utf-8")
    assert load_mission(path).library.warnings == []


CYCLE = (
    "(define-memory-rule up (on (ping ?n)) (assert (pong ?n)))\n"
    "(define-memory-rule down (on (pong ?n)) (assert (ping (+ ?n 1))))\n"
)


def test_memory_rules_that_trigger_each_other_are_warned_at_the_first_rule_of_the_cycle(tmp_path):
    path = tmp_path / "m.rap"
    path.write_text(POST_GO + CYCLE, encoding="utf-8")
    (warning,) = load_mission(path).library.warnings
    assert warning.severity == "warning"
    assert at(warning) == (4, 1)
    file = warning.location.file
    assert file.endswith("m.rap")
    assert warning.message == (f"memory rules can trigger each other in a cycle: up ({file}:4:1) -> "
                               f"down ({file}:5:1) -> up")
    assert warning.hint.startswith("a rule in this cycle needs a (when ...) that stops it")


def test_a_rule_that_triggers_itself_is_warned_and_the_hint_names_its_when(tmp_path):
    path = tmp_path / "m.rap"
    path.write_text(POST_GO + (
        "(define-memory-rule at-is-unique (on (at ?thing ?new))\n"
        "  (when (and (at ?thing ?old) (/= ?old ?new))) (retract (at ?thing ?old)))\n"
        "(define-memory-rule echo (on (seen ?x)) (assert (seen ?x)))\n"
        "(define-memory-rule count (on (count ?n)) (when (< ?n 10)) (assert (count (+ ?n 1))))\n"),
        encoding="utf-8")
    (warning,) = load_mission(path).library.warnings
    assert at(warning) == (7, 1)
    assert warning.message.startswith("memory rule count (")
    assert warning.message.endswith(":7:1) can trigger itself: it asserts a fact its own (on ...) matches")
    assert warning.hint.startswith("make sure the (when ...) of count stops the cycle")


def test_errors_come_before_the_cycle_warnings(tmp_path):
    path = tmp_path / "m.rap"
    path.write_text(CYCLE + POST_GO + "(initial-memory (x (* a 2)))\n", encoding="utf-8")
    with pytest.raises(SourceError) as caught:
        load_mission(path)
    assert [p.severity for p in caught.value.problems] == ["error", "warning"]

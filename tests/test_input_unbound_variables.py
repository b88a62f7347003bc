"""Variables where nothing can give them a value are errors at load, with the caret under the variable.

``(post (go-to ?where))`` used to "succeed" at 0 s without the robot moving
(the RAP's succeed clause matched any place). A posted task, the goals of a
top-level ``(plan ...)`` and of ``(goals ...)``, the facts of ``at-time``,
``initial-memory`` and ``initial``, a virtual skill's asserts beyond its
head and a memory rule's effects beyond its ``on`` and ``when`` have no
bindings to take a value from. Where bindings exist (a RAP's task net, a
``(deadline GOAL ...)`` pattern) variables stay allowed.
"""

from __future__ import annotations

import subprocess

import pytest
from cli_process import ENV, REPO, assert_no_traceback, atlas, atlas_command

from atlas_rap.errors import SourceError
from atlas_rap.lang import parse_text

NAVIGATION = str(REPO / "rap_library" / "navigation.rap")


def only_problem(text: str):
    with pytest.raises(SourceError) as caught:
        parse_text(text, "u.rap")
    (problem,) = caught.value.problems
    return problem


def test_a_posted_task_with_a_variable_is_an_error_at_load_not_a_success_at_0_s(tmp_path):
    (tmp_path / "m.rap").write_text(f'(include "{NAVIGATION}")\n(world "lab-corridor-office")\n'
                                    "(post (go-to ?where))\n", encoding="utf-8")
    for command in ("check", "run"):
        done = atlas(command, "m.rap", cwd=tmp_path)
        assert_no_traceback(done)
        assert done.returncode == 1, done.stdout
        assert done.stderr.splitlines()[:3] == [
            "m.rap:3:14: error: the posted task has the unbound variable ?where: nothing gives it a value",
            "    (post (go-to ?where))",
            "                 ^"]
        assert "hint: a posted task needs a value for each argument, e.g. (post (go-to office))" in done.stderr
        assert "succeeded" not in done.stdout


@pytest.mark.parametrize("text, what, variable", [
    ("(post (deliver mail (to ?)))", "the posted task", "?"),
    ("(plan (at robot ?where) :deadline 30)", "a goal of a top-level plan", "?where"),
    ("(goals (delivered mail ?where))", "a goal", "?where"),
    ("(at-time 30 (assert (door-closed ?door)))", "this assert", "?door"),
    ("(at-time 30 (retract (door-closed ?door)))", "this retract", "?door"),
    ("(define-memory-rule r (on (went ?a)) (when (at ?a ?b)) (assert (gone ?a ?c)))", "this assert", "?c"),
    ("(define-virtual-skill (beep ?x) (after 1 (assert (beeped ?y)) (finish :succeed)))", "this assert", "?y"),
    ("(define-virtual-skill (beep ?x) (when (ok) (after 1 (retract (x ?z)))))", "this retract", "?z"),
], ids=["post, anonymous", "top-level plan", "goals", "at-time assert", "at-time retract", "memory rule effect",
        "script assert", "script retract in when"])
def test_a_variable_nothing_can_bind_is_located_under_the_variable(text, what, variable):
    problem = only_problem(text)
    assert problem.message == f"{what} has the unbound variable {variable}: nothing gives it a value"
    assert (problem.location.line, problem.location.column) == (1, text.rindex(variable) + 1)
    assert problem.hint


@pytest.mark.parametrize("fact_form", ["initial-memory", "initial"])
def test_initial_facts_with_a_variable_are_errors(fact_form):
    problem = only_problem(f"({fact_form} (at robot ?where))")
    assert "must be ground, but (at robot ?where) has a variable" in problem.message


@pytest.mark.parametrize("text", [
    "(define-rap (fetch ?x) (method (task-net (sequence (t1 (go ?x)) (plan (at robot ?x))))))",
    "(deadline (at ?who office) 30)",
    "(define-memory-rule r (on (went ?a)) (when (at ?a ?b)) (assert (gone ?a ?b)))",
    "(define-virtual-skill (beep ?x) (after 1 (assert (beeped ?x)) (finish :succeed)))",
    "(post (go-to office))",
], ids=["a plan in a task net", "a deadline pattern", "a rule's bound effect", "a script on its head",
        "a ground post"])
def test_variables_that_get_values_stay_allowed(text):
    parse_text(text, "ok.rap")


def test_the_repl_reports_a_post_with_a_variable_and_the_session_goes_on(tmp_path):
    script = ("(define-virtual-skill (wave ?who) (after 1 (finish :succeed)))\n"
              "(define-rap (greet ?who) (method (task-net (wave ?who))))\n"
              "(post (greet ?somebody))\n:agenda\n(post (greet ann))\n:run\n")
    done = subprocess.run(atlas_command("repl"), input=script, cwd=tmp_path, capture_output=True, text=True,
                          env=ENV, timeout=60)
    assert_no_traceback(done)
    assert done.returncode == 1  # one submission failed
    assert "<input 3>:1:14: error: the posted task has the unbound variable ?somebody" in done.stderr
    assert "the agenda is empty" in done.stdout  # nothing was posted
    assert "✓ [1] (greet ann) succeeded" in done.stdout

"""What a user coming from PDDL, Lisp or another robot language writes, and the hint that names atlas's form.

Nearest-spelling alone answers ``define-relation`` to ``define-operator``
(close in letters, wrong in meaning); these hints name what atlas calls
the thing, and show its shape when the names are far apart.
"""

from __future__ import annotations

import pytest
from cli_process import REPO, assert_no_traceback, atlas

from atlas_rap.errors import SourceError
from atlas_rap.lang import load_text, parse_text


def only_problem(text: str, *, load: bool = False):
    with pytest.raises(SourceError) as caught:
        if load:
            from atlas_rap.sequencer.checks import check_program

            problems = check_program(load_text(text, "h.rap"), {"beep": {0}}, ())
            raise SourceError(problems)
        parse_text(text, "h.rap")
    (problem,) = caught.value.problems
    return problem


def test_define_operator_is_told_the_form_is_operator_through_atlas_check(tmp_path):
    (tmp_path / "ops.ap").write_text("(define-operator go\n  :effects ((at robot office)))\n", encoding="utf-8")
    done = atlas("check", "ops.ap", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert done.stderr.splitlines()[:4] == [
        "ops.ap:1:2: error: unknown top-level form 'define-operator'",
        "    (define-operator go",
        "     ^",
        "  hint: did you mean 'operator'? e.g. (operator NAME :purpose (GOAL) :preconditions ((FACT) ...) "
        ":effects ((FACT) (not (FACT))))"]
    assert "define-relation" not in done.stderr


@pytest.mark.parametrize("text, message, hint", [
    ("(defrap (go))", "unknown top-level form 'defrap'", "did you mean 'define-rap'?"),
    ("(define-task (go))", "unknown top-level form 'define-task'", "did you mean 'define-rap'?"),
    ("(defrule r (on (a)))", "unknown top-level form 'defrule'", "did you mean 'define-memory-rule'?"),
    ("(defskill (beep))", "unknown top-level form 'defskill'", "did you mean 'define-virtual-skill'?"),
    ("(init (at robot lab))", "unknown top-level form 'init'", "did you mean 'initial-memory'?"),
    ("(goal (at robot lab))", "unknown top-level form 'goal'", "did you mean 'goals'?"),
    ("(require \"nav.rap\")", "unknown top-level form 'require'", "did you mean 'include'?"),
    ("(define (domain office))", "unknown top-level form 'define'", "this looks like PDDL: atlas plan --pddl"),
    ("(defun f (x) x)", "unknown top-level form 'defun'", "atlas files hold RAP and AP forms, not Lisp code"),
    ("(operator go :precondition ((a)) :effects ((b)))", "unknown operator part 'precondition'",
     "did you mean 'preconditions'?"),
    ("(operator go :parameters (?x) :effects ((b)))", "unknown operator part 'parameters'",
     "an operator has no parameter list"),
    ("(define-rap (go) (precondition (a)) (method (task-net (beep))))", "unknown clause 'precondition'",
     "a RAP's validity test is (constraints QUERY); each method has its own (context QUERY)"),
    ("(define-rap (go) (method (precondition (a)) (task-net (beep))))", "unknown method part 'precondition'",
     "did you mean 'context'?"),
    ("(define-rap (go) (context (a)) (method (task-net (beep))))", "unknown clause 'context'",
     "this goes inside a method"),
    ("(define-virtual-skill (beep) (after 1 (done :succeed)))", "unknown script action 'done'",
     "the action that ends a virtual skill is (finish :succeed) or (finish :fail)"),
    ("(define-virtual-skill (beep) (finish :succeed))", "unknown script line 'finish'",
     "a script's actions go inside (after SECONDS ...)"),
    ("(define-rap (go) (method (primitive (start (beep)))))", "unknown primitive action 'start'",
     "did you mean 'enable'?"),
    ("(define-rap (go ?a ?b) (succeed (!= ?a ?b)))", "'!=' is not a comparison or connective here",
     "write (/= ...); the comparisons are < <= > >= = /="),
], ids=lambda value: value if len(value) < 30 else None)
def test_a_wrong_guess_gets_the_name_atlas_uses(text, message, hint):
    problem = only_problem(text)
    assert problem.message == message
    assert problem.hint.startswith(hint), problem.hint


def test_a_misspelling_still_gets_the_nearest_name_without_an_example():
    problem = only_problem("(operator go (effect (b)))")
    assert problem.hint == "did you mean 'effects'?"
    assert only_problem("(define-rap (go) (sucede (a)))").hint == "did you mean 'succeed'?"


@pytest.mark.parametrize("step, hint", [
    ("(seq (beep) (beep))", "did you mean (sequence ...)?"),
    ("(par (beep) (beep))", "did you mean (parallel ...)?"),
    ("(wait-until (ready))", "did you mean (wait-for ...)?"),
    ("(if (ready) (beep))", "a task net has no conditionals: write a method for each case"),
])
def test_a_task_net_step_named_like_another_languages_control_form_gets_the_net_form(step, hint):
    problem = only_problem(f"(world none)\n(define-rap (go) (method (task-net {step})))\n", load=True)
    assert problem.message.endswith("is neither a RAP nor a skill")
    assert problem.hint.startswith(hint)


def test_on_preempt_takes_resume_or_fail_and_says_what_each_does():
    problem = only_problem("(define-rap (a) (method (on-preempt sometimes) (task-net (t1 (beep)))))")
    assert problem.message == "on-preempt takes resume or fail, found 'sometimes'"
    assert "resume (the default)" in problem.hint and "fail: the step ends :preempted" in problem.hint


def test_on_preempt_written_as_a_rap_clause_is_told_it_belongs_to_a_method():
    problem = only_problem("(define-rap (a) (on-preempt fail) (method (task-net (t1 (beep)))))")
    assert problem.message == "unknown clause 'on-preempt'"
    assert problem.hint == "on-preempt belongs to a method: (method (on-preempt fail) (task-net ...))"


def test_a_back_off_by_another_name_is_retry_backoff():
    problem = only_problem("(define-rap (a) (retry-delay 2) (method (task-net (t1 (beep)))))")
    assert problem.hint.startswith("did you mean 'retry-backoff'?")


def test_the_language_references_example_of_on_preempt_and_retry_backoff_means_what_it_says():
    from atlas_rap.lang import ast

    page = (REPO / "docs" / "language" / "rap.md").read_text(encoding="utf-8")
    example = page.split("### method")[1].split("```rap")[1].split("```")[0]
    (rap,) = [form for form in parse_text(example, "rap.md").forms if isinstance(form, ast.RapDef)]
    assert rap.retries == 5 and rap.retry_backoff == 4
    assert [method.on_preempt for method in rap.methods] == ["fail"]

"""Plan deadlines and plans inside task nets, on the language side: ``(plan GOAL ...
:deadline S :max-failures N)`` at top level and as a net item (bare or labelled),
``(deadline GOAL SECONDS)`` in .ap and .rap files; how they read, what is wrong
with them (with a caret), how they print back, what the load-time checks say of
them, and how ``atlas plan`` reports a plan that breaks its deadline."""

from __future__ import annotations

import json
from pathlib import Path

from cli_process import assert_no_traceback, atlas
from source_problems import at, only_problem

from atlas_rap.lang import ast, format_file, format_node, load, parse_text
from atlas_rap.logic import Compound, Var
from atlas_rap.planner.checks import check_problem, raise_problems
from atlas_rap.planner.plan import Plan
from atlas_rap.planner.problem import problem_from_program
from atlas_rap.sequencer.checks import check_program

C = Compound.of


def only_form(text: str, filename: str = "forms.rap"):
    (form,) = parse_text(text, filename).forms
    return form


def nets_of(text: str) -> tuple:
    """The nets of the task-net of the first method of the one define-rap in ``text``."""
    return only_form(text).methods[0].body.nets


def rap_with_net(net: str) -> str:
    return f"(define-rap (fetch ?x)\n  (method\n    (task-net\n      {net})))\n"


# ============================================================================= (plan ...) at top level

def test_a_plan_request_without_options_has_no_deadline_and_no_failure_limit():
    request = only_form("(plan (holding planner box-1) (inspected camera-site))\n")
    assert request == ast.PlanRequest((C("holding", "planner", "box-1"), C("inspected", "camera-site")))
    assert request.deadline is None and request.max_failures is None


def test_a_plan_request_takes_a_deadline_and_a_failure_limit_after_its_goals_in_either_order():
    request = only_form("(plan (delivered mail office-b) :deadline 150 :max-failures 2)\n")
    assert request == ast.PlanRequest((C("delivered", "mail", "office-b"),), deadline=150, max_failures=2)
    assert only_form("(plan (delivered mail office-b) :max-failures 2 :deadline 150)\n") == request
    assert only_form("(plan (a) :deadline 2.5)\n").deadline == 2.5


def test_plan_and_deadline_forms_are_accepted_in_ap_files_too():
    text = "(plan (a) :deadline 5)\n(deadline (a) 5)\n"
    assert parse_text(text, "x.ap").forms == parse_text(text, "x.rap").forms


# ============================================================================= (plan ...) in a task net

def test_a_bare_plan_in_a_sequence_is_a_plan_request_net_node():
    (sequence,) = nets_of(rap_with_net("(sequence (t1 (go ?x)) (plan (at robot ?x) :deadline 30))"))
    first, second = sequence.parts
    assert first == ast.Step(C("go", Var("x")), label="t1")
    assert second == ast.PlanRequest((C("at", "robot", Var("x")),), deadline=30)
    assert (second.loc.line, second.loc.column) == (4, 30)


def test_a_bare_plan_in_a_parallel_and_directly_under_task_net_is_a_plan_request():
    parallel, bare = nets_of(rap_with_net("(parallel (plan (a)) (beep 1))\n      (plan (b) :max-failures 3)"))
    assert parallel.parts == (ast.PlanRequest((C("a"),)), ast.Step(C("beep", 1)))
    assert bare == ast.PlanRequest((C("b"),), max_failures=3)


def test_a_labelled_plan_step_is_a_step_whose_task_is_the_plan_request():
    plan_step, later = nets_of(rap_with_net("(p1 (plan (c) :deadline 5) (for t2) (wait-for (d) :fail))\n"
                                            "      (t2 (go ?x))"))
    assert isinstance(plan_step, ast.Step)
    assert plan_step.label == "p1" and plan_step.before == ("t2",)
    assert plan_step.task == ast.PlanRequest((C("c"),), deadline=5)
    assert plan_step.plan is plan_step.task
    assert plan_step.waits == (ast.WaitFor(C("d"), ":fail"),)
    assert later.plan is None


def test_plan_at_the_head_of_a_net_item_is_never_a_task_or_a_label():
    # '(plan (go x))' used to read as the step labelled plan; now it is a plan for (go x).
    (item,) = nets_of(rap_with_net("(plan (go x))"))
    assert item == ast.PlanRequest((C("go", "x"),))


# ============================================================================= (deadline GOAL SECONDS)

def test_a_deadline_holds_its_goal_and_its_seconds():
    deadline = only_form("(deadline (delivered mail office-b) 150)\n", "g.ap")
    assert deadline == ast.Deadline(C("delivered", "mail", "office-b"), 150)
    assert (deadline.loc.line, deadline.loc.column) == (1, 1)
    assert (deadline.goal_loc.line, deadline.goal_loc.column) == (1, 11)


def test_a_deadline_goal_may_be_negative_like_a_goal():
    assert only_form("(deadline (not (door-open d1)) 9.5)\n").goal == C("not", C("door-open", "d1"))


# ============================================================================= errors, with carets

def test_a_negative_plan_deadline_is_an_error_at_the_value():
    problem = only_problem("(plan (a) :deadline -1)\n")
    assert problem.message == ":deadline must be greater than 0, found -1"
    assert at(problem) == (1, 21)
    assert problem.render().splitlines()[2] == "    " + " " * 20 + "^"


def test_a_zero_plan_deadline_is_an_error():
    assert only_problem("(plan (a) :deadline 0)\n").message == ":deadline must be greater than 0, found 0"


def test_a_misspelt_plan_option_suggests_the_nearest_option():
    problem = only_problem("(plan (a) :deadlin 5)\n")
    assert problem.message == "unknown option :deadlin"
    assert problem.hint == "did you mean ':deadline'?"
    assert at(problem) == (1, 11)


def test_an_unknown_plan_option_lists_the_options():
    problem = only_problem("(plan (a) :colour 5)\n")
    assert problem.hint == "expected one of: :deadline, :max-failures"


def test_max_failures_must_be_a_whole_number_of_at_least_one():
    problem = only_problem("(plan (a) :max-failures 0)\n")
    assert problem.message == ":max-failures must be at least 1, found 0"
    assert at(problem) == (1, 25)
    assert only_problem("(plan (a) :max-failures 1.5)\n").message == \
        ":max-failures must be a whole number, found the number 1.5"


def test_a_plan_option_given_twice_is_an_error_at_the_second():
    problem = only_problem("(plan (a) :deadline 1 :deadline 2)\n")
    assert problem.message == "option :deadline given twice"
    assert at(problem) == (1, 23)


def test_a_plan_with_options_but_no_goals_is_an_error_that_says_goals_come_first():
    problem = only_problem("(plan :deadline 3 (a))\n")
    assert problem.message == "plan needs at least one goal"
    assert at(problem) == (1, 7)
    assert "goals first" in problem.hint


def test_a_bad_option_of_a_plan_inside_a_task_net_is_located_there():
    problem = only_problem(rap_with_net("(p1 (plan (a) :deadline soon))"))
    assert problem.message == ":deadline must be a number, found 'soon'"
    assert at(problem) == (4, 31)


def test_a_deadline_whose_seconds_are_not_a_number_is_an_error_at_the_seconds():
    problem = only_problem("(deadline (a) x)\n")
    assert problem.message == "the seconds of deadline must be a number, found 'x'"
    assert at(problem) == (1, 15)
    assert "^" in problem.render()


def test_a_deadline_of_zero_seconds_or_without_seconds_is_an_error():
    assert only_problem("(deadline (a) 0)\n").message == "the seconds of deadline must be greater than 0, found 0"
    problem = only_problem("(deadline (a))\n")
    assert problem.message == "deadline takes a goal and a number of seconds, found 1 item"
    assert at(problem) == (1, 1)


def test_a_misspelt_deadline_form_suggests_deadline():
    problem = only_problem("(dedline (a) 5)\n")
    assert problem.message == "unknown top-level form 'dedline'"
    assert problem.hint == "did you mean 'deadline'?"


# ============================================================================= printing back

def test_plan_requests_and_deadlines_print_as_written_and_read_back_the_same():
    text = ("(plan (a) (b c) :deadline 10 :max-failures 2)\n\n"
            "(deadline (delivered mail office-b) 150)\n\n"
            "(deadline (a) 2.5)\n")
    source = parse_text(text, "p.rap")
    assert format_file(source) == text
    assert parse_text(format_file(source), "p.rap") == source


def test_a_rap_with_bare_and_labelled_plans_prints_back_as_the_same_rap():
    rap = only_form(rap_with_net("(sequence (t1 (go ?x)) (plan (at robot ?x) :deadline 30))\n"
                                 "      (p1 (plan (c) :max-failures 1) (for t1))"))
    text = format_node(rap)
    assert "(plan (at robot ?x) :deadline 30)" in text and "(p1 (plan (c) :max-failures 1) (for t1))" in text
    assert only_form(text) == rap


# ============================================================================= the sequencer's load-time checks

def test_plans_in_a_task_net_are_not_unknown_tasks_to_the_sequencer_checks(tmp_path: Path):
    (tmp_path / "m.rap").write_text(
        rap_with_net("(sequence (t1 (beep 1)) (plan (at robot ?x)))\n"
                       "      (p1 (plan (done) :deadline 5) (for t1))\n"
                       "      (parallel (plan (a)) (bep 2))")
        + "(post (fetch lab))\n", encoding="utf-8")
    program = load(tmp_path / "m.rap")
    problems = check_program(program, {"beep": {1}}, set())
    assert [(p.message, at(p)) for p in problems] == [("'bep' is neither a RAP nor a skill", (6, 28))]


def test_a_labelled_plan_step_takes_part_in_the_ordering_checks(tmp_path: Path):
    (tmp_path / "m.rap").write_text(
        rap_with_net("(sequence (t1 (beep 1)) (p1 (plan (a)) (for t1)))"), encoding="utf-8")
    [problem] = check_program(load(tmp_path / "m.rap"), {"beep": {1}}, set())
    assert "wait for each other for ever: t1 -> p1 -> t1" in problem.message


def test_check_tree_shows_plan_requests_in_nets_and_deadlines(tmp_path: Path):
    (tmp_path / "t.rap").write_text(
        "(define-virtual-skill (beep ?n) (after 1 (finish :succeed)))\n"
        + rap_with_net("(sequence (beep 1) (plan (at robot ?x) :deadline 30))") + "(deadline (at robot lab) 20)\n",
        encoding="utf-8")
    done = atlas("check", "--tree", "t.rap", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "PlanRequest 5:26" in done.stdout and "deadline: 30" in done.stdout
    assert "Deadline 6:1" in done.stdout and "seconds: 20" in done.stdout
    assert "SourceLocation" not in done.stdout


# ============================================================================= the planning problem and the plan

CORRIDOR = """\
;; A robot walks a corridor a - b - c, 10 s a stretch.
(operator walk
  :purpose (at ?r ?to)
  :agent ?r
  :preconditions ((at ?r ?from) (next ?from ?to))
  :effects ((at ?r ?to) (not (at ?r ?from)))
  :duration 10)
(agents (controlled robot))
(initial (at robot a) (next a b) (next b c))
(goals (at robot c))
"""


def corridor(tmp_path: Path, deadlines: str, name: str = "walk.ap") -> Path:
    path = tmp_path / name
    path.write_text(CORRIDOR + deadlines, encoding="utf-8")
    return path


def test_the_problem_collects_deadlines_and_the_smallest_that_applies_wins(tmp_path: Path):
    problem = problem_from_program(load(corridor(tmp_path, "(deadline (at robot c) 40)\n(deadline (at ?who c) 30)\n"
                                                           "(deadline (at robot b) 5)\n")))
    assert problem.deadlines == ((C("at", "robot", "c"), 40), (C("at", Var("who"), "c"), 30),
                                 (C("at", "robot", "b"), 5))
    assert [(loc.line, loc.column) for loc in problem.deadline_locations] == [(11, 11), (12, 11), (13, 11)]
    assert problem.deadline_for() == 30  # (at robot b) is not asked for
    assert problem.deadline_for([C("at", "robot", "b")]) == 5
    assert problem.deadline_for([C("at", "robot", "z")]) is None


def test_a_problem_without_deadlines_has_none():
    assert problem_from_program(_program("(goals (a))\n")).deadline_for() is None


def _program(text: str):
    from atlas_rap.lang.loader import Program

    source = parse_text(text, "p.ap")
    return Program(root="p.ap", files=(source,), forms=source.forms, lines={})


def test_asking_keeps_the_deadlines_and_adds_the_requests_deadline_for_every_goal(tmp_path: Path):
    base = problem_from_program(load(corridor(tmp_path, "(deadline (at robot c) 40)\n")))
    asked = base.asked((C("at", "robot", "c"),), base.initial)
    assert asked.deadlines == base.deadlines and asked.deadline is None and asked.deadline_for() == 40
    assert base.asked((C("at", "robot", "c"),), base.initial, deadline=25).deadline_for() == 25
    assert base.asked((C("at", "robot", "b"),), base.initial, deadline=50).deadline_for() == 50
    assert base.asked((C("at", "robot", "c"),), base.initial, deadline=50).deadline_for() == 40


def test_a_deadline_for_a_goal_not_asked_for_is_a_warning_with_a_caret(tmp_path: Path):
    problem = problem_from_program(load(corridor(tmp_path, "(deadline (at robot d) 40)\n")), name="walk.ap")
    [warning] = check_problem(problem)
    assert warning.severity == "warning"
    assert warning.message == "deadline for a goal the problem does not ask for: (at robot d)"
    assert at(warning) == (11, 11)
    assert warning.render().splitlines()[1:3] == ["    (deadline (at robot d) 40)", "              ^"]
    assert raise_problems(problem) == [warning]  # a warning does not stop the planner


def test_a_plan_meets_its_deadline_when_it_has_none_or_its_makespan_is_within_it():
    assert Plan("solved", makespan=20).meets_deadline
    assert Plan("solved", makespan=20, deadline=20).meets_deadline
    assert not Plan("solved", makespan=20, deadline=15).meets_deadline


def test_the_json_of_a_plan_has_deadline_fields_only_when_it_has_a_deadline():
    assert "deadline" not in Plan("solved", makespan=20).to_dict()
    assert "meets_deadline" not in Plan("solved", makespan=20).to_dict()
    data = Plan("solved", makespan=20, deadline=15).to_dict()
    assert (data["deadline"], data["meets_deadline"]) == (15, False)


# ============================================================================= atlas plan

def test_atlas_plan_exits_1_and_says_so_when_the_plan_breaks_its_deadline(tmp_path: Path):
    corridor(tmp_path, "(deadline (at robot c) 15)\n")
    done = atlas("plan", "walk.ap", "--plan-file", "walk.plan", cwd=tmp_path)
    assert done.returncode == 1, (done.stdout, done.stderr)
    assert_no_traceback(done)
    assert done.stdout.splitlines()[0].startswith("solved: 2 steps, makespan 20 breaks the deadline of 15 s,")
    lines = done.stderr.splitlines()
    assert lines[0] == ("walk.ap:11:11: error: the plan's makespan 20 breaks the deadline of 15 s "
                        "for (at robot c): it is not a usable plan")
    assert lines[1:3] == ["    (deadline (at robot c) 15)", "              ^"]
    assert not (tmp_path / "walk.plan").exists()


def test_the_json_of_a_plan_that_breaks_its_deadline_is_the_plan_with_meets_deadline_false(tmp_path: Path):
    corridor(tmp_path, "(deadline (at robot c) 15)\n")
    done = atlas("plan", "walk.ap", "--json", cwd=tmp_path)
    assert done.returncode == 1
    data = json.loads(done.stdout)
    assert data["status"] == "solved" and len(data["steps"]) == 2
    assert (data["makespan"], data["deadline"], data["meets_deadline"]) == (20, 15, False)
    [problem] = data["problems"]
    assert (problem["file"], problem["line"], problem["column"]) == ("walk.ap", 11, 11)
    assert "breaks the deadline of 15 s" in problem["message"]
    assert "error: the plan's makespan 20 breaks the deadline" in done.stderr


def test_a_loose_deadline_is_met_and_atlas_plan_exits_0(tmp_path: Path):
    corridor(tmp_path, "(deadline (at robot c) 25)\n")
    done = atlas("plan", "walk.ap", "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    assert (data["makespan"], data["deadline"], data["meets_deadline"]) == (20, 25, True)
    assert data["problems"] == []
    text = atlas("plan", "walk.ap", cwd=tmp_path)
    assert text.returncode == 0
    assert "makespan 20 within the deadline of 25 s" in text.stdout.splitlines()[0]


def test_without_a_deadline_the_json_has_no_deadline_fields(tmp_path: Path):
    corridor(tmp_path, "")
    data = json.loads(atlas("plan", "walk.ap", "--json", cwd=tmp_path).stdout)
    assert "deadline" not in data and "meets_deadline" not in data


def test_atlas_plan_warns_of_a_deadline_for_a_goal_it_does_not_ask_for_and_still_plans(tmp_path: Path):
    corridor(tmp_path, "(deadline (at robot d) 1)\n")
    done = atlas("plan", "walk.ap", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("solved: 2 steps, makespan 20,")
    assert "walk.ap:11:11: warning: deadline for a goal the problem does not ask for: (at robot d)" in done.stderr
    checked = atlas("check", "walk.ap", cwd=tmp_path)
    assert checked.returncode == 0, checked.stderr
    assert "warning: deadline for a goal the problem does not ask for" in checked.stderr

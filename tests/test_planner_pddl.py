"""PDDL reading (atlas_rap.planner.pddl) and plan files and validation (plan_file)."""

from __future__ import annotations

from pathlib import Path

import pytest
from pddl_problems import (
    SHARED_PDDL,
    blocks_problem,
    gripper_problem,
    tireworld_problem,
    write_problem,
)

from atlas_rap.errors import AtlasError, SourceError
from atlas_rap.lang import ast
from atlas_rap.logic import Compound, Var
from atlas_rap.planner.pddl import load_pddl, parse_pddl
from atlas_rap.planner.plan_file import (
    read_plan_file,
    validate_plan,
    validate_plan_file,
    write_plan_file,
)


def C(functor: str, *args) -> Compound:
    return Compound(functor, args)


def V(name: str) -> Var:
    return Var(name)


def plan(*lines: str) -> list[Compound]:
    """Actions from '(name arg ...)' strings."""
    return [C(*line.strip("()").split()) for line in lines]


# ----------------------------------------------------------------------------- reading

def test_gripper_operators_have_declared_parameters_and_type_preconditions_first(tmp_path: Path) -> None:
    problem = load_pddl(*gripper_problem(tmp_path, balls=3))
    assert [op.name for op in problem.operators] == ["move", "pick", "drop"]
    move = problem.operator("move")
    assert move.parameters == (V("from"), V("to"))
    assert move.preconditions == (C("type:room", V("from")), C("type:room", V("to")),
                                  C("at-robby", V("from")))
    assert move.effects == (ast.Effect(C("at-robby", V("to")), True),
                            ast.Effect(C("at-robby", V("from")), False))
    pick = problem.operator("pick")
    assert pick.parameters == (V("obj"), V("room"), V("gripper"))
    assert pick.preconditions[:3] == (C("type:ball", V("obj")), C("type:room", V("room")),
                                      C("type:gripper", V("gripper")))
    assert not any(op.uncontrolled for op in problem.operators)
    assert move.loc.file.endswith("domain.pddl") and move.loc.line == 8


GLUED_DOMAIN = """(define (domain zeno-glued)
  (:requirements :strips)
  (:predicates (aircraft?a) (at?x ?c) (city ?c))
  (:action fly :parameters (?a ?c1 ?c2)
    :precondition (and (aircraft?a) (at?a ?c1) (city?c2))
    :effect (and (at ?a ?c2) (not (at?a?c1)))))"""

GLUED_PROBLEM = """(define (problem hop) (:domain zeno-glued)
  (:objects plane-1 rome paris)
  (:init (aircraft plane-1) (at plane-1 rome) (city rome) (city paris))
  (:goal (at plane-1 paris)))"""


def test_a_name_glued_to_a_variable_is_read_as_pddl_lexers_split_it() -> None:
    # zenotravel as the IPC distributes it writes (aircraft?a); Fast Downward and pyperplan read (aircraft ?a)
    problem = parse_pddl(GLUED_DOMAIN, GLUED_PROBLEM)
    fly = problem.operator("fly")
    assert fly.preconditions == (C("aircraft", V("a")), C("at", V("a"), V("c1")), C("city", V("c2")))
    assert fly.effects[1] == ast.Effect(C("at", V("a"), V("c1")), False)
    from atlas_rap.planner.solve import solve

    assert solve(problem).sequence == [C("fly", "plane-1", "rome", "paris")]


def test_a_glued_variable_keeps_its_column_for_errors() -> None:
    domain = GLUED_DOMAIN.replace("(at?a ?c1) (city?c2)", "(at?a ?c1 ?c2)")
    with pytest.raises(SourceError) as caught:
        parse_pddl(domain, GLUED_PROBLEM)
    problem = caught.value.problems[0]
    line = domain.splitlines()[4]
    assert "'at' takes 2 arguments, not 3" in problem.message
    assert (problem.location.line, problem.location.column) == (5, line.index("(at?a") + 1)


def test_a_file_with_nothing_glued_keeps_its_forms_and_a_glued_name_is_always_found() -> None:
    from atlas_rap.lang.reader import read_text
    from atlas_rap.planner import pddl

    plain = GLUED_PROBLEM
    forms = read_text(plain)
    assert pddl._GLUED.search(plain) is None
    assert pddl._Source("p.pddl", forms, plain).forms == list(forms)  # the very lists: no walk
    for glued in ("(aircraft?a)", "(at?x ?c)", "(at?a?c1)", "(n-2?x)", "(x?)"):
        (form,) = read_text(glued)
        assert pddl._GLUED.search(glued), glued
        assert pddl._unglued(form) is not form, glued


def test_gripper_initial_state_goals_and_objects(tmp_path: Path) -> None:
    domain, prob = gripper_problem(tmp_path, balls=2, rooms=3)
    problem = load_pddl(domain, prob)
    assert problem.name == "gripper-2-3"
    assert problem.objects == ("room1", "room2", "room3", "ball1", "ball2", "left", "right")
    initial = set(problem.initial)
    assert {C("type:room", "room3"), C("type:ball", "ball1"), C("type:gripper", "left"),
            C("at-robby", "room1"), C("at", "ball2", "room1"), C("free", "right")} <= initial
    assert not any(f.functor == "type:object" for f in initial)
    assert problem.goals == (C("at", "ball1", "room3"), C("at", "ball2", "room3"))
    assert [(loc.file, loc.line) for loc in problem.goal_locations] == [(str(prob), 5)] * 2
    assert set(problem.source_lines) == {str(domain), str(prob)}
    assert problem.line(problem.goal_locations[0]).startswith("  (:goal")


def test_blocks_untyped_has_no_type_facts_and_the_generator_is_seeded(tmp_path: Path) -> None:
    problem = load_pddl(*blocks_problem(tmp_path, 6, seed=3))
    unstack = problem.operator("unstack")
    assert unstack.parameters == (V("x"), V("y"))
    assert unstack.preconditions == (C("on", V("x"), V("y")), C("clear", V("x")), C("handempty"))
    assert not any(f.functor.startswith("type:") for f in problem.initial)
    assert C("handempty") in problem.initial
    assert problem.objects == tuple(f"b{i}" for i in range(1, 7))
    assert problem.goals and all(g.functor == "on" for g in problem.goals)
    (tmp_path / "again").mkdir()
    again = load_pddl(*blocks_problem(tmp_path / "again", 6, seed=3))
    assert again.initial == problem.initial and again.goals == problem.goals


EITHER_DOMAIN = """\
(define (domain Transport)
  (:requirements :strips :typing :negative-preconditions :equality)
  (:types truck plane - vehicle place)
  (:constants depot - place)
  (:predicates (at ?v - vehicle ?p - place) (broken ?v))
  (:action Go
    :parameters (?v - (either plane truck) ?from ?to - place)
    :precondition (and (AT ?v ?from) (not (= ?from ?to)) (not (broken ?v)) (= ?to depot))
    :effect (and (at ?v ?to) (not (at ?v ?from)))))
"""
EITHER_PROBLEM = """\
(define (problem t1) (:domain transport)
  (:objects t1 - truck p1 - plane home - place)
  (:init (at t1 home) (at p1 home))
  (:goal (and (at t1 depot) (not (broken p1)))))
"""


def test_types_hierarchy_either_constants_negation_and_equality() -> None:
    problem = parse_pddl(EITHER_DOMAIN, EITHER_PROBLEM)
    go = problem.operator("go")
    assert go.preconditions == (
        C("type:either:plane:truck", V("v")), C("type:place", V("from")), C("type:place", V("to")),
        C("at", V("v"), V("from")), C("not", C("=", V("from"), V("to"))),
        C("not", C("broken", V("v"))), C("=", V("to"), "depot"))
    initial = set(problem.initial)
    assert {C("type:truck", "t1"), C("type:vehicle", "t1"), C("type:either:plane:truck", "t1"),
            C("type:either:plane:truck", "p1"), C("type:place", "depot")} <= initial
    assert C("type:either:plane:truck", "home") not in initial
    assert set(problem.objects) == {"t1", "p1", "home", "depot"}
    assert problem.goals == (C("at", "t1", "depot"), C("not", C("broken", "p1")))
    ok = validate_plan(problem, plan("(go t1 home depot)"))
    assert ok.ok, ok.message
    assert not validate_plan(problem, plan("(go t1 home home)")).ok
    assert "not of type either:plane:truck" in validate_plan(problem, plan("(go home home depot)")).message


# ------------------------------------------------------------------------ validation

GRIPPER_PLAN = ("(pick ball1 room1 left)", "(pick ball2 room1 right)", "(move room1 room2)",
                "(drop ball1 room2 left)", "(drop ball2 room2 right)")


def test_validate_accepts_a_correct_gripper_plan(tmp_path: Path) -> None:
    problem = load_pddl(*gripper_problem(tmp_path, balls=2))
    check = validate_plan(problem, plan(*GRIPPER_PLAN))
    assert check.ok and check.failed_step is None, check.message
    assert "5 steps" in check.message


def test_validate_names_the_step_the_action_and_the_failed_precondition(tmp_path: Path) -> None:
    problem = load_pddl(*gripper_problem(tmp_path, balls=2))
    without_move = [a for a in GRIPPER_PLAN if not a.startswith("(move")]
    check = validate_plan(problem, plan(*without_move))
    assert not check.ok and check.failed_step == 3
    assert "step 3" in check.message and "(drop ball1 room2 left)" in check.message
    assert "(at-robby room2)" in check.message

    wrong_type = validate_plan(problem, plan("(pick room1 room1 left)"))
    assert wrong_type.failed_step == 1 and "'room1' is not of type ball" in wrong_type.message

    unmet = validate_plan(problem, plan(*GRIPPER_PLAN[:3]))
    assert not unmet.ok and unmet.failed_step is None
    assert "goal (at ball1 room2) is not met after 3 steps" in unmet.message

    assert "no action named 'fly'" in validate_plan(problem, plan("(fly room1 room2)")).message
    assert "takes 2 arguments, not 1" in validate_plan(problem, plan("(move room1)")).message


def test_effects_delete_before_they_add() -> None:
    domain = """(define (domain d) (:predicates (p ?x))
      (:action touch :parameters (?x) :precondition (p ?x) :effect (and (p ?x) (not (p ?x)))))"""
    problem = parse_pddl(domain, "(define (problem q) (:domain d) (:objects o) (:init (p o)) (:goal (p o)))")
    assert validate_plan(problem, plan("(touch o)", "(touch o)")).ok


def test_plan_file_round_trip_and_validate_plan_file(tmp_path: Path) -> None:
    domain, prob = gripper_problem(tmp_path, balls=2)
    path = tmp_path / "plan.txt"
    write_plan_file(path, plan(*GRIPPER_PLAN))
    lines = path.read_text().splitlines()
    assert lines[0] == "(pick ball1 room1 left)" and lines[-1] == "; cost = 5 (unit cost)"
    assert read_plan_file(path) == plan(*GRIPPER_PLAN)
    assert validate_plan_file(domain, prob, path).ok

    path.write_text("; a comment\n\n(PICK Ball1 room1 left)  ; trailing\n(move room1 room2\n")
    with pytest.raises(SourceError) as caught:
        read_plan_file(path)
    report = str(caught.value)
    assert f"{path}:4:1" in report and "^" in report and "(move room1 room2" in report
    path.write_text("(PICK Ball1 room1 left)  ; trailing\n")
    assert read_plan_file(path) == [C("pick", "ball1", "room1", "left")]
    with pytest.raises(AtlasError, match="no such file"):
        read_plan_file(tmp_path / "missing.plan")


def test_fond_oneof_gives_a_controlled_and_an_uncontrolled_operator(tmp_path: Path) -> None:
    problem = load_pddl(*tireworld_problem(tmp_path))
    assert [op.name for op in problem.operators] == ["move-car", "move-car~2", "changetire"]
    move, flat = problem.operators[:2]
    assert not move.uncontrolled and move.outcome_of is None
    assert move.effects == (ast.Effect(C("vehicle-at", V("to"))), ast.Effect(C("vehicle-at", V("from")), False))
    assert flat.uncontrolled and flat.outcome_of == "move-car" and flat.probability == 0.5
    assert flat.parameters == move.parameters and flat.preconditions == move.preconditions
    assert flat.effects == move.effects + (ast.Effect(C("not-flattire"), False),)


def test_adversarial_validation_rejects_the_route_without_spares(tmp_path: Path) -> None:
    problem = load_pddl(*tireworld_problem(tmp_path))
    direct = plan("(move-car a d)", "(move-car d c)")
    via_spare = plan("(move-car a b)", "(changetire b)", "(move-car b c)")
    assert validate_plan(problem, direct).ok
    worst = validate_plan(problem, direct, adversarial=True)
    assert not worst.ok and worst.failed_step == 2 and "(not-flattire)" in worst.message
    safe = validate_plan(problem, via_spare, adversarial=True)
    assert safe.ok, safe.message
    nature = validate_plan(problem, plan("(move-car~2 a d)"))
    assert not nature.ok and "uncontrolled" in nature.message


# ------------------------------------------------------------------------------ errors

DOMAIN = """\
(define (domain d)
  (:requirements :strips :typing{req})
  (:types thing)
  (:predicates (p ?x - thing) (q ?x) (r ?x ?y))
  {section}
  (:action a
    :parameters (?x - thing)
    :precondition {pre}
    :effect {eff}))
"""
PROBLEM = """\
(define (problem pr) (:domain {domain})
  (:objects o - thing)
  (:init (p o) {init})
  (:goal {goal}){section})
"""
DEFAULTS = dict(req="", section="", pre="(p ?x)", eff="(q ?x)", init="", goal="(q o)",
                domain="d", psection="")


def broken(tmp_path: Path, **parts: str) -> tuple[SourceError, str, str]:
    """Load the template with ``parts`` replaced; the error, its report and the text of the file at fault."""
    values = {**DEFAULTS, **parts}
    domain_text = DOMAIN.format(**values)
    problem_text = PROBLEM.format(domain=values["domain"], init=values["init"], goal=values["goal"],
                                  section=values["psection"])
    domain, prob = write_problem(tmp_path, domain_text, problem_text)
    with pytest.raises(SourceError) as caught:
        load_pddl(domain, prob)
    error = caught.value
    text = domain_text if error.location.file == str(domain) else problem_text
    return error, str(error), text


def position(text: str, marker: str) -> tuple[int, int]:
    """(line, column) of the first occurrence of ``marker``."""
    before = text[: text.index(marker)]
    return before.count("\n") + 1, len(before) - (before.rfind("\n") + 1) + 1


UNSUPPORTED = [  # ADL (or, imply, exists, forall, when) is compiled away: tests/test_planner_adl.py
    ("numeric fluents are not supported: the only numeric effect is the action's cost",
     dict(section="(:functions (total-cost) - number (fuel ?x) - number)", eff="(and (q ?x) (increase (fuel ?x) 1))"),
     "(increase"),
    ("numeric fluents ('decrease')", dict(eff="(and (q ?x) (decrease (total-cost) 1))"), "(decrease"),
    ("(total-cost) is not declared", dict(eff="(and (q ?x) (increase (total-cost) 1))"), "(total-cost)"),
    ("object fluents", dict(section="(:functions (holder ?x) - widget)"), "widget"),
    ("unknown function 'fuel'", dict(init="(= (fuel o) 3)"), "(fuel"),
    ("numeric fluents ('>')", dict(pre="(> (fuel ?x) 1)"), "(>"),
    ("numeric fluents", dict(pre="(= (fuel ?x) 1)"), "(fuel"),
    ("durative actions (':durative-action')",
     dict(section="(:durative-action b :parameters () :duration (= ?duration 1) :condition () :effect ())"),
     "(:durative-action"),
    ("derived predicates (':derived')", dict(section="(:derived (q ?x) (p ?x))"), "(:derived"),
    ("constraints (':constraints')", dict(section="(:constraints (always (q o)))"), "(:constraints"),
    ("constraints (':constraints')", dict(psection="\n  (:constraints (always (q o)))"), "(:constraints"),
    ("plan metrics other than (:metric minimize (total-cost))", dict(psection=" (:metric minimize (total-time))"),
     "(:metric"),
    ("preferences ('preference')", dict(pre="(and (p ?x) (preference pref1 (q ?x)))"), "(preference"),
    ("timed initial literals", dict(init="(at 10 (q o))"), "(at 10"),
    ("requirement :fluents", dict(req=" :fluents"), ":fluents"),
    ("requirement :durative-actions", dict(req=" :durative-actions"), ":durative-actions"),
    ("requirement :numeric-fluents", dict(req=" :numeric-fluents"), ":numeric-fluents"),
    ("only one (oneof ...) per action", dict(eff="(oneof (q ?x) (oneof (p ?x) (q ?x)))"), "(oneof (p"),
]


@pytest.mark.parametrize("feature, parts, marker", UNSUPPORTED, ids=[f"{i}-{u[2]}" for i, u in enumerate(UNSUPPORTED)])
def test_unsupported_features_are_located_errors(tmp_path: Path, feature: str, parts: dict, marker: str) -> None:
    error, report, text = broken(tmp_path, **parts)
    line, column = position(text, marker)
    assert feature in report
    assert f"{error.location.file}:{line}:{column}: error:" in report
    assert report.splitlines()[2].strip() == "^"
    assert error.problem.hint


ERRORS = [
    ("unknown predicate 'pp'", dict(pre="(and (pp ?x))"), "(pp", "did you mean 'p'?"),
    ("'r' takes 2 arguments, not 1", dict(eff="(r ?x)"), "(r ?x)", "'r' is declared at"),
    ("'p' takes 1 argument, not 2", dict(init="(p o o)"), "(p o o)", "declared at"),
    ("'q' takes 1 argument, not 0", dict(goal="(and (q))"), "(q)", "declared at"),
    ("unknown type 'thnig'", dict(section="(:constants k - thnig)"), "thnig", "did you mean 'thing'?"),
    ("variable ?z is not a parameter of the action", dict(eff="(and (q ?x) (r ?x ?z))"), "?z", ":parameters"),
    ("the problem is for domain 'e', not 'd'", dict(domain="e"), "e)\n", "(:domain d)"),
    ("unknown object 'o2'", dict(init="(q o2)"), "o2", ":objects"),
    ("unknown constant 'k'", dict(pre="(p k)"), "k)", ":constants"),
    ("variable ?z in a ground formula", dict(goal="(q ?z)"), "?z", "goals"),
]


@pytest.mark.parametrize("message, parts, marker, hint", ERRORS, ids=[e[0][:30] for e in ERRORS])
def test_errors_in_domain_and_problem_are_located(tmp_path: Path, message: str, parts: dict,
                                                  marker: str, hint: str) -> None:
    error, report, text = broken(tmp_path, **parts)
    line, column = position(text, marker)
    assert message in report
    assert f"{error.location.file}:{line}:{column}: error:" in report
    assert "^" in report and hint in error.problem.hint


def test_object_of_undeclared_type_is_located_in_the_problem(tmp_path: Path) -> None:
    text = "(define (problem x) (:domain d)\n (:objects o - thing w - widget)\n (:init) (:goal (q o)))"
    domain, prob = write_problem(tmp_path, DOMAIN.format(**DEFAULTS), text)
    with pytest.raises(SourceError) as caught:
        load_pddl(domain, prob)
    line, column = position(text, "widget")
    assert f"{prob}:{line}:{column}: error: unknown type 'widget'" in str(caught.value)


def test_missing_file_is_a_clear_error(tmp_path: Path) -> None:
    domain, _ = gripper_problem(tmp_path, 1)
    with pytest.raises(AtlasError) as caught:
        load_pddl(domain, tmp_path / "nope.pddl")
    assert f"{tmp_path / 'nope.pddl'}:1:1: error: no such file" in str(caught.value)


# ------------------------------------------------------------------ public benchmarks

BENCHMARKS = ["gripper", "blocks", "logistics00", "rovers", "depot",
              "fond-triangle-tireworld", "fond-blocksworld"]


def first_problem(name: str) -> tuple[Path, Path]:
    if not SHARED_PDDL.is_dir():
        pytest.skip(f"the public PDDL benchmarks are not here ({SHARED_PDDL} is absent)")
    folder = SHARED_PDDL / name
    problems = sorted((p for p in folder.glob("*.pddl") if p.name != "domain.pddl"),
                      key=lambda p: (len(p.name), p.name))
    return folder / "domain.pddl", problems[0]


@pytest.mark.parametrize("name", BENCHMARKS)
def test_benchmark_domains_and_first_problems_load(name: str) -> None:
    problem = load_pddl(*first_problem(name))
    assert problem.operators and problem.initial and problem.goals and problem.objects
    for op in problem.operators:
        assert len(set(op.parameters)) == len(op.parameters)


def test_triangle_tireworld_has_the_flat_tire_outcome() -> None:
    problem = load_pddl(*first_problem("fond-triangle-tireworld"))
    move = problem.operator("move-car")
    flat = problem.operator("move-car~2")
    assert not move.uncontrolled
    assert flat.uncontrolled and flat.outcome_of == "move-car"
    assert ast.Effect(C("not-flattire"), False) in flat.effects
    assert ast.Effect(C("not-flattire"), False) not in move.effects


def test_triangle_tireworld_p1_only_the_route_by_spares_is_safe() -> None:
    problem = load_pddl(*first_problem("fond-triangle-tireworld"))
    direct = plan("(move-car l-1-1 l-1-2)", "(move-car l-1-2 l-1-3)")
    by_spares = plan("(move-car l-1-1 l-2-1)", "(changetire l-2-1)", "(move-car l-2-1 l-3-1)",
                     "(changetire l-3-1)", "(move-car l-3-1 l-2-2)", "(changetire l-2-2)",
                     "(move-car l-2-2 l-1-3)")
    assert validate_plan(problem, direct).ok
    assert validate_plan(problem, direct, adversarial=True).failed_step == 2
    check = validate_plan(problem, by_spares, adversarial=True)
    assert check.ok, check.message


def fond_blocksworld(number: int) -> tuple[Path, Path]:
    if not SHARED_PDDL.is_dir():
        pytest.skip(f"the public PDDL benchmarks are not here ({SHARED_PDDL} is absent)")
    folder = SHARED_PDDL / "fond-blocksworld"
    return folder / "domain.pddl", folder / f"p{number}.pddl"


def test_a_fond_outcome_in_which_the_action_does_nothing_is_never_the_nominal_one() -> None:
    problem = load_pddl(*fond_blocksworld(3))
    # (oneof (and) (and (holding ?b) ...)): picking up may fail; what a plan intends is the second outcome
    pick = problem.operator("pick-up-from-table")
    failed = problem.operator("pick-up-from-table~1")
    assert not pick.uncontrolled and ast.Effect(C("holding", V("b")), True) in pick.effects
    assert failed.uncontrolled and failed.outcome_of == "pick-up-from-table" and not failed.effects


def test_fond_blocksworld_plans_name_the_outcomes_that_may_defeat_them() -> None:
    problem = load_pddl(*fond_blocksworld(3))
    from atlas_rap.planner.solve import solve

    result = solve(problem, timeout=30)
    # every stacking may drop the block on the table: no sequential plan is safe, and the plan says why
    assert result.status == "solved" and 0 < result.risk < 1
    dropped = [t for t in result.threats if t.operator == "put-on-block~2"]
    assert dropped and all(t.fact.startswith("(on ") for t in dropped)
    assert validate_plan(problem, result.sequence).ok

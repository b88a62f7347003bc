"""PDDL action costs (:action-costs): read, grounded, reported with the plan and in its file,
checked by the validator; the IPC's cost domains solve end to end."""

from __future__ import annotations

from pathlib import Path

import pytest
from pddl_problems import SHARED_PDDL, write_problem

from atlas_rap.planner.pddl import load_pddl
from atlas_rap.planner.plan_file import read_plan_file, validate_plan, validate_plan_file, write_plan_file
from atlas_rap.planner.solve import solve
from cli_process import atlas

ROADS = """\
(define (domain roads)
  (:requirements :typing :action-costs)
  (:types place)
  (:predicates (at ?p - place) (road ?a ?b - place))
  (:functions (total-cost) - number (length ?a ?b - place) - number)
  (:action drive
    :parameters (?a ?b - place)
    :precondition (and (at ?a) (road ?a ?b))
    :effect (and (not (at ?a)) (at ?b) (increase (total-cost) (length ?a ?b))))
  (:action honk
    :parameters (?a - place)
    :precondition (at ?a)
    :effect (and (at ?a) (increase (total-cost) 0.5))))
"""


def roads(lengths: str, metric: bool = True) -> str:
    return f"""\
(define (problem trip) (:domain roads)
  (:objects a b c - place)
  (:init (at a) (road a b) (road b c) (road a c) (= (total-cost) 0) {lengths})
  (:goal (at c)){' (:metric minimize (total-cost))' if metric else ''})
"""


def test_an_actions_cost_is_its_number_or_its_function_of_the_parameters(tmp_path: Path) -> None:
    problem = load_pddl(*write_problem(tmp_path, ROADS, roads("(= (length a b) 2) (= (length a c) 10)")))
    drive, honk = problem.operators
    assert str(drive.cost) == "(length ?a ?b)" and honk.cost == 0.5
    assert problem.action_costs
    assert {str(k): v for k, v in problem.cost_values.items()} == {"(length a b)": 2.0, "(length a c)": 10.0}


def test_the_plan_reports_its_cost_the_validator_agrees_and_the_plan_file_says_general_cost(tmp_path: Path) -> None:
    domain, prob = write_problem(tmp_path, ROADS, roads("(= (length a b) 2) (= (length b c) 2) (= (length a c) 10)"))
    problem = load_pddl(domain, prob)
    plan = solve(problem)
    assert plan.status == "solved"
    check = validate_plan(problem, plan.sequence)
    assert check.ok and plan.cost == check.cost and plan.cost in (4.0, 10.0)
    assert plan.to_dict()["cost"] == plan.cost
    assert f"cost {plan.cost:g}" in plan.to_text().splitlines()[0]
    write_plan_file(tmp_path / "plan.txt", plan.sequence, plan.cost)
    assert (tmp_path / "plan.txt").read_text().splitlines()[-1] == f"; cost = {plan.cost:g} (general cost)"
    assert read_plan_file(tmp_path / "plan.txt") == plan.sequence
    assert validate_plan_file(domain, prob, tmp_path / "plan.txt").cost == plan.cost


def test_an_action_whose_cost_is_not_given_cannot_be_applied(tmp_path: Path) -> None:
    # No (length a c): driving straight to c has no cost, so it is not an action; the way is through b.
    domain, prob = write_problem(tmp_path, ROADS, roads("(= (length a b) 2) (= (length b c) 3)"))
    problem = load_pddl(domain, prob)
    plan = solve(problem)
    assert [str(step) for step in plan.sequence] == ["(drive a b)", "(drive b c)"] and plan.cost == 5.0
    straight = validate_plan(problem, read_plan_file(_plan(tmp_path, "(drive a c)")))
    assert not straight.ok and "its cost (length a c) is not given" in straight.message


def test_without_a_metric_plans_are_measured_by_their_length(tmp_path: Path) -> None:
    problem = load_pddl(*write_problem(tmp_path, ROADS, roads("(= (length a b) 2) (= (length b c) 2) "
                                                              "(= (length a c) 10)", metric=False)))
    plan = solve(problem)
    assert plan.cost is None and plan.to_dict()["cost"] == len(plan.sequence)
    assert validate_plan(problem, plan.sequence).cost == len(plan.sequence)


@pytest.mark.parametrize("text, message", [
    ("(= (total-cost) 5)", "the plan's total cost starts at 0"),
    ("(= (length a b) -2)", "a cost must be a number >= 0"),
    ("(= (length a d) 2)", "'d' is not an object"),
    ("(= (length a) 2)", "'length' takes 2 arguments, not 1"),
])
def test_bad_cost_values_in_init_are_located_errors(tmp_path: Path, text: str, message: str) -> None:
    domain, prob = write_problem(tmp_path, ROADS, roads(text))
    done = atlas("plan", "--pddl", str(domain), str(prob), cwd=tmp_path)
    assert done.returncode in (1, 2) and message in done.stderr and "Traceback" not in done.stderr
    line = next(i for i, row in enumerate(roads(text).splitlines(), 1) if text in row)
    assert f"{prob.name}:{line}:" in done.stderr and "^" in done.stderr


COST_DOMAINS = ["elevators-sat08-strips", "transport-sat08-strips", "scanalyzer-08-strips"]


@pytest.mark.parametrize("name", COST_DOMAINS)
def test_the_ipc_cost_domains_solve_with_a_valid_plan_and_its_cost(name: str, tmp_path: Path) -> None:
    folder = SHARED_PDDL / name
    if not folder.is_dir():
        pytest.skip(f"the public PDDL benchmarks are not here ({SHARED_PDDL} is absent)")
    plan_file = tmp_path / "plan.txt"
    done = atlas("plan", "--pddl", str(folder / "domain.pddl"), str(folder / "p01.pddl"), "--plan-file",
                 str(plan_file), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    reported = float(plan_file.read_text().splitlines()[-1].split("=")[1].split("(")[0])
    check = validate_plan_file(folder / "domain.pddl", folder / "p01.pddl", plan_file)
    assert check.ok and check.cost == reported and f"cost {reported:g}," in done.stdout


def _plan(folder: Path, *lines: str) -> Path:
    path = folder / "given.plan"
    path.write_text("\n".join(lines) + "\n")
    return path

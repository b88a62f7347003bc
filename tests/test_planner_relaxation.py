"""hFF's two backends: pure Python for small tasks, numpy for large ones, for both ways of
extracting the relaxed plan (layered, and by h_add's best supporters). They must agree on what
matters to the search (which actions apply, whether the goals are reachable at all, that
helpful actions apply) and lead to valid plans; each picks achievers by its own rule, so h
itself may differ by an action or two, never by the relaxed exploration."""

from __future__ import annotations

import random
from dataclasses import replace
from pathlib import Path

from pddl_problems import blocks_problem, gripper_problem

from atlas_rap.planner.ground import ground
from atlas_rap.planner.pddl import load_pddl
from atlas_rap.planner.plan_file import validate_plan
from atlas_rap.planner.pddl import parse_pddl
from atlas_rap.planner.relaxation import (
    INFINITY,
    AdditiveRelaxedPlanHeuristic,
    VectorAdditiveRelaxedPlanHeuristic,
    PYTHON_SECONDS_PER_INCIDENCE,
    BackendCosts,
    RelaxedPlanHeuristic,
    SwitchingRelaxedPlanHeuristic,
    VectorRelaxedPlanHeuristic,
    relaxed_plan_heuristic,
)
from atlas_rap.planner.search import greedy_best_first


def random_walk_states(task, steps: int, seed: int) -> list[frozenset[int]]:
    """States along a random walk from the start (each one reachable)."""
    rng = random.Random(seed)
    state, states = task.init, [task.init]
    for _ in range(steps):
        moves = [a for a in task.actions if task.applicable(a, state)]
        if not moves:
            break
        state = task.apply(rng.choice(moves), state)
        states.append(state)
    return states


def test_both_backends_see_the_same_applicable_actions_and_reachability(tmp_path: Path) -> None:
    (tmp_path / "g").mkdir(), (tmp_path / "b").mkdir()
    for domain, problem in (gripper_problem(tmp_path / "g", 6), blocks_problem(tmp_path / "b", 7, seed=3)):
        task = ground(load_pddl(domain, problem))
        for python, vector in ((RelaxedPlanHeuristic(task), VectorRelaxedPlanHeuristic(task)),
                               (AdditiveRelaxedPlanHeuristic(task), VectorAdditiveRelaxedPlanHeuristic(task))):
            check_agreement(task, python, vector)


def check_agreement(task, python, vector) -> None:
    for state in random_walk_states(task, 40, seed=1):
        h_py, applicable_py, helpful_py = python.evaluate(state)
        h_np, applicable_np, helpful_np = vector.evaluate(state)
        expected = {i for i, a in enumerate(task.actions) if all(p in state for p in a.pre)}
        assert set(applicable_py) == set(applicable_np) == expected
        assert (h_py == INFINITY) == (h_np == INFINITY)
        assert (h_py == 0) == (h_np == 0) == task.is_goal(state)
        assert helpful_np <= set(applicable_np) and helpful_py <= set(applicable_py)
        if 0 < h_np < INFINITY:
            assert helpful_np and helpful_py, "a state short of the goals has a helpful action"


def test_the_goals_unreachable_even_relaxed_are_infinity_for_both(tmp_path: Path) -> None:
    domain, problem = gripper_problem(tmp_path, 2)
    task = ground(load_pddl(domain, problem))
    empty = frozenset()  # no robot anywhere, no ball anywhere: nothing applies
    for backend in (RelaxedPlanHeuristic, VectorRelaxedPlanHeuristic, AdditiveRelaxedPlanHeuristic,
                    VectorAdditiveRelaxedPlanHeuristic):
        assert backend(task).evaluate(empty)[0] == INFINITY


def test_the_numpy_backend_guides_the_search_to_valid_plans(tmp_path: Path) -> None:
    (tmp_path / "g").mkdir(), (tmp_path / "b").mkdir()
    for domain, problem in (gripper_problem(tmp_path / "g", 8), blocks_problem(tmp_path / "b", 8, seed=5)):
        parsed = load_pddl(domain, problem)
        task = ground(parsed)
        found = greedy_best_first(task, heuristic=VectorRelaxedPlanHeuristic(task))
        assert found.status == "solved"
        assert validate_plan(parsed, [a.term for a in found.plan]).ok


def test_the_backend_whose_estimated_cost_is_lower_is_chosen(tmp_path: Path) -> None:
    domain, problem = gripper_problem(tmp_path, 4)
    task = ground(load_pddl(domain, problem))
    assert type(relaxed_plan_heuristic(task)) is RelaxedPlanHeuristic  # 4 balls: Python's (the real costs)
    cheap = BackendCosts(numpy_seconds_per_layer=1e-9, numpy_seconds_per_layer_incidence=0.0,
                         python_seconds_per_incidence=1e-12)
    assert type(relaxed_plan_heuristic(task, costs=cheap)) is RelaxedPlanHeuristic  # Python is cheaper still


def test_where_numpy_is_cheaper_the_search_changes_to_it_once_the_import_is_repaid(tmp_path: Path) -> None:
    domain, problem = gripper_problem(tmp_path, 4)
    parsed = load_pddl(domain, problem)
    task = ground(parsed)
    free_numpy = BackendCosts(numpy_seconds_per_layer=0.0, numpy_seconds_per_layer_incidence=0.0,
                              numpy_import_seconds=0.0)  # repaid at once
    heuristic = relaxed_plan_heuristic(task, costs=free_numpy)
    assert type(heuristic) is SwitchingRelaxedPlanHeuristic and heuristic.after == 0
    vector = VectorRelaxedPlanHeuristic(task)
    assert heuristic.evaluate(task.init) == vector.evaluate(task.init)
    incidences = sum(len(a.pre) for a in task.actions)
    ten_evaluations = replace(free_numpy, numpy_import_seconds=10 * incidences * PYTHON_SECONDS_PER_INCIDENCE)
    heuristic = relaxed_plan_heuristic(task, costs=ten_evaluations)
    assert heuristic.after == 10
    python = RelaxedPlanHeuristic(task)
    states = random_walk_states(task, 12, seed=2)
    for i, state in enumerate(states):
        expected = (python if i < 10 else vector).evaluate(state)
        assert heuristic.evaluate(state) == expected
    found = greedy_best_first(task, heuristic=relaxed_plan_heuristic(task, costs=ten_evaluations))
    assert found.status == "solved" and validate_plan(parsed, [a.term for a in found.plan]).ok


# The goal has two achievers, both one layer away: the first needs three facts (three actions), the
# second one fact (one action). The layered relaxed plan takes the first to fire; h_add the cheaper.
TWO_WAYS_DOMAIN = """(define (domain two-ways)
  (:requirements :strips)
  (:predicates (q1) (q2) (q3) (p) (goal))
  (:action make-q1 :parameters () :effect (q1))
  (:action make-q2 :parameters () :effect (q2))
  (:action make-q3 :parameters () :effect (q3))
  (:action make-p :parameters () :effect (p))
  (:action by-three :parameters () :precondition (and (q1) (q2) (q3)) :effect (goal))
  (:action by-one :parameters () :precondition (p) :effect (goal)))"""
TWO_WAYS_PROBLEM = "(define (problem two) (:domain two-ways) (:init) (:goal (goal)))"


def test_h_add_takes_the_achiever_whose_preconditions_cost_least() -> None:
    task = ground(parse_pddl(TWO_WAYS_DOMAIN, TWO_WAYS_PROBLEM))
    assert RelaxedPlanHeuristic(task).evaluate(task.init)[0] == 4  # by-three and what it needs
    for backend in (AdditiveRelaxedPlanHeuristic, VectorAdditiveRelaxedPlanHeuristic):
        h, _, helpful = backend(task).evaluate(task.init)
        assert h == 2  # make-p, then by-one
        assert {task.actions[a].name for a in helpful} == {"make-p"}  # the relaxed plan's applicable action


def test_the_additive_hff_changes_to_numpy_too(tmp_path: Path) -> None:
    domain, problem = gripper_problem(tmp_path, 4)
    task = ground(load_pddl(domain, problem))
    free_numpy = BackendCosts(numpy_seconds_per_layer=0.0, numpy_seconds_per_layer_incidence=0.0,
                              numpy_import_seconds=0.0)
    heuristic = relaxed_plan_heuristic(task, costs=free_numpy, additive=True)
    assert type(heuristic) is SwitchingRelaxedPlanHeuristic and heuristic.after == 0
    assert heuristic.evaluate(task.init) == VectorAdditiveRelaxedPlanHeuristic(task).evaluate(task.init)


def test_numpy_backends_give_the_same_answers_with_scipys_kernel_or_its_matrix_product(tmp_path: Path) -> None:
    """Both numpy backends call scipy's compiled CSR kernel directly; a scipy without it falls
    back on ``matrix @ x``, which must give every state the same h, applicable and helpful actions."""
    domain, problem = blocks_problem(tmp_path, 7, seed=3)
    task = ground(load_pddl(domain, problem))
    states = random_walk_states(task, 40, seed=2)
    for backend in (VectorRelaxedPlanHeuristic, VectorAdditiveRelaxedPlanHeuristic):
        kernel, fallback = backend(task), backend(task)
        products = [value for value in vars(fallback).values() if type(value).__name__ == "_Product"]
        assert products and all(p._kernel is not None for p in products)
        for product in products:
            product._kernel = None
        for state in states:
            assert kernel.evaluate(state) == fallback.evaluate(state)

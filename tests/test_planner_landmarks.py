"""Landmarks and the LAMA-style restart: facts every plan makes true, found by
back-chaining in the relaxation, and the search that counts them beside hFF, which the
planner restarts with when its hFF search is stuck."""

from __future__ import annotations

from pathlib import Path

from pddl_problems import gripper_problem, write_problem

import importlib
from atlas_rap.planner.ground import ground
from atlas_rap.planner.landmarks import find_landmarks, landmark_search
from atlas_rap.planner.pddl import load_pddl, parse_pddl
from atlas_rap.planner.plan_file import validate_plan
from atlas_rap.planner.relaxation import RelaxedPlanHeuristic

solve_module = importlib.import_module("atlas_rap.planner.solve")  # the module (the package exports solve())

CORRIDOR_DOMAIN = """(define (domain corridor)
  (:requirements :strips)
  (:constants lab vault)
  (:predicates (at ?p) (link ?a ?b) (key-at ?p) (has-key))
  (:action go :parameters (?a ?b) :precondition (and (at ?a) (link ?a ?b)) :effect (and (at ?b) (not (at ?a))))
  (:action take-key :parameters (?p) :precondition (and (at ?p) (key-at ?p)) :effect (and (has-key) (not (key-at ?p))))
  (:action unlock-vault :parameters () :precondition (and (at lab) (has-key)) :effect (link lab vault)))"""

CORRIDOR_PROBLEM = """(define (problem fetch) (:domain corridor)
  (:objects hall store annex)
  (:init (at hall) (link hall store) (link store hall) (link hall annex) (link annex store) (link store annex)
         (link hall lab) (link lab hall) (key-at store))
  (:goal (at vault)))"""


def names(task, facts) -> set[str]:
    return {str(task.facts[f]) for f in facts}


def test_the_facts_every_plan_passes_through_are_landmarks() -> None:
    task = ground(parse_pddl(CORRIDOR_DOMAIN, CORRIDOR_PROBLEM))
    found = names(task, find_landmarks(task, RelaxedPlanHeuristic(task)))
    # the vault is reached only from the lab once unlocked, which needs the key, which is in the store
    assert {"(at vault)", "(link lab vault)", "(at lab)", "(has-key)", "(at store)", "(key-at store)"} <= found
    assert "(at annex)" not in found  # a way to the store the plan may take, not one it must


def test_the_landmark_search_finds_valid_plans(tmp_path: Path) -> None:
    problem = load_pddl(*gripper_problem(tmp_path, balls=6))
    task = ground(problem)
    found = landmark_search(task)
    assert found.status == "solved"
    assert validate_plan(problem, [a.term for a in found.plan]).ok


def test_a_stuck_search_restarts_with_landmarks_and_says_so(tmp_path: Path) -> None:
    problem = load_pddl(*gripper_problem(tmp_path, balls=8))
    plain = solve_module.solve(problem)
    assert "restarted_after" not in plain.stats
    restarted = solve_module.solve(problem, restart_after=10)  # stuck at once, on a problem that needs more
    assert restarted.status == "solved" and restarted.stats["restarted_after"] == 10
    assert validate_plan(problem, restarted.sequence).ok

"""Landmarks and LAMA's search: the facts (or choices of facts) every plan passes through,
found by back-chaining in the relaxation, their orderings, the landmark count a path has
left, and the search that alternates it with hFF (the planner's first search)."""

from __future__ import annotations

from pathlib import Path

from pddl_problems import gripper_problem

from atlas_rap.planner.ground import ground
from atlas_rap.planner.lama import lama_search
from atlas_rap.planner.landmarks import find_landmarks
from atlas_rap.planner.mutexes import fact_mutexes
from atlas_rap.planner.pddl import load_pddl, parse_pddl
from atlas_rap.planner.plan_file import validate_plan
from atlas_rap.planner.relaxation import RelaxedPlanHeuristic

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


def corridor():
    task = ground(parse_pddl(CORRIDOR_DOMAIN, CORRIDOR_PROBLEM))
    return task, find_landmarks(task, RelaxedPlanHeuristic(task))


def node_names(task, graph) -> dict[frozenset[str], int]:
    return {frozenset(str(task.facts[f]) for f in facts): i for i, facts in enumerate(graph.nodes)}


def fact(task, text: str) -> int:
    return next(i for i, f in enumerate(task.facts) if str(f) == text)


def test_the_facts_every_plan_passes_through_are_landmarks() -> None:
    task, graph = corridor()
    found = {name for names in node_names(task, graph) for name in names}
    # the vault is reached only from the lab once unlocked, which needs the key, which is in the store
    assert {"(at vault)", "(link lab vault)", "(at lab)", "(has-key)", "(at store)", "(key-at store)"} <= found
    assert "(at annex)" not in found  # a way to the store the plan may take, not one it must


def test_a_landmark_is_ordered_after_what_must_hold_when_it_is_first_reached() -> None:
    task, graph = corridor()
    number = {next(iter(names)): i for names, i in node_names(task, graph).items()}

    def before(first: str, then: str) -> bool:
        return bool(graph.parents[number[then]] >> number[first] & 1)

    assert before("(at lab)", "(at vault)") and before("(link lab vault)", "(at vault)")
    assert before("(has-key)", "(link lab vault)") and before("(at store)", "(has-key)")
    assert not before("(at vault)", "(at lab)")


def test_a_choice_every_plan_makes_is_a_disjunctive_landmark(tmp_path: Path) -> None:
    task = ground(load_pddl(*gripper_problem(tmp_path, balls=2)))
    graph = find_landmarks(task, RelaxedPlanHeuristic(task))
    names = node_names(task, graph)
    carried = frozenset({"(carry ball1 left)", "(carry ball1 right)"})
    assert carried in names  # no one gripper is needed, but one of the two is
    assert graph.parents[names[frozenset({"(at ball1 room2)"})]] >> names[carried] & 1


def test_the_landmark_count_keeps_what_the_path_reached_and_what_must_be_true_again() -> None:
    task, graph = corridor()
    reached = graph.initially_reached(task.init)
    state = task.init
    counts = [graph.count(reached, graph.true_in(state))]
    for moved_out, moved_in in [("(at hall)", "(at store)"), ("(key-at store)", "(has-key)"),
                                ("(at store)", "(at hall)"), ("(at hall)", "(at lab)"), (None, "(link lab vault)")]:
        state = (state - {fact(task, moved_out)} if moved_out else state) | {fact(task, moved_in)}
        reached, true = graph.progress(reached, state)
        counts.append(graph.count(reached, true))
    # 8 landmarks, 3 true at the start. In the store: (at store) is reached, but (at hall) must be true
    # again (the lab is entered from the hall, and it is not reached yet); the key; back in the hall,
    # which counts no more, while the store it left is not needed again (the key it was for is reached)
    assert len(graph) == 8 and counts == [5, 5, 4, 3, 2, 1]


def test_a_landmark_reached_before_what_is_ordered_before_it_does_not_count_as_reached() -> None:
    task, graph = corridor()
    start = graph.initially_reached(task.init)
    # (at lab) straight from the hall, without the key: it is reached, being ordered after nothing unreached
    in_lab = (task.init - {fact(task, "(at hall)")}) | {fact(task, "(at lab)")}
    reached, _ = graph.progress(start, in_lab)
    lab = node_names(task, graph)[frozenset({"(at lab)"})]
    assert reached >> lab & 1
    # (has-key) appearing on a path that never passed the store is not reached: the store comes first
    jumped = in_lab | {fact(task, "(has-key)")}
    reached, _ = graph.progress(start, jumped)
    key = node_names(task, graph)[frozenset({"(has-key)"})]
    assert not reached >> key & 1


def test_lama_search_finds_valid_plans_and_always_the_same(tmp_path: Path) -> None:
    problem = load_pddl(*gripper_problem(tmp_path, balls=6))
    found = lama_search(ground(problem))
    assert found.status == "solved"
    assert validate_plan(problem, [a.term for a in found.plan]).ok
    assert [a.term for a in lama_search(ground(problem)).plan] == [a.term for a in found.plan]
    # it carries two balls per trip, as the landmarks (a gripper for each ball) lead it to
    assert len(found.plan) == 6 // 2 * 5 + (6 // 2 - 1)


def test_lama_search_says_when_no_plan_exists() -> None:
    one_way = CORRIDOR_PROBLEM.replace("(link store hall)", "").replace("(link store annex)", "")
    task = ground(parse_pddl(CORRIDOR_DOMAIN, one_way))  # the key is in a room with no way out
    assert task.unreachable_goals == ()  # in the relaxation, the vault can be reached
    assert lama_search(task).status == "unsolvable"


def test_a_search_without_progress_gives_up_as_stuck(tmp_path: Path) -> None:
    task = ground(load_pddl(*gripper_problem(tmp_path, balls=6)))
    assert lama_search(task, stagnation=0).status == "stuck"  # the first evaluation that does not improve
    assert lama_search(task, stagnation=1000).status == "solved"


def test_a_stuck_search_restarts_with_h_add_and_says_so(tmp_path: Path, monkeypatch) -> None:
    import importlib

    solve_module = importlib.import_module("atlas_rap.planner.solve")  # the module (the package exports solve())
    problem = load_pddl(*gripper_problem(tmp_path, balls=8))
    first = solve_module.solve(problem)
    assert "restarted_after" not in first.stats and "reasonable_orderings" not in first.stats
    monkeypatch.setattr(solve_module, "STAGNATION", 0)
    restarted = solve_module.solve(problem)
    assert restarted.status == "solved" and restarted.stats["restarted_after"] >= 2
    # the restart orders the landmarks with the mutexes too (a ball in room 1 before in room 2: they are mutex)
    task = ground(problem)
    assert restarted.stats["reasonable_orderings"] > find_landmarks(task, RelaxedPlanHeuristic(task)).reasonable
    assert restarted.stats["evaluated"] > restarted.stats["restarted_after"]
    assert validate_plan(problem, restarted.sequence).ok


PATIENCE_DOMAIN = """(define (domain patience)
  (:requirements :strips)
  (:predicates (on ?c ?b) (clear ?c) (incell ?c) (home ?c) (cellfree))
  (:action home-from-column :parameters (?c ?b) :precondition (and (clear ?c) (on ?c ?b))
    :effect (and (home ?c) (clear ?b) (not (on ?c ?b)) (not (clear ?c))))
  (:action to-cell :parameters (?c ?b) :precondition (and (clear ?c) (on ?c ?b) (cellfree))
    :effect (and (incell ?c) (clear ?b) (not (on ?c ?b)) (not (clear ?c)) (not (cellfree))))
  (:action home-from-cell :parameters (?c) :precondition (incell ?c)
    :effect (and (home ?c) (cellfree) (not (incell ?c)))))"""

PATIENCE_PROBLEM = """(define (problem tidy) (:domain patience)
  (:objects ace two table)
  (:init (on two ace) (on ace table) (clear two) (cellfree))
  (:goal (home ace)))"""


def test_the_lookahead_finds_a_step_both_ways_pass_once_mutexes_are_known() -> None:
    task = ground(parse_pddl(PATIENCE_DOMAIN, PATIENCE_PROBLEM))
    h = RelaxedPlanHeuristic(task)
    # the ace goes home from its column or through the cell: no way is a landmark, and the two
    # ways share no precondition, yet both begin with the ace clear (the two taken off it)
    plain = find_landmarks(task, h)
    assert frozenset({"(clear ace)"}) not in node_names(task, plain)
    graph = find_landmarks(task, h, fact_mutexes(task, h))
    names = node_names(task, graph)
    assert graph.natural >= 1
    assert graph.parents[names[frozenset({"(home ace)"})]] >> names[frozenset({"(clear ace)"})] & 1
    assert frozenset({"(incell ace)"}) not in names  # one of the two ways only


def test_the_lookahead_takes_no_one_of_several_ways(tmp_path: Path) -> None:
    task = ground(load_pddl(*gripper_problem(tmp_path, balls=2)))
    h = RelaxedPlanHeuristic(task)
    graph = find_landmarks(task, h, fact_mutexes(task, h))
    names = node_names(task, graph)
    # a ball is carried in the left or the right gripper: the choice stays a disjunction
    assert frozenset({"(carry ball1 left)", "(carry ball1 right)"}) in names
    assert frozenset({"(carry ball1 left)"}) not in names and frozenset({"(carry ball1 right)"}) not in names
    assert graph.natural == 0

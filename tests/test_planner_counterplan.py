"""Counterplanning (atlas_rap.planner.counterplan): the preventive step is added
exactly when an uncontrolled agent threatens the plan, and the risk follows
the model of the module docstring: 1 - prod(1 - p) over the distinct
(uncontrolled action, state) pairs that threaten a causal link."""

from __future__ import annotations

from pathlib import Path

import pytest
from pddl_problems import SHARED_PDDL, tireworld_problem
from planner_cases import (
    TOOL_TAKEN,
    door_problem,
    linearisations,
    load_problem,
    runs,
    sequential_plan,
)

from atlas_rap.planner.counterplan import Adversary, assess, counterplan
from atlas_rap.planner.ground import ground
from atlas_rap.planner.partial_order import check_every_linearisation, deorder
from atlas_rap.planner.pddl import load_pddl
from atlas_rap.planner.plan_file import validate_plan
from atlas_rap.planner.solve import solve

P_CLOSE = 0.3  # close-door's :probability


def actions(plan) -> list[str]:
    return [str(s.action) for s in plan.steps]


def prop_steps(plan) -> list[str]:
    return [a for a in actions(plan) if a.startswith("(prop-door")]


# ============================================================================= the door a person may close

def test_a_person_who_may_close_the_door_makes_the_robot_prop_it(tmp_path: Path) -> None:
    plan = solve(load_problem(tmp_path, door_problem()))
    assert plan.status == "solved"
    assert prop_steps(plan) == ["(prop-door d1 robot hall lab)"]
    prop = next(s for s in plan.steps if s.action.functor == "prop-door")
    go = next(s for s in plan.steps if s.action.functor == "go-through")
    assert _precedes(plan, prop.id, go.id)
    assert plan.counterplan == [{"step": prop.id, "threat": "(close-door person d1)", "protects": "(open d1)"}]
    assert plan.risk == 0
    # before: the plan (pick-up, go-through) leaves one state, after the pick-up,
    # where the person may close the door that go-through needs
    assert plan.risk_before_counterplanning == pytest.approx(1 - (1 - P_CLOSE))
    text = plan.to_text()
    assert "counters (close-door person d1) (protects (open d1))" in text


def _precedes(plan, a: int, b: int) -> bool:
    """Step a is ordered before step b, directly or through other steps."""
    frontier, seen = [a], set()
    while frontier:
        x = frontier.pop()
        for first, second in plan.orderings:
            if first == x and second not in seen:
                if second == b:
                    return True
                seen.add(second)
                frontier.append(second)
    return False


def test_the_first_plans_threat_is_named_by_assess(tmp_path: Path) -> None:
    task = ground(load_problem(tmp_path, door_problem()))
    plan = sequential_plan(task)
    assert [str(a.term) for a in plan] == ["(pick-up robot parcel hall)", "(go-through robot lab hall d1)"]
    found = assess(task, plan)
    assert [(str(t.action.term), str(task.facts[t.fact]), t.after, t.consumer) for t in found.threats] == [
        ("(close-door person d1)", "(open d1)", 1, 1)]
    assert found.risk == pytest.approx(P_CLOSE)
    assert [str(a.term) for a in found.actions()] == ["(close-door person d1)"]


def test_risk_counts_each_state_where_the_threat_may_happen(tmp_path: Path) -> None:
    """Two pick-ups before going through: two states where the door may close."""
    problem = load_problem(tmp_path, door_problem(things=("parcel", "box")))
    unprotected = solve(problem, protect=False)
    assert prop_steps(unprotected) == []
    assert unprotected.risk == pytest.approx(1 - (1 - P_CLOSE) ** 2)
    protected = solve(problem)
    assert prop_steps(protected) == ["(prop-door d1 robot hall lab)"]
    assert protected.risk == 0
    assert protected.risk_before_counterplanning == pytest.approx(1 - (1 - P_CLOSE) ** 2)


def test_risk_counts_each_person_who_may_close_the_door(tmp_path: Path) -> None:
    problem = load_problem(tmp_path, door_problem(people=("person", "visitor")))
    unprotected = solve(problem, protect=False)
    assert unprotected.risk == pytest.approx(1 - (1 - P_CLOSE) ** 2)
    plan = solve(problem)
    assert plan.risk == 0 and len(prop_steps(plan)) == 1
    prop = next(s for s in plan.steps if s.action.functor == "prop-door")
    assert sorted(c["threat"] for c in plan.counterplan) == ["(close-door person d1)", "(close-door visitor d1)"]
    assert {(c["step"], c["protects"]) for c in plan.counterplan} == {(prop.id, "(open d1)")}


def test_the_text_form_names_every_threat_a_step_answers(tmp_path: Path) -> None:
    plan = solve(load_problem(tmp_path, door_problem(people=("person", "visitor"))))
    assert len(plan.counterplan) == 2
    text = plan.to_text()
    assert "(close-door person d1)" in text and "(close-door visitor d1)" in text, text


def test_without_an_uncontrolled_agent_there_is_nothing_to_prevent(tmp_path: Path) -> None:
    plan = solve(load_problem(tmp_path, door_problem(people=())))
    assert plan.status == "solved"
    assert actions(plan) == ["(pick-up robot parcel hall)", "(go-through robot lab hall d1)"]
    assert plan.counterplan == [] and plan.risk == 0 and plan.risk_before_counterplanning == 0


def test_when_the_door_is_not_needed_there_is_nothing_to_prevent(tmp_path: Path) -> None:
    plan = solve(load_problem(tmp_path, door_problem(things=("parcel", "box"), go_to_lab=False)))
    assert plan.status == "solved"
    assert sorted(actions(plan)) == ["(pick-up robot box hall)", "(pick-up robot parcel hall)"]
    assert plan.counterplan == [] and plan.risk == 0 and plan.risk_before_counterplanning == 0


def test_a_one_step_plan_is_not_threatened(tmp_path: Path) -> None:
    """Nothing happens before the first step: the state it starts in has been observed."""
    plan = solve(load_problem(tmp_path, door_problem(things=())))
    assert actions(plan) == ["(go-through robot lab hall d1)"]
    assert plan.counterplan == [] and plan.risk == 0


def test_when_prevention_is_impossible_the_plan_is_returned_with_its_risk(tmp_path: Path) -> None:
    plan = solve(load_problem(tmp_path, door_problem(wedge=False)))
    assert plan.status == "solved"
    assert actions(plan) == ["(pick-up robot parcel hall)", "(go-through robot lab hall d1)"]
    assert plan.counterplan == []
    assert plan.risk == pytest.approx(P_CLOSE)
    assert plan.risk_before_counterplanning == pytest.approx(P_CLOSE)
    assert "risk left: 0.3" in plan.to_text()


def test_protect_false_reports_the_risk_without_a_prop_step(tmp_path: Path) -> None:
    plan = solve(load_problem(tmp_path, door_problem()), protect=False)
    assert prop_steps(plan) == [] and plan.counterplan == []
    assert plan.risk == pytest.approx(P_CLOSE)


def test_the_counterplanned_door_plan_is_safe_in_every_linearisation(tmp_path: Path) -> None:
    """The plan says risk 0, so whichever order the executive picks among the steps the
    partial order leaves unordered, no uncontrolled action may defeat it: the prop
    step must come before anything after which the person could close the door."""
    for things in [("parcel",), ("parcel", "box")]:
        folder = tmp_path / "-".join(things)
        folder.mkdir()
        task = ground(load_problem(folder, door_problem(things=things)))
        protected = counterplan(task, sequential_plan(task))
        assert protected.assessment.risk == 0 and protected.counters
        order = deorder(task, protected.plan, fixed={c.step for c in protected.counters})  # as solve() does
        assert check_every_linearisation(task, order) == []
        risky = []
        for seq in linearisations(len(order.steps), order.orderings):
            steps = [order.steps[i] for i in seq]
            assert runs(task, steps)
            risk = assess(task, steps).risk
            if risk:
                risky.append(([str(a.term) for a in steps], risk))
        assert risky == [], risky


SHUT_THE_DOOR = """\
(include "door-operators.ap")
(operator shut
  :purpose (not (open ?d))
  :agent ?r
  :preconditions ((open ?d) (at ?r ?place) (door ?d ?place ?other))
  :effects ((not (open ?d))))
(agents (controlled robot) (uncontrolled person))
(initial (at robot hall) (at parcel hall) (portable parcel)
         (door d1 hall lab) (door d1 lab hall) (open d1))
(goals (holding robot parcel) (not (open d1)))
"""


def test_a_plan_never_relies_on_an_uncontrolled_agent_acting(tmp_path: Path) -> None:
    """The person *may* close the door; the goal wants it closed. The worst case is
    that the person does nothing, so the robot must shut the door itself: a plan of
    only the pick-up reaches the goal only if the person happens to close it."""
    problem = load_problem(tmp_path, SHUT_THE_DOOR)
    plan = solve(problem)
    assert plan.status == "solved"
    assert sorted(actions(plan)) == ["(pick-up robot parcel hall)", "(shut d1 robot hall lab)"]
    task = ground(problem)
    by_term = {str(a.term): a for a in task.actions}
    assert runs(task, [by_term[str(a)] for a in plan.sequence])


def test_worst_case_takes_every_fact_a_possible_action_deletes(tmp_path: Path) -> None:
    task = ground(load_problem(tmp_path, door_problem()))
    adversary = Adversary(task)
    open_d1 = task.fact_ids[next(f for f in task.facts if str(f) == "(open d1)")]
    pick = next(a for a in task.actions if str(a.term) == "(pick-up robot parcel hall)")
    prop = next(a for a in task.actions if str(a.term) == "(prop-door d1 robot hall lab)")
    after_pick = task.apply(pick, task.init)
    assert open_d1 not in adversary.worst_case(after_pick, pick)
    after_prop = task.apply(prop, task.init)
    assert adversary.possible_after(after_prop, prop) == []
    assert adversary.worst_case(after_prop, prop) == after_prop


# ============================================================================= FOND triangle tireworld

def unprotected_risk(problem, sequence) -> float:
    """The model's risk of a tireworld plan, counted directly: each move-car may flatten
    the tyre (p = 1/2) in the state after it; that defeats the plan when a later
    move-car needs (not-flattire) before a changetire restores it."""
    threatening = 0
    for k, action in enumerate(sequence):
        if action.functor != "move-car":
            continue
        for later in sequence[k + 1:]:
            if later.functor == "changetire":
                break
            if later.functor == "move-car":
                threatening += 1
                break
    return 1 - 0.5 ** threatening


def check_tireworld(problem) -> None:
    plan = solve(problem, timeout=20)
    assert plan.status == "solved"
    assert plan.risk == 0
    assert validate_plan(problem, plan.sequence).ok
    verdict = validate_plan(problem, plan.sequence, adversarial=True)
    assert verdict.ok, verdict.message
    assert plan.counterplan and all(c["protects"] == "(not-flattire)" for c in plan.counterplan)
    assert all(c["threat"].startswith("(move-car~2 ") for c in plan.counterplan)

    bare = solve(problem, timeout=20, protect=False)
    assert bare.status == "solved" and bare.counterplan == []
    assert validate_plan(problem, bare.sequence).ok
    assert bare.risk > 0
    assert bare.risk == pytest.approx(unprotected_risk(problem, bare.sequence))
    assert plan.risk_before_counterplanning == pytest.approx(bare.risk)
    assert not validate_plan(problem, bare.sequence, adversarial=True).ok


def test_small_tireworld_takes_the_road_with_a_spare(tmp_path: Path) -> None:
    problem = load_pddl(*tireworld_problem(tmp_path))
    check_tireworld(problem)
    plan = solve(problem)
    assert [str(a) for a in plan.sequence] == ["(move-car a b)", "(changetire b)", "(move-car b c)"]


TRIANGLE = SHARED_PDDL / "fond-triangle-tireworld"


@pytest.mark.parametrize("name", ["p1", "p2", "p3"])
def test_fond_triangle_tireworld_is_solved_with_no_risk(name: str) -> None:
    if not (TRIANGLE / "domain.pddl").exists() or not (TRIANGLE / f"{name}.pddl").exists():
        pytest.skip(f"the FOND triangle-tireworld benchmark is not at {TRIANGLE}")
    check_tireworld(load_pddl(TRIANGLE / "domain.pddl", TRIANGLE / f"{name}.pddl"))


def test_an_uncontrolled_action_counts_once_whatever_the_values_of_its_effects_only_variables(tmp_path: Path) -> None:
    """The person takes the wrench while the robot walks to the workshop, and leaves it
    somewhere: one event of probability 0.2, however many places it could end up in."""
    plan = solve(load_problem(tmp_path, TOOL_TAKEN))
    assert plan.status == "solved"
    assert [str(s.action) for s in plan.steps] == ["(go robot workshop hall)", "(pick-up robot wrench workshop)"]
    assert plan.risk == pytest.approx(0.2)

"""The AP planner's core: grounding, agent assignment, search, partial order,
the plan it returns and the load-time checks (atlas_rap.planner)."""

from __future__ import annotations

import random
import time
from pathlib import Path

import pytest
from pddl_problems import BLOCKS_DOMAIN, blocks_problem, gripper_problem, write_problem
from planner_cases import (
    DELIVERY,
    LOCKS,
    ONE_WAY_DOOR,
    PLOT_CYCLE,
    STATION,
    bulky_box,
    door_problem,
    linearisations,
    load_problem,
    partial_order_of,
    runs,
    sequential_plan,
)

from atlas_rap.views.plan_dot import plan_dot
from atlas_rap.logic import Compound, Subst, Term, Var, substitute
from atlas_rap.planner.agents import AgentProblem, assign_agents
from atlas_rap.planner.checks import check_problem
from atlas_rap.planner.ground import agent_variables, ground, variable_order
from atlas_rap.planner.partial_order import PartialOrder, check_every_linearisation
from atlas_rap.planner.pddl import load_pddl
from atlas_rap.planner.plan import Plan
from atlas_rap.planner.plan_file import validate_plan
from atlas_rap.planner.search import eliminate_redundant, greedy_best_first
from atlas_rap.planner.solve import solve


def C(functor: str, *args: Term) -> Compound:
    return Compound(functor, args)


def V(name: str) -> Var:
    return Var(name)


def terms(actions) -> list[str]:
    return [str(a.term) for a in actions]


TWO_ARMS = bulky_box(["left-arm", "right-arm"], {"left-arm": 25, "right-arm": 25})


# ============================================================================= grounding

def test_variable_order_and_agent_variables_of_the_papers_operator(tmp_path: Path) -> None:
    op = load_problem(tmp_path, TWO_ARMS).operator("grasp-bulky-object")
    # purpose, arguments, preconditions, constraints: in order of first appearance
    assert variable_order(op) == (V("large-thing"), V("size-of-thing"), V("something"),
                                  V("arm-or-robot1"), V("arm-or-robot2"))
    # no :agent, so the agents are the first arguments of the plot's actions
    assert agent_variables(op) == (V("arm-or-robot1"), V("arm-or-robot2"))


def test_ground_keeps_only_reachable_bindings_and_drops_static_preconditions(tmp_path: Path) -> None:
    task = ground(load_problem(tmp_path, ONE_WAY_DOOR))
    assert terms(task.actions) == ["(go robot hall lab)"]
    go = task.actions[0]
    assert go.agents == ("robot",)
    # (one-way lab hall) is static: it always holds, so it is no precondition of the ground action
    assert [task.facts[p] for p in go.pre] == [C("at", "robot", "lab")]
    assert {task.facts[a] for a in go.add} == {C("at", "robot", "hall"), C("visited", "hall")}
    assert [task.facts[d] for d in go.delete] == [C("at", "robot", "lab")]
    assert {task.facts[i] for i in task.init} == {C("at", "robot", "lab"), C("one-way", "lab", "hall")}
    assert {task.facts[g] for g in task.goal} == {C("visited", "hall"), C("at", "robot", "lab")}
    assert task.unreachable_goals == ()


def test_ground_negative_preconditions_and_uncontrolled_actions_apart(tmp_path: Path) -> None:
    task = ground(load_problem(tmp_path, door_problem()))
    assert terms(task.nature) == ["(close-door person d1)"]
    close = task.nature[0]
    assert [task.facts[n] for n in close.neg] == [C("propped", "d1")]
    assert close.probability == pytest.approx(0.3)
    assert all(not a.operator.uncontrolled for a in task.actions)
    assert "(prop-door d1 robot hall lab)" in terms(task.actions)


def test_ground_reports_a_goal_nothing_reaches(tmp_path: Path) -> None:
    text = ONE_WAY_DOOR.replace("(goals (visited hall) (at robot lab))", "(goals (visited attic))")
    task = ground(load_problem(tmp_path, text))
    assert task.unreachable_goals == (C("visited", "attic"),)
    plan = solve(load_problem(tmp_path, text))
    assert plan.status == "unsolvable" and "(visited attic)" in plan.reason


def test_apply_deletes_first_then_adds() -> None:
    from atlas_rap.lang import ast
    from atlas_rap.planner.ground import GroundAction, GroundTask

    action = GroundAction(index=0, operator=ast.Operator("a"), binding={}, args=(), pre=(), neg=(),
                          add=(1,), delete=(0, 1))
    assert GroundTask.apply(action, frozenset({0, 1, 2})) == frozenset({1, 2})


# ============================================================================= agents: the bulky box

def test_bulky_box_is_gripped_by_two_distinct_agents_at_once(tmp_path: Path) -> None:
    plan = solve(load_problem(tmp_path, TWO_ARMS))
    assert plan.status == "solved"
    grips = [s for s in plan.steps if s.action.functor == "grip"]
    assert len(grips) == 2
    assert {s.operator for s in grips} == {"grasp-bulky-object"}
    assert {s.agent for s in grips} == {"left-arm", "right-arm"}
    assert sorted(str(s.action) for s in grips) == ["(grip left-arm box-1)", "(grip right-arm box-1)"]
    assert sorted(sorted(g) for g in plan.simultaneous) == [sorted(s.id for s in grips)]
    assert grips[0].start == grips[1].start


@pytest.mark.parametrize("strength", [20, 1000, 10**6])
def test_one_strong_one_armed_robot_cannot_grasp_the_bulky_box(tmp_path: Path, strength: int) -> None:
    problem = load_problem(tmp_path, bulky_box(["strong-robot"], {"strong-robot": strength}))
    assert check_problem(problem) == []
    started = time.monotonic()
    plan = solve(problem, timeout=10)
    assert plan.status == "unsolvable"
    assert plan.steps == []
    assert time.monotonic() - started < 5


def test_bulky_box_needs_two_arms_each_strong_enough(tmp_path: Path) -> None:
    # three arms; only the right one and the crane can each lift half of 40
    text = bulky_box(["left-arm", "right-arm", "crane"], {"left-arm": 19, "right-arm": 20, "crane": 500})
    plan = solve(load_problem(tmp_path, text))
    assert plan.status == "solved"
    assert sorted(s.agent for s in plan.steps) == ["crane", "right-arm"]
    weak = bulky_box(["left-arm", "right-arm"], {"left-arm": 19, "right-arm": 500})
    assert solve(load_problem(tmp_path, weak)).status == "unsolvable"


# ============================================================================= assign_agents alone

FACTS = {C("strong", "crane"), C("strong", "arm-b"), C("camera", "cam")}


def holds_in(facts: set[Compound], calls: list | None = None):
    """A ``holds`` answering a ground query by membership, recording each query."""
    def holds(query: Term, s: Subst) -> bool:
        ground_query = substitute(query, s)
        if calls is not None:
            calls.append(ground_query)
        return ground_query in facts
    return holds


def values(assignments, *names: str) -> list[tuple]:
    return [tuple(s[V(n)] for n in names) for s in assignments]


def test_assign_agents_without_tests_yields_every_candidate_in_declared_order() -> None:
    problem = AgentProblem(variables=(V("a"),), candidates=("zeta", "alpha", "mid"))
    assert values(assign_agents(problem, holds_in(FACTS)), "a") == [("zeta",), ("alpha",), ("mid",)]


def test_assign_agents_two_variables_in_lexicographic_candidate_order() -> None:
    problem = AgentProblem(variables=(V("a"), V("b")), candidates=("y", "x"))
    assert values(assign_agents(problem, holds_in(FACTS)), "a", "b") == [
        ("y", "y"), ("y", "x"), ("x", "y"), ("x", "x")]


def test_assign_agents_unary_test_prunes_before_the_next_variable() -> None:
    calls: list = []
    problem = AgentProblem(variables=(V("a"), V("b")), candidates=("arm-a", "arm-b", "crane"),
                           tests=(C("strong", V("a")),))
    found = list(assign_agents(problem, holds_in(FACTS, calls)))
    assert values(found, "a", "b") == [("arm-b", "arm-a"), ("arm-b", "arm-b"), ("arm-b", "crane"),
                                       ("crane", "arm-a"), ("crane", "arm-b"), ("crane", "crane")]
    # the test on ?a is asked once per candidate of ?a, not once per pair
    assert calls == [C("strong", "arm-a"), C("strong", "arm-b"), C("strong", "crane")]


def test_assign_agents_distinct_pairs_never_share_an_agent() -> None:
    problem = AgentProblem(variables=(V("a"), V("b")), candidates=("l", "r", "c"),
                           distinct=((V("a"), V("b")),))
    assert values(assign_agents(problem, holds_in(FACTS)), "a", "b") == [
        ("l", "r"), ("l", "c"), ("r", "l"), ("r", "c"), ("c", "l"), ("c", "r")]


def test_assign_agents_one_candidate_and_a_distinct_pair_has_no_assignment() -> None:
    problem = AgentProblem(variables=(V("a"), V("b")), candidates=("strong-robot",),
                           distinct=((V("a"), V("b")),))
    assert list(assign_agents(problem, holds_in(FACTS))) == []


def test_assign_agents_tests_and_distinct_together() -> None:
    problem = AgentProblem(variables=(V("a"), V("b")), candidates=("arm-a", "arm-b", "crane"),
                           tests=(C("strong", V("a")), C("strong", V("b"))), distinct=((V("a"), V("b")),))
    assert values(assign_agents(problem, holds_in(FACTS)), "a", "b") == [("arm-b", "crane"), ("crane", "arm-b")]


def test_assign_agents_respects_and_checks_a_given_binding() -> None:
    problem = AgentProblem(variables=(V("a"), V("b")), candidates=("l", "r"), distinct=((V("a"), V("b")),))
    assert values(assign_agents(problem, holds_in(FACTS), {V("a"): "r"}), "a", "b") == [("r", "l")]
    # a bound agent that is not a candidate (say an uncontrolled one) gives nothing
    assert list(assign_agents(problem, holds_in(FACTS), {V("a"): "astronaut"})) == []


def test_assign_agents_a_test_without_agent_variables_is_checked_once_first() -> None:
    calls: list = []
    problem = AgentProblem(variables=(V("a"),), candidates=("l", "r"), tests=(C("camera", "nobody"),))
    assert list(assign_agents(problem, holds_in(FACTS, calls))) == []
    assert calls == [C("camera", "nobody")]
    calls.clear()
    problem = AgentProblem(variables=(V("a"),), candidates=("l", "r"), tests=(C("camera", "cam"),))
    assert values(assign_agents(problem, holds_in(FACTS, calls)), "a") == [("l",), ("r",)]
    assert calls == [C("camera", "cam")]


def test_assign_agents_is_deterministic() -> None:
    problem = AgentProblem(variables=(V("a"), V("b"), V("c")), candidates=("p", "q", "r", "s"),
                           tests=(C("strong", V("b")),), distinct=((V("a"), V("c")),))
    facts = {C("strong", "q"), C("strong", "s")}
    first = values(assign_agents(problem, holds_in(facts)), "a", "b", "c")
    assert first == values(assign_agents(problem, holds_in(facts)), "a", "b", "c")
    assert first == sorted(first, key=lambda t: tuple("pqrs".index(x) for x in t))
    assert len(first) == 4 * 2 * 3


# ============================================================================= search

def test_greedy_best_first_solves_gripper_and_the_plan_runs(tmp_path: Path) -> None:
    problem = load_pddl(*gripper_problem(tmp_path, balls=3))
    task = ground(problem)
    found = greedy_best_first(task)
    assert found.status == "solved"
    assert runs(task, found.plan)
    assert validate_plan(problem, [a.term for a in found.plan]).ok
    assert found.expanded > 0 and found.evaluated > 0


def test_greedy_best_first_is_deterministic(tmp_path: Path) -> None:
    problem = load_pddl(*blocks_problem(tmp_path, 6, seed=4))
    first = terms(greedy_best_first(ground(problem)).plan)
    assert first == terms(greedy_best_first(ground(problem)).plan)


def test_greedy_best_first_exhausts_a_relaxed_reachable_but_unsolvable_task(tmp_path: Path) -> None:
    task = ground(load_problem(tmp_path, ONE_WAY_DOOR))
    assert task.unreachable_goals == ()  # every goal fact is reachable on its own
    assert greedy_best_first(task, timeout=5).status == "unsolvable"


def test_greedy_best_first_on_an_already_reached_goal_is_the_empty_plan(tmp_path: Path) -> None:
    text = ONE_WAY_DOOR.replace("(goals (visited hall) (at robot lab))", "(goals (at robot lab))")
    task = ground(load_problem(tmp_path, text))
    found = greedy_best_first(task)
    assert (found.status, found.plan) == ("solved", [])
    plan = solve(load_problem(tmp_path, text))
    assert plan.status == "solved" and plan.steps == [] and plan.makespan == 0


def test_eliminate_redundant_drops_a_detour(tmp_path: Path) -> None:
    task = ground(load_pddl(*gripper_problem(tmp_path, balls=2)))
    plan = sequential_plan(task)
    by_term = {str(a.term): a for a in task.actions}
    detour = [by_term["(move room1 room2)"], by_term["(move room2 room1)"]]
    assert runs(task, detour + plan)
    assert eliminate_redundant(task, detour + plan) == plan
    # a plan with nothing to drop is left as it is
    assert eliminate_redundant(task, plan) == plan


# ============================================================================= partial order: valid in every linearisation

def pddl_cases(tmp_path: Path):
    """(name, problem) for small generated gripper and blocks problems."""
    cases = []
    for balls in (1, 2, 3):
        folder = tmp_path / f"gripper{balls}"
        folder.mkdir()
        cases.append((f"gripper-{balls}", load_pddl(*gripper_problem(folder, balls))))
    for n, seed in [(3, 1), (4, 2), (4, 7), (5, 3), (5, 11), (6, 5)]:
        folder = tmp_path / f"blocks{n}-{seed}"
        folder.mkdir()
        cases.append((f"blocks-{n}-{seed}", load_pddl(*blocks_problem(folder, n, seed))))
    return cases


def ap_cases(tmp_path: Path):
    cases = []
    for name, text in [("door", door_problem()), ("door-two-things", door_problem(things=("parcel", "box"))),
                       ("delivery", DELIVERY), ("bulky-box", TWO_ARMS), ("locks", LOCKS)]:
        folder = tmp_path / name
        folder.mkdir()
        cases.append((name, load_problem(folder, text)))
    return cases


def test_check_every_linearisation_accepts_the_planners_partial_orders(tmp_path: Path) -> None:
    for name, problem in pddl_cases(tmp_path) + ap_cases(tmp_path):
        task, order = partial_order_of(problem)
        assert runs(task, order.steps), name
        assert check_every_linearisation(task, order) == [], name


def test_every_linearisation_of_a_pddl_plan_passes_the_independent_validator(tmp_path: Path) -> None:
    """Enumerate the linearisations of the plan as printed (steps and orderings) and
    check each with plan_file.validate_plan, which does not trust the planner."""
    checked = 0
    for name, problem in pddl_cases(tmp_path):
        plan = solve(problem)
        assert plan.status == "solved", name
        if len(plan.steps) > 8:
            continue
        action_of = {s.id: plan.sequence[s.source] for s in plan.steps}
        assert sorted(s.id for s in plan.steps) == list(range(1, len(plan.steps) + 1))
        count = 0
        for order in linearisations(len(plan.steps), plan.orderings, first=1):
            verdict = validate_plan(problem, [action_of[i] for i in order])
            assert verdict.ok, (name, order, verdict.message)
            count += 1
        assert count >= 1
        checked += 1
    assert checked >= 5


def test_every_linearisation_of_an_ap_partial_order_runs(tmp_path: Path) -> None:
    counts = {}
    for name, problem in ap_cases(tmp_path):
        task, order = partial_order_of(problem)
        assert len(order.steps) <= 8
        count = 0
        for seq in linearisations(len(order.steps), order.orderings):
            assert runs(task, [order.steps[i] for i in seq]), (name, seq)
            count += 1
        counts[name] = count
    # the two robots' chains interleave freely: 3 + 3 steps, C(6, 3) orders
    assert counts["delivery"] == 20
    assert counts["locks"] == 20


def test_deorder_keeps_a_negative_precondition_before_the_step_that_breaks_it(tmp_path: Path) -> None:
    _, order = partial_order_of(load_problem(tmp_path, LOCKS))
    index = {str(a.term): i for i, a in enumerate(order.steps)}
    closure = order.closure()
    for door, room, who, keeper in [("d1", "lab", "robot", "helper"), ("d2", "store", "helper", "robot")]:
        unlock, enter, lock = (index[f"(unlock {door} {keeper})"], index[f"(enter {who} {room} {door})"],
                               index[f"(lock {door} {keeper})"])
        assert unlock in closure[enter] and enter in closure[lock]
    assert any(not link.positive for link in order.links)


def test_deorder_keeps_independent_work_unordered(tmp_path: Path) -> None:
    _, order = partial_order_of(load_problem(tmp_path, DELIVERY))
    assert len(order.steps) == 6
    assert order.parallel_length() == 3
    closure = order.closure()
    r1 = [i for i, a in enumerate(order.steps) if a.agents == ("r1",)]
    r2 = [i for i, a in enumerate(order.steps) if a.agents == ("r2",)]
    assert len(r1) == len(r2) == 3
    assert not any(a in closure[b] or b in closure[a] for a in r1 for b in r2)


def without(order: PartialOrder, dropped: set[tuple[int, int]]) -> PartialOrder:
    return PartialOrder(order.steps, set(order.orderings) - dropped, order.links)


def failing_linearisations(task, order: PartialOrder) -> list[list[int]]:
    return [seq for seq in linearisations(len(order.steps), order.orderings)
            if not runs(task, [order.steps[i] for i in seq])]


def test_dropping_a_needed_ordering_is_reported_by_the_checker_and_the_enumeration(tmp_path: Path) -> None:
    problem = load_pddl(*gripper_problem(tmp_path, balls=1))
    task, order = partial_order_of(problem)
    assert terms(order.steps) == ["(pick ball1 room1 left)", "(move room1 room2)", "(drop ball1 room2 left)"]
    assert (1, 2) in order.orderings  # the robot must have moved before it drops the ball
    broken = without(order, {(1, 2)})
    problems = check_every_linearisation(task, broken)
    assert problems, "the checker missed a missing ordering"
    assert any("(drop ball1 room2 left)" in p and "(at-robby room2)" in p for p in problems), problems
    bad = failing_linearisations(task, broken)
    assert [terms(broken.steps[i] for i in seq) for seq in bad] == [
        ["(pick ball1 room1 left)", "(drop ball1 room2 left)", "(move room1 room2)"]]


def test_the_checker_agrees_with_enumeration_on_every_dropped_ordering(tmp_path: Path) -> None:
    """Drop each ordering of the transitive reduction in turn (the two steps then
    become unordered): the checker must fail exactly when some linearisation does."""
    needed = 0
    for name, problem in pddl_cases(tmp_path) + ap_cases(tmp_path):
        task, order = partial_order_of(problem)
        if len(order.steps) > 8:
            continue
        for pair in order.reduced_orderings():
            broken = without(order, {pair})
            assert pair[0] not in broken.closure()[pair[1]], (name, pair)  # now unordered
            enumeration_fails = bool(failing_linearisations(task, broken))
            checker_fails = bool(check_every_linearisation(task, broken))
            assert checker_fails == enumeration_fails, (name, pair, terms(order.steps))
            needed += enumeration_fails
    assert needed >= 5  # the deorderer keeps orderings that matter


def test_the_checker_agrees_with_enumeration_on_random_weaker_orders(tmp_path: Path) -> None:
    rng = random.Random(2024)
    disagreements = []
    trials = failures = 0
    for name, problem in pddl_cases(tmp_path) + ap_cases(tmp_path):
        task, order = partial_order_of(problem)
        if len(order.steps) > 7:
            continue
        pairs = sorted(order.orderings)
        for _ in range(8):
            kept = {p for p in pairs if rng.random() < 0.6}
            weaker = PartialOrder(order.steps, kept, order.links)
            enumeration_fails = bool(failing_linearisations(task, weaker))
            checker_fails = bool(check_every_linearisation(task, weaker))
            trials += 1
            failures += enumeration_fails
            if enumeration_fails != checker_fails:
                disagreements.append((name, sorted(kept)))
    assert disagreements == []
    assert trials >= 40 and failures >= 10


# ============================================================================= the plan: structure and schedule

def assert_schedule_respects_orderings(plan: Plan) -> None:
    by_id = {s.id: s for s in plan.steps}
    for a, b in plan.orderings:
        assert by_id[b].start >= by_id[a].end, (by_id[a], by_id[b])
    for group in plan.simultaneous:
        assert len({by_id[i].start for i in group}) == 1, group
    for s in plan.steps:
        assert s.end > s.start >= 0
    assert plan.makespan == max((s.end for s in plan.steps), default=0)


def test_schedule_respects_orderings_and_groups(tmp_path: Path) -> None:
    for name, problem in pddl_cases(tmp_path) + ap_cases(tmp_path):
        plan = solve(problem)
        assert plan.status == "solved", name
        assert_schedule_respects_orderings(plan)


def test_plots_expand_into_steps_sharing_the_operators_duration(tmp_path: Path) -> None:
    text = STATION
    plan = solve(load_problem(tmp_path, text))
    assert plan.status == "solved"
    by_action = {str(s.action): s for s in plan.steps}
    take, downlink = by_action["(take-image camera-1 camera-site)"], by_action["(downlink-image camera-1)"]
    point = by_action["(point-camera camera-1 camera-site)"]
    assert take.operator == downlink.operator == "inspect-site"
    assert take.agent == downlink.agent == point.agent == "camera-1"
    # inspect-site takes 2: its two sequential steps take 1 each, in order, after pointing
    assert (take.end - take.start, downlink.end - downlink.start) == (1, 1)
    assert [take.id, downlink.id] in [list(p) for p in plan.orderings]
    assert [point.id, take.id] in [list(p) for p in plan.orderings]
    assert_schedule_respects_orderings(plan)
    assert {"from": point.id, "to": take.id, "fact": "(pointed-at camera-1 camera-site)"} in plan.to_dict()["links"]


def test_an_agent_never_does_two_steps_at_once(tmp_path: Path) -> None:
    """One robot cannot pick up a parcel, pick up a box and prop a door in the same
    time unit (docs/language/ap.md: agents of overlapping steps must be distinct)."""
    for name, text in [("door", door_problem(things=("parcel", "box"))), ("delivery", DELIVERY),
                       ("bulky-box", TWO_ARMS)]:
        folder = tmp_path / name
        folder.mkdir()
        plan = solve(load_problem(folder, text))
        assert plan.status == "solved"
        overlapping = [(str(a.action), str(b.action), a.agent)
                       for a in plan.steps for b in plan.steps
                       if a.id < b.id and a.agent is not None and a.agent == b.agent
                       and a.start < b.end and b.start < a.end]
        assert overlapping == [], (name, overlapping)


def test_plan_json_text_and_dot_forms(tmp_path: Path) -> None:
    plan = solve(load_problem(tmp_path, TWO_ARMS))
    data = plan.to_dict()
    assert {"status", "steps", "orderings", "links", "counterplan", "risk", "makespan"} <= set(data)
    assert data["status"] == "solved" and data["risk"] == 0 and data["counterplan"] == []
    for step in data["steps"]:
        assert set(step) == {"id", "action", "operator", "agent", "start", "end"}
    assert {"from": "init", "to": data["steps"][0]["id"], "fact": "(top box-1 clear)"} in data["links"]
    assert any(link["to"] == "goal" and link["fact"] == "(holding planner box-1)" for link in data["links"])
    text = plan.to_text()
    assert text.startswith("solved: 2 steps") and "(grip left-arm box-1) [left-arm]" in text
    dot = plan_dot(plan)
    assert dot.startswith("digraph plan {") and dot.rstrip().endswith("}")
    for step in plan.steps:
        assert f"s{step.id} [label=\"{step.action}" in dot


# ============================================================================= load-time checks

def test_check_effect_arity(tmp_path: Path) -> None:
    text = ONE_WAY_DOOR.replace("(visited ?to)", "(visited ?to ?r)")
    found = check_problem(load_problem(tmp_path, text))
    first = found[0]
    assert "(visited ?to ?r)" in first.message and "2 arguments" in first.message
    line = text.split("\n")[6]
    assert (first.location.line, first.location.column) == (7, line.index("(visited ?to ?r)") + 1)
    assert first.location.file.endswith("problem.ap")
    assert first.source_line == line


def test_check_goal_no_operator_achieves(tmp_path: Path) -> None:
    text = ONE_WAY_DOOR.replace("(goals (visited hall) (at robot lab))",
                                "(goals (visited hall)\n       (flying robot))")
    found = check_problem(load_problem(tmp_path, text))
    assert len(found) == 1
    assert "(flying robot)" in found[0].message
    assert found[0].location.line in (10, 11)


def test_check_constraint_variable_used_nowhere_else(tmp_path: Path) -> None:
    text = ONE_WAY_DOOR.replace(":preconditions", ":constraints ((strong ?helper))\n  :preconditions")
    found = check_problem(load_problem(tmp_path, text))
    assert len(found) == 1 and "?helper" in found[0].message and "go" in found[0].message


def test_check_operator_needing_agents_without_agents(tmp_path: Path) -> None:
    text = ONE_WAY_DOOR.replace("(agents (controlled robot))\n", "")
    found = check_problem(load_problem(tmp_path, text))
    assert len(found) == 1 and "declares no controlled agents" in found[0].message


def test_check_plot_cycle(tmp_path: Path) -> None:
    text = PLOT_CYCLE
    found = check_problem(load_problem(tmp_path, text))
    assert len(found) == 1
    assert "plot cycle" in found[0].message and "fetch" in found[0].message and "prepare" in found[0].message


def test_check_accepts_the_good_problems(tmp_path: Path) -> None:
    for name, problem in ap_cases(tmp_path):
        assert check_problem(problem) == [], name


# ============================================================================= unsolvable ends

def cycle_blocks(folder: Path, n: int) -> tuple[Path, Path]:
    blocks = [f"b{i}" for i in range(1, n + 1)]
    init = " ".join(f"(ontable {b}) (clear {b})" for b in blocks) + " (handempty)"
    goal = " ".join(f"(on {a} {b})" for a, b in zip(blocks, blocks[1:] + blocks[:1]))
    return write_problem(folder, BLOCKS_DOMAIN, f"""\
(define (problem cycle-{n}) (:domain blocks) (:objects {' '.join(blocks)})
  (:init {init}) (:goal (and {goal})))
""", f"cycle-{n}.pddl")


@pytest.mark.parametrize("n", [2, 4, 5])
def test_a_goal_cycle_is_unsolvable_quickly(tmp_path: Path, n: int) -> None:
    problem = load_pddl(*cycle_blocks(tmp_path, n))
    assert ground(problem).unreachable_goals == ()
    started = time.monotonic()
    plan = solve(problem, timeout=10)
    assert plan.status == "unsolvable"
    assert "searched" in plan.reason
    assert time.monotonic() - started < 3


def test_a_one_way_door_is_unsolvable(tmp_path: Path) -> None:
    plan = solve(load_problem(tmp_path, ONE_WAY_DOOR), timeout=10)
    assert plan.status == "unsolvable" and plan.steps == []
    assert plan.to_dict()["status"] == "unsolvable"


def test_a_constraint_binds_the_other_variables_it_names_once_the_agent_is_chosen(tmp_path: Path) -> None:
    """The robot charges at its own dock: the constraint that picks the agent also
    gives ?dock its value, instead of ?dock ranging over every object."""
    text = """\
(operator charge :purpose (charged ?r) :agent ?r :constraints ((robot ?r) (dock-of ?r ?dock))
  :effects ((charged ?r) (at ?r ?dock)))
(agents (controlled r1))
(initial (robot r1) (dock-of r1 dock-1) (room kitchen) (room dock-2))
(goals (charged r1))
"""
    task = ground(load_problem(tmp_path, text))
    assert [str(a.term) for a in task.actions] == ["(charge r1 dock-1)"]

"""Plan post-processing (atlas_rap.planner.search.eliminate_redundant): greedy action
elimination in about linear time gives the same plans, step for step, as the
quadratic algorithm it replaces (kept here as the reference), with and without
the counterplanner's worst-case ``settle``; its counted work grows linearly
with the plan's length where the reference's grows quadratically; and it is
anytime: a deadline that has passed still leaves a valid plan."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from pddl_problems import SHARED_PDDL, gripper_problem, tireworld_problem

from atlas_rap.lang import load
from atlas_rap.planner.counterplan import Adversary
from atlas_rap.planner.ground import GroundAction, GroundTask, ground
from atlas_rap.planner.pddl import load_pddl
from atlas_rap.planner.problem import problem_from_program
from atlas_rap.planner.search import EliminationWork, Settle, eliminate_redundant, greedy_best_first

REPO = Path(__file__).resolve().parent.parent
OPERATORS = REPO / "operators"
SHIPPED = sorted(p.name for p in OPERATORS.glob("*-goals.ap")) + sorted(
    p.name for p in OPERATORS.glob("adversarial*.ap") if p.name != "adversarial.ap")
TRIANGLE = SHARED_PDDL / "fond-triangle-tireworld"


# ----------------------------------------------------------------------------- the reference

def reference_elimination(task: GroundTask, plan: list[GroundAction], init: frozenset[int] | None = None,
                          settle: Settle | None = None, counted: list[int] | None = None) -> list[GroundAction]:
    """The algorithm as it was before issue 16 (a copy): each trial runs the whole plan
    from the start. ``counted[0]`` is increased by the actions it applies."""
    start = task.init if init is None else init
    i = 0
    while i < len(plan):
        trial = reference_without(task, plan, i, start, settle, counted)
        if trial is not None:
            plan = trial
        else:
            i += 1
    return plan


def reference_without(task: GroundTask, plan: list[GroundAction], i: int, start: frozenset[int],
                      settle: Settle | None, counted: list[int] | None) -> list[GroundAction] | None:
    state = start
    kept: list[GroundAction] = []
    for j, action in enumerate(plan):
        if j == i:
            continue
        if task.applicable(action, state):
            state = task.apply(action, state)
            if settle is not None:
                state = settle(state, action)
            if counted is not None:
                counted[0] += 1
            kept.append(action)
        elif j < i:
            return None
    return kept if task.is_goal(state) else None


# ----------------------------------------------------------------------------- helpers

def valid(task: GroundTask, plan: list[GroundAction], settle: Settle | None = None) -> bool:
    """Whether ``plan`` applies step by step from the initial state and reaches the goals."""
    state = task.init
    for action in plan:
        if not task.applicable(action, state):
            return False
        state = task.apply(action, state)
        if settle is not None:
            state = settle(state, action)
    return task.is_goal(state)


def searched(task: GroundTask, settle: Settle | None = None) -> list[GroundAction]:
    found = greedy_best_first(task, timeout=30.0, settle=settle)
    assert found.status == "solved", found.status
    return found.plan


def padded(task: GroundTask, plan: list[GroundAction], rng: random.Random, executable: bool) -> list[GroundAction]:
    """``plan`` with actions put in at random places: actions applicable where they are put
    (``executable``; a later step may still become inapplicable), else any actions."""
    out: list[GroundAction] = []
    state = task.init
    for action in [*plan, None]:
        for _ in range(rng.randrange(3)):
            if executable:
                choices = [a for a in task.actions if task.applicable(a, state)]
                if not choices:
                    break
                extra = rng.choice(choices)
            else:
                extra = rng.choice(task.actions)
            out.append(extra)
            if task.applicable(extra, state):
                state = task.apply(extra, state)
        if action is not None:
            out.append(action)
            if task.applicable(action, state):
                state = task.apply(action, state)
    return out


def same_as_reference(task: GroundTask, plan: list[GroundAction], settle: Settle | None = None) -> list[GroundAction]:
    expected = reference_elimination(task, plan, settle=settle)
    got = eliminate_redundant(task, plan, settle=settle)
    assert [str(a.term) for a in got] == [str(a.term) for a in expected]
    assert all(a is b for a, b in zip(got, expected))
    return got


def robust_tasks(task: GroundTask):
    """The worst-case tasks counterplanning searches: against every uncontrolled action,
    and against each one alone."""
    adversaries = [Adversary(task)] + [Adversary(task, [u]) for u in task.nature]
    return [adversary.robust_task() for adversary in adversaries]


def load_shipped(name: str) -> GroundTask:
    return ground(problem_from_program(load(OPERATORS / name), name=name))


# ----------------------------------------------------------------------------- the same plans

@pytest.mark.parametrize("name", SHIPPED)
def test_the_plans_are_the_same_as_before_on_each_shipped_domain(name: str) -> None:
    task = load_shipped(name)
    plan = searched(task)
    assert valid(task, same_as_reference(task, plan))
    rng = random.Random(name)
    for executable in (True, False):
        for _ in range(10):
            same_as_reference(task, padded(task, plan, rng, executable))


@pytest.mark.parametrize("name", [n for n in SHIPPED if n.startswith("adversarial")])
def test_the_plans_are_the_same_as_before_under_the_worst_case_adversary(name: str) -> None:
    task = load_shipped(name)
    assert task.nature
    rng = random.Random(name)
    for worst, settle in robust_tasks(task):
        found = greedy_best_first(worst, timeout=30.0, settle=settle)
        plans = [found.plan] if found.status == "solved" else []
        plans += [padded(worst, searched(task), rng, executable) for executable in (True, False)]
        for plan in plans:
            same_as_reference(worst, plan, settle)


def test_the_plans_are_the_same_as_before_on_the_small_tireworld(tmp_path: Path) -> None:
    task = ground(load_pddl(*tireworld_problem(tmp_path)))
    rng = random.Random(7)
    for worst, settle in robust_tasks(task):
        found = greedy_best_first(worst, timeout=30.0, settle=settle)
        if found.status == "solved":
            assert valid(worst, same_as_reference(worst, found.plan, settle), settle)
        for _ in range(20):
            same_as_reference(worst, padded(worst, searched(task), rng, executable=True), settle)
            same_as_reference(task, padded(task, searched(task), rng, executable=False))


@pytest.mark.parametrize("name", [f"p{k}" for k in range(1, 11)])
def test_the_plans_are_the_same_as_before_on_fond_triangle_tireworld(name: str) -> None:
    if not (TRIANGLE / "domain.pddl").exists() or not (TRIANGLE / f"{name}.pddl").exists():
        pytest.skip(f"the FOND triangle-tireworld benchmark is not at {TRIANGLE}")
    task = ground(load_pddl(TRIANGLE / "domain.pddl", TRIANGLE / f"{name}.pddl"))
    bare = searched(task)
    same_as_reference(task, bare)
    worst, settle = Adversary(task).robust_task()
    found = greedy_best_first(worst, timeout=30.0, settle=settle)
    assert found.status == "solved"
    assert valid(worst, same_as_reference(worst, found.plan, settle), settle)
    # the bare plan under the worst case is not executable: nothing can be dropped, as before
    same_as_reference(worst, bare, settle)
    rng = random.Random(name)
    same_as_reference(worst, padded(worst, found.plan, rng, executable=True), settle)


def test_a_settle_that_achieves_a_goal_is_taken_into_account(tmp_path: Path) -> None:
    """A goal that no later step adds may still come from ``settle``: unless told which
    facts it may add, elimination must not give up on such a trial early."""
    task = ground(load_pddl(*gripper_problem(tmp_path, balls=3)))
    ball1 = [task.fact_ids[f] for f in task.fact_ids if str(f) in ("(at ball1 room1)", "(at ball1 room2)")]
    there = task.fact_ids[next(f for f in task.fact_ids if str(f) == "(at ball1 room2)")]
    carried = {task.fact_ids[f] for f in task.fact_ids if str(f).startswith("(carry ball1 ")}

    def settle(state: frozenset[int], action: GroundAction) -> frozenset[int]:
        # someone else takes ball1 across whenever the robot comes back to room1 without it
        if str(action.term) == "(move room2 room1)" and not carried & state:
            return state.difference(ball1) | {there}
        return state

    plan = searched(task)
    rng = random.Random(3)
    for executable in (True, False):
        for _ in range(20):
            same_as_reference(task, padded(task, plan, rng, executable), settle)
    same_as_reference(task, plan, settle)


def test_a_plan_that_is_not_executable_keeps_the_old_outcome(tmp_path: Path) -> None:
    task = ground(load_pddl(*gripper_problem(tmp_path, balls=2)))
    plan = searched(task)
    by_term = {str(a.term): a for a in task.actions}
    back = by_term["(move room2 room1)"]  # inapplicable at the start: the robot is in room1
    assert same_as_reference(task, [back] + plan) == plan
    # inapplicable after the goals are reached: dropped with the step before it
    assert same_as_reference(task, plan + [back, back]) == plan
    # a plan that never reaches the goals is left as it is
    assert same_as_reference(task, plan[:-1]) == plan[:-1]


# ----------------------------------------------------------------------------- linear work

def detoured_gripper(folder: Path, balls: int) -> tuple[GroundTask, list[GroundAction], list[GroundAction]]:
    """A gripper task, its searched plan, and that plan with a detour (there and back to
    the other room) after every step."""
    task = ground(load_pddl(*gripper_problem(folder, balls=balls)))
    plan = searched(task)
    by_term = {str(a.term): a for a in task.actions}
    rooms = {"room1": "room2", "room2": "room1"}
    out: list[GroundAction] = []
    here = "room1"
    for action in plan:
        out.append(action)
        if action.name == "move":
            here = str(action.args[1])
        other = rooms[here]
        out += [by_term[f"(move {here} {other})"], by_term[f"(move {other} {here})"]]
    assert valid(task, out)
    return task, plan, out


def test_the_counted_work_grows_linearly_with_the_plan_length(tmp_path: Path) -> None:
    ratios, reference_ratios = [], []
    for balls in (4, 16):
        folder = tmp_path / str(balls)
        folder.mkdir()
        task, plan, detoured = detoured_gripper(folder, balls)
        work = EliminationWork()
        kept = eliminate_redundant(task, detoured, work=work)
        counted = [0]
        assert kept == reference_elimination(task, detoured, counted=counted) == plan
        ratios.append([count / len(detoured) for count in (work.applied, work.copied, work.checked)])
        reference_ratios.append(counted[0] / len(detoured))
        assert work.trials >= len(plan)
    # the plan is 4x as long: the work per step (applications, other copies of a state,
    # applicability tests) stays about the same ...
    small, large = ratios
    assert all(b <= 1.25 * a for a, b in zip(small, large)), ratios
    assert all(b < 4 for b in large), ratios
    # ... where the reference's grows with the length
    assert reference_ratios[1] > 3 * reference_ratios[0]


def test_the_counted_work_is_linear_under_the_worst_case_adversary_too(tmp_path: Path) -> None:
    ratios = []
    for balls in (4, 16):
        folder = tmp_path / str(balls)
        folder.mkdir()
        task, plan, detoured = detoured_gripper(folder, balls)
        # a settle that changes nothing, and may add no goal
        work = EliminationWork()
        kept = eliminate_redundant(task, detoured, settle=lambda state, action: state, work=work,
                                   settle_adds=())
        assert kept == plan
        ratios.append(work.applied / len(detoured))
    assert ratios[1] <= 1.25 * ratios[0]


# ----------------------------------------------------------------------------- anytime

class Expired:
    """A deadline in the form of a run's limits: ``expired()`` after ``after`` questions."""

    def __init__(self, after: int) -> None:
        self.after = after
        self.asked = 0

    def expired(self) -> bool:
        self.asked += 1
        return self.asked > self.after


def test_a_deadline_that_has_passed_returns_a_valid_plan(tmp_path: Path) -> None:
    task, plan, detoured = detoured_gripper(tmp_path, balls=4)
    work = EliminationWork()
    assert eliminate_redundant(task, detoured, deadline=lambda: True, work=work) == detoured
    assert work.applied == 0
    assert eliminate_redundant(task, detoured, deadline=Expired(0)) == detoured
    assert valid(task, detoured)


def test_a_deadline_met_on_the_way_returns_the_best_plan_so_far(tmp_path: Path) -> None:
    task, plan, detoured = detoured_gripper(tmp_path, balls=4)
    lengths = []
    for after in (1, 5, 20, 10_000):
        deadline = Expired(after)
        kept = eliminate_redundant(task, detoured, deadline=deadline)
        assert valid(task, kept)
        lengths.append(len(kept))
    assert lengths == sorted(lengths, reverse=True)
    # the first question comes before any trial; the last deadline is never met
    assert lengths[0] == len(detoured) and lengths[-1] == len(plan)
    assert len(plan) < lengths[2] < len(detoured)
    worst, settle = Adversary(task).robust_task()
    assert valid(worst, eliminate_redundant(worst, detoured, settle=settle, deadline=Expired(3)), settle)


def test_a_deadline_that_never_expires_changes_nothing(tmp_path: Path) -> None:
    task, plan, detoured = detoured_gripper(tmp_path, balls=3)
    assert eliminate_redundant(task, detoured, deadline=lambda: False) == plan
    assert eliminate_redundant(task, detoured, deadline=Expired(10**9)) == plan

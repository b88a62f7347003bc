"""Grounding is semi-naive: each round joins only what uses a fact reached since the
operator's last join, and sorts the new bindings into the order a whole join would find
them in, so the ground task (and every plan) is the same as with whole joins."""

from __future__ import annotations

from pathlib import Path

import pytest
from pddl_problems import gripper_problem, triangle_tireworld_problem

from atlas_rap.lang import load
from atlas_rap.planner.ground import ground
from atlas_rap.planner.pddl import load_pddl
from atlas_rap.planner.problem import problem_from_program

REPO = Path(__file__).resolve().parents[1]
GOAL_FILES = sorted(p for p in (REPO / "operators").glob("*.ap") if "(goals" in p.read_text(encoding="utf-8"))


def signature(task) -> tuple:
    """Everything of a ground task that search and plans depend on, in order."""
    return ([str(f) for f in task.facts],
            [(str(a.term), a.pre, a.neg, a.add, a.delete, a.agents) for a in task.actions],
            [(str(a.term), a.pre, a.neg, a.add, a.delete) for a in task.nature],
            task.goal, task.goal_neg, task.init)


@pytest.mark.parametrize("path", GOAL_FILES, ids=lambda p: p.name)
def test_semi_naive_grounding_gives_the_same_task_on_the_shipped_domains(path: Path) -> None:
    problem = problem_from_program(load(path))
    assert problem.goals
    assert signature(ground(problem)) == signature(ground(problem, naive=True))


@pytest.mark.parametrize("n", [1, 3, 6, 10])
def test_semi_naive_grounding_gives_the_same_task_on_triangle_tireworld(tmp_path: Path, n: int) -> None:
    problem = load_pddl(*triangle_tireworld_problem(tmp_path, n))
    assert signature(ground(problem)) == signature(ground(problem, naive=True))


def test_semi_naive_grounding_gives_the_same_task_on_gripper(tmp_path: Path) -> None:
    problem = load_pddl(*gripper_problem(tmp_path, balls=6, rooms=3))
    assert signature(ground(problem)) == signature(ground(problem, naive=True))


def test_the_joins_index_answers_as_memory_does_in_memorys_order() -> None:
    """The grounder's joins look facts up by every argument bound (``_Grown.answers``), where
    Memory indexes the first only: the answers, and their order, must be Memory's, whichever
    arguments are bound, with a variable twice, and with compound arguments (Memory answers those)."""
    import random

    from atlas_rap.logic import Compound, Memory, Var, variables
    from atlas_rap.planner.ground import _Grown, _Probe

    rng = random.Random(7)
    objects = ["a", "b", "c", 1, 2]
    facts = list(dict.fromkeys(
        Compound(rng.choice(["p", "q"]), tuple(rng.choice(objects) for _ in range(3))) for _ in range(120)))
    facts += [Compound("r", ("a", Compound("room", (1,)))), Compound("r", ("b", Compound("room", (2,))))]
    memory = Memory(facts)
    grown = _Grown(memory)
    x, y, z = Var("x"), Var("y"), Var("z")
    atoms = [Compound("p", (x, y, z)), Compound("p", (x, x, z)), Compound("q", ("a", y, x)),
             Compound("q", (x, 2, x)), Compound("r", (x, Compound("room", (y,)))), Compound("r", (x, y))]
    checked = 0
    for atom in atoms:
        names = variables(atom)
        for _ in range(12):
            s = {v: rng.choice(objects) for v in names if rng.random() < 0.5}
            expected = list(memory.matches(atom, s))
            got = list(grown.answers(atom, _Probe.of(atom, set(s)), s))
            assert [answer for answer, _ in got] == expected, (atom, s)
            assert all(fact in facts for _, fact in got)
            checked += bool(expected)
    assert checked > 20  # most lookups found something


def test_the_join_order_is_greedy_by_bound_variables_then_static_then_fewest_new() -> None:
    """``_greedy_order`` scores with one number; it must pick as the plain rule says: the atom
    with most variables bound so far, then a static one, then the fewest new variables, then
    the first written (checked against that rule on random atoms)."""
    import random

    from atlas_rap.logic import Var
    from atlas_rap.planner.ground import _greedy_order

    def by_the_rule(is_static, names, bound):
        pending, order, bound = list(range(len(names))), [], set(bound)
        while pending:
            best = min(pending, key=lambda i: (-len(names[i] & bound), not is_static[i], len(names[i] - bound), i))
            pending.remove(best)
            order.append(best)
            bound |= names[best]
        return order

    rng = random.Random(3)
    pool = [Var(f"v{i}") for i in range(7)]
    for _ in range(300):
        count = rng.randint(1, 7)
        names = [frozenset(rng.sample(pool, rng.randint(0, 5))) for _ in range(count)]
        is_static = [rng.random() < 0.4 for _ in range(count)]
        bound = frozenset(rng.sample(pool, rng.randint(0, 2)))
        assert _greedy_order(is_static, names, bound) == by_the_rule(is_static, names, bound)


def test_an_atoms_arguments_read_off_a_binding_are_those_substitute_gives() -> None:
    from atlas_rap.logic import Compound, Var, substitute
    from atlas_rap.planner.ground import _args_getter, _instance

    x, y, z = Var("x"), Var("y"), Var("z")
    s = {x: "a", y: 2, z: "room-1"}
    for atom in [Compound("p", ()), Compound("p", ("a", "b")), Compound("p", (x,)), Compound("p", (x, y, z)),
                 Compound("p", (x, "c", y)), Compound("p", (x, x)), Compound("p", (Compound("f", (x,)), y)),
                 Compound("p", (x, Var("free")))]:
        assert _instance(atom, _args_getter(atom), s) == substitute(atom, s), atom
    assert _args_getter(Compound("p", (Compound("f", (x,)),))) is None  # a compound argument: substituted

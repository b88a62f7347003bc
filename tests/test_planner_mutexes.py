"""Fact-pair mutexes (h²): the pairs of facts no reachable state holds together, and the
reasonable landmark orderings they give (a tower is built from the bottom up)."""

from __future__ import annotations

from collections import deque
from itertools import combinations

from pddl_problems import BLOCKS_DOMAIN

from atlas_rap.planner.ground import ground
from atlas_rap.planner.landmarks import find_landmarks
from atlas_rap.planner.mutexes import fact_mutexes
from atlas_rap.planner.pddl import parse_pddl
from atlas_rap.planner.relaxation import RelaxedPlanHeuristic

TOWER = """(define (problem tower) (:domain blocks)
  (:objects a b c)
  (:init (clear a) (clear b) (clear c) (ontable a) (ontable b) (ontable c) (handempty))
  (:goal (and (on a b) (on b c))))"""


def tower():
    task = ground(parse_pddl(BLOCKS_DOMAIN, TOWER))
    return task, RelaxedPlanHeuristic(task)


def fact(task, text: str) -> int:
    return next(i for i, f in enumerate(task.facts) if str(f) == text)


def reachable_states(task) -> set[frozenset[int]]:
    states, frontier = {task.init}, deque([task.init])
    while frontier:
        state = frontier.popleft()
        for action in task.actions:
            if task.applicable(action, state):
                following = task.apply(action, state)
                if following not in states:
                    states.add(following)
                    frontier.append(following)
    return states


def test_no_reachable_state_holds_a_mutex_pair_and_every_other_pair_is_held_by_one() -> None:
    task, heuristic = tower()
    mutexes = fact_mutexes(task, heuristic)
    states = reachable_states(task)
    together = {pair for state in states for pair in combinations(sorted(state), 2)}
    facts = sorted(set().union(*states))
    for f, g in combinations(facts, 2):
        assert mutexes.mutex(f, g) == ((f, g) not in together), (task.facts[f], task.facts[g])
    assert mutexes.count() == len(list(combinations(facts, 2))) - len(together) > 0


def test_the_mutexes_are_those_of_the_blocks_world() -> None:
    task, heuristic = tower()
    mutexes = fact_mutexes(task, heuristic)
    assert mutexes.mutex(fact(task, "(on a b)"), fact(task, "(clear b)"))
    assert mutexes.mutex(fact(task, "(holding a)"), fact(task, "(handempty)"))
    assert mutexes.mutex(fact(task, "(on a b)"), fact(task, "(on c b)"))  # one block on another at most
    assert not mutexes.mutex(fact(task, "(on a b)"), fact(task, "(on b c)"))
    assert fact_mutexes(task, heuristic, stop=lambda: True) is None  # the planner's time or memory ran out


def test_mutexes_order_a_tower_from_the_bottom_up() -> None:
    task, heuristic = tower()
    with_mutexes = find_landmarks(task, heuristic, fact_mutexes(task, heuristic))
    without = find_landmarks(task, heuristic)
    number = {str(task.facts[next(iter(facts))]): i for i, facts in enumerate(with_mutexes.nodes) if len(facts) == 1}
    top, bottom = number["(on a b)"], number["(on b c)"]
    # b must be held to go onto c, and nothing may be on b then: (on a b) first would be undone
    assert with_mutexes.parents[top] >> bottom & 1
    assert not with_mutexes.parents[bottom] >> top & 1
    assert not without.parents[top] >> bottom & 1 and with_mutexes.reasonable > without.reasonable


def test_landmarks_back_chained_once_give_each_ordering_as_a_fresh_search_for_them() -> None:
    """Landmarks back-chained once are ordered as often as asked, with or without the mutexes'
    reasonable orderings: the same graphs as finding them afresh (on a tower, where the
    lookahead, which back-chaining with mutexes adds, finds nothing more)."""
    from atlas_rap.planner.landmarks import back_chain

    task, heuristic = tower()
    mutexes = fact_mutexes(task, heuristic)
    chained = back_chain(task, heuristic)
    first, then = chained.graph(), chained.graph(mutexes)
    for reused, fresh in ((first, find_landmarks(task, heuristic)), (then, find_landmarks(task, heuristic, mutexes))):
        assert (reused.nodes, reused.parents, reused.gn_children, reused.greedy_necessary, reused.reasonable) == \
            (fresh.nodes, fresh.parents, fresh.gn_children, fresh.greedy_necessary, fresh.reasonable)
    assert then.reasonable > first.reasonable

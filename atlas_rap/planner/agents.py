"""Agent assignment: which controlled agents can do an operator's parts.

A small constraint problem of its own, separate from the search so that it
can be tested alone. The variables are an operator's *agent variables*: its
``:agent`` and the first argument of each action in its ``:plot`` (the agent
that does that step). Each ranges over the declared agents (controlled ones
for our operators, uncontrolled ones for an adversary's). The constraints are

- **tests**: queries over the initial facts and the defined relations (the
  operator's ``:constraints``), each checked as soon as all the agent
  variables it mentions have values, so that a domain is pruned early;
- **non-codesignation**: agents of steps under one ``simultaneous`` must be
  different (two arms lift the bulky box together; one strong arm cannot).

:func:`assign_agents` yields every consistent assignment, in the order of the
declared agents, so plans are deterministic.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator, Sequence

from atlas_rap.logic import Subst, Term, Var, variables


@dataclass(frozen=True)
class AgentProblem:
    """The agent variables of one operator, their candidates and constraints.

    ``tests`` are queries; ``holds(query, subst)`` answers them. ``distinct``
    pairs must take different agents.
    """

    variables: tuple[Var, ...]
    candidates: tuple[str, ...]
    tests: tuple[Term, ...] = ()
    distinct: tuple[tuple[Var, Var], ...] = ()


def assign_agents(problem: AgentProblem, holds: Callable[[Term, Subst], bool],
                  binding: Subst | None = None) -> Iterator[Subst]:
    """Every assignment of agents to ``problem.variables`` extending ``binding``
    that passes every test and keeps ``distinct`` pairs apart.

    Variables already bound in ``binding`` must still be candidates. A test
    mentioning no agent variable is checked once, first.
    """
    start: Subst = dict(binding or {})
    agent_vars = problem.variables
    # A test is checked after the last of its agent variables is assigned.
    last_needed: dict[int, list[Term]] = {i: [] for i in range(-1, len(agent_vars))}
    for test in problem.tests:
        mentioned = set(variables(test))
        positions = [i for i, v in enumerate(agent_vars) if v in mentioned and v not in start]
        last_needed[max(positions, default=-1)].append(test)
    if any(not holds(test, start) for test in last_needed[-1]):
        return
    for var in agent_vars:
        if var in start and start[var] not in problem.candidates:
            return
    yield from _extend(problem, holds, last_needed, 0, start)


def _extend(problem: AgentProblem, holds: Callable[[Term, Subst], bool],
            last_needed: dict[int, list[Term]], i: int, s: Subst) -> Iterator[Subst]:
    if i == len(problem.variables):
        yield s
        return
    var = problem.variables[i]
    choices: Sequence[Term] = (s[var],) if var in s else problem.candidates
    for agent in choices:
        if any((a == var and s.get(b) == agent) or (b == var and s.get(a) == agent)
               for a, b in problem.distinct):
            continue
        trial = s if var in s else {**s, var: agent}
        if all(holds(test, trial) for test in last_needed[i]):
            yield from _extend(problem, holds, last_needed, i + 1, trial)

"""Load-time checks of a planning problem: mistakes reported with a caret before
any search starts (also run by ``atlas check`` on ``.ap`` files with goals).

- an effect that uses a predicate with a number of arguments it has nowhere
  else (initial facts, goals, preconditions, other effects, purposes);
- a goal that is not initially true and that no operator of ours can make
  true (no positive effect unifies with it), or a negative goal no operator
  can make false;
- a variable in ``:constraints`` that no other part of the operator uses
  (an agent named only in constraints is never declared as the operator's
  ``:agent`` or a plot step's agent, so nothing could bind it sensibly);
- an operator of ours that needs agents when the problem declares no
  controlled agents (an uncontrolled operator with nobody to do it simply
  never happens), and an agent declared both controlled and uncontrolled;
- a plot cycle: an operator whose plot, through the purposes of other
  operators, comes back to itself.

Warnings (``severity`` ``"warning"``) do not stop the planner:

- a ``(deadline GOAL SECONDS)`` whose GOAL unifies with none of the problem's
  goals (a misspelt goal, or a deadline of another goals file): it constrains
  nothing here.
"""

from __future__ import annotations

from atlas_rap.errors import PlanFileError, Problem, SourceLocation
from atlas_rap.lang import ast
from atlas_rap.logic import Compound, Term, term_to_str, unify, variables
from atlas_rap.planner.operator_parts import agent_variables, operator_purposes, plot_steps
from atlas_rap.planner.problem import PlanningProblem

_NOT_FACTS = frozenset({"not", "and", "or", "=", "/=", "<", "<=", ">", ">="})


class UnreachableGoals(PlanFileError):
    """The only problems are goals that no operator can achieve: the problem is
    well formed, and unsolvable (``atlas plan --json`` says ``unsolvable``)."""


def check_problem(problem: PlanningProblem) -> list[Problem]:
    """Every problem found, in the order of the checks above (errors, then warnings)."""
    return [p for part in _check_parts(problem) for p in part] + _deadline_warnings(problem)


def raise_problems(problem: PlanningProblem) -> list[Problem]:
    """Raise a :class:`PlanFileError` with every error :func:`check_problem` finds
    (an :class:`UnreachableGoals` when they are all goals no operator achieves);
    else return the warnings, for the caller to show."""
    arity, goals, agents, cycles = _check_parts(problem)
    problems = arity + goals + agents + cycles
    if problems:
        raise (PlanFileError if arity or agents or cycles else UnreachableGoals)(problems)
    return _deadline_warnings(problem)


def _check_parts(problem: PlanningProblem) -> tuple[list[Problem], list[Problem], list[Problem], list[Problem]]:
    """The problems of each check above: arity, goals, agents, plot cycles."""
    return _arity_problems(problem), _goal_problems(problem), _agent_problems(problem), _plot_cycles(problem)


def _deadline_warnings(problem: PlanningProblem) -> list[Problem]:
    """A warning at each deadline whose goal is none of the problem's goals."""
    found = []
    locations = problem.deadline_locations or (None,) * len(problem.deadlines)
    for (goal, _), loc in zip(problem.deadlines, locations):
        if any(unify(goal, asked) is not None for asked in problem.goals):
            continue
        asked = " ".join(term_to_str(g) for g in problem.goals)
        found.append(Problem(f"deadline for a goal the problem does not ask for: {term_to_str(goal)}",
                             loc or SourceLocation(problem.name, 1, 1), problem.line(loc),
                             f"the goals are {asked}; fix the goal's spelling, or add it to the goals"
                             if asked else "add (goals ...) that include it", severity="warning"))
    return found


def _problem(problem: PlanningProblem, message: str, loc: SourceLocation | None, hint: str) -> Problem:
    where = loc or SourceLocation(problem.name, 1, 1)
    return Problem(message, where, problem.line(loc), hint)


def _atoms(term: Term) -> list[Compound]:
    """The fact patterns inside a precondition or goal (under not/and/or)."""
    if type(term) is not Compound:
        return []
    if term.functor in ("not", "and", "or"):
        return [a for arg in term.args for a in _atoms(arg)]
    if term.functor in _NOT_FACTS:
        return []
    return [term]


def _arity_problems(problem: PlanningProblem) -> list[Problem]:
    uses: dict[str, dict[int, str]] = {}

    def note(atom: Compound, where: str) -> None:
        uses.setdefault(atom.functor, {}).setdefault(len(atom.args), where)

    for fact in problem.initial:
        note(fact, "in the initial facts")
    for goal in problem.goals:
        for atom in _atoms(goal):
            note(atom, "in the goals")
    for op in problem.operators:
        for pre in op.preconditions:
            for atom in _atoms(pre):
                note(atom, f"in the preconditions of {op.name}")
        if op.purpose is not None:
            for atom in _atoms(op.purpose):
                note(atom, f"in the purpose of {op.name}")
    found = []
    for op in problem.operators:
        for effect in op.effects:
            fact = effect.fact
            arities = uses.get(fact.functor, {})
            if arities and len(fact.args) not in arities:
                other, where = next(iter(arities.items()))
                found.append(_problem(
                    problem, f"effect {term_to_str(fact)} of operator {op.name} gives {fact.functor} "
                             f"{len(fact.args)} argument{'s' * (len(fact.args) != 1)}, but it has {other} {where}",
                    effect.loc, f"write {fact.functor} with {other} argument{'s' * (other != 1)}"))
    return found


def _goal_problems(problem: PlanningProblem) -> list[Problem]:
    ours = [op for op in problem.operators if not op.uncontrolled]
    found = []
    initial = set(problem.initial)
    for goal, loc in zip(problem.goals, problem.goal_locations or (None,) * len(problem.goals)):
        negative = type(goal) is Compound and goal.functor == "not" and len(goal.args) == 1
        fact = goal.args[0] if negative else goal
        if type(fact) is not Compound:
            continue
        if negative:
            if fact not in initial or any(not e.positive and unify(e.fact, fact) is not None
                                          for op in ours for e in op.effects):
                continue
            found.append(_problem(problem, f"goal {term_to_str(goal)}: no operator can make "
                                           f"{term_to_str(fact)} false", loc,
                                  "add an operator with the effect (not ...), or drop the goal"))
        elif fact not in initial and not any(e.positive and unify(e.fact, fact) is not None
                                             for op in ours for e in op.effects):
            found.append(_problem(problem, f"goal {term_to_str(fact)}: no operator achieves it and it is "
                                           f"not initially true", loc,
                                  "add an operator whose effects (or purpose) include it, or fix its spelling"))
    return found


def _agent_problems(problem: PlanningProblem) -> list[Problem]:
    found = []
    both = sorted(set(problem.controlled) & set(problem.uncontrolled))
    for name in both:
        found.append(_problem(problem, f"agent {name} is declared both controlled and uncontrolled",
                              problem.agents_location, "declare it in one group"))
    for op in problem.operators:
        used: set = set()
        others: list[Term] = [e.fact for e in op.effects] + list(op.preconditions)
        others += [step.term for step in plot_steps(op.plot)]
        others += [arg.var for arg in op.arguments] + [arg.expr for arg in op.arguments]
        if op.purpose is not None:
            others.append(op.purpose)
        if op.agent is not None:
            others.append(op.agent)
        for term in others:
            used.update(variables(term))
        for constraint in op.constraints:
            for var in variables(constraint):
                if var not in used:
                    found.append(_problem(
                        problem, f"operator {op.name}: constraint {term_to_str(constraint)} names {var}, "
                                 f"which is not the operator's :agent, a plot step's agent or any other "
                                 f"variable of the operator", op.loc,
                        f"declare it with :agent {var}, use it in the plot, or fix its spelling"))
        agent_vars = agent_variables(op, operator_purposes(problem))
        if agent_vars and not op.uncontrolled and not problem.controlled:
            found.append(_problem(
                problem, f"operator {op.name} needs an agent for {', '.join(map(str, agent_vars))}, "
                         f"but the problem declares no controlled agents", op.loc,
                "add (agents (controlled NAME ...)) to the problem"))
    return found


def _plot_cycles(problem: PlanningProblem) -> list[Problem]:
    ours = [op for op in problem.operators if not op.uncontrolled]
    calls: dict[str, list[tuple[str, ast.PlotStep]]] = {}
    for op in ours:
        for step in plot_steps(op.plot):
            for other in ours:
                if other.purpose is not None and unify(step.term, other.purpose) is not None:
                    calls.setdefault(op.name, []).append((other.name, step))
    found = []
    reported: set[frozenset[str]] = set()
    for op in ours:
        path = _cycle_from(op.name, calls)
        if path and frozenset(name for name, _ in path) not in reported:
            reported.add(frozenset(name for name, _ in path))
            names = " -> ".join([op.name] + [name for name, _ in path])
            step = path[-1][1]
            found.append(_problem(problem, f"plot cycle: {names}: expanding these plots would never end",
                                  step.loc, "make one of these plot steps an action, not another "
                                            "operator's purpose"))
    return found


def _cycle_from(start: str, calls: dict[str, list[tuple[str, ast.PlotStep]]]) -> list | None:
    """A path of (operator, plot step) calls from ``start`` back to ``start``, if any."""
    stack = [(start, [])]
    seen = set()
    while stack:
        name, path = stack.pop()
        for callee, step in calls.get(name, []):
            if callee == start:
                return path + [(callee, step)]
            if callee not in seen:
                seen.add(callee)
                stack.append((callee, path + [(callee, step)]))
    return None

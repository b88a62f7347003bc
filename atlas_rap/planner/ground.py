"""Grounding: from lifted operators to the ground actions the search runs on.

:func:`ground` turns a :class:`PlanningProblem` into a :class:`GroundTask`:
facts numbered 0..n-1, the initial state as a frozenset of fact numbers, and
one :class:`GroundAction` per operator binding that can ever apply.

How bindings are found (the choices, in order):

1. **Preconditions** are joined against memory (``atlas_rap.logic.Memory``,
   the same index the sequencer queries): *static* atoms (of predicates no
   operator changes) against the initial facts, *fluent* atoms against the
   facts reachable in the delete relaxation. Reachability is a fixpoint:
   an operator is joined again whenever a predicate it reads gained facts.
   Uncontrolled operators do not add to what our plan may reach; they are
   grounded once, against everything our actions can reach.
2. ``:arguments`` are evaluated over the initial facts (``get-value``).
3. **Agents** are assigned by :mod:`atlas_rap.planner.agents`.
4. The remaining ``:constraints`` are queries over the initial facts and the
   defined relations; they may bind further variables.
5. A variable still unbound (say one that appears only in the purpose) ranges
   over every object of the problem.
6. Equalities ``(= a b)`` and their negations are checked; static
   preconditions are dropped from the ground action (they always hold).

Negative preconditions ``(not F)`` are kept as a separate tuple (``neg``);
a negated fact that can never become true is dropped.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product
from typing import Iterator, Sequence

from atlas_rap.lang import ast
from atlas_rap.logic import (
    Compound,
    Memory,
    String,
    Subst,
    Term,
    Var,
    evaluate,
    substitute,
    unify,
    variables,
)
from atlas_rap.planner.agents import AgentProblem, assign_agents
from atlas_rap.planner.problem import PlanningProblem

_TESTS = frozenset({"=", "/=", "<", "<=", ">", ">="})


@dataclass(slots=True, eq=False)
class GroundAction:
    """One operator with every variable bound: what a plan step is.

    ``pre``/``neg``/``add``/``delete`` are fact numbers of the task. ``args``
    are the values of the operator's variables in order (declared
    ``parameters``, else first appearance); ``agents`` the agents doing it.
    """

    index: int
    operator: ast.Operator
    binding: Subst
    args: tuple[Term, ...]
    pre: tuple[int, ...]
    neg: tuple[int, ...]
    add: tuple[int, ...]
    delete: tuple[int, ...]
    agents: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        return self.operator.name

    @property
    def term(self) -> Compound:
        """``(OPERATOR-NAME VALUE ...)``: how the action is named in plans and plan files."""
        return Compound(self.operator.name, self.args)

    @property
    def duration(self) -> float:
        return float(self.operator.duration)

    @property
    def probability(self) -> float:
        p = self.operator.probability
        return 1.0 if p is None else float(p)

    def __repr__(self) -> str:
        return f"<GroundAction {self.term}>"


@dataclass
class GroundTask:
    """A grounded problem: numbered facts, initial state, goals and actions.

    ``actions`` are ours (controlled); ``nature`` are the uncontrolled ones,
    never planned, reasoned about by counterplanning.
    """

    problem: PlanningProblem
    facts: list[Compound]
    fact_ids: dict[Compound, int]
    init: frozenset[int]
    goal: tuple[int, ...]
    goal_neg: tuple[int, ...]
    actions: list[GroundAction]
    nature: list[GroundAction]
    unreachable_goals: tuple[Term, ...] = ()

    def is_goal(self, state: frozenset[int]) -> bool:
        return all(g in state for g in self.goal) and not any(g in state for g in self.goal_neg)

    def applicable(self, action: GroundAction, state: frozenset[int]) -> bool:
        return all(p in state for p in action.pre) and not any(n in state for n in action.neg)

    @staticmethod
    def apply(action: GroundAction, state: frozenset[int]) -> frozenset[int]:
        """The state after ``action`` (PDDL semantics: deletions first, then additions)."""
        return state.difference(action.delete).union(action.add)


def variable_order(op: ast.Operator) -> tuple[Var, ...]:
    """An operator's variables: its declared ``parameters``, else in order of first
    appearance in purpose, agent, arguments, preconditions, constraints, plot, effects."""
    if op.parameters:
        return op.parameters
    parts: list[Term] = []
    if op.purpose is not None:
        parts.append(op.purpose)
    if op.agent is not None:
        parts.append(op.agent)
    for arg in op.arguments:
        parts.extend((arg.var, arg.expr))
    parts.extend(op.preconditions)
    parts.extend(op.constraints)
    parts.extend(step.term for step in plot_steps(op.plot))
    parts.extend(e.fact for e in op.effects)
    return tuple(variables(Compound("", tuple(parts))))


def plot_steps(plot: ast.Plot | None) -> list[ast.PlotStep]:
    """The leaf steps of a plot, in order."""
    if plot is None:
        return []
    if isinstance(plot, ast.PlotStep):
        return [plot]
    return [step for part in plot.parts for step in plot_steps(part)]


def agent_variables(op: ast.Operator, purposes: Sequence[Term] = ()) -> tuple[Var, ...]:
    """The ``:agent`` variable and the first argument of each plot *action*, when a
    variable. A plot step that unifies with one of ``purposes`` (other operators'
    purposes) is a goal, not an action, so it names no agent."""
    found: dict[Var, None] = {}
    if op.agent is not None:
        found[op.agent] = None
    for step in plot_steps(op.plot):
        if any(unify(step.term, purpose) is not None for purpose in purposes):
            continue
        if step.term.args and type(step.term.args[0]) is Var:
            found[step.term.args[0]] = None
    return tuple(found)


def operator_purposes(problem: PlanningProblem) -> list[Term]:
    """The purposes of our operators: what a plot step may name as a goal."""
    return [op.purpose for op in problem.operators if op.purpose is not None and not op.uncontrolled]


def simultaneous_pairs(plot: ast.Plot | None) -> list[tuple[Var, Var]]:
    """Pairs of agent variables that must differ: agents of different steps of one
    ``simultaneous`` group."""
    pairs: list[tuple[Var, Var]] = []
    if plot is None or isinstance(plot, ast.PlotStep):
        return pairs
    if plot.kind == "simultaneous":
        groups = [[s.term.args[0] for s in plot_steps(part) if s.term.args and type(s.term.args[0]) is Var]
                  for part in plot.parts]
        for i, first in enumerate(groups):
            for second in groups[i + 1:]:
                pairs.extend((a, b) for a in first for b in second)
    for part in plot.parts:
        pairs.extend(simultaneous_pairs(part))
    return pairs


class _OperatorGrounder:
    """The bindings of one operator, found again whenever what it reads grows."""

    def __init__(self, op: ast.Operator, static: set[tuple[str, int]], problem: PlanningProblem,
                 objects: tuple[Term, ...], init: Memory) -> None:
        self.op = op
        self.order = variable_order(op)
        self.init = init
        self.relations = problem.relations
        self.objects = objects
        positive: list[Compound] = []
        self.negative: list[Compound] = []
        self.tests: list[Term] = []
        for pre in op.preconditions:
            if type(pre) is not Compound:
                continue
            if pre.functor == "not" and len(pre.args) == 1 and type(pre.args[0]) is Compound \
                    and pre.args[0].functor not in _TESTS and pre.args[0].functor not in self.relations:
                self.negative.append(pre.args[0])
            elif pre.functor in _TESTS or pre.functor in ("not", "and", "or") or pre.functor in self.relations:
                self.tests.append(pre)
            else:
                positive.append(pre)
        self.static_atoms = [a for a in positive if (a.functor, len(a.args)) in static]
        self.fluent_atoms = [a for a in positive if (a.functor, len(a.args)) not in static]
        self.reads = {(a.functor, len(a.args)) for a in self.fluent_atoms}
        self.join_order = _join_order(self.static_atoms, self.fluent_atoms)
        candidates = problem.uncontrolled if op.uncontrolled else problem.controlled
        self.agents = AgentProblem(variables=agent_variables(op, operator_purposes(problem)),
                                   candidates=tuple(candidates),
                                   tests=tuple(op.constraints), distinct=tuple(simultaneous_pairs(op.plot)))
        self.seen: dict[tuple[Term, ...], Subst] = {}

    def new_bindings(self, reach: Memory) -> Iterator[Subst]:
        """Bindings not found before, in a deterministic order."""
        for s in self._join(reach, 0, {}):
            for full in self._complete(s):
                key = tuple(full.get(v, v) for v in self.order)
                if key not in self.seen:
                    self.seen[key] = full
                    yield full

    def _join(self, reach: Memory, i: int, s: Subst) -> Iterator[Subst]:
        if i == len(self.join_order):
            yield s
            return
        atom, is_static = self.join_order[i]
        memory = self.init if is_static else reach
        for answer in memory.matches(atom, s):
            yield from self._join(reach, i + 1, answer)

    def _complete(self, s: Subst) -> Iterator[Subst]:
        op = self.op
        for arg in op.arguments:
            answer = next(evaluate(Compound("=", (arg.var, arg.expr)), self.init, s, self.relations), None)
            if answer is None:
                return
            s = answer
        holds = self._holds
        for assigned in assign_agents(self.agents, holds, s) if self.agents.variables else (s,):
            # The agents passed the constraints; solving them again binds the
            # other variables they mention.
            answers: Iterator[Subst] = (evaluate(Compound("and", op.constraints), self.init, assigned, self.relations)
                                        if op.constraints else iter((assigned,)))
            for answer in answers:
                yield from self._free(answer)

    def _free(self, s: Subst) -> Iterator[Subst]:
        unbound = [v for v in self.order if v not in s]
        if not unbound:
            if self._tests_hold(s):
                yield s
            return
        for values in product(self.objects, repeat=len(unbound)):
            full = {**s, **dict(zip(unbound, values))}
            if self._tests_hold(full):
                yield full

    def _tests_hold(self, s: Subst) -> bool:
        return all(self._holds(test, s) for test in self.tests)

    def _holds(self, query: Term, s: Subst) -> bool:
        return next(evaluate(query, self.init, s, self.relations), None) is not None


def _join_order(static: list[Compound], fluent: list[Compound]) -> list[tuple[Compound, bool]]:
    """Atoms in the order to join them: greedily the one with most bound variables,
    static before fluent, then fewest new variables, then as written."""
    pending = [(a, True) for a in static] + [(a, False) for a in fluent]
    bound: set[Var] = set()
    order: list[tuple[Compound, bool]] = []
    while pending:
        def score(item: tuple[Compound, bool]) -> tuple[int, int, int]:
            atom_vars = set(variables(item[0]))
            return (-len(atom_vars & bound) if bound else 0, 0 if item[1] else 1, len(atom_vars - bound))
        best = min(range(len(pending)), key=lambda i: (score(pending[i]), i))
        atom, is_static = pending.pop(best)
        order.append((atom, is_static))
        bound |= set(variables(atom))
    return order


def ground(problem: PlanningProblem) -> GroundTask:
    """Ground ``problem``: see the module docstring for how."""
    ops = problem.operators
    changed_preds = {(e.fact.functor, len(e.fact.args)) for op in ops for e in op.effects}
    mentioned = {(a.functor, len(a.args)) for op in ops for a in op.preconditions if type(a) is Compound}
    static = {key for key in mentioned if key not in changed_preds}
    init = Memory(problem.initial)
    reach = Memory(problem.initial)
    objects = _objects(problem)
    ours = [_OperatorGrounder(op, static, problem, objects, init) for op in ops if not op.uncontrolled]
    theirs = [_OperatorGrounder(op, static, problem, objects, init) for op in ops if op.uncontrolled]
    found: list[tuple[_OperatorGrounder, Subst]] = []
    dirty = {g: True for g in ours}
    while any(dirty.values()):
        grew: set[tuple[str, int]] = set()
        for g in ours:
            if not dirty[g]:
                continue
            dirty[g] = False
            for binding in list(g.new_bindings(reach)):
                found.append((g, binding))
                for effect in g.op.effects:
                    if effect.positive:
                        fact = substitute(effect.fact, binding)
                        if fact not in reach:
                            reach.assert_fact(fact)
                            grew.add((fact.functor, len(fact.args)))
        for g in ours:
            if g.reads & grew:
                dirty[g] = True
    nature_found = [(g, b) for g in theirs for b in g.new_bindings(reach)]

    facts: list[Compound] = list(dict.fromkeys(reach))
    fact_ids = {f: i for i, f in enumerate(facts)}
    static_facts = {f for f in problem.initial if (f.functor, len(f.args)) in static}
    build = _ActionBuilder(fact_ids, static_facts, static)
    if problem.avoid:
        found = [(g, b) for g, b in found if Compound(g.op.name, tuple(b.get(v, v) for v in g.order))
                 not in problem.avoid]
    actions = build.all(found)
    nature = build.all(nature_found)
    goal, goal_neg, unreachable = [], [], []
    for g in problem.goals:
        if _is_test(g):  # (= a b), (not (= a b)): true or false whatever the plan does
            if next(evaluate(g, init, {}, problem.relations), None) is None:
                unreachable.append(g)
        elif type(g) is Compound and g.functor == "not" and len(g.args) == 1:
            if g.args[0] in fact_ids:
                goal_neg.append(fact_ids[g.args[0]])
        elif g in fact_ids:
            goal.append(fact_ids[g])
        else:
            unreachable.append(g)
    return GroundTask(problem=problem, facts=facts, fact_ids=fact_ids,
                      init=frozenset(fact_ids[f] for f in problem.initial if f in fact_ids),
                      goal=tuple(dict.fromkeys(goal)), goal_neg=tuple(dict.fromkeys(goal_neg)),
                      actions=actions, nature=nature, unreachable_goals=tuple(unreachable))


def _is_test(goal: Term) -> bool:
    if type(goal) is Compound and goal.functor == "not" and len(goal.args) == 1:
        goal = goal.args[0]
    return type(goal) is Compound and goal.functor in _TESTS


class _ActionBuilder:
    def __init__(self, fact_ids: dict[Compound, int], static_facts: set[Compound],
                 static: set[tuple[str, int]]) -> None:
        self.fact_ids = fact_ids
        self.static_facts = static_facts
        self.static = static

    def all(self, found: list[tuple[_OperatorGrounder, Subst]]) -> list[GroundAction]:
        actions: list[GroundAction] = []
        for g, binding in found:
            action = self.one(g, binding, len(actions))
            if action is not None:
                actions.append(action)
        return actions

    def one(self, g: _OperatorGrounder, s: Subst, index: int) -> GroundAction | None:
        ids = self.fact_ids
        pre: list[int] = []
        for atom in g.fluent_atoms:
            pre.append(ids[substitute(atom, s)])  # type: ignore[index]
        neg: list[int] = []
        for atom in g.negative:
            fact = substitute(atom, s)
            if (fact.functor, len(fact.args)) in self.static:  # type: ignore[union-attr]
                if fact in self.static_facts:
                    return None
            elif fact in ids:
                neg.append(ids[fact])  # type: ignore[index]
        add: list[int] = []
        delete: list[int] = []
        for effect in g.op.effects:
            fact = substitute(effect.fact, s)
            if effect.positive:
                if fact in ids:
                    add.append(ids[fact])  # type: ignore[index]
            elif fact in ids:
                delete.append(ids[fact])  # type: ignore[index]
        add_set = set(add)
        agents = tuple(dict.fromkeys(str(s[v]) for v in g.agents.variables if v in s))
        return GroundAction(index=index, operator=g.op, binding=s,
                            args=tuple(s.get(v, v) for v in g.order),
                            pre=tuple(dict.fromkeys(pre)), neg=tuple(dict.fromkeys(neg)),
                            add=tuple(dict.fromkeys(add)),
                            delete=tuple(dict.fromkeys(d for d in delete if d not in add_set)),
                            agents=agents)


def _objects(problem: PlanningProblem) -> tuple[Term, ...]:
    """What a variable no fact binds may range over: the problem's objects, then every
    symbol or string that appears in the initial facts or the goals, in order."""
    found: dict[Term, None] = dict.fromkeys(problem.objects)

    def collect(term: Term) -> None:
        if type(term) is Compound:
            for arg in term.args:
                collect(arg)
        elif (type(term) is str and not term.startswith(":")) or type(term) is String:
            found[term] = None

    for fact in problem.initial:
        for arg in fact.args:
            collect(arg)
    for goal in problem.goals:
        collect(goal)
    for name in problem.controlled + problem.uncontrolled:
        found.pop(name, None)
    found.pop("not", None)
    return tuple(found)

"""Grounding: from lifted operators to the ground actions the search runs on.

:func:`ground` turns a :class:`PlanningProblem` into a :class:`GroundTask`:
facts numbered 0..n-1, the initial state as a frozenset of fact numbers, and
one :class:`GroundAction` per operator binding that can ever apply.

How bindings are found (the choices, in order):

1. **Preconditions** are joined, *static* atoms (of predicates no operator
   changes) against the initial facts, *fluent* atoms against the facts
   reachable in the delete relaxation. Each atom is looked up by a hash
   index on the argument positions the atoms before it bind (``_Probe``,
   ``_Grown.answers``), with the answers in the order
   ``atlas_rap.logic.Memory`` (which indexes the first argument only) gives
   them; a fact is numbered by its functor and arguments, without building
   it. A round of the semi-naive join, which matches one atom to a new fact
   first, joins the others in an order of its own (greedy from that atom's
   variables, as the whole join's). On the fifteen shared domains, p01-p10,
   grounding took 48 % less CPU than through Memory, for the same tasks.
   Reachability is a fixpoint: an operator is joined again whenever a
   predicate it reads gained facts.
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

**ADL** (PDDL's ``or``, ``imply``, ``exists``, ``forall``, ``when``, as
:mod:`atlas_rap.planner.pddl` writes them) is compiled away here, so the
search, the partial order and counterplanning see plain STRIPS actions:

- Quantifiers are expanded over the problem's objects (their types are
  static guards), atoms of *static* predicates (that no operator changes),
  type facts and equalities are decided against the initial facts, and
  fluent atoms that can never be reached are false. What is left is a
  formula over fluent facts.
- A precondition formula is written in disjunctive normal form: one
  :class:`GroundAction` per disjunct (a *variant*), each with the disjunct's
  literals as extra ``pre``/``neg``.
- Universal effects are expanded over the objects. Conditional effects are
  grouped by their ground condition; each group whose condition the variant
  does not decide splits the variant in two: one where it fires (the
  condition's disjuncts as extra preconditions) and one where it does not
  (the disjuncts of its negation, in negation normal form). Conditions are
  thus checked in the state before the action, and the variant's effects
  apply with PDDL semantics (deletions first, then additions).
- Reachability is relaxed the same way: an instance counts once its fluent
  precondition atoms of some disjunct are reachable, and a conditional
  addition once its condition is (negative literals assumed possible).
- A goal that grounds to one conjunction of literals is the usual ``goal``
  and ``goal_neg``. A goal that stays disjunctive is compiled into the fact
  ``(goal:reached)`` (GOAL_FACT), the task's only goal, true only when the
  goal formula holds: it is initially true when the goal holds initially;
  every variant that adds or deletes a fact of the goal gets, per disjunct
  of the goal regressed through it (what must hold before it for the goal to
  hold after it), a copy that also adds GOAL_FACT, and itself deletes
  GOAL_FACT. Whenever a step makes the goal true, its adding copy applies,
  so no plan is lost; no extra plan step is needed; and the negation of the
  goal is not put in normal form (it could be exponential). Uncontrolled
  actions, which happen whenever they can, delete GOAL_FACT only under
  that negation, so that they threaten the goal only when they undo it.
- Variants are all named as the PDDL action (same ``operator``, ``args``),
  so plans print as ``(name arg ...)``; identical variants are merged.
  The compilation is exponential in the number of conditional effects whose
  condition the variant leaves open: more than MAX_VARIANTS (2^8) variants
  for one ground action is a located error at the action.

Over 25 KB on purpose: grounding, operators to actions, with the reachability and static-
fact pruning that share its indexes (what an operator's form says is already in ``operator_parts``).
"""

from __future__ import annotations

from bisect import bisect_left
from dataclasses import dataclass
from functools import cached_property
from itertools import product
from operator import itemgetter
from typing import Callable, Iterator

from atlas_rap.errors import Problem, SourceError
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
    term_to_str,
    unify,
    variables,
)
from atlas_rap.planner.agents import AgentProblem, assign_agents
from atlas_rap.planner.limits import LimitReached
from atlas_rap.planner.operator_parts import (  # plot_steps: its old name here stays importable
    agent_variables,
    operator_purposes,
    plot_steps,
    simultaneous_pairs,
    variable_order,
)
from atlas_rap.planner.pddl import ADL_AND, ADL_EXISTS, ADL_FORALL, ADL_FUNCTORS, ADL_OR
from atlas_rap.planner.problem import PlanningProblem

__all__ = ["GOAL_FACT", "MAX_VARIANTS", "GroundAction", "GroundTask", "agent_variables", "ground",
           "operator_purposes", "plot_steps", "simultaneous_pairs", "variable_order"]

_TESTS = frozenset({"=", "/=", "<", "<=", ">", ">="})
MAX_VARIANTS = 2 ** 8  # ground actions one ADL ground action may compile to
GOAL_FACT = Compound("goal:reached", ())  # a disjunctive goal, compiled (module docstring)


@dataclass(slots=True, eq=False)
class GroundAction:
    """One operator with every variable bound: what a plan step is.

    ``pre``/``neg``/``add``/``delete`` are fact numbers of the task. ``args``
    are the values of the operator's variables in order (declared
    ``parameters``, else first appearance); ``agents`` the agents doing it;
    ``cost`` what it adds to a plan's cost (``PlanningProblem.action_cost``; 1
    without action costs).
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
    cost: float = 1.0

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

    @cached_property
    def step_by_name(self) -> dict[tuple[str, tuple[Term, ...]], GroundAction]:
        """Our actions by operator name and values (the step a FOND outcome's ``outcome_of`` names),
        built once per task, when first asked for."""
        return {(a.operator.name, a.args): a for a in self.actions}

    def applicable(self, action: GroundAction, state: frozenset[int]) -> bool:
        return all(p in state for p in action.pre) and not any(n in state for n in action.neg)

    @staticmethod
    def apply(action: GroundAction, state: frozenset[int]) -> frozenset[int]:
        """The state after ``action`` (PDDL semantics: deletions first, then additions)."""
        return state.difference(action.delete).union(action.add)


class _Probe:
    """How a join looks a flat atom up once the variables ``bound`` have values: the argument
    ``positions`` it has values for and where each comes from (``values``: a constant, or the
    variable to read), and the ``free`` (position, variable) pairs an answer binds (``repeated``
    when a variable is free twice). :meth:`of` is None for an atom with a compound argument."""

    __slots__ = ("key", "positions", "values", "free", "repeated")

    def __init__(self, atom: Compound, bound: set[Var]) -> None:
        self.key = (atom.functor, len(atom.args))
        positions: list[int] = []
        values: list[Term] = []
        free: list[tuple[int, Var]] = []
        for i, arg in enumerate(atom.args):
            if type(arg) is Var and arg not in bound:
                free.append((i, arg))
            else:
                positions.append(i)
                values.append(arg)
        self.positions, self.values, self.free = tuple(positions), tuple(values), tuple(free)
        self.repeated = len({var for _, var in free}) < len(free)

    @staticmethod
    def of(atom: Compound, bound: set[Var]) -> _Probe | None:
        return None if any(type(arg) is Compound for arg in atom.args) else _Probe(atom, bound)


class _Grown:
    """The facts of a ``memory`` in the order they came (reach's: the initial facts first), indexed
    for the joins: each fact's position, the facts of a predicate that came after a mark
    (semi-naive joins), and the facts of a predicate with given values at given argument positions
    (:meth:`answers`). Whoever asserts a fact into the memory gives it to :meth:`add` too."""

    def __init__(self, memory: Memory) -> None:
        self.memory = memory  # the same facts, for atoms that are not flat
        self.facts: list[Compound] = []
        self.position: dict[Compound, int] = {}
        self.by_predicate: dict[tuple[str, int], list[int]] = {}
        self.of_predicate: dict[tuple[str, int], list[Compound]] = {}
        # (predicate, positions) -> [values at those positions -> facts in order, how many indexed]
        self._tables: dict[tuple[tuple[str, int], tuple[int, ...]], list] = {}
        for fact in memory:
            self.add(fact)

    def add(self, fact: Compound) -> None:
        if fact in self.position:
            return
        key = (fact.functor, len(fact.args))
        self.position[fact] = len(self.facts)
        self.by_predicate.setdefault(key, []).append(len(self.facts))
        self.of_predicate.setdefault(key, []).append(fact)
        self.facts.append(fact)

    def since(self, mark: int, predicate: tuple[str, int]) -> list[Compound]:
        """The facts of ``predicate`` that came at or after position ``mark``, in order."""
        positions = self.by_predicate.get(predicate, ())
        return [self.facts[i] for i in positions[bisect_left(positions, mark):]]

    def answers(self, atom: Compound, probe: _Probe | None, s: Subst) -> list[tuple[Subst, Compound]]:
        """The answers of ``atom`` under ``s``, with the fact each matched, in the order the facts
        came: what :meth:`Memory.matches` gives on the same facts. ``probe`` (the atom's, for the
        variables ``s`` binds) looks them up by a hash index on the positions it has values for
        (built when first asked, and brought up to date as facts come), where Memory indexes the
        first argument only; None (an atom with a compound argument) asks the memory. An answer
        that binds nothing new is ``s`` itself: nobody changes an answer once it is made."""
        if probe is None:
            return [(answer, substitute(atom, answer)) for answer in self.memory.matches(atom, s)]  # type: ignore[misc]
        facts = self.of_predicate.get(probe.key, ())
        if probe.positions:
            values = tuple([s[term] if type(term) is Var else term for term in probe.values])  # type: ignore[index]
            facts = self._table(probe.key, probe.positions).get(values, ())
        free = probe.free
        if not free:
            return [(s, fact) for fact in facts]
        found = []
        repeated = probe.repeated
        for fact in facts:
            answer = s.copy()
            fact_args = fact.args
            for i, var in free:
                if repeated and var in answer:
                    if answer[var] != fact_args[i]:
                        break
                    continue
                answer[var] = fact_args[i]
            else:
                found.append((answer, fact))
        return found

    def _table(self, key: tuple[str, int], positions: tuple[int, ...]) -> dict[tuple[Term, ...], list[Compound]]:
        entry = self._tables.get((key, positions))
        if entry is None:
            entry = self._tables[(key, positions)] = [{}, 0]
        table, indexed = entry
        facts = self.of_predicate.get(key, ())
        if indexed < len(facts):
            for fact in facts[indexed:]:
                fact_args = fact.args
                table.setdefault(tuple([fact_args[i] for i in positions]), []).append(fact)
            entry[1] = len(facts)
        return table


class _OperatorGrounder:
    """The bindings of one operator, found again whenever what it reads grows."""

    def __init__(self, op: ast.Operator, static: set[tuple[str, int]], problem: PlanningProblem,
                 objects: tuple[Term, ...], init: Memory, static_facts: _Grown) -> None:
        self.op = op
        self.order = variable_order(op)
        self.init = init
        self.static = static_facts  # the initial facts, indexed for the joins of static atoms
        self.relations = problem.relations
        self.objects = objects
        positive: list[Compound] = []
        self.negative: list[Compound] = []
        self.tests: list[Term] = []
        for pre in op.preconditions:
            if type(pre) is not Compound or pre.functor in ADL_FUNCTORS:  # ADL: see _AdlOperator
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
        # each atom an action is built from, with how to read its arguments off a binding
        self.fluent_args = [(atom, _args_getter(atom)) for atom in self.fluent_atoms]
        self.effect_args = [(effect, _args_getter(effect.fact)) for effect in op.effects
                            if type(effect) is ast.Effect]
        self.additions = [(effect.fact, args) for effect, args in self.effect_args if effect.positive]
        self.join_order = _join_order(self.static_atoms, self.fluent_atoms)
        self.atom_variables = [frozenset(variables(atom)) for atom, _ in self.join_order]
        self.fluent_positions = [i for i, (_, is_static) in enumerate(self.join_order) if not is_static]
        self.probes = [probe for *_, probe in self._steps(list(range(len(self.join_order))), set())]  # the full join's
        # the join round the k-th atom (matched first to a new fact), made when first needed:
        # the others in their own greedy order from its variables (the joins found are sorted
        # afterwards), with their probes
        self.rounds: dict[int, list[tuple[int, Compound, bool, _Probe | None]]] = {}
        self.watermark = 0  # how many of reach's facts this operator's last join saw
        candidates = problem.uncontrolled if op.uncontrolled else problem.controlled
        self.agents = AgentProblem(variables=agent_variables(op, operator_purposes(problem)),
                                   candidates=tuple(candidates),
                                   tests=tuple(op.constraints), distinct=tuple(simultaneous_pairs(op.plot)))
        self.seen: dict[tuple[Term, ...], Subst] = {}
        self.adl: _AdlOperator | None = None

    def _steps(self, numbers: list[int], bound: set[Var]) -> list[tuple[int, Compound, bool, _Probe | None]]:
        """(number in the join order, atom, is it static, probe) of the atoms ``numbers``, joined in
        that order with ``bound`` bound from the start: each probe knows the variables before it."""
        bound = set(bound)
        steps = []
        for i in numbers:
            atom, is_static = self.join_order[i]
            steps.append((i, atom, is_static, _Probe.of(atom, bound)))
            bound |= self.atom_variables[i]
        return steps

    def _round(self, k: int) -> list[tuple[int, Compound, bool, _Probe | None]]:
        """The steps of every atom but the ``k``-th, in the order to join them once the ``k``-th is matched."""
        steps = self.rounds.get(k)
        if steps is None:
            others = [i for i in range(len(self.join_order)) if i != k]
            matched = self.atom_variables[k]
            order = _greedy_order([self.join_order[i][1] for i in others],
                                  [self.atom_variables[i] for i in others], matched)
            steps = self.rounds[k] = self._steps([others[j] for j in order], matched)
        return steps

    def key(self, s: Subst) -> tuple[Term, ...]:
        return tuple([s.get(v, v) for v in self.order])

    def added(self, bindings: list[Subst]) -> list[Compound]:
        """The facts the plain (not conditional) positive effects of ``bindings`` add."""
        made = []
        for binding in bindings:
            for fact, args in self.additions:
                made.append(_instance(fact, args, binding))
        return made

    def new_bindings(self, reach: Memory, grown: _Grown | None = None) -> Iterator[Subst]:
        """Bindings not found before, in a deterministic order.

        With ``grown`` (the facts reach gained, in order), only the joins that
        use a fact gained since this operator's last join are made (semi-naive
        evaluation: any other join was made before), and they are sorted into
        the order the full join would have found them in: the full join's nested
        loops meet facts in memory order at each atom, so its answers are sorted
        by the positions of their facts, atom by atom. The bindings, and so the
        actions and the plans, are the same as with a full join each time."""
        if grown is None or self.watermark == 0 or not self.fluent_positions:
            joins = self._join(grown if grown is not None else _Grown(reach), 0, {}, [])
        else:
            joins = self._joins_since(grown)
        if grown is not None:
            self.watermark = len(grown.facts)
        for s in joins:
            for full in self._complete(s):
                key = self.key(full)
                if key not in self.seen:
                    if any(type(value) is Var for value in full.values()):
                        full = {var: substitute(value, full) for var, value in full.items()}  # no chains
                    self.seen[key] = full
                    yield full

    def _joins_since(self, grown: _Grown) -> list[Subst]:
        """The joins that use a fact gained since the last join (see :meth:`new_bindings`)."""
        mark = self.watermark
        found: dict[tuple[int, ...], Subst] = {}
        positions = [0] * len(self.join_order)  # of each atom's fact in grown, in join order
        for k in self.fluent_positions:
            atom = self.join_order[k][0]
            for fact in grown.since(mark, (atom.functor, len(atom.args))):
                first = unify(atom, fact)
                if first is None:
                    continue
                positions[k] = grown.position[fact]
                self._join_rest(grown, self._round(k), 0, first, k, mark, positions, found)
        return [found[key] for key in sorted(found)]

    def _join_rest(self, grown: _Grown, steps: list, j: int, s: Subst, k: int, mark: int,
                   positions: list[int], found: dict[tuple[int, ...], Subst]) -> None:
        """The join of the round's ``steps`` from the ``j``-th, writing the position in ``grown`` of
        each fact matched into ``positions`` and each join into ``found`` under them (the first
        one made, for positions met twice); the fluent atoms before the ``k``-th (in the join
        order) only on facts older than ``mark``, so each join is made once. Recursion, not
        generators: a generator would hand each join up through every level."""
        if j == len(steps):
            found.setdefault(tuple(positions), s)
            return
        i, atom, is_static, probe = steps[j]
        older = not is_static and i < k
        where = grown.position
        for answer, fact in (self.static if is_static else grown).answers(atom, probe, s):
            at = where[fact]
            if older and at >= mark:
                continue
            positions[i] = at
            self._join_rest(grown, steps, j + 1, answer, k, mark, positions, found)

    def _join(self, grown: _Grown, i: int, s: Subst, found: list[Subst]) -> list[Subst]:
        """Every join of the atoms from the ``i``-th, in order, appended to ``found``."""
        if i == len(self.join_order):
            found.append(s)
            return found
        atom, is_static = self.join_order[i]
        for answer, _ in (self.static if is_static else grown).answers(atom, self.probes[i], s):
            self._join(grown, i + 1, answer, found)
        return found

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
    items = [(a, True) for a in static] + [(a, False) for a in fluent]
    order = _greedy_order([True] * len(static) + [False] * len(fluent),
                          [frozenset(variables(atom)) for atom, _ in items], frozenset())
    return [items[i] for i in order]


def _greedy_order(is_static: list[bool], atom_variables: list[frozenset[Var]], bound: frozenset[Var]) -> list[int]:
    """The numbers of the atoms (whether each ``is_static``, the variables of each) in the order
    :func:`_join_order` says, with the variables ``bound`` bound from the start."""
    pending = list(range(len(is_static)))
    order: list[int] = []
    # the score (most bound variables, static, fewest new variables) as one number
    # (more bound scores lower): an atom has far fewer than `weight` variables
    weight = 1 + max(map(len, atom_variables), default=0)
    rank = [len(names) + (0 if static else weight) for names, static in zip(atom_variables, is_static)]
    while pending:
        best, best_score = -1, 0
        for i in pending:  # the first of the lowest scores
            shared = len(atom_variables[i] & bound)
            score = rank[i] - shared * (2 * weight + 1)
            if best < 0 or score < best_score:
                best, best_score = i, score
        pending.remove(best)
        order.append(best)
        bound = bound | atom_variables[best]
    return order


def ground(problem: PlanningProblem, stop: Callable[[], bool] | None = None, *, naive: bool = False) -> GroundTask:
    """Ground ``problem``: see the module docstring for how. ``stop()`` (a run's limits)
    is asked before each operator is joined again; when it says so, :class:`LimitReached`.
    Joins are semi-naive (only those that use a new fact); ``naive`` makes every join
    whole again, which gives the same task, slower (for tests)."""
    ops = problem.operators
    changed_preds = {(e.fact.functor, len(e.fact.args)) for op in ops for e in op.effects}
    mentioned = {(a.functor, len(a.args)) for op in ops for a in op.preconditions if type(a) is Compound}
    static = {key for key in mentioned if key not in changed_preds}
    init = Memory(problem.initial)
    reach = Memory(problem.initial)
    objects = _objects(problem)
    initial = _Grown(init)
    ours = [_OperatorGrounder(op, static, problem, objects, init, initial) for op in ops if not op.uncontrolled]
    theirs = [_OperatorGrounder(op, static, problem, objects, init, initial) for op in ops if op.uncontrolled]
    formulas = _Formulas(changed_preds, set(problem.initial), objects)
    for g in ours + theirs:
        if _is_adl(g.op):
            g.adl = _AdlOperator(g.op, formulas)
            g.reads |= g.adl.reads
    found: list[tuple[_OperatorGrounder, Subst]] = []
    grown = _Grown(reach)
    dirty = {g: True for g in ours}
    while any(dirty.values()):
        grew: set[tuple[str, int]] = set()
        for g in ours:
            if not dirty[g]:
                continue
            if stop is not None and stop():
                raise LimitReached("grounding")
            dirty[g] = False
            bindings, conditional = _enabled(g, reach, None if naive else grown)
            found.extend((g, binding) for binding in bindings)
            added = g.added(bindings)
            for fact in added + conditional:
                if fact not in reach:
                    reach.assert_fact(fact)
                    grown.add(fact)  # type: ignore[arg-type]
                    grew.add((fact.functor, len(fact.args)))  # type: ignore[union-attr]
        for g in ours:
            if g.reads & grew:
                dirty[g] = True
    nature_found = [(g, b) for g in theirs for b in _enabled(g, reach, grown)[0]]

    facts: list[Compound] = list(dict.fromkeys(reach))
    fact_ids = {f: i for i, f in enumerate(facts)}
    static_facts = {f for f in problem.initial if (f.functor, len(f.args)) in static}
    adl_goal = _AdlGoal(problem, formulas, fact_ids) if any(map(_is_adl_term, problem.goals)) else None
    if adl_goal is not None and adl_goal.formula is not None:
        fact_ids[GOAL_FACT] = len(facts)
        facts.append(GOAL_FACT)
    build = _ActionBuilder(fact_ids, static_facts, static, problem,
                           adl_goal if adl_goal is not None and adl_goal.formula is not None else None)
    if problem.avoid:
        found = [(g, b) for g, b in found if Compound(g.op.name, tuple(b.get(v, v) for v in g.order))
                 not in problem.avoid]
    actions = build.all(found)
    nature = build.all(nature_found)
    goal, goal_neg, unreachable = [], [], []
    for g in problem.goals:
        if _is_adl_term(g):
            continue  # adl_goal's
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
    init_ids = frozenset(fact_ids[f] for f in problem.initial if f in fact_ids)
    if adl_goal is not None:
        init_ids = adl_goal.finish(goal, goal_neg, unreachable, init_ids)
    return GroundTask(problem=problem, facts=facts, fact_ids=fact_ids,
                      init=init_ids,
                      goal=tuple(dict.fromkeys(goal)), goal_neg=tuple(dict.fromkeys(goal_neg)),
                      actions=actions, nature=nature, unreachable_goals=tuple(unreachable))


def _is_test(goal: Term) -> bool:
    if type(goal) is Compound and goal.functor == "not" and len(goal.args) == 1:
        goal = goal.args[0]
    return type(goal) is Compound and goal.functor in _TESTS


class _ActionBuilder:
    def __init__(self, fact_ids: dict[Compound, int], static_facts: set[Compound],
                 static: set[tuple[str, int]], problem: PlanningProblem | None = None,
                 goal: _AdlGoal | None = None) -> None:
        self.fact_ids = fact_ids
        self.static_facts = static_facts
        self.static = static
        self.problem = problem
        self.goal = goal  # a disjunctive goal compiled into GOAL_FACT
        # the same numbers by (functor, arguments): a flat atom's fact is found without building it
        self.key_ids = {(fact.functor, fact.args): i for fact, i in fact_ids.items() if type(fact) is Compound}

    def _id(self, atom: Compound, args: _ArgsGetter | None, s: Subst) -> int | None:
        """The number of the fact ``substitute(atom, s)``, None if it is not one of the task's;
        ``args`` is the atom's :func:`_args_getter`."""
        if args is not None:
            try:
                return self.key_ids.get((atom.functor, args if type(args) is tuple else args(s)))
            except KeyError:  # a variable s leaves free (a quantifier's, say): no fact has it
                pass
        return self.fact_ids.get(substitute(atom, s))  # type: ignore[arg-type]

    def all(self, found: list[tuple[_OperatorGrounder, Subst]]) -> list[GroundAction]:
        actions: list[GroundAction] = []
        for g, binding in found:
            if g.adl is None and self.goal is None:
                action = self.one(g, binding, len(actions))
                if action is not None:
                    actions.append(action)
                continue
            for action in self.variants(g, binding):
                action.index = len(actions)
                actions.append(action)
        return actions

    def variants(self, g: _OperatorGrounder, s: Subst) -> list[GroundAction]:
        """The STRIPS variants of one ground ADL action (module docstring)."""
        base = self.one(g, s, 0)
        if base is None:
            return []
        leaves: list[_Leaf] = [(frozenset(base.pre), frozenset(base.neg),
                                list(base.add), list(base.delete))]
        try:
            if g.adl is not None:
                leaves = g.adl.split(g.key(s), leaves[0], self.fact_ids)
            if self.goal is not None:
                leaves = self.goal.split(leaves, exact=g.op.uncontrolled)
        except _TooMany:
            op = g.op
            why = "its conditional effects and disjunctive preconditions" if g.adl is not None else "it"
            loc = op.loc
            raise SourceError(Problem(
                f"action {term_to_str(base.term)}: {why}"
                f"{' with the disjunctive goal' if self.goal is not None else ''} compile to more than "
                f"{MAX_VARIANTS} variants", loc, self.problem.line(loc) if self.problem is not None else None,
                f"each (when ...) whose condition can change, and each disjunct of a precondition, "
                f"multiplies the variants of a ground action (at most {MAX_VARIANTS}); make fewer "
                f"conditions depend on facts that change, or split the action")) from None
        out: list[GroundAction] = []
        seen: set[tuple] = set()
        for true, false, add, delete in leaves:
            pre = tuple(dict.fromkeys([*base.pre, *sorted(true)]))
            neg = tuple(dict.fromkeys([*base.neg, *sorted(false)]))
            adds = tuple(dict.fromkeys(add))
            deletes = tuple(dict.fromkeys(d for d in delete if d not in adds))
            key = (frozenset(pre), frozenset(neg), frozenset(adds), frozenset(deletes))
            if key in seen:
                continue
            seen.add(key)
            out.append(GroundAction(index=0, operator=g.op, binding=s, args=base.args, pre=pre, neg=neg,
                                    add=adds, delete=deletes, agents=base.agents, cost=base.cost))
        return out

    def one(self, g: _OperatorGrounder, s: Subst, index: int) -> GroundAction | None:
        ids = self.fact_ids
        cost = self.problem.action_cost(g.op, s) if self.problem is not None else 1.0
        if cost is None:  # its cost is not given: PDDL cannot apply it
            return None
        pre: list[int] = []
        for atom, args in g.fluent_args:
            fact_id = self._id(atom, args, s)
            if fact_id is None:
                raise KeyError(substitute(atom, s))  # reachable by construction: a grounding bug
            pre.append(fact_id)
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
        for effect, args in g.effect_args:  # conditional effects: compiled by variants()
            fact_id = self._id(effect.fact, args, s)
            if fact_id is not None:
                (add if effect.positive else delete).append(fact_id)
        add_set = set(add)
        agents = tuple(dict.fromkeys(str(s[v]) for v in g.agents.variables if v in s))
        return GroundAction(index=index, operator=g.op, binding=s, args=g.key(s),
                            pre=tuple(dict.fromkeys(pre)), neg=tuple(dict.fromkeys(neg)),
                            add=tuple(dict.fromkeys(add)),
                            delete=tuple(dict.fromkeys(d for d in delete if d not in add_set)),
                            agents=agents, cost=cost)


# how to read an atom's arguments off a binding: a function of the binding, or the arguments
# themselves when the atom has no variable
_ArgsGetter = Callable[[Subst], tuple] | tuple


def _args_getter(atom: Compound) -> _ArgsGetter | None:
    """How to read the arguments of ``substitute(atom, s)`` for a binding ``s``
    of every variable of the atom, the same but without building the fact: the bindings
    grounding makes hold constants and no chains. None for an atom with a compound argument
    (substitute it). Every ground action is numbered through these, so they are made once per
    operator: an ``itemgetter`` when every argument is a variable."""
    args = atom.args
    if any(type(arg) is Compound for arg in args):
        return None
    if not any(type(arg) is Var for arg in args):
        return args
    if all(type(arg) is Var for arg in args):
        if len(args) > 1:
            return itemgetter(*args)
        only = args[0]
        return lambda s: (s[only],)
    return lambda s: tuple([s[arg] if type(arg) is Var else arg for arg in args])


def _instance(atom: Compound, args: _ArgsGetter | None, s: Subst) -> Compound:
    """``substitute(atom, s)``, built from the arguments ``args`` (the atom's :func:`_args_getter`)
    reads when it can."""
    if args is not None:
        try:
            return atom if type(args) is tuple else Compound(atom.functor, args(s))
        except KeyError:  # a variable s leaves free
            pass
    return substitute(atom, s)  # type: ignore[return-value]


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


# ------------------------------------------------------------------ ADL, compiled away
#
# A ground formula is True, False, ("+", FACT), ("-", FACT), ("and", PARTS) or
# ("or", PARTS), PARTS a tuple of formulas: FACT is a Compound while grounding,
# a fact number once the facts are numbered. Only fluent facts are left in it.

GroundFormula = object
_Leaf = tuple  # (true facts, false facts, additions, deletions) of one variant


class _TooMany(Exception):
    """More than MAX_VARIANTS variants (or disjuncts)."""


def _is_adl_term(term: Term) -> bool:
    return type(term) is Compound and term.functor in ADL_FUNCTORS


def _is_adl(op: ast.Operator) -> bool:
    return (any(_is_adl_term(pre) for pre in op.preconditions)
            or any(type(e) is ast.ConditionalEffect for e in op.effects))


def _enabled(g: _OperatorGrounder, reach: Memory, grown: _Grown | None = None) -> tuple[list[Subst], list[Compound]]:
    """The bindings of ``g`` that became usable in ``reach`` (``grown``: its facts in order),
    and the facts its conditional effects may add there that they could not add before."""
    bindings = list(g.new_bindings(reach, grown))
    if g.adl is None:
        return bindings, []
    for binding in bindings:
        g.adl.add(g.key(binding), binding)
    return g.adl.advance(reach)


def _g_and(parts) -> GroundFormula:
    return _g_join("and", parts, absorbing=False)


def _g_or(parts) -> GroundFormula:
    return _g_join("or", parts, absorbing=True)


def _g_join(kind: str, parts, absorbing: bool) -> GroundFormula:
    """``kind`` ("and"/"or") of ``parts``, flattened and simplified: ``absorbing`` (False for
    and, True for or) decides it at once; the other truth value drops out."""
    flat: list = []
    for part in parts:
        if part is absorbing:
            return absorbing
        if part is (not absorbing):
            continue
        if part[0] == kind:
            flat.extend(part[1])
        else:
            flat.append(part)
    flat = list(dict.fromkeys(flat))
    if not flat:
        return not absorbing
    return flat[0] if len(flat) == 1 else (kind, tuple(flat))


def _g_not(f: GroundFormula) -> GroundFormula:
    if f is True or f is False:
        return not f
    kind = f[0]  # type: ignore[index]
    if kind == "+":
        return ("-", f[1])  # type: ignore[index]
    if kind == "-":
        return ("+", f[1])  # type: ignore[index]
    parts = (_g_not(p) for p in f[1])  # type: ignore[index]
    return _g_or(parts) if kind == "and" else _g_and(parts)


def _g_map(f: GroundFormula, literal: Callable[[tuple], GroundFormula]) -> GroundFormula:
    """``f`` with each literal replaced by ``literal(it)``, simplified."""
    if f is True or f is False:
        return f
    kind = f[0]  # type: ignore[index]
    if kind == "and":
        return _g_and(_g_map(p, literal) for p in f[1])  # type: ignore[index]
    if kind == "or":
        return _g_or(_g_map(p, literal) for p in f[1])  # type: ignore[index]
    return literal(f)  # type: ignore[arg-type]


def _numbered(f: GroundFormula, ids: dict[Compound, int]) -> GroundFormula:
    """``f`` over fact numbers: a fact that never becomes true is false."""
    def literal(lit: tuple) -> GroundFormula:
        number = ids.get(lit[1])
        if number is None:
            return lit[0] == "-"
        return (lit[0], number)
    return _g_map(f, literal)


def _assume(f: GroundFormula, true: frozenset, false: frozenset) -> GroundFormula:
    """``f`` where the facts of ``true`` hold and those of ``false`` do not."""
    def literal(lit: tuple) -> GroundFormula:
        if lit[1] in true:
            return lit[0] == "+"
        if lit[1] in false:
            return lit[0] == "-"
        return lit
    return _g_map(f, literal)


def _relaxed(f: GroundFormula, reach: Memory) -> bool:
    """Whether ``f`` may hold in the delete relaxation: its positive facts reached,
    negative literals assumed possible."""
    if f is True or f is False:
        return f
    kind = f[0]  # type: ignore[index]
    if kind == "+":
        return f[1] in reach  # type: ignore[index]
    if kind == "-":
        return True
    if kind == "and":
        return all(_relaxed(p, reach) for p in f[1])  # type: ignore[index]
    return any(_relaxed(p, reach) for p in f[1])  # type: ignore[index]


def _holds_in(f: GroundFormula, state: frozenset[int]) -> bool:
    if f is True or f is False:
        return f
    kind = f[0]  # type: ignore[index]
    if kind == "+":
        return f[1] in state  # type: ignore[index]
    if kind == "-":
        return f[1] not in state  # type: ignore[index]
    if kind == "and":
        return all(_holds_in(p, state) for p in f[1])  # type: ignore[index]
    return any(_holds_in(p, state) for p in f[1])  # type: ignore[index]


def _facts_of(f: GroundFormula, out: dict) -> dict:
    """The facts of ``f``, in order of first appearance (a dict used as a list)."""
    if f is True or f is False:
        return out
    if f[0] in ("+", "-"):  # type: ignore[index]
        out[f[1]] = None  # type: ignore[index]
    else:
        for p in f[1]:  # type: ignore[index]
            _facts_of(p, out)
    return out


Disjunct = tuple  # (frozenset of true facts, frozenset of false facts)


def _dnf(f: GroundFormula) -> list[Disjunct]:
    """``f`` in disjunctive normal form: contradictory disjuncts dropped, and those
    that contain another one (they add nothing); more than MAX_VARIANTS: _TooMany."""
    if f is True:
        return [(frozenset(), frozenset())]
    if f is False:
        return []
    kind = f[0]  # type: ignore[index]
    if kind == "+":
        return [(frozenset((f[1],)), frozenset())]  # type: ignore[index]
    if kind == "-":
        return [(frozenset(), frozenset((f[1],)))]  # type: ignore[index]
    if kind == "or":
        return _minimal([d for p in f[1] for d in _dnf(p)])  # type: ignore[index]
    out: list[Disjunct] = [(frozenset(), frozenset())]
    for part in f[1]:  # type: ignore[index]
        options = _dnf(part)
        out = _minimal([(t | t2, n | n2) for t, n in out for t2, n2 in options
                        if not (t | t2) & (n | n2)])
        if not out:
            return []
    return out


def _minimal(disjuncts: list[Disjunct]) -> list[Disjunct]:
    kept: list[Disjunct] = []
    for t, n in sorted(dict.fromkeys(disjuncts), key=lambda d: len(d[0]) + len(d[1])):
        if any(t2 <= t and n2 <= n for t2, n2 in kept):
            continue
        kept.append((t, n))
        if len(kept) > MAX_VARIANTS:
            raise _TooMany()
    return kept


class _Formulas:
    """Grounds the formulas :mod:`atlas_rap.planner.pddl` writes: quantifiers over
    ``objects``, static atoms (predicates not in ``changed``) and equalities decided
    against the initial facts ``init``."""

    def __init__(self, changed: set[tuple[str, int]], init: set[Compound], objects: tuple[Term, ...]) -> None:
        self.changed = changed
        self.init = init
        self.objects = objects

    def ground(self, term: Term, s: Subst) -> GroundFormula:
        if type(term) is not Compound:
            return False
        functor = term.functor
        if functor == ADL_AND:
            return _g_and(self.ground(arg, s) for arg in term.args)
        if functor == ADL_OR:
            return _g_or(self.ground(arg, s) for arg in term.args)
        if functor in (ADL_FORALL, ADL_EXISTS):
            names = term.args[0].args  # type: ignore[union-attr]
            body = term.args[1]
            parts = (self.ground(body, {**s, **dict(zip(names, values))})
                     for values in product(self.objects, repeat=len(names)))
            return _g_and(parts) if functor == ADL_FORALL else _g_or(parts)
        if functor == "not" and len(term.args) == 1:
            return _g_not(self.ground(term.args[0], s))
        fact = substitute(term, s)
        if functor == "=" and len(term.args) == 2:
            return fact.args[0] == fact.args[1]  # type: ignore[union-attr]
        if (functor, len(term.args)) not in self.changed:
            return fact in self.init
        return ("+", fact)

    def reads(self, term: Term, out: set[tuple[str, int]]) -> None:
        """The changing predicates ``term`` reads, into ``out``."""
        if type(term) is not Compound:
            return
        if term.functor in ADL_FUNCTORS or term.functor == "not":
            for arg in term.args:
                self.reads(arg, out)
        elif (term.functor, len(term.args)) in self.changed:
            out.add((term.functor, len(term.args)))


class _Instance:
    """One binding of an ADL operator: its precondition formula and conditional
    effects, ground (``effects``: (condition, fact, positive)); ``pending``: the
    additions not yet reached in the relaxation."""

    __slots__ = ("binding", "pre", "effects", "pending")

    def __init__(self, binding: Subst, pre: GroundFormula, effects: list[tuple]) -> None:
        self.binding = binding
        self.pre = pre
        self.effects = effects
        self.pending = [(cond, fact) for cond, fact, positive in effects if positive]


class _AdlOperator:
    """The ADL parts of one operator: its formula preconditions and its conditional
    and universal effects, per binding (the rest is grounded as for STRIPS)."""

    def __init__(self, op: ast.Operator, formulas: _Formulas) -> None:
        self.op = op
        self.formulas = formulas
        self.pre = [p for p in op.preconditions if _is_adl_term(p)]
        self.conditional = [e for e in op.effects if type(e) is ast.ConditionalEffect]
        self.reads: set[tuple[str, int]] = set()
        for term in self.pre:
            formulas.reads(term, self.reads)
        for effect in self.conditional:
            formulas.reads(effect.condition, self.reads)
        self.instances: dict[tuple[Term, ...], _Instance] = {}
        self.waiting: list[_Instance] = []
        self.firing: list[_Instance] = []

    def add(self, key: tuple[Term, ...], binding: Subst) -> None:
        """A binding the join found: kept unless its precondition can never hold."""
        ground = self.formulas.ground
        pre = _g_and(ground(term, binding) for term in self.pre)
        if pre is False:
            return
        effects = []
        for effect in self.conditional:
            for values in product(self.formulas.objects, repeat=len(effect.variables)):
                s = {**binding, **dict(zip(effect.variables, values))} if effect.variables else binding
                cond = ground(effect.condition, s)
                if cond is not False:
                    effects.append((cond, substitute(effect.fact, s), effect.positive))
        instance = _Instance(binding, pre, effects)
        self.instances[key] = instance
        self.waiting.append(instance)

    def advance(self, reach: Memory) -> tuple[list[Subst], list[Compound]]:
        """The bindings whose precondition now may hold in ``reach`` and the facts
        their conditional effects may now add (module docstring)."""
        enabled = [i for i in self.waiting if _relaxed(i.pre, reach)]
        if enabled:
            self.waiting = [i for i in self.waiting if not _relaxed(i.pre, reach)]
            self.firing.extend(enabled)
        facts: list[Compound] = []
        firing = []
        for instance in self.firing:
            left = []
            for cond, fact in instance.pending:
                if _relaxed(cond, reach):
                    facts.append(fact)
                else:
                    left.append((cond, fact))
            instance.pending = left
            if left:
                firing.append(instance)
        self.firing = firing
        return [i.binding for i in enabled], facts

    def split(self, key: tuple[Term, ...], base: _Leaf, ids: dict[Compound, int]) -> list[_Leaf]:
        """The variants of the instance ``key`` (module docstring); ``base`` is its
        STRIPS part."""
        instance = self.instances[key]
        true0, false0, add0, delete0 = base
        groups: dict[GroundFormula, tuple[list[int], list[int]]] = {}
        add, delete = list(add0), list(delete0)
        for cond, fact, positive in instance.effects:
            cond = _numbered(cond, ids)
            number = ids.get(fact)
            if cond is False or number is None:  # never fires, or adds or deletes a fact never true
                continue
            adds, deletes = (add, delete) if cond is True else groups.setdefault(cond, ([], []))
            (adds if positive else deletes).append(number)
        leaves: list[_Leaf] = []
        pending = list(groups.items())

        def fire(i: int, true: frozenset, false: frozenset, add: list[int], delete: list[int]) -> None:
            if i == len(pending):
                leaves.append((true, false, add, delete))
                if len(leaves) > MAX_VARIANTS:
                    raise _TooMany()
                return
            cond, (adds, deletes) = pending[i]
            cond = _assume(cond, true, false)
            if cond is True or cond is False:
                fire(i + 1, true, false, add + adds if cond else add, delete + deletes if cond else delete)
                return
            for t, n in _dnf(cond):
                fire(i + 1, true | t, false | n, add + adds, delete + deletes)
            for t, n in _dnf(_g_not(cond)):
                fire(i + 1, true | t, false | n, add, delete)

        for t, n in _dnf(_assume(_numbered(instance.pre, ids), true0, false0)):
            fire(0, true0 | t, false0 | n, add, delete)
        return leaves


class _AdlGoal:
    """The ADL conjuncts of a problem's goals, ground. ``literals`` when, with the
    other goals, they are one conjunction of literals; else ``formula`` (the whole
    goal over fact numbers) is compiled into GOAL_FACT; ``false``: those that can
    never hold."""

    def __init__(self, problem: PlanningProblem, formulas: _Formulas, ids: dict[Compound, int]) -> None:
        self.ids = ids
        terms = [g for g in problem.goals if _is_adl_term(g)]
        parts = [_numbered(formulas.ground(term, {}), ids) for term in terms]
        self.false = [term for term, part in zip(terms, parts) if part is False]
        self.literals: tuple[list[int], list[int]] = ([], [])
        self.formula: GroundFormula | None = None
        self.facts: frozenset[int] = frozenset()
        if self.false:
            return
        adl = _g_and(parts)
        try:
            options: list[Disjunct] | None = _dnf(adl)
        except _TooMany:
            options = None
        if options is not None and len(options) <= 1:
            if not options:
                self.false = terms
                return
            order = list(_facts_of(adl, {}))
            true, false = options[0]
            self.literals = (sorted(true, key=order.index), sorted(false, key=order.index))
            return
        plain: list[GroundFormula] = []
        for g in problem.goals:
            if _is_adl_term(g) or _is_test(g) or type(g) is not Compound:
                continue
            negative = g.functor == "not" and len(g.args) == 1
            fact = g.args[0] if negative else g
            plain.append(_numbered((("-" if negative else "+"), fact), ids))
        self.formula = _g_and([*plain, adl])
        self.facts = frozenset(_facts_of(self.formula, {}))

    def finish(self, goal: list[int], goal_neg: list[int], unreachable: list[Term],
               init: frozenset[int]) -> frozenset[int]:
        """Put the ADL goals into ``goal``, ``goal_neg`` and ``unreachable``; the
        initial state, with GOAL_FACT when the compiled goal holds in it."""
        unreachable.extend(self.false)
        goal.extend(self.literals[0])
        goal_neg.extend(self.literals[1])
        if self.formula is None:
            return init
        reached = self.ids[GOAL_FACT]
        goal[:] = [reached]
        goal_neg[:] = []
        return init | {reached} if _holds_in(self.formula, init) else init

    def split(self, leaves: list[_Leaf], exact: bool = False) -> list[_Leaf]:
        """Each variant that changes a fact of the goal: one that adds GOAL_FACT per
        disjunct of the goal regressed through it (the goal holds after it), and one
        without more preconditions that deletes it (module docstring); ``exact``
        (uncontrolled actions, which happen whenever they can): the one that deletes
        it only where the goal does not hold after it."""
        reached = self.ids[GOAL_FACT]
        out: list[_Leaf] = []
        for true, false, add, delete in leaves:
            adds = set(add)
            deletes = set(delete) - adds
            if self.facts.isdisjoint(adds) and self.facts.isdisjoint(deletes):
                out.append((true, false, add, delete))
                continue

            holds = _assume(_assume(self.formula, frozenset(adds), frozenset(deletes)), true, false)
            if holds is True or holds is False:
                out.append((true, false, add + [reached] if holds else add,
                            delete if holds else delete + [reached]))
                continue
            for t, n in _dnf(holds):
                out.append((true | t, false | n, add + [reached], delete))
            for t, n in (_dnf(_g_not(holds)) if exact else [(frozenset(), frozenset())]):
                out.append((true | t, false | n, add, delete + [reached]))
            if len(out) > MAX_VARIANTS:
                raise _TooMany()
        return out

"""hFF, the FF heuristic (Hoffmann & Nebel's relaxed plan), with helpful actions.

Use :func:`relaxed_plan_heuristic` to get the one for a task; the searches of
:mod:`~atlas_rap.planner.search` and :mod:`~atlas_rap.planner.landmarks` call
its ``evaluate(state)`` once per state they evaluate, and it returns

- **h**: the number of actions of a relaxed plan (deletes ignored) from
  ``state`` to the goals, or infinity when the goals are unreachable even so;
- **the applicable actions** (their numbers): the relaxed exploration finds
  them in its first layer, so generating successors costs nothing more;
- **the helpful actions**: the relaxed plan's actions that are applicable
  in the state (Fast Downward's preferred operators for hFF; FF's helpful
  actions, every applicable action adding a fact the relaxed plan needs at
  its first layer, are more: on the thirteen IPC domains, p01-p10, the
  LAMA search took 4 % less CPU with these, 2026-12-05).

The exploration is layered (each fact gets the first layer it is reached in)
and counts satisfied preconditions per action; the relaxed plan takes, for
each fact it needs, the first achiever that fired in the layer before.
``additive=True`` extracts it instead from h_add's *best supporters*, as Fast
Downward's ``ff()`` does (:class:`AdditiveRelaxedPlanHeuristic`): better
guidance where the layered plan picks expensive achievers, at about twice
the cost (the exploration must go on until every goal's cost is final); the
search restarts with it when it stagnates (:mod:`~atlas_rap.planner.solve`).
Two backends compute each:

- :class:`RelaxedPlanHeuristic`, pure Python over lists: each evaluation
  touches each (fact, action) precondition incidence at most once.
- :class:`VectorRelaxedPlanHeuristic`, numpy and scipy.sparse: each layer is a
  sparse matrix-vector product over the precondition incidences and one over
  the add incidences (by scipy's compiled kernel, called directly:
  :class:`_Product`). A layer costs some 15 µs of calls, so it pays only on
  large tasks whose goals are few layers away: on depot p12 (3,762 actions,
  16,542 incidences, 10 layers) it evaluates in 0.47 ms against 0.93 ms; on
  blocks with 15 blocks (1,185 incidences, 13 layers) it would take 0.24 ms
  against 0.14; on triangle-tireworld p40 (16,558 incidences but 80 layers)
  3.4 ms against 2.0.
- For h_add's relaxed plan, :class:`AdditiveRelaxedPlanHeuristic` (Python,
  Dijkstra's over integer buckets) and
  :class:`VectorAdditiveRelaxedPlanHeuristic` (numpy, Bellman-Ford rounds of
  the same two products); the costs weighed are the layered ones times
  ADDITIVE_PYTHON_FACTOR and ADDITIVE_NUMPY_FACTOR.

:func:`relaxed_plan_heuristic` estimates both costs from the task's size and
the number of layers between its initial state and its goals (constants
measured on the shared benchmarks, 2026-12-02). Importing scipy costs about
0.25 s, more than many whole searches, so where numpy is cheaper the search
starts in Python and changes to numpy after as many evaluations as it takes
the saving to repay the import (:class:`SwitchingRelaxedPlanHeuristic`). The
change comes after a count of evaluations, never a time, so the same task
still gives the same plan.

Both extract the relaxed plan backwards from the goals, choosing for a fact
of layer ``l`` an achiever that fired in layer ``l - 1``; they choose by
different rules (the first to fire in Python, the lowest number in numpy), so
the same task always gets the same backend and the same plans, but the two
can differ in h on the same state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

from atlas_rap.planner.ground import GroundAction, GroundTask

INFINITY = float("inf")
PYTHON_SECONDS_PER_INCIDENCE = 56e-9  # an evaluation in Python, per precondition incidence
NUMPY_SECONDS_PER_LAYER = 15e-6  # an evaluation in numpy, per layer: the calls ...
NUMPY_SECONDS_PER_LAYER_INCIDENCE = 1.5e-9  # ... and the products, per precondition incidence
NUMPY_IMPORT_SECONDS = 0.25  # importing numpy and scipy.sparse
ADDITIVE_PYTHON_FACTOR = 2.4  # h_add's exploration against the layered one, in Python (1.8-3.0 measured) ...
ADDITIVE_NUMPY_FACTOR = 1.5  # ... and in numpy (1.1-1.6), on transport, depot and elevators, 2026-12-05


@dataclass(frozen=True)
class BackendCosts:
    """The costs :func:`relaxed_plan_heuristic` weighs to choose a backend; the defaults are the measured ones."""

    python_seconds_per_incidence: float = PYTHON_SECONDS_PER_INCIDENCE
    numpy_seconds_per_layer: float = NUMPY_SECONDS_PER_LAYER
    numpy_seconds_per_layer_incidence: float = NUMPY_SECONDS_PER_LAYER_INCIDENCE
    numpy_import_seconds: float = NUMPY_IMPORT_SECONDS
    additive_python_factor: float = ADDITIVE_PYTHON_FACTOR
    additive_numpy_factor: float = ADDITIVE_NUMPY_FACTOR


MEASURED_COSTS = BackendCosts()


def relaxed_plan_heuristic(task: GroundTask, actions: Sequence[GroundAction] | None = None, *,
                           costs: BackendCosts = MEASURED_COSTS, additive: bool = False) -> RelaxedPlanHeuristic:
    """The hFF of ``task`` over ``actions`` (default its own), with the backend that
    should evaluate its states faster by ``costs`` (module docstring); ``additive``, by h_add's
    best supporters (:class:`AdditiveRelaxedPlanHeuristic`)."""
    python = (AdditiveRelaxedPlanHeuristic if additive else RelaxedPlanHeuristic)(task, actions)
    incidences = sum(python.pre_count)
    python_cost = incidences * costs.python_seconds_per_incidence
    if python_cost < 5 * costs.numpy_seconds_per_layer:
        return python  # no need to look: five numpy layers would cost more than a whole evaluation here
    if RelaxedPlanHeuristic.evaluate(python, task.init)[0] in (0, INFINITY):  # layered: it counts the layers
        return python
    numpy_cost = python.layers * (costs.numpy_seconds_per_layer + incidences * costs.numpy_seconds_per_layer_incidence)
    if additive:
        python_cost *= costs.additive_python_factor
        numpy_cost *= costs.additive_numpy_factor
    saving = python_cost - numpy_cost
    if saving <= 0:
        return python
    after = math.ceil(costs.numpy_import_seconds / saving)
    return SwitchingRelaxedPlanHeuristic(task, actions, after=after, built=python, additive=additive)


class RelaxedPlanHeuristic:
    """hFF over a task's actions in pure Python (module docstring).

    It also holds, once, what the searches need to apply an action by number:
    ``negs`` (negative preconditions), ``deletes`` and ``add_sets`` (frozensets),
    and the incidence lists the landmark finder uses (``pre_of``, ``pres``, ``adds``).
    ``layers`` is how many layers the last evaluation that reached the goals took.

    ``built``, one already made for the same task and actions, lends its lists
    (nothing changes them after they are built) instead of building them again.
    """

    _BUILT = ("actions", "n_facts", "pre_of", "pre_count", "adds", "pres", "no_pre", "goal", "is_goal_fact",
              "n_goals", "negs", "deletes", "add_sets")

    def __init__(self, task: GroundTask, actions: Sequence[GroundAction] | None = None, *,
                 built: RelaxedPlanHeuristic | None = None) -> None:
        self.layers = 0
        if built is not None:
            for name in self._BUILT:
                setattr(self, name, getattr(built, name))
            return
        self.actions = list(task.actions if actions is None else actions)
        self.n_facts = n_facts = len(task.facts)
        self.pre_of: list[list[int]] = [[] for _ in range(n_facts)]
        self.pre_count: list[int] = []
        self.adds: list[tuple[int, ...]] = []
        self.pres: list[tuple[int, ...]] = []
        self.no_pre: list[int] = []
        for i, action in enumerate(self.actions):
            for f in action.pre:
                self.pre_of[f].append(i)
            self.pre_count.append(len(action.pre))
            self.adds.append(action.add)
            self.pres.append(action.pre)
            if not action.pre:
                self.no_pre.append(i)
        self.goal = task.goal
        self.is_goal_fact = [False] * n_facts
        for g in self.goal:
            self.is_goal_fact[g] = True
        self.n_goals = len(set(self.goal))
        self.negs = [a.neg for a in self.actions]
        self.deletes = [frozenset(a.delete) for a in self.actions]
        self.add_sets = [frozenset(a.add) for a in self.actions]

    def evaluate(self, state: frozenset[int]) -> tuple[float, list[int], set[int]]:
        """(h, applicable action numbers, helpful action numbers) of ``state``."""
        counter = self.pre_count[:]
        pre_of = self.pre_of
        adds = self.adds
        is_goal = self.is_goal_fact
        level = [-1] * self.n_facts
        for f in state:
            level[f] = 0
        missing = self.n_goals - sum(1 for g in set(self.goal) if level[g] == 0)
        achiever: dict[int, int] = {}
        fired: list[int] = list(self.no_pre)
        new_facts: list[int] | frozenset[int] = state
        applicable: list[int] = fired
        layer = 0
        while True:
            append = fired.append
            for f in new_facts:
                for a in pre_of[f]:
                    c = counter[a] - 1
                    counter[a] = c
                    if c == 0:
                        append(a)
            if layer == 0 and missing == 0:
                return 0, applicable, set()
            following: list[int] = []
            layer += 1
            for a in fired:
                for g in adds[a]:
                    if level[g] < 0:
                        level[g] = layer
                        achiever[g] = a
                        following.append(g)
                        if is_goal[g]:
                            missing -= 1
            if not following:
                return INFINITY, applicable, set()
            if missing <= 0:
                break
            new_facts = following
            fired = []
        self.layers = layer
        return self._relaxed_plan(level, achiever.__getitem__, applicable)

    def _relaxed_plan(self, level: Sequence[float], achiever: Callable[[int], int],
                      applicable: list[int]) -> tuple[int, list[int], set[int]]:
        """h and the helpful actions, from each fact's layer (or h_add cost: 0 in the state, 1 one
        action away) and ``achiever(fact)``: the actions of the relaxed plan applicable in the state
        (those achieving a fact of the first layer)."""
        pres = self.pres
        relaxed: set[int] = set()
        helpful: set[int] = set()
        goals = self.goal
        marked: set[int] = set(goals)
        stack = [g for g in goals if level[g] > 0]
        while stack:
            g = stack.pop()
            a = achiever(g)
            if a in relaxed:
                continue
            relaxed.add(a)
            if level[g] == 1:
                helpful.add(a)
            for p in pres[a]:
                if p not in marked and level[p] > 0:
                    marked.add(p)
                    stack.append(p)
        return len(relaxed), applicable, helpful


class AdditiveRelaxedPlanHeuristic(RelaxedPlanHeuristic):
    """hFF as Fast Downward's ``ff()`` computes it: the relaxed plan follows each fact's *best
    supporter* by h_add (the achiever whose preconditions cost least in sum, unit costs), and the
    helpful actions are the relaxed plan's actions applicable in the state.

    The exploration is Dijkstra's over facts with buckets (the costs are small integers): a fact
    is final when taken from its bucket, an action fires when its last precondition is, at one
    plus the sum of its preconditions' costs. It goes on until every goal is final, past the
    layer where the layered exploration stops: about twice its cost per evaluation.
    """

    def evaluate(self, state: frozenset[int]) -> tuple[float, list[int], set[int]]:
        counter = self.pre_count[:]
        pre_of, adds, pres = self.pre_of, self.adds, self.pres
        unreached = 1 << 30
        cost = [unreached] * self.n_facts
        for f in state:
            cost[f] = 0
        support: dict[int, int] = {}
        is_goal = self.is_goal_fact
        missing = self.n_goals
        buckets: list[list[int]] = [list(state), []]  # the facts reached at each cost
        applicable = list(self.no_pre)
        for a in applicable:
            for g in adds[a]:
                if cost[g] > 1:
                    cost[g] = 1
                    support[g] = a
                    buckets[1].append(g)
        c = 0
        while c < len(buckets):
            for f in buckets[c]:
                if cost[f] != c:
                    continue
                if is_goal[f]:
                    missing -= 1
                for a in pre_of[f]:
                    left = counter[a] - 1
                    counter[a] = left
                    if left == 0:
                        if c == 0:
                            applicable.append(a)
                            through = 1
                        else:
                            through = 1 + sum([cost[p] for p in pres[a]])
                        for g in adds[a]:
                            if through < cost[g]:
                                cost[g] = through
                                support[g] = a
                                while len(buckets) <= through:
                                    buckets.append([])
                                buckets[through].append(g)
            if missing <= 0:
                break
            c += 1
        else:
            return INFINITY, applicable, set()
        if c == 0:
            return 0, applicable, set()
        # a fact of cost 1 is one whose supporter applies in the state: the "first layer" of the extraction
        return self._relaxed_plan(cost, support.__getitem__, applicable)


class VectorRelaxedPlanHeuristic(RelaxedPlanHeuristic):
    """hFF with the exploration as sparse matrix-vector products (module docstring)."""

    def __init__(self, task: GroundTask, actions: Sequence[GroundAction] | None = None, *,
                 built: RelaxedPlanHeuristic | None = None) -> None:
        import numpy as np  # here, not at the top: they cost `atlas plan` 0.1 s of start-up on small tasks
        from scipy import sparse

        super().__init__(task, actions, built=built)
        self._np = np
        n_actions, n_facts = len(self.actions), self.n_facts
        self.pre_matrix = _precondition_matrix(self, np.int32)
        rows = [f for add in self.adds for f in add]
        cols = [a for a, add in enumerate(self.adds) for _ in add]
        self.add_matrix = sparse.csr_matrix((np.ones(len(rows), dtype=np.int32), (rows, cols)),
                                            shape=(n_facts, n_actions))
        self.pre_needed = np.array(self.pre_count, dtype=np.int32)
        self.goal_mask = np.zeros(n_facts, dtype=bool)
        self.goal_mask[list(self.goal)] = True
        self.adders = _adders(self)
        self.pre_product, self.add_product = _Product(self.pre_matrix), _Product(self.add_matrix)

    def evaluate(self, state: frozenset[int]) -> tuple[float, list[int], set[int]]:
        np, n_facts = self._np, self.n_facts
        needed = self.pre_needed
        count_pres, count_adds = self.pre_product.add_into, self.add_product.add_into
        facts = np.fromiter(state, dtype=np.intp, count=len(state))
        reached = np.zeros(n_facts, dtype=bool)
        reached[facts] = True
        fact_level = np.full(n_facts, -1, dtype=np.int32)
        fact_level[facts] = 0
        action_level = np.full(len(needed), -1, dtype=np.int32)
        satisfied = np.zeros(len(needed), dtype=np.int32)
        count_pres(reached.astype(np.int32), satisfied)
        fired = satisfied == needed
        applicable = np.flatnonzero(fired).tolist()
        missing = self.goal_mask & ~reached
        if not missing.any():
            return 0, applicable, set()
        new_actions = fired
        layer = 0
        while True:
            action_level[new_actions] = layer
            layer += 1
            gained = np.zeros(n_facts, dtype=np.int32)
            count_adds(new_actions.astype(np.int32), gained)
            new_facts = (gained > 0) & ~reached
            if not new_facts.any():
                return INFINITY, applicable, set()
            reached |= new_facts
            fact_level[new_facts] = layer
            missing &= ~new_facts
            if not missing.any():
                break
            count_pres(new_facts.astype(np.int32), satisfied)
            now = satisfied == needed
            new_actions = now & ~fired
            fired = now
        levels = fact_level.tolist()
        fired_in = action_level.tolist()
        adders = self.adders

        def achiever(fact: int) -> int:
            wanted = levels[fact] - 1
            return next(a for a in adders[fact] if fired_in[a] == wanted)

        return self._relaxed_plan(levels, achiever, applicable)


class VectorAdditiveRelaxedPlanHeuristic(RelaxedPlanHeuristic):
    """:class:`AdditiveRelaxedPlanHeuristic` with numpy: h_add as Bellman-Ford rounds, each a
    sparse matrix-vector product over the precondition incidences (an action's cost, one plus
    its preconditions') and a minimum over each fact's achievers, until nothing changes.
    Best supporters: of a fact's cheapest achievers, the lowest numbered."""

    def __init__(self, task: GroundTask, actions: Sequence[GroundAction] | None = None, *,
                 built: RelaxedPlanHeuristic | None = None) -> None:
        import numpy as np

        super().__init__(task, actions, built=built)
        self._np = np
        self.pre_matrix = _precondition_matrix(self, np.float64)
        pairs = sorted((f, a) for a, add in enumerate(self.adds) for f in add)
        self.add_facts = np.array(sorted({f for f, _ in pairs}), dtype=np.intp)
        self.add_actions = np.array([a for _, a in pairs], dtype=np.intp)
        fact_of_pair = np.array([f for f, _ in pairs], dtype=np.intp)
        self.add_starts = (np.flatnonzero(np.r_[True, fact_of_pair[1:] != fact_of_pair[:-1]]) if pairs
                           else np.zeros(0, dtype=np.intp))
        self.adders = _adders(self)
        self.pre_product = _Product(self.pre_matrix)

    def _action_costs(self, cost):
        """One plus the sum of each action's preconditions' costs."""
        action_cost = self._np.ones(len(self.pres))
        self.pre_product.add_into(cost, action_cost)
        return action_cost

    def evaluate(self, state: frozenset[int]) -> tuple[float, list[int], set[int]]:
        np = self._np
        cost = np.full(self.n_facts, np.inf)
        cost[np.fromiter(state, dtype=np.intp, count=len(state))] = 0.0
        goal = list(self.goal)
        action_cost = self._action_costs(cost)
        applicable = np.flatnonzero(action_cost == 1.0).tolist()
        if not cost[goal].any():
            return 0, applicable, set()
        facts, starts, via = self.add_facts, self.add_starts, self.add_actions
        while len(via):
            cheapest = np.minimum.reduceat(action_cost[via], starts)
            improved = cheapest < cost[facts]
            if not improved.any():
                break
            cost[facts[improved]] = cheapest[improved]
            action_cost = self._action_costs(cost)
        if np.isinf(cost[goal]).any():
            return INFINITY, applicable, set()
        through, adders = action_cost.tolist(), self.adders

        def supporter(fact: int) -> int:
            return min(adders[fact], key=through.__getitem__)

        return self._relaxed_plan(cost.tolist(), supporter, applicable)


def _adders(heuristic: RelaxedPlanHeuristic) -> list[list[int]]:
    """For each fact, the actions that add it, in order."""
    adders: list[list[int]] = [[] for _ in range(heuristic.n_facts)]
    for a, add in enumerate(heuristic.adds):
        for f in add:
            adders[f].append(a)
    return adders


def _precondition_matrix(heuristic: RelaxedPlanHeuristic, dtype):
    """The (actions × facts) sparse matrix with a one where an action needs a fact."""
    import numpy as np
    from scipy import sparse

    rows = [a for a, pre in enumerate(heuristic.pres) for _ in pre]
    cols = [f for pre in heuristic.pres for f in pre]
    return sparse.csr_matrix((np.ones(len(rows), dtype=dtype), (rows, cols)),
                             shape=(len(heuristic.actions), heuristic.n_facts))


class _Product:
    """``y += M @ x`` for a scipy CSR matrix ``M``, by scipy's own compiled kernel
    (``scipy.sparse._sparsetools.csr_matvec``, what ``M @ x`` calls) when it is there: ``M @ x``
    spends more time in scipy's Python checks than in the product on these sizes (on elevators
    p20, 15 against 12 µs a product, 20 % of an evaluation). If a scipy release moves the
    kernel, ``M @ x`` does the same sums."""

    def __init__(self, matrix) -> None:
        try:
            from scipy.sparse._sparsetools import csr_matvec
        except ImportError:  # pragma: no cover - a private module: scipy 1.17 has it, a later release may not
            csr_matvec = None
        self.matrix = matrix
        self._kernel = csr_matvec
        self._args = (*matrix.shape, matrix.indptr, matrix.indices, matrix.data)

    def add_into(self, x, y) -> None:
        """``y += M @ x``: ``x`` and ``y`` of the matrix's dtype, ``y`` contiguous."""
        if self._kernel is None:
            y += self.matrix @ x
        else:
            self._kernel(*self._args, x, y)


class SwitchingRelaxedPlanHeuristic(RelaxedPlanHeuristic):
    """hFF in Python for the first ``after`` evaluations, then in numpy (module docstring);
    ``additive``, both by h_add's best supporters."""

    def __init__(self, task: GroundTask, actions: Sequence[GroundAction] | None = None, *, after: int,
                 built: RelaxedPlanHeuristic | None = None, additive: bool = False) -> None:
        super().__init__(task, actions, built=built)
        self.task, self.after, self.evaluated = task, after, 0
        self._python = AdditiveRelaxedPlanHeuristic.evaluate if additive else RelaxedPlanHeuristic.evaluate
        self._vector_class = VectorAdditiveRelaxedPlanHeuristic if additive else VectorRelaxedPlanHeuristic
        self._vector: RelaxedPlanHeuristic | None = None

    def evaluate(self, state: frozenset[int]) -> tuple[float, list[int], set[int]]:
        if self._vector is not None:
            return self._vector.evaluate(state)
        self.evaluated += 1
        if self.evaluated > self.after:
            # built once: a search may hold on to this bound method, so it must not build one per call
            self._vector = self._vector_class(self.task, self.actions, built=self)
            return self._vector.evaluate(state)
        return self._python(self, state)

"""The plan the planner returns (docs/language/ap.md, What the planner returns): steps with agents and times,
orderings, causal links, simultaneity, counterplan steps, risk and the threats
that make it; as text, JSON and Graphviz DOT. A result that is not a plan (an
unsolvable problem, bad input: :func:`plan_of_error`) has the same JSON form,
with its ``reason`` and located ``problems``.

Each operator of the partial order is expanded by its ``:plot`` into the
steps RAPs execute, hierarchically: a plot step that is the purpose of
another operator of the plan's task is expanded by that operator (so a plot
may name goals as well as actions); an operator without a plot is one step,
``(OPERATOR-NAME VALUE ...)``. Orderings between operators become orderings
from the last steps of one to the first steps of the other. Choices where
the language is silent:

- a plot step's agent is its first argument when that is an agent, else the
  operator's ``:agent``;
- an operator's ``:duration`` is shared by its plot: each step lasts the
  duration divided by the number of steps on the plot's longest sequential
  chain, so the expansion takes exactly the operator's duration;
- steps start as soon as everything ordered before them has ended and
  their agent is free (an agent does one step at a time, in the order of
  the plan's linearisation); the steps of one ``simultaneous`` group start
  together (at the latest of their earliest starts); the makespan is the
  latest end.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from atlas_rap.errors import AtlasError, Problem, SourceError
from atlas_rap.logic import Compound, Term, substitute, term_to_str
from atlas_rap.planner.checks import UnreachableGoals
from atlas_rap.planner.counterplan import Assessment, Protected, happening
from atlas_rap.planner.ground import GroundAction, GroundTask
from atlas_rap.planner.partial_order import INIT, PartialOrder

MAX_PLOT_DEPTH = 16
DEADLINE_SLACK = 1e-9  # seconds: a makespan this much past a deadline (rounding of shared durations) meets it


@dataclass
class PlanStep:
    """One executable step: ``action`` as written in the plot with bindings (or the
    operator's name and values), the ``operator`` it belongs to, its agent, its
    times, and the index of the operator step of the partial order it expands.
    ``purpose`` is the operator's purpose with bindings when the step is a whole
    operator that has one (RAPs are matched to it), else the action itself.
    ``needs`` are the operator's preconditions with its bindings, static facts
    included: the causal links leave out facts that no operator changes, and a
    plan being carried out watches these too."""

    id: int
    action: Compound
    operator: str
    agent: str | None
    start: float
    end: float
    source: int
    purpose: Term | None = None
    binding: dict = field(default_factory=dict, repr=False)
    needs: tuple[Term, ...] = field(default=(), repr=False)


@dataclass(frozen=True)
class PlanThreat:
    """What may still defeat the plan: the uncontrolled ``action`` (as written, with
    its values) may happen after step ``after`` and delete ``fact``, which the causal
    link ``producer -> consumer`` needs kept (``"init"``: the initial state,
    ``"goal"``: the goals), with ``probability``. ``event`` numbers the distinct
    happenings (an event in a state, :func:`~atlas_rap.planner.counterplan.happening`):
    threats that share one are a single chance of defeat, counted once in the risk."""

    action: Compound
    operator: str
    agent: str | None
    after: int
    producer: int | str
    consumer: int | str
    fact: str
    probability: float
    event: int

    def to_dict(self) -> dict[str, object]:
        """The JSON form; ``link`` is the threatened entry of the plan's ``links``."""
        return {"action": term_to_str(self.action), "operator": self.operator, "agent": self.agent,
                "after": self.after, "link": {"from": self.producer, "to": self.consumer, "fact": self.fact},
                "probability": self.probability, "event": self.event}

    def describe(self) -> str:
        """One line for a reader: what may happen when, and which link it breaks."""
        source = "the initial state" if self.producer == "init" else f"step {self.producer}"
        need = "the goals" if self.consumer == "goal" else f"step {self.consumer}"
        return (f"p {self.probability:g}: {term_to_str(self.action)} after step {self.after} may undo "
                f"{self.fact} (from {source}, needed by {need})")


@dataclass
class Plan:
    """The planner's answer; ``status`` is ``solved``, ``unsolvable`` or ``timeout``
    (or ``error`` for bad input, :func:`plan_of_error`). ``threats`` are what the
    ``risk`` is made of; ``problems`` the located reasons there is no plan.
    ``limits`` are the run's limits and what happened to them
    (:meth:`~atlas_rap.planner.limits.Limits.to_dict`; None for bad input);
    ``limited`` says in words, when a limit ran out after a plan was found,
    what the plan is (the best by then), for the text output.
    ``deadline`` is the time (seconds from the plan's start) by which its goals
    must be achieved (``PlanningProblem.deadline_for``), or None; a solved plan
    whose makespan is past it is still a plan, but :attr:`meets_deadline` is False.
    ``cost`` is the plan's cost, the sum of its actions' (PDDL ``:action-costs``), or None
    when the problem does not measure plans by cost (then it is the number of actions)."""

    status: str
    steps: list[PlanStep] = field(default_factory=list)
    orderings: list[tuple[int, int]] = field(default_factory=list)
    links: list[tuple[int | str, int | str, str]] = field(default_factory=list)
    simultaneous: list[list[int]] = field(default_factory=list)
    counterplan: list[dict[str, object]] = field(default_factory=list)
    risk: float = 0.0
    threats: list[PlanThreat] = field(default_factory=list)
    risk_before_counterplanning: float = 0.0
    makespan: float = 0.0
    sequence: list[Compound] = field(default_factory=list)
    stats: dict[str, float | int] = field(default_factory=dict)
    timing: dict[str, float] = field(default_factory=dict)
    reason: str = ""
    problems: list[Problem] = field(default_factory=list)
    deadline: float | None = None
    limits: dict[str, object] | None = None
    limited: str = ""
    cost: float | None = None

    @property
    def meets_deadline(self) -> bool:
        """True when there is no deadline or the makespan is within it."""
        return self.deadline is None or self.makespan <= self.deadline + DEADLINE_SLACK

    def to_dict(self, timing: bool = False) -> dict[str, object]:
        """The JSON form of docs/language/ap.md, What the planner returns. ``stats`` holds counts only, so the same
        input gives the same JSON; ``timing`` (CPU seconds) only when asked for;
        ``deadline`` and ``meets_deadline`` only when the plan has a deadline."""
        return {
            "status": self.status,
            "steps": [{"id": s.id, "action": term_to_str(s.action), "operator": s.operator, "agent": s.agent,
                       "start": _number(s.start), "end": _number(s.end)} for s in self.steps],
            "orderings": [list(pair) for pair in self.orderings],
            "links": [{"from": a, "to": b, "fact": fact} for a, b, fact in self.links],
            "simultaneous": self.simultaneous,
            "counterplan": self.counterplan,
            "risk": self.risk,
            "threats": [t.to_dict() for t in self.threats],
            "risk_before_counterplanning": self.risk_before_counterplanning,
            "makespan": _number(self.makespan),
            "cost": _number(self.cost if self.cost is not None else len(self.sequence)),
            **({"deadline": _number(self.deadline), "meets_deadline": self.meets_deadline}
               if self.deadline is not None else {}),
            "stats": self.stats,
            **({"timing": self.timing} if timing else {}),
            **({"reason": self.reason} if self.reason else {}),
            "limits": self.limits,
            "problems": [_problem_dict(p) for p in self.problems],
        }

    def to_json(self, timing: bool = False) -> str:
        return json.dumps(self.to_dict(timing), indent=2)

    def to_text(self) -> str:
        """A readable listing: the steps by start time, then links and counterplan."""
        if self.status != "solved":
            return f"{self.status}" + (f": {self.reason}" if self.reason else "")
        makespan = self.deadline_text() or f"makespan {_number(self.makespan)}"
        cost = f"cost {_number(self.cost)}, " if self.cost is not None else ""
        lines = [f"solved: {len(self.steps)} steps, {cost}{makespan}, "
                 f"parallel length {self.stats.get('parallel_length', '?')}, risk {self.risk:g}"]
        if self.limited:
            lines.append(f"  note: {self.limited}")
        before = {s.id: [] for s in self.steps}
        for a, b in self.orderings:
            before[b].append(a)
        together = {i: group for group in self.simultaneous for i in group}
        counters_of: dict[object, list[dict]] = {}
        for c in self.counterplan:
            counters_of.setdefault(c["step"], []).append(c)
        for s in sorted(self.steps, key=lambda s: (s.start, s.id)):
            notes = []
            if before[s.id]:
                notes.append("after " + ", ".join(map(str, sorted(before[s.id]))))
            if s.id in together:
                notes.append("with " + ", ".join(str(i) for i in together[s.id] if i != s.id))
            for c in counters_of.get(s.id, ()):
                notes.append(f"counters {c['threat']} (protects {c['protects']})")
            agent = f" [{s.agent}]" if s.agent else ""
            note = f"  ; {'; '.join(notes)}" if notes else ""
            lines.append(f"  {s.id:>3}  {_number(s.start):>6}-{_number(s.end):<6} {term_to_str(s.action)}{agent}{note}")
        if self.risk:
            lines.append(f"risk left: {self.risk:g} (an uncontrolled action may still defeat the plan)")
            lines.extend(f"  {t.describe()}" for t in self.threats)
        return "\n".join(lines)

    def deadline_text(self) -> str:
        """How the makespan stands to the deadline, e.g. ``makespan 160 breaks the
        deadline of 150 s`` (or ``... within the deadline ...``); "" without a deadline."""
        if self.deadline is None:
            return ""
        verb = "within" if self.meets_deadline else "breaks"
        return f"makespan {_number(self.makespan)} {verb} the deadline of {_number(self.deadline)} s"


def build_plan(task: GroundTask, order: PartialOrder, protected: Protected, stats: dict) -> Plan:
    """Expand the operators of ``order`` into plot steps, schedule them and collect
    the links, simultaneous groups and counterplan steps."""
    expander = _Expander(task)
    steps: list[PlanStep] = []
    entries: list[list[int]] = []
    exits: list[list[int]] = []
    inner: list[tuple[int, int]] = []
    groups: list[list[int]] = []
    for index, action in enumerate(order.steps):
        tree = expander.expand(action, 0)
        unit = action.duration / max(1, _chain(tree))
        first, last = _place(tree, index, unit, steps, inner, groups)
        entries.append(first)
        exits.append(last)
    orderings: set[tuple[int, int]] = set(inner)
    for a, b in order.reduced_orderings():
        orderings.update((x, y) for x in exits[a] for y in entries[b])
    _schedule(steps, orderings, groups)
    links = []
    for link in order.links:
        fact = term_to_str(task.facts[link.fact])
        if not link.positive:
            fact = f"(not {fact})"
        src: int | str = "init" if link.producer == INIT else exits[link.producer][0]
        dst: int | str = "goal" if link.consumer >= len(order.steps) else entries[link.consumer][0]
        links.append((src, dst, fact))
    counterplan = [{"step": exits[c.step][0], "threat": term_to_str(c.threat.term),
                    "protects": term_to_str(task.facts[c.fact])} for c in protected.counters]
    threats = _threats(task, order, protected.assessment, entries, exits)
    return Plan(status="solved", steps=steps, orderings=sorted(orderings), links=links,
                simultaneous=[g for g in groups if len(g) > 1], counterplan=counterplan,
                risk=protected.assessment.risk, threats=threats, risk_before_counterplanning=protected.first_risk,
                makespan=max((s.end for s in steps), default=0.0),
                sequence=[a.term for a in order.steps], stats=stats,
                cost=sum(a.cost for a in order.steps) if task.problem.action_costs else None)


def plan_of_error(error: AtlasError) -> Plan:
    """The result for input that gives no plan, in the plan's JSON form: ``unsolvable``
    when the only problems are goals no operator achieves, else ``error``; the
    ``reason`` says what is wrong and ``problems`` are its located problems."""
    problems = list(error.problems) if isinstance(error, SourceError) else []
    status = "unsolvable" if isinstance(error, UnreachableGoals) else "error"
    reason = "; ".join(p.message for p in problems) if problems else str(error)
    return Plan(status=status, reason=reason, problems=problems)


def _threats(task: GroundTask, order: PartialOrder, assessment: Assessment,
             entries: list[list[int]], exits: list[list[int]]) -> list[PlanThreat]:
    """The threats of ``assessment`` (on ``order``'s sequence of operators) in plan step
    ids: the step after which each may happen and the causal link it breaks."""
    producers = {(link.consumer, link.fact): link.producer for link in order.links if link.positive}
    events: dict[tuple, int] = {}
    found = []
    for t in assessment.threats:
        producer = producers[(t.consumer, t.fact)]
        found.append(PlanThreat(
            action=t.action.term, operator=t.action.operator.name,
            agent=t.action.agents[0] if t.action.agents else None,
            after=exits[t.after - 1][-1],
            producer="init" if producer == INIT else exits[producer][0],
            consumer="goal" if t.consumer >= len(order.steps) else entries[t.consumer][0],
            fact=term_to_str(task.facts[t.fact]), probability=t.action.probability,
            event=events.setdefault(happening(t), len(events) + 1)))
    return found


class _Expander:
    """Plot trees of ground actions: ('step', term, action, agent) leaves under
    ('sequence' | 'parallel' | 'simultaneous', parts) nodes."""

    def __init__(self, task: GroundTask) -> None:
        self.by_purpose: dict[Term, GroundAction] = {}
        for action in task.actions:
            purpose = action.operator.purpose
            if purpose is not None:
                self.by_purpose.setdefault(substitute(purpose, action.binding), action)

    def expand(self, action: GroundAction, depth: int) -> tuple:
        op = action.operator
        if op.plot is None or depth > MAX_PLOT_DEPTH:
            return ("step", action.term, action, action.agents[0] if action.agents else None)
        return self._plot(op.plot, action, depth)

    def _plot(self, plot, action: GroundAction, depth: int) -> tuple:
        from atlas_rap.lang import ast

        if isinstance(plot, ast.PlotGroup):
            return (plot.kind, [self._plot(part, action, depth) for part in plot.parts])
        term = substitute(plot.term, action.binding)
        sub = self.by_purpose.get(term)
        if sub is not None and sub.operator is not action.operator:
            return self.expand(sub, depth + 1)
        first = term.args[0] if term.args else None
        agent = first if first in action.agents else (action.agents[0] if action.agents else None)
        return ("step", term, action, agent)


def _chain(tree: tuple) -> int:
    kind = tree[0]
    if kind == "step":
        return 1
    lengths = [_chain(part) for part in tree[1]]
    return sum(lengths) if kind == "sequence" else max(lengths, default=0)


def _place(tree: tuple, index: int, unit: float, steps: list[PlanStep],
           inner: list[tuple[int, int]], groups: list[list[int]]) -> tuple[list[int], list[int]]:
    """Add the tree's steps; return the ids of its first and last steps."""
    kind = tree[0]
    if kind == "step":
        _, term, action, agent = tree
        purpose = action.operator.purpose if term == action.term else None
        step = PlanStep(id=len(steps) + 1, action=term, operator=action.operator.name,
                        agent=None if agent is None else str(agent), start=0.0, end=unit, source=index,
                        purpose=term if purpose is None else substitute(purpose, action.binding),
                        needs=tuple(substitute(pre, action.binding) for pre in action.operator.preconditions),
                        binding=action.binding)
        steps.append(step)
        return [step.id], [step.id]
    parts = [_place(part, index, unit, steps, inner, groups) for part in tree[1]]
    if kind == "sequence":
        for (_, last), (first, _) in zip(parts, parts[1:]):
            inner.extend((a, b) for a in last for b in first)
        return parts[0][0] if parts else [], parts[-1][1] if parts else []
    if kind == "simultaneous":
        groups.append([i for first, _ in parts for i in first])
    return [i for first, _ in parts for i in first], [i for _, last in parts for i in last]


def _schedule(steps: list[PlanStep], orderings: set[tuple[int, int]], groups: list[list[int]]) -> None:
    """Start each step when its predecessors have ended and its agent is free (an
    agent does one step at a time, in step order); a simultaneous group starts
    together."""
    before: dict[int, list[int]] = {s.id: [] for s in steps}
    for a, b in orderings:
        before[b].append(a)
    by_id = {s.id: s for s in steps}
    group_of = {i: group for group in groups if len(group) > 1 for i in group}
    free: dict[str, float] = {}
    done: set[int] = set()
    for step in steps:  # ids are a topological order
        if step.id in done:
            continue
        members = group_of.get(step.id, [step.id])
        start = max((by_id[p].end for m in members for p in before[m] if p not in members), default=0.0)
        start = max([start] + [free.get(by_id[m].agent, 0.0) for m in members if by_id[m].agent])
        for m in members:
            s = by_id[m]
            length = s.end - s.start
            s.start, s.end = start, start + length
            if s.agent:
                free[s.agent] = s.end
            done.add(m)


def _problem_dict(problem: Problem) -> dict[str, object]:
    loc = problem.location
    return {"file": loc.file, "line": loc.line, "column": loc.column, "message": problem.message,
            "hint": problem.hint, "severity": problem.severity}


def _number(x: float) -> float | int:
    return int(x) if float(x).is_integer() else round(x, 6)

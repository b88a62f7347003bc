"""Typed, frozen AST nodes for RAP (.rap) and AP (.ap) files.

The validator (``validator.py``) builds these from the reader's forms; the
sequencer and the planner consume them. Every node carries ``loc``, the
:class:`~atlas_rap.errors.SourceLocation` of the form it came from, so any
later error or trace line can point back into the source. ``loc`` does not
take part in equality: two nodes read from different places but meaning
the same thing compare equal (that is what the round-trip tests check).

Queries, facts and task calls inside nodes are logic terms
(``atlas_rap.logic``), ready for unification and memory.

The language reference, docs/language/, documents every form; the sections below
follow its pages.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Union

from atlas_rap.errors import NOWHERE, SourceLocation
from atlas_rap.logic import Compound, MemoryRule, Term, Var


def _loc() -> SourceLocation:
    return field(default=NOWHERE, compare=False, repr=False)


# ----------------------------------------------------------------- task nets, wait-for (rap.md)

@dataclass(frozen=True, slots=True)
class WaitFor:
    """``(wait-for QUERY [OUTCOME] [:timeout S])``: block until QUERY holds.

    ``outcome`` is the keyword the step ends with when QUERY matches
    (``:succeed`` when not written); ``timeout`` in seconds, or None.
    """

    query: Term
    outcome: str = ":succeed"
    timeout: float | None = None
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class MemoryOp:
    """``(assert FACT)`` or ``(retract FACT)`` as a net step or script action."""

    kind: str  # 'assert' or 'retract'
    fact: Compound
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class PlanRequest:
    """``(plan GOAL ... [:deadline S] [:max-failures N])``: plan for these goals and
    execute the plan.

    A top-level form of a mission, and a net item too (``NET := ... | PLAN``):
    bare in a ``sequence``, ``parallel`` or ``task-net``, or as the task of a
    labelled :class:`Step`. ``deadline`` (seconds, > 0) is for the whole
    request: every goal must be achieved within it, counted from the request
    (the planner's ``PlanningProblem.deadline``); ``max_failures`` (a whole
    number, >= 1) is how many failures carrying the plan out may charge to a
    goal before that goal is given up (``sequencer.deliberation`` says what a
    failure is). Both None when not written (no deadline; the executor's
    default limit).
    """

    goals: tuple[Term, ...]
    deadline: float | None = None
    max_failures: int | None = None
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class Step:
    """A subtask in a task net: ``(LABEL (TASK ARG ...) ANNOTATION ...)``.

    ``label`` is None for the bare form ``(TASK ARG ...)``. ``before`` holds
    the labels named by ``(for LABEL)``: this step must end successfully
    before those start. ``until_end`` names the step whose end halts this
    one (a monitor). ``waits`` are the step's ``wait-for`` annotations: with
    any, the first to match decides the step's outcome.

    ``task`` is the task call, or a :class:`PlanRequest` for a labelled plan
    step ``(LABEL (plan GOAL ... [:deadline S] [:max-failures N]) ANNOTATION ...)``:
    plan for the goals and carry the plan out, as one step that others may
    be ordered against. (A bare ``(plan ...)`` in a net is a PlanRequest net
    node, not a Step.) ``plan`` is that request, or None for a task call.
    """

    task: Compound | PlanRequest
    label: str | None = None
    before: tuple[str, ...] = ()
    until_end: str | None = None
    waits: tuple[WaitFor, ...] = ()
    loc: SourceLocation = _loc()

    @property
    def plan(self) -> PlanRequest | None:
        """The plan request of a labelled plan step, else None."""
        return self.task if isinstance(self.task, PlanRequest) else None


@dataclass(frozen=True, slots=True)
class Sequence:
    """``(sequence NET ...)``: the parts run one after another."""

    parts: tuple[Net, ...]
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class Parallel:
    """``(parallel NET ...)``: the parts run at once; ends when all have ended."""

    parts: tuple[Net, ...]
    loc: SourceLocation = _loc()


Net = Union[Sequence, Parallel, Step, WaitFor, MemoryOp, PlanRequest]


@dataclass(frozen=True, slots=True)
class TaskNet:
    """``(task-net NET ...)``: several nets run at once, ordered only by ``for``."""

    nets: tuple[Net, ...]
    loc: SourceLocation = _loc()


# ----------------------------------------------------------------- primitives (rap.md)

@dataclass(frozen=True, slots=True)
class Enable:
    """``(enable (SKILL ARG ...) ...)``: turn skills on with arguments."""

    skills: tuple[Compound, ...]
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class Disable:
    """``(disable :above)`` (every skill this primitive enabled) or named skills.

    ``skills`` is empty when ``above`` is true.
    """

    skills: tuple[Compound, ...] = ()
    above: bool = False
    loc: SourceLocation = _loc()


PrimitiveAction = Union[Enable, Disable, WaitFor, MemoryOp]


@dataclass(frozen=True, slots=True)
class Primitive:
    """``(primitive ACTION ...)``: a leaf method body that drives skills."""

    actions: tuple[PrimitiveAction, ...]
    loc: SourceLocation = _loc()


# ----------------------------------------------------------------- define-rap (rap.md)

@dataclass(frozen=True, slots=True)
class Method:
    """``(method [NAME] (context Q) [(on-preempt resume|fail)] BODY)``: one way to do a task.

    ``context`` None means always applicable. ``body`` is a task net or a
    primitive. ``on_preempt`` says what a step of this method does when a
    task of higher priority takes its skill: ``"resume"`` (the default: it
    waits and runs again) or ``"fail"`` (it ends ``:preempted``).
    """

    body: TaskNet | Primitive
    name: str | None = None
    context: Term | None = None
    on_preempt: str = "resume"
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class RapDef:
    """``(define-rap (NAME ?ARG ...) CLAUSE ...)``: a Reactive Action Package.

    ``head`` is the task as written, e.g. ``(attach-at-site ?thesite)``.
    Clauses not written are None; ``retries`` None means the default (3),
    ``retry_backoff`` None the default (1 s).
    """

    head: Compound
    methods: tuple[Method, ...] = ()
    succeed: Term | None = None
    constraints: Term | None = None
    repeat_while: Term | None = None
    repeat_until: Term | None = None
    timeout: float | None = None
    priority: float | None = None
    retries: int | None = None
    retry_backoff: float | None = None
    loc: SourceLocation = _loc()

    @property
    def name(self) -> str:
        """The task name, e.g. ``attach-at-site``."""
        return self.head.functor

    @property
    def params(self) -> tuple[Term, ...]:
        """The head's arguments, usually variables."""
        return self.head.args


# ----------------------------------------------------------------- memory rules, virtual skills, at-time (rap.md)

@dataclass(frozen=True, slots=True)
class MemoryRuleDef:
    """``(define-memory-rule NAME (on F) [(when Q)] (assert F) | (retract F) ...)``.

    ``rule`` is the logic-level rule the memory engine runs.
    """

    rule: MemoryRule
    loc: SourceLocation = _loc()

    @property
    def name(self) -> str:
        return self.rule.name


@dataclass(frozen=True, slots=True)
class Finish:
    """``(finish OUTCOME)`` in a virtual skill: asserts ``(done (SKILL ARG ...) OUTCOME)``."""

    outcome: str
    loc: SourceLocation = _loc()


ScriptAction = Union[MemoryOp, Finish]


@dataclass(frozen=True, slots=True)
class After:
    """``(after SECONDS ACTION ...)``: actions this long after the skill is enabled."""

    delay: float
    actions: tuple[ScriptAction, ...]
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class When:
    """``(when Q (after ...) ...)``: script lines guarded by a query at enable time."""

    condition: Term
    lines: tuple[After, ...]
    loc: SourceLocation = _loc()


ScriptLine = Union[After, When]


@dataclass(frozen=True, slots=True)
class VirtualSkillDef:
    """``(define-virtual-skill (SKILL ?ARG ...) LINE ...)``: a scripted skill."""

    head: Compound
    lines: tuple[ScriptLine, ...]
    loc: SourceLocation = _loc()

    @property
    def name(self) -> str:
        return self.head.functor


@dataclass(frozen=True, slots=True)
class AtTime:
    """``(at-time SECONDS (assert F) | (retract F) ...)``: the world acting on its own."""

    time: float
    actions: tuple[MemoryOp, ...]
    loc: SourceLocation = _loc()


# ----------------------------------------------------------------- mission forms (rap.md)
# (PlanRequest, also a net item, is with the task nets above.)

@dataclass(frozen=True, slots=True)
class Include:
    """``(include "path")``: load another file, relative to this one, once."""

    path: str
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class WorldDecl:
    """``(world "name-or-path")`` or ``(world none)``: the default world for a run."""

    world: str
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class InitialMemory:
    """``(initial-memory FACT ...)``: facts in memory before anything runs."""

    facts: tuple[Compound, ...]
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class Post:
    """``(post (TASK ARG ...) [:priority N] [:deadline S])``: a top-level task."""

    task: Compound
    priority: float | None = None
    deadline: float | None = None
    loc: SourceLocation = _loc()


# ----------------------------------------------------------------- AP operators (ap.md)

@dataclass(frozen=True, slots=True)
class PlotStep:
    """One step of a plot: a goal or an action, e.g. ``(grip ?arm ?thing)``."""

    term: Compound
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class PlotGroup:
    """``(sequence ...)``, ``(parallel ...)`` or ``(simultaneous ...)`` in a plot."""

    kind: str
    parts: tuple[Plot, ...]
    loc: SourceLocation = _loc()


Plot = Union[PlotGroup, PlotStep]


@dataclass(frozen=True, slots=True)
class Effect:
    """An effect: ``fact`` made true, or false when ``positive`` is False (``(not F)``)."""

    fact: Compound
    positive: bool = True
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class ConditionalEffect:
    """A PDDL conditional or universal effect literal (read from ``when`` and
    ``forall`` effects; AP files have none): for every value of ``variables``
    (each over the problem's objects) for which ``condition`` holds in the state
    *before* the action, ``fact`` is made true, or false when ``positive`` is False.

    ``condition`` is a precondition formula as :mod:`atlas_rap.planner.pddl`
    writes it (``(adl:and)`` when there is none: a plain universal effect); it
    may use ``variables`` and the operator's parameters, and so may ``fact``.
    Like :class:`Effect` it has ``fact`` and ``positive``, so code that only
    asks which facts an operator may change reads both alike.
    """

    fact: Compound
    positive: bool = True
    condition: Term = Compound("adl:and", ())
    variables: tuple[Var, ...] = ()
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class Argument:
    """``(?var EXPR)`` in ``:arguments``: a derived value."""

    var: Var
    expr: Term
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class Operator:
    """``(operator NAME :purpose ... :effects ...)`` (keyword or clause style).

    Parts not written are None or empty. ``duration`` defaults to 1.
    ``parameters`` is the declared order of the operator's variables (PDDL
    ``:parameters``); when empty, the order is that of first appearance.
    ``outcome_of`` names the controlled operator whose bad outcome this
    uncontrolled operator is (read from a FOND ``oneof``): it can happen only
    as that operator's step, with the same values of the parameters.
    ``cost`` is a PDDL action's cost (``:action-costs``: ``(increase (total-cost)
    COST)``): a number, or a term of a static function, e.g. ``(road-length ?from
    ?to)``, whose values the problem's ``:init`` gives; None for 1.
    """

    name: str
    purpose: Term | None = None
    agent: Var | None = None
    arguments: tuple[Argument, ...] = ()
    preconditions: tuple[Term, ...] = ()
    constraints: tuple[Term, ...] = ()
    plot: Plot | None = None
    effects: tuple[Effect, ...] = ()
    duration: float = 1
    uncontrolled: bool = False
    probability: float | None = None
    parameters: tuple[Var, ...] = ()
    outcome_of: str | None = None
    cost: Term | None = None
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class Agents:
    """``(agents (controlled A ...) (uncontrolled B ...))``."""

    controlled: tuple[str, ...] = ()
    uncontrolled: tuple[str, ...] = ()
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class RelationDef:
    """``(define-relation (NAME ?ARG ...) QUERY)``: a derived relation."""

    head: Compound
    body: Term
    loc: SourceLocation = _loc()

    @property
    def name(self) -> str:
        return self.head.functor


@dataclass(frozen=True, slots=True)
class Initial:
    """``(initial FACT ...)``: the planning problem's initial state."""

    facts: tuple[Compound, ...]
    loc: SourceLocation = _loc()


@dataclass(frozen=True, slots=True)
class Goals:
    """``(goals GOAL ...)``: what the plan must achieve; ``goal_locs`` says where
    each goal is written."""

    goals: tuple[Term, ...]
    loc: SourceLocation = _loc()
    goal_locs: tuple[SourceLocation, ...] = field(default=(), compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class Deadline:
    """``(deadline GOAL SECONDS)``: GOAL (a goal as in ``goals``) must be achieved
    within SECONDS (> 0) of the plan's start. ``goal_loc`` says where GOAL is
    written (None when the node was not read from a file)."""

    goal: Term
    seconds: float
    loc: SourceLocation = _loc()
    goal_loc: SourceLocation | None = field(default=None, compare=False, repr=False)


TopLevel = Union[RapDef, MemoryRuleDef, VirtualSkillDef, AtTime, Include, WorldDecl,
                 InitialMemory, Post, PlanRequest, Operator, Agents, RelationDef, Initial, Goals, Deadline]


@dataclass(frozen=True, slots=True)
class SourceFile:
    """The validated top-level forms of one file, in order."""

    path: str
    forms: tuple[TopLevel, ...]

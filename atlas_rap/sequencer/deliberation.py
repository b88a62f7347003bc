"""Carrying out a plan on the agenda, watching it and repairing it: the 3T loop.

A ``(plan GOAL ...)`` step of a task net (``net.PlanNode``) asks the
*deliberator* (the planner, beside the sequencer: :class:`Deliberator`) for a
plan from memory, and a :class:`PlanExecution` carries it out:

- **Dispatch.** Each plan step goes to the RAP whose ``succeed`` unifies with
  its purpose (``planner.dispatch``), as a subtask of the task that asked,
  with the agent the planner chose. A step starts as soon as every step
  ordered before it has succeeded and its agent has done its step before
  (an agent does one step at a time, in the schedule's order), so the
  steps of different agents run concurrently and the steps of one
  ``simultaneous`` group start together.
- **Monitoring.** The plan is watched step by step and against memory. It is
  in trouble when a step's RAP fails, when a fact that a causal link of the
  plan still needs is retracted (or, for ``(not F)``, asserted) while the
  link is live (its producer done, its consumer not yet started), or a
  precondition of a step not yet started that no step of the plan provides
  (a static fact, such as a passage, is in no link), when a
  step is done but a fact it was to make true for a later step does not
  hold (its RAP succeeded another way: another attach point), when a
  controlled agent the plan still uses is lost (``(agent-failed A)`` is
  asserted), and when every step is done but the goals do not hold.
- **Repair.** The deliberator plans again from *current* memory (the steps
  already done are in it; a lost agent is left out; the actions that failed
  are left out too while a plan exists without them, so another agent or
  another route is tried before the same one again) while the running steps
  go on. The new plan is then adopted: a running step whose RAP task the new
  plan also has (the same call, or the same work by another agent: its RAP
  may be substituting that agent already) keeps running; the other running steps are
  halted (their skills disabled); new steps are dispatched. The
  ``replanned`` trace record says what changed: steps done, kept, new,
  halted, and agents re-assigned.
- **Deadlines.** ``:deadline S`` (or an AP ``(deadline GOAL S)``) counts from
  the request. A plan whose makespan does not fit in the time left is
  reported and not carried out, and a plan still running at the deadline is
  abandoned.
- **Sharing the robot.** A step whose RAP waits for a skill another task
  holds (``Sequencer.enable_skill``) waits like any task: waiting is neither
  progress nor failure. Only a wait that endangers the deadline counts: a
  step still waiting when the rest of the plan (the makespan after the
  step's scheduled start) no longer fits before the deadline is a changed
  situation, repaired (another agent may be free), and a plan that cannot
  fit is abandoned.
- **Giving up.** Each failure (a step whose RAP failed, or every step done
  and goals still false) is charged to the goals its step serves. A goal
  charged ``max_failures`` times (default 3) is abandoned and the plan is
  repaired for the rest. A changed situation is no failure, but a plan
  repaired ``MAX_REPAIRS`` times is abandoned (the world keeps changing
  under it). When no goal is left, when no plan exists, or when no plan
  meets the deadline,
  the plan is abandoned: its running steps are halted, ``(goal-abandoned G)``
  is asserted for each goal given up, and the plan step ends ``:fail`` with
  the reason, so the RAP that asked recovers through its other methods
  (return to the dock). A plan that achieves some goals after giving others
  up ends ``:partial`` (a success outcome, in the trace).

Choices a ROSPlan or PlanSys2 user should know: memory holds what skills
and RAPs made true, so a plan's effects are not written into it blindly when
an operator's steps end (a substituted arm or attach point is not mistaken
for the planned one). The facts the operator was to provide for later steps
are checked against memory instead: a fact of a predicate of which memory
holds no fact but the plans' own is the planner's bookkeeping (``(holding
planner crate-1)``) and is asserted then, as ROSPlan and PlanSys2 apply
effects; any other that does not hold is a changed situation, repaired. A
step's purpose is checked by its RAP's ``succeed`` test, and the goals by
memory at the end.

Trace records: ``plan-requested``, ``plan-ready`` (with the simulated
``latency``; in simulated time a count, so the trace is the same on every
machine), ``plan-step-started``,
``plan-step-done``, ``plan-step-failed``, ``replanned``, ``plan-abandoned``
(with ``scope`` ``goal`` or ``plan``) and ``plan-done``; each with ``plan``
(the plan's number in the run), ``version`` and ``id`` (the task that asked).

Over 25 KB on purpose: a plan's execution: its steps, their tasks, monitoring and repair,
which share the plan's state.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Protocol

from atlas_rap.lang import parse_term
from atlas_rap.logic import Compound, Term, Var, is_ground, term_to_str
from atlas_rap.planner.dispatch import match_steps
from atlas_rap.planner.plan import Plan, PlanStep
from atlas_rap.sequencer.host import PlanHost
from atlas_rap.sequencer.status import Outcome, PlanStepState
from atlas_rap.sequencer.task import SUCCEEDED, Failure, SkillWait, Task
from atlas_rap.sequencer.trace import Event

if TYPE_CHECKING:
    from atlas_rap.skillbus.timers import Timer

DEFAULT_MAX_FAILURES = 3
"""Failures charged to one goal before it is abandoned (``:max-failures``)."""

MAX_REPAIRS = 20
"""Repairs of one plan (for failures and changed situations alike) before it is abandoned."""

AGENT_FAILED = "agent-failed"
"""``(agent-failed AGENT)`` in memory: that controlled agent is lost; plans leave it out."""

GOAL_ABANDONED = "goal-abandoned"
"""``(goal-abandoned GOAL)`` is asserted for each goal a plan gave up, for RAPs to react to."""

PARTIAL = Outcome.PARTIAL
"""The outcome of a plan step that achieved some of its goals after abandoning others."""

_ANY = Var("%any")


class Ticket(Protocol):
    """A plan being made; :meth:`cancel` drops it (its result is never delivered)."""

    def cancel(self) -> None: ...


class Deliberator(Protocol):
    """The planner as the sequencer sees it (the mission engine provides one).

    :meth:`request` plans for ``goals`` from memory as it is now, leaving out
    the ``lost`` agents and, if a plan exists without them, the ground actions
    in ``avoid`` (those that failed), and later calls ``deliver(plan, latency)``
    on the sequencer's clock, ``latency`` being the simulated seconds it took.
    It never calls ``deliver`` from inside ``request``.
    """

    def request(self, goals: tuple[Term, ...], lost: frozenset[str], avoid: frozenset[Term],
                deliver: Callable[[Plan, float], None]) -> Ticket: ...

    def deadline_for(self, goals: tuple[Term, ...]) -> float | None:
        """The deadline (seconds) the planning problem sets for these goals, if any."""


@dataclass(eq=False)
class StepRun:
    """One step of the plan being carried out: its RAP task and how it stands.

    ``status``: a :class:`~atlas_rap.sequencer.status.PlanStepState` (waiting
    for the steps ordered before it, running, done, failed or halted). The execution is the spawned task's
    "step": the interpreter tells it when the task ends (:meth:`child_ended`).
    """

    execution: PlanExecution
    step: PlanStep
    call: Compound
    before: list[int] = field(default_factory=list)
    status: PlanStepState = PlanStepState.WAITING
    task: Task | None = None

    @property
    def action(self) -> str:
        return term_to_str(self.step.action)

    @property
    def work(self) -> tuple[str, Term]:
        """What the step does whoever does it: its operator and action with the agent left out,
        so ``(repair-site left-arm site-b)`` and ``(repair-site right-arm site-b)`` are one work."""
        action, agent = self.step.action, self.step.agent
        return self.step.operator, Compound(action.functor, tuple(
            _ANY if term_to_str(arg) == agent else arg for arg in action.args))

    def child_ended(self, task: Task) -> None:
        self.execution.step_ended(self, task)

    def subtask_waiting(self, wait: SkillWait, what: str) -> None:
        """The step's task, or a task under it, waits for a skill (``what`` says which and who has it)."""
        self.execution.step_waiting(self, wait, what)

    def describe(self) -> str:
        return f"plan step s{self.step.id} {self.action}"


class PlanExecution:
    """One ``(plan GOAL ...)`` being planned, carried out, watched and repaired (module docstring).

    ``owner`` is the task whose net asked; ``on_end(outcome, why)`` is called
    once, when the plan is done (``:succeed``, or ``:partial``) or abandoned
    (``:fail``, or ``:timeout`` at the deadline).
    """

    def __init__(self, host: PlanHost, deliberator: Deliberator, owner: Task, goals: tuple[Term, ...],
                 on_end: Callable[[str, str], None], *, deadline: float | None = None,
                 max_failures: int | None = None) -> None:
        self.host = host
        self.deliberator = deliberator
        self.owner = owner
        self.goals = list(goals)
        self.goals_asked = tuple(goals)
        self.abandoned_goals: list[Term] = []
        self.on_end = on_end
        written = deliberator.deadline_for(tuple(goals))
        self.deadline = min((d for d in (deadline, written) if d is not None), default=None)
        self.max_failures = max_failures if max_failures is not None else DEFAULT_MAX_FAILURES
        self.number = host.next_plan_number()
        self.version = 0
        self.plan: Plan | None = None
        self.steps: dict[int, StepRun] = {}
        self.failures: dict[Term, int] = {}
        self.repairs = 0
        self.done: list[str] = []  # the actions of the steps done, in every version of the plan
        self.failed: dict[Term, None] = {}  # the operators' ground actions whose steps failed, in order
        self.serves: dict[int, frozenset[Term]] = {}
        self.provided: dict[int, set[str]] = {}
        self.ticket: Ticket | None = None
        self.cause = "the first plan"
        self.deadline_at: float | None = None
        self.ended = False
        self.trouble: str | None = None
        self.changed: list[tuple[str, Compound]] = []  # memory changes while the planner works
        self._timers: list[Timer] = []
        self._unsubscribe: Callable[[], None] | None = None

    # -- life ---------------------------------------------------------------------

    def start(self) -> None:
        """Ask for the first plan (and start the deadline's clock)."""
        host = self.host
        fields = {}
        if self.deadline is not None:
            self.deadline_at = host.now() + self.deadline
            fields["deadline"] = self.deadline_at
            self._timers.append(host.timers.at(self.deadline_at, self._deadline_passed, late=True))
        host.trace.emit(Event.PLAN_REQUESTED, plan=self.number, id=self.owner.id, task=self.owner.text,
                        goals=_terms(self.goals), **fields)
        self._unsubscribe = host.memory.subscribe(self._memory_changed)
        self._ask()

    def halt(self, why: str) -> None:
        """Stop from outside (the method that asked was halted): halt the running steps."""
        if self.ended:
            return
        self._halt_running(why)
        self._close()

    @property
    def planning(self) -> bool:
        return self.ticket is not None

    def waiting_for(self) -> list[str]:
        """What the plan waits for, for introspection."""
        if self.planning:
            return [f"plan {self.number}: the planner ({self.cause})"]
        running = [s.describe() for s in self.steps.values() if s.status == PlanStepState.RUNNING]
        return running or [f"plan {self.number}"]

    # -- planning -----------------------------------------------------------------

    def _ask(self) -> None:
        self.changed = []
        self.ticket = self.deliberator.request(tuple(self.goals), self._lost_agents(), frozenset(self.failed),
                                               self._delivered)

    def _lost_agents(self) -> frozenset[str]:
        return frozenset(term_to_str(fact.args[0]) for fact in self.host.memory.facts(
            Compound(AGENT_FAILED, (_ANY,))))

    def _delivered(self, plan: Plan, latency: float) -> None:
        self.ticket = None
        if self.ended:
            return
        self.trouble = None
        if plan.status != "solved":
            goals = " ".join(_terms(self.goals))
            self._abandon(f"no plan for {goals}: {plan.status}" + (f" ({plan.reason})" if plan.reason else ""))
            return
        dispatches = match_steps(plan, list(self.host.library.values()))
        for d in dispatches:
            if d.task is None or not is_ground(d.task):
                self._abandon(f"plan step s{d.step.id} {term_to_str(d.step.action)}: no RAP can execute it "
                              f"(write a RAP whose succeed clause unifies with the step's purpose)")
                return
        now = self.host.now()
        if self.deadline_at is not None and now + plan.makespan > self.deadline_at + 1e-9:
            left = max(0.0, self.deadline_at - now)
            repair = {"cause": self.cause} if self.version else {}  # what the plan was being repaired for
            self._abandon(f"no plan meets the deadline: the plan takes {_num(plan.makespan)} s and "
                          f"{_num(left)} s are left", makespan=_num(plan.makespan), left=_num(left), **repair)
            return
        old = self.steps
        self.version += 1
        self.plan = plan
        self.steps = {}
        for d in dispatches:
            self.steps[d.step.id] = StepRun(self, d.step, d.task)
        for a, b in plan.orderings + _agent_turns(plan):
            if a not in self.steps[b].before:
                self.steps[b].before.append(a)
        self.serves = _goals_served(plan, self.goals)
        self.provided = {i: set() for i in self.steps}  # what other steps of the plan make true for each
        for producer, consumer, link in plan.links:
            if producer != "init" and consumer != "goal":
                self.provided[consumer].add(link)  # type: ignore[index]
        if self.version > 1:
            self._adopt(old)
        agents = sorted({s.step.agent for s in self.steps.values() if s.step.agent})
        self.host.trace.emit(Event.PLAN_READY, plan=self.number, version=self.version, id=self.owner.id,
                             goals=_terms(self.goals), steps=len(plan.steps), makespan=_num(plan.makespan),
                             agents=agents, latency=round(latency, 6),
                             actions=[f"s{s.id} {term_to_str(s.action)}" + (f" [{s.agent}]" if s.agent else "")
                                      for s in plan.steps])
        changed, self.changed = self.changed, []
        for kind, fact in changed:  # what happened while the planner worked may break the new plan
            broken = self._breaks(kind, fact)
            if broken is not None and self._still(kind, fact):
                self._changed(broken)
                return
        self._dispatch()

    def _still(self, kind: str, fact: Compound) -> bool:
        """Whether memory still shows the change (a retracted fact still absent, an asserted one present)."""
        return (fact in self.host.memory) == (kind == "assert")

    def _adopt(self, old: dict[int, StepRun]) -> None:
        """Take the new plan over the old: keep running steps it keeps, halt the others; trace it."""
        running = [s for s in old.values() if s.status == PlanStepState.RUNNING]
        kept, new, reassigned = [], [], []
        for run in self.steps.values():
            match = next((o for o in running if o.call == run.call), None) or next(
                (o for o in running if o.work == run.work), None)
            if match is not None:
                running.remove(match)
                run.status, run.task = PlanStepState.RUNNING, match.task
                match.task.step = run  # the running task now reports to the new plan
                kept.append(run.action)
                if match.step.agent != run.step.agent:
                    reassigned.append({"step": f"s{run.step.id}", "action": run.action, "from": match.step.agent,
                                       "to": run.step.agent, "running": True})
                continue
            new.append(run.action)
            earlier = next((o for o in old.values()
                            if o.status in (PlanStepState.WAITING, PlanStepState.FAILED, PlanStepState.HALTED)
                            and o.work == run.work and o.step.agent != run.step.agent), None)
            if earlier is not None:
                reassigned.append({"step": f"s{run.step.id}", "action": run.action, "from": earlier.step.agent,
                                   "to": run.step.agent})
        halted = [o.action for o in running]
        for o in running:
            o.status = PlanStepState.HALTED
            self.host.halt(o.task, f"re-plan {self.version} of plan {self.number} dropped this step")
        self.host.trace.emit(Event.REPLANNED, plan=self.number, version=self.version, id=self.owner.id,
                             cause=self.cause, done=list(self.done),
                             kept=kept, new=new, halted=halted, reassigned=reassigned,
                             lost_agents=sorted(self._lost_agents()))

    # -- carrying it out ---------------------------------------------------------------

    def _dispatch(self) -> None:
        """Start every waiting step whose predecessors are done; end the plan when all are."""
        if self.planning or self.ended:
            return
        host = self.host
        for run in self.steps.values():
            if run.status != PlanStepState.WAITING or any(
                    self.steps[b].status != PlanStepState.DONE for b in run.before):
                continue
            run.status = PlanStepState.RUNNING
            run.task = host.spawn(run.call, self.owner, run)
            host.trace.emit(Event.PLAN_STEP_STARTED, plan=self.number, version=self.version, step=run.step.id,
                            action=run.action, agent=run.step.agent, id=self.owner.id, step_task=run.task.id,
                            task=run.task.text)
            if self.ended or self.planning:
                return
        if all(run.status == PlanStepState.DONE for run in self.steps.values()):
            self._all_done()

    def step_ended(self, run: StepRun, task: Task) -> None:
        """A step's RAP task ended (the interpreter calls this through the task's step)."""
        if self.ended or run.status != PlanStepState.RUNNING or self.steps.get(run.step.id) is not run:
            return
        host = self.host
        fields = {"plan": self.number, "version": self.version, "step": run.step.id, "action": run.action,
                  "agent": run.step.agent, "id": self.owner.id, "step_task": task.id, "task": task.text}
        if task.status == SUCCEEDED:
            run.status = PlanStepState.DONE
            self.done.append(run.action)
            host.trace.emit(Event.PLAN_STEP_DONE, **fields)
            unmet = self._unmet_links(run.step.id)
            if unmet is not None:
                self._changed(unmet)
                return
            self._dispatch()
            return
        run.status = PlanStepState.FAILED
        self.failed[self.plan.sequence[run.step.source]] = None  # type: ignore[union-attr]
        reason = _root_reason(task.failure)
        host.trace.emit(Event.PLAN_STEP_FAILED, reason=reason, **fields)
        self._trouble(f"step s{run.step.id} {run.action} failed: {reason}", self.serves.get(run.step.id))

    def step_waiting(self, run: StepRun, wait: SkillWait, what: str) -> None:
        """A running step waits for a skill: if it still waits when the rest of the plan no longer fits
        before the deadline, the plan is repaired."""
        if self.ended or self.deadline_at is None or self.plan is None or run.status != PlanStepState.RUNNING:
            return
        host = self.host
        rest = self.plan.makespan - run.step.start
        latest = self.deadline_at - rest

        def check() -> None:
            if (wait.live and run.status == PlanStepState.RUNNING and not self.ended
                    and self.steps.get(run.step.id) is run):
                self._changed(f"step s{run.step.id} {run.action} waits for {what}, and the {_num(rest)} s of plan "
                              f"left from it no longer fit before the deadline at t={_num(self.deadline_at or 0.0)} s")

        self._timers.append(host.timers.at(max(latest, host.now()), check))

    def _all_done(self) -> None:
        memory, relations = self.host.memory, self.host.relations
        unmet = [g for g in self.goals if not memory.holds(g, None, relations)]
        if unmet:
            self._trouble("every step is done but " + " ".join(_terms(unmet)) + " does not hold",
                          frozenset(unmet))
            return
        outcome = PARTIAL if self.abandoned_goals else Outcome.SUCCEED
        self.host.trace.emit(Event.PLAN_DONE, plan=self.number, version=self.version, id=self.owner.id,
                             goals=_terms(self.goals), abandoned=_terms(self.abandoned_goals))
        self._close()
        why = (f"plan {self.number} achieved {' '.join(_terms(self.goals))}"
               + (f", and gave up {' '.join(_terms(self.abandoned_goals))}" if self.abandoned_goals else ""))
        self.on_end(outcome, why)

    # -- trouble -------------------------------------------------------------------------

    def _memory_changed(self, kind: str, fact: Compound, time: float) -> None:
        """Memory changed: note it while planning, else see whether it breaks the plan."""
        if self.ended or self.plan is None:
            return
        if self.planning:
            self.changed.append((kind, fact))
        elif self.trouble is None:
            broken = self._breaks(kind, fact)
            if broken is not None:
                self._later(broken)

    def _breaks(self, kind: str, fact: Compound) -> str | None:
        """Whether a change breaks a live causal link or loses an agent the plan still uses: the cause."""
        if fact.functor == AGENT_FAILED and kind == "assert" and fact.args:
            agent = term_to_str(fact.args[0])
            users = [r for r in self.steps.values()
                     if r.status in (PlanStepState.WAITING, PlanStepState.RUNNING) and r.step.agent == agent]
            return f"agent {agent} was lost ({term_to_str(fact)})" if users else None
        text = term_to_str(fact)
        change = "asserted" if kind == "assert" else "retracted"
        wanted = f"(not {text})" if kind == "assert" else text
        for producer, consumer, link in self.plan.links:  # type: ignore[union-attr]
            if link != wanted or not self._live(producer, consumer):
                continue
            need = "the goals" if consumer == "goal" else f"step s{consumer}"
            return f"{text} was {change}, which {need} needs"
        needed = Compound("not", (fact,)) if kind == "assert" else fact
        for run in self.steps.values():  # a fact no operator changes is in no link, but a step needs it
            if (run.status == PlanStepState.WAITING and needed in run.step.needs
                    and wanted not in self.provided[run.step.id]):
                return f"{text} was {change}, which step s{run.step.id} needs"
        return None

    def _unmet_links(self, done: int) -> str | None:
        """When the last plot step of an operator is done: check the facts the operator was
        planned to make true (or false) for later steps or the goals, against memory.

        A fact memory shows is fine. A fact of a predicate of which memory holds no fact but
        the plans' own beliefs is the planner's bookkeeping (``(holding planner crate-1)``): it is asserted, as ROSPlan
        and PlanSys2 apply an action's effects. Any other fact that does not hold means the
        step's RAP succeeded otherwise than planned (another attach point, another arm): a
        changed situation, returned as the cause, so the rest of the plan is made again from
        what is true.
        """
        source = self.steps[done].step.source
        mine = {i for i, run in self.steps.items() if run.step.source == source}
        if any(self.steps[i].status != PlanStepState.DONE for i in mine):
            return None
        memory, relations = self.host.memory, self.host.relations
        believed = []
        for producer, consumer, link in self.plan.links:  # type: ignore[union-attr]
            if producer not in mine or not self._live(producer, consumer):
                continue
            negative = link.startswith("(not ")
            fact = parse_term(link[5:-1] if negative else link, "<plan link>")
            if memory.holds(fact, None, relations) != negative:
                continue
            if not negative and isinstance(fact, Compound) and self._bookkeeping(fact):
                believed.append(fact)
                continue
            need = "the goals" if consumer == "goal" else f"step s{consumer}"
            return f"s{done} {self.steps[done].action} is done but {link} does not hold, which {need} needs"
        if believed:
            self.host.plan_beliefs.update(believed)
            self.host.change([("assert", fact) for fact in dict.fromkeys(believed)], f"plan {self.number}")
        return None

    def _bookkeeping(self, fact: Compound) -> bool:
        """Whether ``fact`` is of a predicate only plans keep: memory holds no fact of it that
        a skill, a RAP or the program asserted (only the plans' own beliefs, if any)."""
        pattern = Compound(fact.functor, tuple(Var(f"%any{i}") for i in range(len(fact.args))))
        beliefs = self.host.plan_beliefs
        return all(known in beliefs for known in self.host.memory.facts(pattern))

    def _live(self, producer: int | str, consumer: int | str) -> bool:
        if producer != "init" and self.steps[producer].status != PlanStepState.DONE:  # type: ignore[index]
            return False
        return consumer == "goal" or self.steps[consumer].status == PlanStepState.WAITING  # type: ignore[index]

    def _later(self, cause: str) -> None:
        """Handle a change of memory after the change is done (not inside the rules' run)."""
        self.trouble = cause
        self._timers.append(self.host.timers.after(0.0, lambda: self._changed(cause)))

    def _changed(self, cause: str) -> None:
        """The situation changed under the plan (no failure): repair it."""
        self._trouble(cause, None, failure=False)

    def _trouble(self, cause: str, served: frozenset[Term] | None, *, failure: bool = True) -> None:
        """Something broke the plan: charge a failure to the goals concerned, then repair or give up."""
        if self.ended:
            return
        self.trouble = cause
        self.repairs += 1
        if self.repairs > MAX_REPAIRS:
            self._abandon(f"repaired {MAX_REPAIRS} times and still broken; the last: {cause}")
            return
        charged = [g for g in self.goals if served is None or not served or g in served] if failure else []
        for goal in charged:
            self.failures[goal] = self.failures.get(goal, 0) + 1
        spent = [g for g in charged if self.failures[g] >= self.max_failures]
        if spent and len(spent) < len(self.goals):
            for goal in spent:
                self.goals.remove(goal)
                self.abandoned_goals.append(goal)
            why = f"{self.max_failures} failures; the last: {cause}"
            self._emit_abandoned("goal", why, spent)
            self.host.change([("assert", Compound(GOAL_ABANDONED, (g,))) for g in spent], f"plan {self.number}")
            if self.ended:
                return
        elif spent:
            total = sum(self.failures.values())
            self._abandon(f"gave up after {total} failures; the last: {cause}")
            return
        self.cause = cause
        if not self.planning:  # a plan being made already sees this memory, or is checked on delivery
            self._ask()

    def _deadline_passed(self) -> None:
        if not self.ended:
            self._abandon(f"missed its deadline at t={_num(self.deadline_at or 0.0)} s", outcome=Outcome.TIMEOUT)

    def _abandon(self, reason: str, *, outcome: str = Outcome.FAIL, **fields: object) -> None:
        """Give the plan up: halt its running steps, say why, and end the plan step."""
        self._halt_running(f"plan {self.number} was abandoned: {reason}")
        goals = list(self.goals)
        self.abandoned_goals += goals
        self._emit_abandoned("plan", reason, goals, **fields)
        self._close()
        self.host.change([("assert", Compound(GOAL_ABANDONED, (g,))) for g in goals], f"plan {self.number}")
        self.on_end(outcome, f"plan {self.number} abandoned: {reason}")

    def _emit_abandoned(self, scope: str, reason: str, goals: list[Term], **fields: object) -> None:
        self.host.trace.emit(Event.PLAN_ABANDONED, plan=self.number, version=self.version, id=self.owner.id,
                             scope=scope, goals=_terms(goals), reason=reason, **fields)

    def _halt_running(self, why: str) -> None:
        for run in self.steps.values():
            if run.status == PlanStepState.RUNNING and run.task is not None:
                run.status = PlanStepState.HALTED
                self.host.halt(run.task, why)

    def _close(self) -> None:
        self.ended = True
        if self.ticket is not None:
            self.ticket.cancel()
            self.ticket = None
        for timer in self._timers:
            timer.cancel()
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None


def _agent_turns(plan: Plan) -> list[tuple[int, int]]:
    """An agent does one step at a time: each step of an agent waits for the agent's step
    before it in the plan's schedule (the steps of one ``simultaneous`` group excepted)."""
    together = {i: frozenset(group) for group in plan.simultaneous for i in group}
    turns = []
    last: dict[str, PlanStep] = {}
    for step in sorted(plan.steps, key=lambda s: (s.start, s.id)):
        if step.agent is None:
            continue
        previous = last.get(step.agent)
        if previous is not None and previous.id not in together.get(step.id, ()):
            turns.append((previous.id, step.id))
        last[step.agent] = step
    return turns


def _goals_served(plan: Plan, goals: list[Term]) -> dict[int, frozenset[Term]]:
    """For each step, the goals it works towards: those reached from it along causal links
    (a step that reaches none, such as a counterplan step, serves all)."""
    by_text = {term_to_str(g): g for g in goals}
    after: dict[int, set[int]] = {s.id: set() for s in plan.steps}
    direct: dict[int, set[Term]] = {s.id: set() for s in plan.steps}
    for a, b, fact in plan.links:
        if a == "init":
            continue
        if b == "goal":
            if fact in by_text:
                direct[a].add(by_text[fact])  # type: ignore[index]
        else:
            after[a].add(b)  # type: ignore[index,arg-type]
    served: dict[int, frozenset[Term]] = {}
    for step in sorted(plan.steps, key=lambda s: -s.id):  # ids are a topological order
        found = set(direct[step.id])
        for b in after[step.id]:
            found |= served.get(b, frozenset())
        served[step.id] = frozenset(found)
    everything = frozenset(goals)
    return {i: goals_ or everything for i, goals_ in served.items()}


def _root_reason(failure: Failure | None) -> str:
    if failure is None:
        return "failed"
    root = failure.root()
    return f"{root.what}: {root.reason}" if root is not failure else failure.reason


def _terms(terms: list[Term] | tuple[Term, ...]) -> list[str]:
    return [term_to_str(t) for t in terms]


def _num(x: float) -> float | int:
    return int(x) if float(x).is_integer() else round(x, 3)


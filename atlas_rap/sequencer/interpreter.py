"""The RAP interpreter: selects tasks from the agenda, chooses methods, runs them.

This is Firby's RAP execution cycle (seed 003 §3.2; the language reference, docs/language/rap.md) on a
simulated clock:

1. :meth:`Sequencer.settle` takes the best pending task off the agenda
   (priority, then deadline, then age) and *selects* it:
   ``succeed`` true → it succeeds doing nothing (checked first, so a method
   that ends its own constraint on the way to success still succeeds);
   ``constraints`` false → the task fails; otherwise an applicable method
   is chosen by ``context``
   (untried methods first, then the least tried, then the first written),
   its bindings are taken and its body starts (``net.MethodRun``).
2. Subtasks go on the agenda; steps wait for events through the wait index;
   nothing runs until a fact changes or a timer fires.
3. When a method's net ends well, the task goes back on the agenda and its
   ``succeed`` test is checked again (no test: the task succeeds). A failed
   method sends it back to choose again, until ``retries`` attempts are
   spent; the failure goes up to the parent's step, and so on.

Choices where the papers are silent (docs/language/rap.md, How a task runs), as Firby's system did or as a robotics
user would expect:

- A subtask takes its RAP's ``priority`` if it has one, else its parent's;
  it inherits its parent's deadline.
- ``:deadline S`` on a post is S seconds after posting; it orders the agenda
  and is hard: a task not done by then fails ("missed its deadline").
- ``timeout`` counts from the task's first selection.
- ``repeat-while`` / ``repeat-until`` repeat only a task that ran a method
  (a task whose ``succeed`` test was already true is done); each repeat
  starts with a fresh count of attempts.
- A task that tries :data:`MAX_REPEATS_AT_ONCE` methods at one instant (a
  huge ``retries`` of a method that fails at once) fails as a runaway, as
  one that repeats that often does.
- Failures that retrying cannot fix (a task nested deeper than
  ``max_depth``, a RAP removed by a reload) are *fatal*: the tasks above
  fail at once instead of retrying.
- Reloading (:meth:`Sequencer.define`) replaces definitions; a running task
  keeps its current method and uses the new definition at its next selection.
- Skills are resources (:meth:`Sequencer.enable_skill`, ``resources``): a
  skill instance belongs to the task whose step enabled it, until that step
  ends. A task whose step needs an instance that another live task holds
  *waits* when the holder's priority is equal or higher: its step stays on
  the agenda in a visible state (``waiting for (navigate-to storeroom) held
  by [4] (go-to office)``, a ``task-waiting`` record) and takes the instance
  when it is let go (``task-resumed``), costing no retry. Waiters are served
  in the agenda's order (priority, deadline, age), so who is served is
  deterministic. A task of higher priority (or a subtask of the holder,
  which would otherwise wait for itself) takes the instance instead: the
  holder's step is *halted*, not failed (``skill-preempted`` with outcome
  ``:halted``, naming both tasks), and waits in the queue itself. When it is
  served it runs the halted step again from its start (a ``primitive``
  enables the skill again and waits again where it waited), or, when its
  method's ``context`` no longer holds or its ``succeed`` test already does,
  its task chooses a method again, without being charged a retry. A method
  with ``(on-preempt fail)`` fails instead: its step ends ``:preempted``, a
  failure outcome, as a behaviour-tree action that cannot resume. A task's
  ``timeout`` and deadline count while it waits; one that runs out says what
  it waited for. A wait that would close a circle of waits (two
  primitives, each holding one skill and waiting for the other's) takes
  the instance instead, as if it outranked the holder. A task enabling an
  instance it already holds restarts it.
- A failed attempt whose task would next repeat a method waits for a
  change first (``retrying.RetryWait``): a change of a fact the RAP's tests
  read, or its ``retry-backoff`` (default 1 s). An applicable method not yet
  tried is another way, and is tried at once.
- A memory rule that cannot be applied (a cycle, an effect that is not
  ground, arithmetic that fails) leaves memory untrustworthy, so the run
  stops: the task whose change triggered it fails (fatally), every other
  live task fails saying the run stopped, every skill is disabled, and
  :attr:`Sequencer.fault` keeps the message for the summary. A fact whose
  own arithmetic fails fails only the task that asserted it.

Over 25 KB on purpose: the sequencer's core: the agenda loop, method choice, a task's life
and what the parts' host protocols ask of it; what it could shed is already in ``net``,
``resources``, ``waiting`` and ``retrying``.
"""

from __future__ import annotations

from itertools import count
from typing import Callable, Hashable, Iterable, Mapping, Sequence

from atlas_rap.lang import ast
from atlas_rap.logic import (
    Compound,
    LogicError,
    Memory,
    MemoryRule,
    QueryError,
    Relation,
    RuleEngine,
    Subst,
    Term,
    Var,
    is_ground,
    substitute,
    term_to_str,
    unify,
)
from atlas_rap.logic.errors import RuleError
from atlas_rap.logic.rules import Change
from atlas_rap.sequencer.agenda import Agenda, agenda_key
from atlas_rap.sequencer.deliberation import Deliberator, PlanExecution
from atlas_rap.sequencer.net import HALTED_OUTCOME, WAITING_OUTCOME, MethodRun, Node, Refusal, method_label
from atlas_rap.sequencer.resources import Claim, Resources
from atlas_rap.sequencer.retrying import DEFAULT_RETRY_BACKOFF, RetryWait
from atlas_rap.sequencer.status import FAILURE_OUTCOMES, Outcome, Status
from atlas_rap.sequencer.task import FAILED, HALTED, PENDING, RUNNING, SUCCEEDED, AtOnce, Failure, Spawner, Task
from atlas_rap.sequencer.trace import Event, Trace
from atlas_rap.sequencer.waiting import WaitIndex
from atlas_rap.skillbus.skill_link import NoSkills, SkillLink
from atlas_rap.skillbus.timers import Timers

DEFAULT_RETRIES = 3
"""Method attempts a task gets when its RAP has no ``retries`` clause (docs/language/rap.md, define-rap)."""

DEFAULT_MAX_DEPTH = 64
"""How deeply tasks may nest before the innermost fails (a RAP calling itself without end)."""

MAX_REPEATS_AT_ONCE = 1000
"""Repeats of one task, or method attempts, at one instant of simulated time before it fails as a
runaway loop."""

_ANY = Var("%any")


class Sequencer:
    """The RAP interpreter: agenda, memory, memory rules, wait index, timers and trace.

    Build one from RAP definitions and memory rules (and add more with
    :meth:`define`, :meth:`define_rules`, :meth:`define_relations`); :meth:`post` tasks;
    change memory with :meth:`change` (or :meth:`assert_fact` /
    :meth:`retract_fact`); call :meth:`settle` to let the agenda run at the
    current time and :meth:`advance_to` to move simulated time on.
    The mission engine (``atlas_rap.layers.engine``) drives all of that.
    """

    def __init__(
        self,
        raps: Iterable[ast.RapDef] = (),
        rules: Iterable[MemoryRule] = (),
        skills: SkillLink | None = None,
        *,
        relations: Mapping[str, Sequence[Relation]] | None = None,
        memory: Memory | None = None,
        timers: Timers | None = None,
        trace: Trace | None = None,
        max_depth: int = DEFAULT_MAX_DEPTH,
    ) -> None:
        self.memory = memory if memory is not None else Memory()
        self.relations: dict[str, list[Relation]] = {name: list(clauses) for name, clauses in (relations or {}).items()}
        self.rules = RuleEngine(rules, relations=self.relations)
        self.timers = timers if timers is not None else Timers()
        self.trace = trace if trace is not None else Trace(self.now)
        if self.trace.clock is None:
            self.trace.clock = self.now
        self.waits = WaitIndex(self.relations)
        self.agenda = Agenda()
        self.max_depth = max_depth
        self.library: dict[tuple[str, int], ast.RapDef] = {}
        self.roots: list[Task] = []
        self._ids = count(1)
        self.resources = Resources()  # who holds each skill instance, and who waits for it
        self.holders: dict[Hashable, tuple[MethodRun, Compound]] = self.resources.holders
        self.fault: str | None = None  # why memory rules stopped the run, until the runner takes it
        self.deliberator: Deliberator | None = None  # the planner, for (plan GOAL ...) steps
        self._plan_numbers = count(1)
        self.plan_beliefs: set[Compound] = set()  # facts plans asserted as the planner's bookkeeping
        self.skills: SkillLink = skills if skills is not None else NoSkills()
        self.skills.connect(self)
        self._skill_names = self.skills.skills()
        self.define(raps)

    # -- definitions -------------------------------------------------------

    def define(self, raps: Iterable[ast.RapDef]) -> None:
        """Add or replace RAP definitions (by name and arity); running tasks finish their method first."""
        for rap in raps:
            self.library[(rap.name, len(rap.params))] = rap

    def define_rules(self, rules: Iterable[MemoryRule]) -> None:
        """Add memory rules, replacing any rule of the same name (a reload); order is kept."""
        new = {rule.name: rule for rule in rules}
        kept = [new.pop(rule.name, rule) for rule in self.rules.rules]
        engine = RuleEngine(kept + list(new.values()), relations=self.relations)
        self.rules = engine

    def define_relations(self, relations: Mapping[str, Sequence[Relation]]) -> None:
        """Add or replace defined relations by name: the clauses given replace every
        earlier clause of that relation (memory rules and waiting queries see them at once)."""
        for name, clauses in relations.items():
            self.relations[name] = list(clauses)

    def refresh_skills(self) -> None:
        """Ask the skill link again which skills it has (after it gained some)."""
        self._skill_names = self.skills.skills()

    def is_rap(self, call: Compound) -> bool:
        return (call.functor, len(call.args)) in self.library

    def is_skill(self, call: Compound) -> bool:
        return len(call.args) in self._skill_names.get(call.functor, ())

    def now(self) -> float:
        """The current simulated time, in seconds."""
        return self.timers.now

    def start_plan(self, owner: Task, goals: tuple[Term, ...], on_end: Callable[[str, str], None], *,
                   deadline: float | None, max_failures: int | None) -> PlanExecution | None:
        """Start carrying out a plan for ``goals``, asked by a step of ``owner``'s method
        (``deliberation``); None when this run has no planner (no :attr:`deliberator`)."""
        if self.deliberator is None:
            return None
        execution = PlanExecution(self, self.deliberator, owner, goals, on_end, deadline=deadline,
                                  max_failures=max_failures)
        execution.start()
        return execution

    def next_plan_number(self) -> int:
        """The number of the next plan of this run (1, 2, ...), as the trace names plans."""
        return next(self._plan_numbers)

    # -- tasks ---------------------------------------------------------------

    def post(self, call: Compound, priority: float | None = None, deadline: float | None = None) -> Task:
        """Put a top-level task on the agenda; ``deadline`` is seconds from now."""
        rap = self.library.get((call.functor, len(call.args)))
        if priority is None:
            priority = rap.priority if rap is not None and rap.priority is not None else 0
        due = None if deadline is None else self.timers.now + deadline
        task = Task(next(self._ids), call, None, None, priority, due)
        self.roots.append(task)
        self.trace.emit(Event.TASK_POSTED, id=task.id, task=task.text, priority=priority,
                        **({"deadline": due} if due is not None else {}))
        if due is not None:
            task.timers.append(self.timers.at(due, lambda: self._missed_deadline(task), late=True))
        self.agenda.push(task)
        return task

    def spawn(self, call: Compound, parent: Task, step: Spawner) -> Task:
        """A subtask for ``step`` of ``parent``'s net, on the agenda."""
        rap = self.library[(call.functor, len(call.args))]
        priority = rap.priority if rap.priority is not None else parent.priority
        task = Task(next(self._ids), call, parent, step, priority, parent.deadline)
        parent.children.append(task)
        self.trace.emit(Event.TASK_POSTED, id=task.id, task=task.text, priority=priority, parent=parent.id)
        self.agenda.push(task)
        return task

    def halt(self, task: Task, why: str) -> None:
        """Stop a task and everything under it, disabling every skill they enabled."""
        if task.finished:
            return
        self._stop(task)
        task.status = HALTED
        task.ended = self.timers.now
        self.trace.emit(Event.TASK_HALTED, id=task.id, task=task.text, reason=why)

    def cancel(self, task: Task, why: str = "cancelled") -> None:
        """Halt a task from outside (a person or a program); its parent's step fails."""
        if task.finished:
            return
        self._end(task, FAILED, Failure(task.text, why, fatal=True))

    def live_roots(self) -> list[Task]:
        """The posted tasks that have not ended, in posting order."""
        return [task for task in self.roots if not task.finished]

    # -- the agenda ----------------------------------------------------------

    def settle(self) -> None:
        """Select pending tasks, best first, and hand skill instances let go to the tasks waiting
        for them, until neither is left (no time passes)."""
        pop = self.agenda.pop
        while True:
            task = pop()
            while task is not None:
                self._select(task)
                task = pop()
            if not self.resources.released:
                return
            self._serve_released()

    def advance_to(self, time: float) -> None:
        """Move the clock to ``time``, instant by instant: fire the timers due, settle the agenda.

        At each instant the ordinary timers fire and the agenda settles
        before the late ones (timeouts, deadlines): work that ends exactly
        on time is on time.
        """
        timers = self.timers
        if self.resources.released:
            self.settle()
        due = timers.next_time()
        while due is not None and due <= time:
            timers.fire_due(due, late=False)
            self.settle()
            timers.fire_due(due)
            self.settle()
            due = timers.next_time()
        timers.fire_due(time)
        self.settle()

    def _select(self, task: Task) -> None:
        trace = self.trace
        if trace.active:
            fields = {"repeat": task.repeats} if task.repeats else {}
            trace.emit(Event.TASK_SELECTED, id=task.id, task=task.text, **fields)
        rap = self.library.get((task.call.functor, len(task.call.args)))
        if rap is None:
            self._fail(task, "no RAP of this name and arity is defined (was it removed by a reload?)", fatal=True)
            return
        if task.depth > self.max_depth:
            chain = " > ".join(t.text for t in _ancestors(task)[-4:])
            self._fail(task, f"tasks nested deeper than {self.max_depth} (… > {chain}): "
                             f"does {task.name} call itself without end?", fatal=True)
            return
        if task.started is None:
            task.started = self.timers.now
            if rap.timeout is not None:
                task.timers.append(self.timers.after(rap.timeout, lambda: self._timed_out(task, rap.timeout),
                                                     late=True))
        bindings = unify(rap.head, task.call)
        if bindings is None:
            self._fail(task, f"does not match the RAP's head {term_to_str(rap.head)}", fatal=True)
            return
        task.bindings = bindings
        memory, relations = self.memory, self.relations
        try:
            if rap.succeed is not None and memory.holds(rap.succeed, bindings, relations):
                self._succeed(task)
                return
            if rap.constraints is not None and not memory.holds(rap.constraints, bindings, relations):
                self._fail(task, f"its constraints do not hold: {_shown(rap.constraints, bindings)}")
                return
            methods = task.methods
            if methods.ended_ok:
                methods.ended_ok = False
                methods.last_failure = Failure(
                    f"method {methods.last_method}", f"ended, but the succeed test "
                    f"{_shown(rap.succeed, bindings)} is still false")
            if methods.count >= _retries(rap):
                self._fail(task, f"gave up after {_plural(methods.count, 'attempt')}", methods.last_failure)
                return
            if methods.at_once.add(self.timers.now) > MAX_REPEATS_AT_ONCE:  # (retries 1000000000) failing at once
                self._fail(task, f"tried {MAX_REPEATS_AT_ONCE} methods without simulated time passing",
                           methods.last_failure, fatal=True)
                return
            self._choose_method(task, rap, bindings)
        except QueryError as exc:
            self._fail(task, str(exc), fatal=True)

    def _choose_method(self, task: Task, rap: ast.RapDef, bindings: Subst) -> None:
        best: tuple[int, int, Subst] | None = None
        for number, method in enumerate(rap.methods, 1):
            tries = task.methods.by_method.get(number, 0)
            if best is not None and tries >= best[0]:
                continue
            if method.context is None:
                answer: Subst | None = dict(bindings)
            else:
                answer = self.memory.ask(method.context, bindings, self.relations)
            if answer is not None:
                best = (tries, number, answer)
        if best is None:
            self._fail(task, _no_method(rap, bindings), task.methods.last_failure)
            return
        _, number, answer = best
        method = rap.methods[number - 1]
        task.children = [child for child in task.children if not child.finished]  # the tree shows this attempt
        methods = task.methods
        methods.begin(number, method_label(method, number))
        task.status = RUNNING
        self.trace.emit(Event.METHOD_SELECTED, id=task.id, task=task.text, method=methods.last_method,
                        attempt=methods.count)
        run = task.run = MethodRun(self, task, method, number, answer)
        run.start()

    def method_ended(self, run: MethodRun, failure: Failure | None) -> None:
        """Called by a method run when its body ended (``failure`` None) or failed."""
        task = run.task
        if task.run is run:
            task.run = None
        if task.finished:
            return
        rap = self.library.get((task.call.functor, len(task.call.args)))
        if failure is not None:
            task.methods.last_failure = failure
            if failure.fatal:
                self._fail(task, "a failure that retrying cannot fix", failure, fatal=True)
                return
        else:
            if rap is not None and rap.succeed is None:
                self._succeed(task)
                return
            task.methods.ended_ok = True
        task.status = PENDING
        if rap is not None and self._waits_to_retry(task, rap):
            self._back_off(task, rap)
            return
        self.agenda.push(task)

    def _waits_to_retry(self, task: Task, rap: ast.RapDef) -> bool:
        """Whether a task whose attempt failed waits for a change (``retrying``) before its next one:
        it has retries left and a back-off, its ``succeed`` test does not already hold, and its next
        choice would repeat a method: an applicable method not yet tried is another way, tried at once,
        and a task with no applicable method fails at once, as it always has."""
        if task.methods.count >= _retries(rap) or _retry_backoff(rap) <= 0:
            return False
        memory, bindings, relations = self.memory, task.bindings, self.relations
        try:
            if rap.succeed is not None and memory.holds(rap.succeed, bindings, relations):
                return False
            applicable = [number for number, m in enumerate(rap.methods, 1)
                          if m.context is None or memory.holds(m.context, bindings, relations)]
            return bool(applicable) and all(number in task.methods.by_method for number in applicable)
        except QueryError:
            return False  # the selection reports it

    def _back_off(self, task: Task, rap: ast.RapDef) -> None:
        queries = [query for query in (rap.succeed, rap.constraints, *(m.context for m in rap.methods))
                   if query is not None and query not in ("t", "nil")]
        bindings = task.bindings
        queries = list(dict.fromkeys(substitute(query, bindings) if bindings else query for query in queries))

        def resume(wait: RetryWait, by: str) -> None:
            task.backoff = None
            self.trace.emit(Event.TASK_RESUMED, id=task.id, task=task.text,
                            waited=_seconds(self.timers.now - wait.since), by=by)
            self.agenda.push(task)

        task.backoff = RetryWait(queries, _retry_backoff(rap), waits=self.waits, timers=self.timers,
                                 relations=self.relations, on_end=resume)
        self.trace.emit(Event.TASK_WAITING, id=task.id, task=task.text, until=task.backoff.until,
                        watching=task.backoff.watching)

    # -- ending tasks --------------------------------------------------------

    def _succeed(self, task: Task) -> None:
        rap = self.library.get((task.call.functor, len(task.call.args)))
        if rap is not None and task.methods.count and self._repeats(rap, task):
            at_once = task.repeats_at_once = task.repeats_at_once or AtOnce()
            if at_once.add(self.timers.now) > MAX_REPEATS_AT_ONCE:
                self._fail(task, f"repeated {MAX_REPEATS_AT_ONCE} times without simulated time passing", fatal=True)
                return
            task.repeats += 1
            task.methods.restart()
            task.status = PENDING
            self.agenda.push(task)
            return
        self._end(task, SUCCEEDED, None)

    def _repeats(self, rap: ast.RapDef, task: Task) -> bool:
        memory, bindings, relations = self.memory, task.bindings, self.relations
        if rap.repeat_while is not None and memory.holds(rap.repeat_while, bindings, relations):
            return True
        return rap.repeat_until is not None and not memory.holds(rap.repeat_until, bindings, relations)

    def _fail(self, task: Task, reason: str, cause: Failure | None = None, *, fatal: bool = False,
              outcome: str = Outcome.FAIL) -> None:
        self._end(task, FAILED, Failure(task.text, reason, cause, fatal, outcome))

    def _timed_out(self, task: Task, seconds: float) -> None:
        if not task.finished:
            self._fail(task, f"timed out after {seconds:g} s (its timeout clause){self._waited(task)}",
                       task.methods.last_failure, outcome=Outcome.TIMEOUT)

    def _missed_deadline(self, task: Task) -> None:
        if not task.finished:
            self._fail(task, f"missed its deadline at t={task.deadline:g} s{self._waited(task)}",
                       task.methods.last_failure, outcome=Outcome.TIMEOUT)

    def _waited(self, task: Task) -> str:
        """What ``task`` (or a task under it) is waiting for, as the end of a timeout's reason."""
        for claim in self.resources.claims():
            under: Task | None = claim.task
            while under is not None and under is not task:
                under = under.parent
            if under is task:
                return f": it waited for {term_to_str(claim.call)} {self.held_by(claim)} since t={claim.since:g} s"
        return ""

    def _end(self, task: Task, status: Status, failure: Failure | None) -> None:
        self._stop(task)
        task.status = status
        task.failure = failure
        task.ended = self.timers.now
        if status == SUCCEEDED:
            self.trace.emit(Event.TASK_SUCCEEDED, id=task.id, task=task.text)
        else:
            fields = {"because": failure.root().what + ": " + failure.root().reason} if failure.cause else {}
            self.trace.emit(Event.TASK_FAILED, id=task.id, task=task.text, reason=failure.reason, **fields)
        if task.step is not None:
            task.step.child_ended(task)

    def _stop(self, task: Task) -> None:
        for timer in task.timers:
            timer.cancel()
        task.timers.clear()
        if task.backoff is not None:
            task.backoff.cancel()
            task.backoff = None
        run = task.run
        if run is not None:
            task.run = None
            run.halt()

    # -- memory and skills ------------------------------------------------------

    def change(self, changes: Iterable[Change], source: str = "", *, task: Task | None = None,
               skill: Compound | None = None) -> list[Change]:
        """Assert/retract facts, run the memory rules, trace it, and wake waiters it concerns.

        ``source`` names who made the outside changes (a skill, a task, an
        ``at-time`` event) in the trace; changes the rules made are traced
        as ``"by": "memory rule"``. ``task`` (or the holder of ``skill``) is
        the task a failure of these changes is charged to (see the module
        docstring for what a memory error does).
        """
        made: list[Change] = []
        trace = self.trace
        for change in changes:
            try:
                done = self.rules.apply(self.memory, (change,), self.timers.now)
            except LogicError as exc:
                self._memory_error(exc, change, source, task or self._holder(skill))
                return made
            if trace.active:
                for i, (kind, fact) in enumerate(done):
                    by = source if i == 0 else "memory rule"
                    event = Event.FACT_ASSERTED if kind == "assert" else Event.FACT_RETRACTED
                    trace.emit(event, fact=term_to_str(fact), **({"by": by} if by else {}))
            made += done
        if made and self.waits.size:
            self._wake(made)
        return made

    def _holder(self, skill: Compound | None) -> Task | None:
        if skill is None:
            return None
        held = self.holders.get(self.skills.instance(skill))
        return held[0].task if held is not None and held[1] == skill else None

    def _memory_error(self, exc: LogicError, change: Change, source: str, task: Task | None) -> None:
        """A change that memory could not take: fail its task; a broken rule stops the run."""
        message = str(exc)
        fields = {"id": task.id, "task": task.text} if task is not None else {}
        self.trace.emit(Event.MEMORY_ERROR, error=message, fact=term_to_str(change[1]),
                        **({"by": source} if source else {}), **fields)
        if not isinstance(exc, RuleError):
            if task is not None and not task.finished:
                self._fail(task, message)
            return
        self.fault = message
        if task is not None and not task.finished:
            self._fail(task, message, fatal=True)
        for root in self.live_roots():
            self.cancel(root, f"the run stopped: {message}")

    def assert_fact(self, fact: Compound, source: str = "") -> list[Change]:
        """Assert one fact (memory rules run, waiters wake); the changes made."""
        return self.change((("assert", fact),), source)

    def retract_fact(self, fact: Compound, source: str = "") -> list[Change]:
        """Retract one fact; the changes made."""
        return self.change((("retract", fact),), source)

    def _wake(self, made: list[Change]) -> None:
        memory, relations = self.memory, self.relations
        for waiter in self.waits.candidates(made):
            if not waiter.active:
                continue
            if waiter.any_change:
                waiter.owner.woken(waiter, {})
                continue
            try:
                answer = memory.ask(waiter.query, None, relations)
            except QueryError as exc:
                waiter.owner.broken(waiter, str(exc))
                continue
            if answer is not None:
                waiter.owner.woken(waiter, answer)

    def enable_skill(self, run: MethodRun, call: Compound, node: Node) -> Refusal | None:
        """Enable a skill for ``node`` of a method; None, or the outcome and reason its step ends with.

        The skill's instance (:meth:`SkillLink.instance`) then belongs to
        ``run``'s task. If another live task holds it (or waits for it
        ahead of this one), this one waits: the outcome is
        :data:`~atlas_rap.sequencer.net.WAITING_OUTCOME` and ``node.claim``
        its place in the queue, served by :meth:`settle`. A task that
        outranks the holder takes the instance and halts the holder's step.
        """
        if not is_ground(call):
            return Outcome.FAIL, f"skill {term_to_str(call)} was enabled with unbound arguments"
        if not self.is_skill(call):
            return Outcome.FAIL, f"no skill {call.functor} with {_plural(len(call.args), 'argument')}"
        instance = self.skills.instance(call)
        held = self.holders.get(instance)
        task = run.task
        if held is not None and held[0] is not run:
            if not _outranks(task, held[0].task) and not self._closes_a_circle(run, held[0]):
                return self._wait(node, call, instance)
            self._preempt(held, run, call)
            if not run.live:  # the holder's failure halted this very task
                return HALTED_OUTCOME, "its method was halted"
        elif held is None and instance in self.resources.queues:
            ahead = self.resources.best(instance)
            if ahead is not None and ahead.task is not task and agenda_key(ahead.task) < agenda_key(task):
                return self._wait(node, call, instance)
        stale = list(self.memory.facts(Compound("done", (call, _ANY)))) + list(
            self.memory.facts(Compound("why", (call, _ANY))))
        if stale:
            self.change([("retract", fact) for fact in stale], "sequencer (a new run of the skill)")
        self.skills.enable(call)
        self.holders[instance] = (run, call)
        run.enabled[call] = node
        self.trace.emit(Event.SKILL_ENABLED, skill=term_to_str(call), id=task.id, task=task.text)
        return None

    def _wait(self, node: Node, call: Compound, instance: Hashable, *, preempted: bool = False) -> Refusal:
        """Queue ``node``'s claim on ``instance`` and trace the wait."""
        task = node.run.task
        claim = node.claim = Claim(node, task, call, instance, self.timers.now, preempted)
        self.resources.queue(claim)
        held = self.holders.get(instance)
        holder = {"holder_id": held[0].task.id, "holder": held[0].task.text} if held is not None else {}
        self.trace.emit(Event.TASK_WAITING, id=task.id, task=task.text, skill=term_to_str(call), **holder)
        what = f"{term_to_str(call)} {self.held_by(claim)}"
        above: Task | None = task
        while above is not None:  # a plan whose step this is watches the wait against its deadline
            if above.step is not None:
                above.step.subtask_waiting(claim, what)
            above = above.parent
        return WAITING_OUTCOME, f"waiting for {what}"

    def _closes_a_circle(self, run: MethodRun, holder: MethodRun) -> bool:
        """Whether ``run`` waiting for ``holder`` would close a circle of waits: the holder waits (a
        ``primitive`` holding one skill while it waits for another) for a run that waits ... for
        ``run``. Then ``run`` takes the instance instead, as if it outranked the holder."""
        waiting = self.resources.waiting_runs
        seen: set[MethodRun] = set()
        while holder is not run:
            claim = waiting.get(holder)
            if claim is None or holder in seen:
                return False
            seen.add(holder)
            held = self.holders.get(claim.instance)
            if held is None:
                return False
            holder = held[0]
        return True

    def held_by(self, claim: Claim) -> str:
        """Who has the instance ``claim`` waits for: ``held by [4] (go-to office) of [1] (deliver ...)``."""
        held = self.holders.get(claim.instance)
        if held is None:
            return "(free: it is handed over at the end of this instant)"
        holder = held[0].task
        root = _ancestors(holder)[0]
        of = f" of [{root.id}] {root.text}" if root is not holder else ""
        return f"held by [{holder.id}] {holder.text}{of}"

    def _preempt(self, held: tuple[MethodRun, Compound], run: MethodRun, call: Compound) -> None:
        """``run``'s task outranks the holder: halt the holder's step (it waits to resume) or, with
        ``(on-preempt fail)``, fail it."""
        holder_run, holder_call = held
        holder, newcomer = holder_run.task, run.task
        resume = holder_run.method.on_preempt == "resume"
        outcome = Outcome.HALTED if resume else Outcome.PREEMPTED
        self.trace.emit(Event.SKILL_PREEMPTED, skill=term_to_str(holder_call), outcome=outcome,
                        id=holder.id, task=holder.text, winner_id=newcomer.id, winner=newcomer.text)
        reason = f"preempted by [{newcomer.id}] {newcomer.text}, which enabled {term_to_str(call)}"
        holder_run.preempt(holder_call, reason, resume)

    def withdraw(self, claim: Claim) -> None:
        """``claim``'s step stops waiting (it was halted, or ended another way)."""
        self.resources.withdraw(claim)

    def wait_again(self, node: Node, call: Compound) -> None:
        """``node`` lost the skill ``call`` to a task that outranks it: it waits to resume."""
        self._wait(node, call, self.skills.instance(call), preempted=True)

    def _serve_released(self) -> None:
        """Hand each instance let go to the best claim waiting for it (agenda order)."""
        resources, holders = self.resources, self.holders
        for instance in resources.take_released():
            while instance not in holders:
                claim = resources.pop_best(instance)
                if claim is None:
                    break
                node = claim.node
                if node.claim is claim and node.run.live:
                    self._resume(claim)

    def _resume(self, claim: Claim) -> None:
        task, node = claim.task, claim.node
        node.claim = None
        run = node.run
        waited = self.timers.now - claim.since
        changed = self._changed_while_halted(run) if claim.preempted else None
        fields = {"rechoose": changed} if changed is not None else {}
        self.trace.emit(Event.TASK_RESUMED, id=task.id, task=task.text, skill=term_to_str(claim.call),
                        waited=_seconds(waited), **fields)
        if changed is None:
            node.resume(claim.call, claim.preempted)
            return
        task.methods.refund(run.number)  # the halted attempt is not charged
        if task.run is run:
            task.run = None
        run.halt()
        task.status = PENDING
        self.agenda.push(task)

    def _changed_while_halted(self, run: MethodRun) -> str | None:
        """Why a halted method should not just go on (its task chooses again), or None."""
        task = run.task
        rap = self.library.get((task.call.functor, len(task.call.args)))
        memory, relations = self.memory, self.relations
        try:
            if rap is not None and rap.succeed is not None and memory.holds(rap.succeed, task.bindings, relations):
                return f"its succeed test {_shown(rap.succeed, task.bindings)} holds"
            context = run.method.context
            if context is not None and not memory.holds(context, task.bindings, relations):
                return f"the context of method {run.label} no longer holds: {_shown(context, task.bindings)}"
        except QueryError:
            return None
        return None

    def disable_skill(self, run: MethodRun, call: Compound) -> None:
        """Disable a skill a method enabled (nothing if it did not or already did)."""
        if call in run.enabled:
            del run.enabled[call]
            instance = self.skills.instance(call)
            if self.holders.get(instance) == (run, call):
                del self.holders[instance]
                self.resources.release(instance)
            self.skills.disable(call)
            self.trace.emit(Event.SKILL_DISABLED, skill=term_to_str(call), id=run.task.id, task=run.task.text)

    def step_outcome(self, task: Task, step, outcome: str, why: str = "") -> None:
        """Trace the outcome of a step (a net node with ``describe()``); a failure carries its reason."""
        if self.trace.active:
            fields = {"reason": why} if why and outcome in FAILURE_OUTCOMES else {}
            self.trace.emit(Event.STEP_OUTCOME, id=task.id, task=task.text, step=step.describe(), outcome=outcome,
                            **fields)


def _retries(rap: ast.RapDef) -> int:
    """The method attempts a task of ``rap`` gets (its ``retries``, else the default)."""
    return rap.retries if rap.retries is not None else DEFAULT_RETRIES


def _retry_backoff(rap: ast.RapDef) -> float:
    """How long a failed attempt of ``rap`` waits for a change (its ``retry-backoff``, else the default)."""
    return rap.retry_backoff if rap.retry_backoff is not None else DEFAULT_RETRY_BACKOFF


def _outranks(newcomer: Task, holder: Task) -> bool:
    """Whether ``newcomer`` takes a skill instance ``holder`` holds: a higher priority, or the holder
    is its own ancestor (it would wait for itself). On a tie the newcomer waits."""
    above = newcomer.parent
    while above is not None:
        if above is holder:
            return True
        above = above.parent
    return newcomer.priority > holder.priority


def _ancestors(task: Task) -> list[Task]:
    chain = []
    node: Task | None = task
    while node is not None:
        chain.append(node)
        node = node.parent
    return chain[::-1]


def _shown(query: Term | None, bindings: Subst) -> str:
    return term_to_str(substitute(query, bindings)) if query is not None else "t"


def _seconds(span: float) -> float:
    """A span of simulated time as the trace writes it (no float noise: 8.8, not 8.799999999999997)."""
    return round(span, 9)


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def _no_method(rap: ast.RapDef, bindings: Subst) -> str:
    if not rap.methods:
        return "its RAP has no method"
    contexts = "; ".join(f"method {method_label(m, i)}: {_shown(m.context, bindings)}"
                         for i, m in enumerate(rap.methods, 1) if m.context is not None)
    return f"no applicable method (contexts false: {contexts})"


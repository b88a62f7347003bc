"""Running a method: task nets, primitives and wait-fors as live nodes.

When the interpreter chooses a method it builds a :class:`MethodRun`, a tree
of nodes mirroring the method's body (docs/language/rap.md: task nets, wait-for, primitive):

- :class:`SequenceNode` starts its parts one after another; a
  :class:`ParallelNode` starts them all and ends when all have ended
  (several nets directly under ``task-net`` are a parallel);
- a :class:`StepNode` runs one subtask: a child task when its name is a
  RAP, else the skill-step shorthand (enable the skill, wait for
  ``(done (SKILL ARG ...) OUTCOME)``, disable it). Its ``wait-for``
  annotations race with that: the first to match decides the outcome and
  the rest is halted. ``(for L)`` holds step ``L`` back until this step has
  ended well; ``(until-end L)`` halts this step when ``L`` ends;
- a :class:`WaitNode` is a bare ``(wait-for Q)``; a :class:`MemoryNode` an
  ``assert``/``retract`` step; a :class:`PrimitiveNode` a ``primitive`` body;
- a :class:`PlanNode` is a ``(plan GOAL ...)`` step: it asks the planner and
  carries the plan out (``deliberation.PlanExecution``), ending ``:succeed``
  when the goals hold and ``:fail`` when the plan is abandoned.

Nodes report upward: a part that ends well calls ``parent.child_done``; a
step that ends with a failure outcome (``:fail``, ``:timeout``, and for a
skill taken by a task of higher priority in a method with ``(on-preempt
fail)``, ``:preempted``) fails the whole method (``MethodRun.fail``), which
halts every live node. A step whose skill is held by another task waits
(state ``waiting``, its ``claim`` queued in the sequencer's resources) and
begins when it is served (:meth:`Node.resume`); a step whose skill is taken
from it waits the same way and runs again. Bindings made by a
``wait-for`` join the method's bindings, so later steps can use them.
Every skill a method enabled is disabled when the method ends, however it
ends: no skill is ever left running by a dead method.

Over 25 KB on purpose: task nets: their nodes, orderings and the method run that executes
them, which share the step state machine.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Protocol

from atlas_rap.lang import ast
from atlas_rap.logic import (
    Compound,
    FactError,
    QueryError,
    String,
    Subst,
    Term,
    Var,
    is_ground,
    substitute,
    term_to_str,
)
from atlas_rap.logic.arithmetic import evaluated_fact
from atlas_rap.sequencer.deliberation import PlanExecution
from atlas_rap.sequencer.host import Subtasks, Watching
from atlas_rap.sequencer.status import FAILURE_OUTCOMES, Outcome, StepState
from atlas_rap.sequencer.task import SUCCEEDED, Failure, SkillWait, Task
from atlas_rap.sequencer.waiting import Waiter

if TYPE_CHECKING:
    from atlas_rap.skillbus.timers import Timer

HALTED_OUTCOME = Outcome.HALTED
"""The outcome recorded for a monitor halted by ``until-end``."""

WAITING_OUTCOME = Outcome.WAITING
"""What ``Sequencer.enable_skill`` answers when the step must wait for its skill (not an outcome a
step ends with: the step goes on when it is served)."""

_NEW, _BLOCKED, _WAITING = StepState.NEW, StepState.BLOCKED, StepState.WAITING  # StepNode's states, read
_RUNNING, _DONE = StepState.RUNNING, StepState.DONE  # as globals: cheaper than StepState.X in its hot paths

_OUTCOME = Var("%outcome")  # binds the outcome in (done (SKILL ...) ?outcome); no source can name it
_WHY = Var("%why")  # binds the reason in (why (SKILL ...) "reason"), which a skill may post before done


Refusal = tuple[Outcome, str]
"""Why ``enable_skill`` did not enable a skill: the outcome its step ends with (or :data:`WAITING_OUTCOME`:
the step waits for the skill) and the reason."""


class SkillResources(Protocol):
    """Skills as resources, as a method's steps use them (``Sequencer.enable_skill``: who holds,
    who waits, who is preempted)."""

    def is_skill(self, call: Compound) -> bool:
        """Whether ``call`` names a skill the skill link has, with that many arguments."""
        ...

    def enable_skill(self, run: MethodRun, call: Compound, node: Node) -> Refusal | None:
        """Enable ``call`` for ``node``: None, or why not (the step may have to wait: ``node.claim``)."""
        ...

    def disable_skill(self, run: MethodRun, call: Compound) -> None:
        """Disable a skill ``run`` enabled (nothing if it did not, or already did)."""
        ...

    def wait_again(self, node: Node, call: Compound) -> None:
        """``node`` lost the skill ``call`` to a task that outranks it: it waits to resume."""
        ...

    def held_by(self, claim: SkillWait) -> str:
        """Who holds the skill instance ``claim`` waits for, for people."""
        ...

    def withdraw(self, claim: SkillWait) -> None:
        """``claim``'s step stops waiting."""
        ...


class NetHost(Watching, Subtasks, SkillResources, Protocol):
    """What a method run and its nodes need of the interpreter (``Sequencer`` satisfies it): memory,
    the wait index and timers, subtasks, the skills as resources, plans, and where steps and
    methods report."""

    def is_rap(self, call: Compound) -> bool:
        """Whether ``call`` names a RAP (a step with it spawns a subtask)."""
        ...

    def start_plan(self, owner: Task, goals: tuple[Term, ...], on_end: Callable[[str, str], None], *,
                   deadline: float | None, max_failures: int | None) -> PlanExecution | None:
        """Start carrying out a plan for ``goals`` (a ``(plan GOAL ...)`` step of ``owner``'s method);
        None when the run has no planner."""
        ...

    def step_outcome(self, task: Task, step: _Leaf, outcome: str, why: str = "") -> None:
        """Trace the outcome of a step of ``task``'s method."""
        ...

    def method_ended(self, run: MethodRun, failure: Failure | None) -> None:
        """The method's body ended (``failure`` None) or failed: the task goes on or fails."""
        ...


def method_label(method: ast.Method, number: int) -> str:
    """How a method is named in the trace: its name, or its 1-based position."""
    return method.name or str(number)


class MethodRun:
    """One attempt of one method of a task: its live net, bindings and enabled skills."""

    def __init__(self, host: NetHost, task: Task, method: ast.Method, number: int, subst: Subst) -> None:
        self.host = host
        self.task = task
        self.method = method
        self.number = number
        self.subst = subst
        self.live = True
        self.enabled: dict[Compound, Node] = {}  # each skill call enabled, and the node that enabled it
        self.labels: dict[str, StepNode] = {}
        self.root = _build(method.body, self, self)
        for node in self.labels.values():
            for label in node.step.before:
                successor = self.labels[label]
                successor.gate += 1
                node.successors.append(successor)
            if node.step.until_end is not None:
                self.labels[node.step.until_end].monitors.append(node)

    @property
    def label(self) -> str:
        return method_label(self.method, self.number)

    def start(self) -> None:
        self.root.start()

    def child_done(self, node: Node) -> None:
        """The body ended well."""
        if self.live:
            self._stop()
            self.host.method_ended(self, None)

    def fail(self, failure: Failure) -> None:
        """A step failed: halt everything still live, then tell the task."""
        if self.live:
            self._stop()
            self.host.method_ended(self, Failure(f"method {self.label}", "a step failed", failure,
                                                 failure.fatal))

    def halt(self) -> None:
        """Stop the method from outside (its task ended, failed or was halted)."""
        if self.live:
            self._stop()

    def preempt(self, call: Compound, reason: str, resume: bool) -> None:
        """A task that outranks this one took the skill ``call``: the step that runs it waits to
        resume (``resume``) or ends ``:preempted``."""
        node = self.enabled.get(call)
        if node is None or not self.live:
            self.host.disable_skill(self, call)
            return
        node.preempted(call, reason, resume)

    def _stop(self) -> None:
        self.live = False
        self.root.halt()
        for call in list(self.enabled):
            self.host.disable_skill(self, call)

    def waiting_for(self) -> list[str]:
        """What the live leaves of this method are waiting for, for introspection."""
        return self.root.waiting_for()


class Node:
    """A live part of a method body."""

    __slots__ = ("run", "parent", "claim")

    def __init__(self, run: MethodRun, parent: Node | MethodRun) -> None:
        self.run = run
        self.parent = parent
        self.claim: SkillWait | None = None  # its place in the queue for a skill, while it waits for one

    def start(self) -> None:
        raise NotImplementedError

    def halt(self) -> None:
        """Stop without telling the parent (safe on a node that never started or has ended)."""

    def child_done(self, child: Node) -> None:
        raise NotImplementedError

    def waiting_for(self) -> list[str]:
        return []

    def preempted(self, call: Compound, reason: str, resume: bool) -> None:
        """A task that outranks this one took the skill ``call`` this node enabled (only
        skill-running nodes do more than let it go)."""
        self.run.host.disable_skill(self.run, call)

    def resume(self, call: Compound, preempted: bool) -> None:
        """The skill ``call`` this node waited for is free for it: go on (only skill-running nodes wait)."""
        raise NotImplementedError

    def _stop_waiting(self) -> None:
        """Leave the queue for a skill, if waiting in one."""
        claim, self.claim = self.claim, None
        if claim is not None:
            self.run.host.withdraw(claim)


class SequenceNode(Node):
    """Starts its parts one after another; parts that end at once do not nest calls."""

    __slots__ = ("parts", "index", "starting", "ended_at_once")

    def __init__(self, run: MethodRun, parent: Node | MethodRun, parts: tuple[ast.Net, ...]) -> None:
        super().__init__(run, parent)
        self.parts = [_build(part, run, self) for part in parts]
        self.index = -1
        self.starting = False
        self.ended_at_once = False

    def start(self) -> None:
        self.index = 0
        self._run_parts()

    def _run_parts(self) -> None:
        """Start parts from ``index`` on until one keeps running (or all have ended)."""
        parts = self.parts
        while self.index < len(parts):
            self.starting, self.ended_at_once = True, False
            parts[self.index].start()
            self.starting = False
            if not self.ended_at_once or not self.run.live:
                return
            self.index += 1
        self.parent.child_done(self)

    def child_done(self, child: Node) -> None:
        if not self.run.live:
            return
        if self.starting:
            self.ended_at_once = True
            return
        self.index += 1
        self._run_parts()

    def halt(self) -> None:
        if 0 <= self.index < len(self.parts):
            self.parts[self.index].halt()
        self.index = len(self.parts)

    def waiting_for(self) -> list[str]:
        if 0 <= self.index < len(self.parts):
            return self.parts[self.index].waiting_for()
        return []


class ParallelNode(Node):
    __slots__ = ("parts", "remaining")

    def __init__(self, run: MethodRun, parent: Node | MethodRun, parts: tuple[ast.Net, ...]) -> None:
        super().__init__(run, parent)
        self.parts = [_build(part, run, self) for part in parts]
        self.remaining = 0

    def start(self) -> None:
        self.remaining = len(self.parts)
        if not self.parts:
            self.parent.child_done(self)
        for part in self.parts:
            if not self.run.live:
                return
            part.start()

    def child_done(self, child: Node) -> None:
        if not self.run.live:
            return
        self.remaining -= 1
        if self.remaining == 0:
            self.parent.child_done(self)

    def halt(self) -> None:
        for part in self.parts:
            part.halt()

    def waiting_for(self) -> list[str]:
        return [text for part in self.parts for text in part.waiting_for()]


WaitEntry = tuple[Term, "str | None", "float | None", "str | None"]
"""One raced wait: (query, outcome or None, timeout or None, label or None); see :class:`WaitGroup`."""


class WaitGroup:
    """Several wait-fors raced on one step: the first to match decides the outcome.

    Each entry is ``(query, outcome, timeout, label)`` with the query already
    substituted; ``outcome`` None takes the outcome from the ``%outcome``
    binding (a skill's ``done`` fact); ``label`` names the entry in messages
    (None: the ``wait-for`` as written, made only when a message needs it).
    Queries that hold when the group starts match at once, in the order
    written.
    """

    __slots__ = ("host", "entries", "on_done", "waiters", "timers", "done")

    def __init__(self, host: Watching, entries: list[WaitEntry],
                 on_done: Callable[[str, str, Subst | None], None]) -> None:
        self.host = host
        self.entries = entries
        self.on_done = on_done
        self.waiters: list[Waiter] = []
        self.timers: list[Timer] = []
        self.done = False

    def start(self) -> None:
        memory, relations = self.host.memory, self.host.relations
        for index, (query, _, _, _) in enumerate(self.entries):
            try:
                answer = memory.ask(query, None, relations)
            except QueryError as exc:
                self._decide(Outcome.FAIL, f"{_entry_text(self.entries[index])} cannot be evaluated: {exc}", None)
                return
            if answer is not None:
                self._matched(index, answer)
                return
        waits = self.host.waits
        for index, entry in enumerate(self.entries):
            waiter = Waiter(entry[0], self, index)
            waits.add(waiter)
            self.waiters.append(waiter)
            timeout = entry[2]
            if timeout is not None:
                self.timers.append(self.host.timers.after(
                    timeout, lambda entry=entry, timeout=timeout: self._decide(
                        Outcome.TIMEOUT, f"{_entry_text(entry)} timed out after {_seconds(timeout)}", None),
                    late=True))

    def woken(self, waiter: Waiter, answer: Subst) -> None:
        self._matched(waiter.tag, answer)  # type: ignore[arg-type]

    def broken(self, waiter: Waiter, message: str) -> None:
        entry = self.entries[waiter.tag]  # type: ignore[index]
        self._decide(Outcome.FAIL, f"{_entry_text(entry)} cannot be evaluated: {message}", None)

    def _matched(self, index: int, answer: Subst) -> None:
        entry = self.entries[index]
        outcome = entry[1]
        if outcome is None:
            outcome = str(answer.get(_OUTCOME, ":succeed"))
            why = f"finished {outcome}"
            if outcome in FAILURE_OUTCOMES:
                said = self.host.memory.ask(Compound("why", (entry[0].args[0], _WHY)))  # type: ignore[union-attr]
                if said is not None:
                    why += f": {_plain(said[_WHY])}"
        elif outcome in FAILURE_OUTCOMES:  # a reason is only ever shown for a failure
            why = f"{_entry_text(entry)} matched {term_to_str(substitute(entry[0], answer))}"
        else:
            why = ""
        self._decide(outcome, why, answer)

    def _decide(self, outcome: str, why: str, answer: Subst | None) -> None:
        if self.done:
            return
        self.cancel()
        self.on_done(outcome, why, answer)

    def cancel(self) -> None:
        self.done = True
        waits = self.host.waits
        for waiter in self.waiters:
            waits.remove(waiter)
        for timer in self.timers:
            timer.cancel()

    def describe(self) -> list[str]:
        return [] if self.done else [_entry_text(entry) for entry in self.entries]


def _wait_entry(wait: ast.WaitFor, subst: Subst) -> WaitEntry:
    return (substitute(wait.query, subst) if subst else wait.query), wait.outcome, wait.timeout, None


def _entry_text(entry: WaitEntry) -> str:
    return entry[3] or f"(wait-for {term_to_str(entry[0])})"


class _Leaf(Node):
    """A node that ends with an outcome: records it, then fails the method or reports up."""

    __slots__ = ("group",)

    def describe(self) -> str:
        raise NotImplementedError

    def record(self, outcome: str, why: str, cause: Failure | None = None) -> bool:
        """Trace the outcome; fail the method on a failure outcome. True when it counts as success."""
        run = self.run
        self.run.host.step_outcome(run.task, self, outcome, why)
        if outcome in FAILURE_OUTCOMES:
            run.fail(Failure(self.describe(), why, cause))
            return False
        return True

    def bind(self, answer: Subst | None) -> None:
        if answer:
            subst = self.run.subst
            for var, value in answer.items():
                if var not in subst and var is not _OUTCOME:
                    subst[var] = value


class WaitNode(_Leaf):
    """A bare ``(wait-for Q [OUTCOME] [:timeout S])`` in a net."""

    __slots__ = ("wait",)

    def __init__(self, run: MethodRun, parent: Node | MethodRun, wait: ast.WaitFor) -> None:
        super().__init__(run, parent)
        self.wait = wait
        self.group: WaitGroup | None = None

    def describe(self) -> str:
        return _entry_text(_wait_entry(self.wait, self.run.subst))

    def start(self) -> None:
        self.group = WaitGroup(self.run.host, [_wait_entry(self.wait, self.run.subst)], self._decided)
        self.group.start()

    def _decided(self, outcome: str, why: str, answer: Subst | None) -> None:
        self.bind(answer)
        if self.record(outcome, why):
            self.parent.child_done(self)

    def halt(self) -> None:
        if self.group is not None:
            self.group.cancel()

    def waiting_for(self) -> list[str]:
        return self.group.describe() if self.group is not None else []


class MemoryNode(Node):
    """An ``(assert FACT)`` or ``(retract FACT)`` step: changes memory and ends at once."""

    __slots__ = ("op",)

    def __init__(self, run: MethodRun, parent: Node | MethodRun, op: ast.MemoryOp) -> None:
        super().__init__(run, parent)
        self.op = op

    def start(self) -> None:
        run = self.run
        if _apply_memory_op(run, self.op):
            if run.live:
                self.parent.child_done(self)


class StepNode(_Leaf):
    """A subtask: a child task (RAP) or the skill-step shorthand, raced by its wait-fors."""

    __slots__ = ("step", "gate", "successors", "monitors", "state", "child", "skill", "cut", "call", "execution")

    def __init__(self, run: MethodRun, parent: Node | MethodRun, step: ast.Step) -> None:
        super().__init__(run, parent)
        self.step = step
        self.gate = 0  # steps that must end well first, from their (for L) annotations
        self.successors: list[StepNode] = []
        self.monitors: list[StepNode] = []
        self.state = _NEW
        self.child: Task | None = None
        self.skill: Compound | None = None
        self.group: WaitGroup | None = None
        self.cut = False
        self.execution: PlanExecution | None = None
        request = step.plan
        self.call: Term = step.task if request is None else Compound("plan", request.goals)  # type: ignore[assignment]
        if step.label is not None:
            run.labels[step.label] = self

    def describe(self) -> str:
        label = f"{self.step.label} " if self.step.label else ""
        return f"step {label}{term_to_str(self.call)}"

    def start(self) -> None:
        if self.cut:
            self.state = _DONE
            self._ended()
        elif self.gate:
            self.state = _BLOCKED
        else:
            self._begin()

    def open_gate(self) -> None:
        self.gate -= 1
        if self.gate == 0 and self.state is _BLOCKED:
            self._begin()

    def _begin(self) -> None:
        run = self.run
        host = run.host
        self.state = _RUNNING
        if self.step.plan is not None:
            self._begin_plan(self.step.plan)
            return
        call = self.call = substitute(self.step.task, run.subst) if run.subst else self.step.task
        if host.is_rap(call):
            self.child = host.spawn(call, run.task, self)
            entries = []
        elif host.is_skill(call):
            refused = host.enable_skill(run, call, self)
            if refused is not None:
                if refused[0] == WAITING_OUTCOME:
                    self.state = _WAITING
                    return
                self.state = _DONE
                if run.live:
                    self.record(*refused)
                return
            self.skill = call
            entries = [(Compound("done", (call, _OUTCOME)), None, None, f"skill {term_to_str(call)}")]
        else:
            self.state = _DONE
            self.record(Outcome.FAIL, f"{call.functor} is neither a RAP nor a skill")
            return
        entries += [_wait_entry(wait, run.subst) for wait in self.step.waits]
        if entries and run.live and self.state is _RUNNING:
            self.group = WaitGroup(host, entries, self._decided)
            self.group.start()

    def _begin_plan(self, request: ast.PlanRequest) -> None:
        """A labelled ``(LABEL (plan GOAL ...) ...)`` step: carry out a plan, raced by the step's wait-fors."""
        run = self.run
        started = _start_plan(run, request, self._plan_ended)
        if not isinstance(started, PlanExecution):
            self.state = _DONE
            self.record(*started)
            return
        self.execution = started
        self.call = Compound("plan", started.goals_asked)
        entries = [_wait_entry(wait, run.subst) for wait in self.step.waits]
        if entries and run.live and self.state is _RUNNING:
            self.group = WaitGroup(run.host, entries, self._decided)
            self.group.start()

    def _plan_ended(self, outcome: str, why: str) -> None:
        self.execution = None
        if self.state is _RUNNING:
            self._finish(outcome, why, None)

    def subtask_waiting(self, wait: object, what: str) -> None:
        """A task under this step waits for a skill: nothing to do (a plan's step watches its deadline)."""

    def child_ended(self, child: Task) -> None:
        """The child task ended (succeeded or failed) before any wait-for matched."""
        if self.state is not _RUNNING:
            return
        if child.status == SUCCEEDED:
            self._finish(Outcome.SUCCEED, f"{child.text} succeeded", None)
        else:
            failure = child.failure
            self._finish(failure.outcome if failure else Outcome.FAIL, failure.reason if failure else "failed",
                         failure, fatal=bool(failure and failure.fatal))

    def _decided(self, outcome: str, why: str, answer: Subst | None) -> None:
        if self.state is not _RUNNING:
            return
        self.bind(answer)
        cause = None
        if self.skill is not None and outcome in FAILURE_OUTCOMES:
            cause = Failure(f"skill {term_to_str(self.skill)}", why)
            why = "the skill failed"
        self._finish(outcome, why, cause)

    def _finish(self, outcome: str, why: str, cause: Failure | None, fatal: bool = False) -> None:
        self.state = _DONE
        self._release(self, f"ended {outcome}")
        run = self.run
        run.host.step_outcome(run.task, self, outcome, cause.reason if cause else why)
        if outcome in FAILURE_OUTCOMES:
            if cause is not None and self.child is not None:
                run.fail(Failure(self.describe(), "the subtask failed", cause, fatal))
            else:
                run.fail(Failure(self.describe(), why, cause, fatal))
            return
        self._ended()

    def _ended(self) -> None:
        for monitor in self.monitors:
            monitor.cut_off(self)
        for successor in self.successors:
            if self.run.live:
                successor.open_gate()
        if self.run.live:
            self.parent.child_done(self)

    def cut_off(self, target: StepNode) -> None:
        """``until-end``: the step this one monitors has ended, so this one stops."""
        if self.state is _DONE or not self.run.live:
            return
        if self.state is _NEW:
            self.cut = True
            return
        was_running = self.state is _RUNNING or self.state is _WAITING
        self._stop_waiting()
        self.state = _DONE
        if was_running:
            self._release(target, "ended (until-end)")
            self.run.host.step_outcome(self.run.task, self, HALTED_OUTCOME)
        self._ended()

    def _release(self, cause: _Leaf | None, what: str) -> None:
        """Stop this step's work: its waits, its child task (saying why) and its skill."""
        if self.group is not None:
            self.group.cancel()
        execution, self.execution = self.execution, None
        if execution is not None:
            execution.halt(f"{cause.describe()} {what}" if cause is not None else what)
        child = self.child
        if child is not None and not child.finished:
            self.run.host.halt(child, f"{cause.describe()} {what}" if cause is not None else what)
        if self.skill is not None:
            self.run.host.disable_skill(self.run, self.skill)

    def halt(self) -> None:
        if self.state is _RUNNING:
            self._release(None, "its method was halted")
        self._stop_waiting()
        self.state = _DONE

    def preempted(self, call: Compound, reason: str, resume: bool) -> None:
        if self.state is not _RUNNING or call != self.skill:
            super().preempted(call, reason, resume)
            return
        if not resume:
            self._finish(Outcome.PREEMPTED, "the skill was taken by another task",
                         Failure(f"skill {term_to_str(call)}", reason))
            return
        self._release(None, "its skill was taken")  # its waits and its skill
        self.group = self.skill = None
        self.state = _WAITING
        self.run.host.wait_again(self, call)

    def resume(self, call: Compound, preempted: bool) -> None:
        if self.state is _WAITING and self.run.live:
            self._begin()

    def waiting_for(self) -> list[str]:
        if self.state is _BLOCKED:
            return [f"{self.describe()}: waiting for an earlier step (for)"]
        if self.state is _WAITING and self.claim is not None:
            return [f"{term_to_str(self.claim.call)} {self.run.host.held_by(self.claim)}"]
        if self.execution is not None:
            return self.execution.waiting_for()
        if self.state is not _RUNNING or self.group is None or self.child is not None:
            return []
        return self.group.describe()


class PrimitiveNode(_Leaf):
    """A ``primitive`` body: enable, wait-for groups, disable and memory actions, in order.

    An ``enable`` whose skill another task holds waits there (``claim``) and
    goes on from that skill when served. A skill taken from it by a task that
    outranks it is enabled again when served, and the primitive goes on where
    it was: waiting on the ``wait-for`` group it was waiting on (again from
    the group's start), or at the ``enable`` it was waiting at.
    """

    __slots__ = ("actions", "index", "skill_index", "group_start")

    def __init__(self, run: MethodRun, parent: Node | MethodRun, primitive: ast.Primitive) -> None:
        super().__init__(run, parent)
        self.actions = primitive.actions
        self.index = 0
        self.skill_index = 0  # within an enable of several skills, the next to enable
        self.group: WaitGroup | None = None
        self.group_start = 0

    def describe(self) -> str:
        return "primitive"

    def start(self) -> None:
        self._continue()

    def _continue(self) -> None:
        run, host, actions = self.run, self.run.host, self.actions
        while self.index < len(actions) and run.live:
            action = actions[self.index]
            if isinstance(action, ast.WaitFor):
                end = self.index
                while end < len(actions) and isinstance(actions[end], ast.WaitFor):
                    end += 1
                entries = [_wait_entry(wait, run.subst) for wait in actions[self.index:end]]  # type: ignore[arg-type]
                self.group_start, self.index = self.index, end
                self.group = WaitGroup(host, entries, self._decided)
                self.group.start()
                return
            if isinstance(action, ast.Enable):
                skills = action.skills
                while self.skill_index < len(skills):
                    skill = substitute(skills[self.skill_index], run.subst)
                    refused = host.enable_skill(run, skill, self)  # type: ignore[arg-type]
                    if refused is not None:
                        if refused[0] != WAITING_OUTCOME and run.live:
                            self.record(*refused)
                        return
                    self.skill_index += 1
                self.skill_index = 0
                self.index += 1
                continue
            self.index += 1
            if isinstance(action, ast.Disable):
                calls = list(run.enabled) if action.above else [substitute(s, run.subst) for s in action.skills]
                for call in calls:
                    host.disable_skill(run, call)  # type: ignore[arg-type]
            elif not _apply_memory_op(run, action):  # type: ignore[arg-type]
                return
        if run.live:
            self.parent.child_done(self)

    def _decided(self, outcome: str, why: str, answer: Subst | None) -> None:
        self.bind(answer)
        if self.record(outcome, why):
            self._continue()

    def halt(self) -> None:
        if self.group is not None:
            self.group.cancel()
        self._stop_waiting()
        self.index = len(self.actions)

    def preempted(self, call: Compound, reason: str, resume: bool) -> None:
        if self.group is not None and not self.group.done:
            self.group.cancel()
            self.index = self.group_start  # resumed, it waits on this group again
        self._stop_waiting()  # waiting at a later enable: it goes on there once it has this skill back
        if resume:
            self.run.host.disable_skill(self.run, call)
            self.run.host.wait_again(self, call)
            return
        self.index = len(self.actions)
        self.record(Outcome.PREEMPTED, f"skill {term_to_str(call)} {reason}")

    def resume(self, call: Compound, preempted: bool) -> None:
        run = self.run
        if preempted:
            refused = run.host.enable_skill(run, call, self)
            if refused is not None:
                if refused[0] != WAITING_OUTCOME and run.live:
                    self.record(*refused)
                return
            if self.index >= len(self.actions):  # it had ended, leaving the skill on: on again, that is all
                return
        self._continue()  # from the group or the enable it was at

    def waiting_for(self) -> list[str]:
        if self.claim is not None:
            return [f"{term_to_str(self.claim.call)} {self.run.host.held_by(self.claim)}"]
        return self.group.describe() if self.group is not None else []


class PlanNode(_Leaf):
    """A ``(plan GOAL ... [:deadline S] [:max-failures N])`` step: the sequencer calling the deliberator.

    The goals (with the method's bindings) go to the planner; the plan is
    carried out by RAPs as subtasks of this task, watched and repaired
    (:class:`~atlas_rap.sequencer.deliberation.PlanExecution`). The step
    ends with the plan: ``:succeed`` (or ``:partial``) when carried out,
    ``:fail`` when abandoned, ``:timeout`` at its deadline.
    """

    __slots__ = ("request", "execution", "goals")

    def __init__(self, run: MethodRun, parent: Node | MethodRun, request: ast.PlanRequest) -> None:
        super().__init__(run, parent)
        self.request = request
        self.execution: PlanExecution | None = None
        self.goals: tuple[Term, ...] = request.goals

    def describe(self) -> str:
        return "(plan " + " ".join(term_to_str(g) for g in self.goals) + ")"

    def start(self) -> None:
        started = _start_plan(self.run, self.request, self._ended)
        if isinstance(started, PlanExecution):
            self.execution = started
            self.goals = started.goals_asked
        else:
            self.record(*started)

    def _ended(self, outcome: str, why: str) -> None:
        self.execution = None
        if self.run.live and self.record(outcome, why):
            self.parent.child_done(self)

    def halt(self) -> None:
        execution, self.execution = self.execution, None
        if execution is not None:
            execution.halt("its method was halted")

    def waiting_for(self) -> list[str]:
        return self.execution.waiting_for() if self.execution is not None else []


def _start_plan(run: MethodRun, request: ast.PlanRequest,
                on_end: Callable[[str, str], None]) -> PlanExecution | tuple[str, str]:
    """Start carrying out ``request`` for ``run``'s task: the execution, or the outcome and
    reason the step ends with at once (goals not ground, no planner)."""
    host = run.host
    goals = tuple(substitute(goal, run.subst) for goal in request.goals) if run.subst else request.goals
    unbound = [term_to_str(g) for g in goals if not is_ground(g)]
    if unbound:
        return Outcome.FAIL, f"its goals have unbound variables: {', '.join(unbound)}"
    execution = host.start_plan(run.task, goals, on_end, deadline=request.deadline, max_failures=request.max_failures)
    if execution is None:
        return Outcome.FAIL, "this run has no planner"
    return execution


def _apply_memory_op(run: MethodRun, op: ast.MemoryOp) -> bool:
    """Apply an assert/retract step of a method; False (and the method fails) if it cannot be."""
    fact = substitute(op.fact, run.subst) if run.subst else op.fact
    if not is_ground(fact):
        run.fail(Failure(f"({op.kind} {term_to_str(fact)})", "the fact has unbound variables"))
        return False
    try:
        fact = evaluated_fact(fact)
    except FactError as exc:
        run.fail(Failure(f"({op.kind} {term_to_str(fact)})", str(exc)))
        return False
    run.host.change(((op.kind, fact),), f"task {run.task.id}", task=run.task)
    return run.live


def _build(body: object, run: MethodRun, parent: Node | MethodRun) -> Node:
    if isinstance(body, ast.PlanRequest):
        return PlanNode(run, parent, body)
    if isinstance(body, ast.Step):
        return StepNode(run, parent, body)
    if isinstance(body, ast.Sequence):
        return SequenceNode(run, parent, body.parts)
    if isinstance(body, ast.WaitFor):
        return WaitNode(run, parent, body)
    if isinstance(body, ast.MemoryOp):
        return MemoryNode(run, parent, body)
    if isinstance(body, ast.Parallel):
        return ParallelNode(run, parent, body.parts)
    if isinstance(body, ast.TaskNet):
        if len(body.nets) == 1:
            return _build(body.nets[0], run, parent)
        return ParallelNode(run, parent, body.nets)
    if isinstance(body, ast.Primitive):
        return PrimitiveNode(run, parent, body)
    raise TypeError(f"not a method body or net: {body!r}")


def _plain(term: Term) -> str:
    """A reason as people read it: a string without its quotes."""
    return term.value if isinstance(term, String) else term_to_str(term)


def _seconds(value: float) -> str:
    return f"{value:g} s"

"""Tasks: the instances of RAPs on the agenda, and why they fail.

A :class:`Task` is one call such as ``(attach-at-site hull-3)``: posted at
top level or spawned by a step of its parent's task net. It lives through
these statuses::

    pending ──selected──▶ running ──method ends──▶ pending (check again) ──▶ ...
       │                     │
       └──────────────▶ succeeded | failed | halted

``pending`` tasks are on the agenda, waiting to be selected (or, after a
failed attempt, waiting for a change before they go back on it:
:attr:`Task.backoff`); ``running`` tasks have a method whose task net is
live (a step of it may be waiting for a skill another task holds). A task that fails keeps a
:class:`Failure`: what went wrong and, when a subtask, a skill or an
event caused it, the failure underneath, so the whole chain can be told.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from atlas_rap.logic import Compound, term_to_str
from atlas_rap.sequencer.status import Outcome, Status

if TYPE_CHECKING:
    from atlas_rap.sequencer.retrying import RetryWait
    from atlas_rap.skillbus.timers import Timer

PENDING = Status.PENDING  # the statuses by name, as before they were an enum (and as fast to read)
RUNNING = Status.RUNNING
SUCCEEDED = Status.SUCCEEDED
FAILED = Status.FAILED
HALTED = Status.HALTED
FINISHED = frozenset({SUCCEEDED, FAILED, HALTED})
"""The statuses of a task that has ended."""


class SkillWait(Protocol):
    """A step's wait for a skill instance (``resources.Claim``): ``live`` while the step still waits for ``call``."""

    live: bool
    call: Compound


class Spawner(Protocol):
    """What spawned a subtask: a step of its parent's net (``net.StepNode``) or of a plan
    (``deliberation.StepRun``). The interpreter tells it when the task ends or waits for a skill."""

    def child_ended(self, task: Task) -> None:
        """The task ended (succeeded, failed or halted)."""
        ...

    def subtask_waiting(self, wait: SkillWait, what: str) -> None:
        """The task, or a task under it, waits for a skill (``what`` says which and who has it)."""
        ...


class RunningMethod(Protocol):
    """A task's running method (``net.MethodRun``), as readers of the task see it."""

    @property
    def label(self) -> str:
        """The method's name, or its 1-based position."""
        ...

    def waiting_for(self) -> list[str]:
        """What the method's live steps wait for."""
        ...

    def halt(self) -> None:
        """Stop the method (its task ended)."""
        ...


@dataclass(frozen=True, slots=True)
class Failure:
    """Why something failed: a task, a method, a step, a skill or an event.

    ``what`` names the thing (``"(attach-at-site hull-7)"``, ``"method 2"``,
    ``"step t2 (grip-attach hull-7)"``), ``reason`` says why, and ``cause``
    is the failure underneath, if any. ``fatal`` failures (a depth bound, an
    error in a query) are not retried by the tasks above. ``outcome`` is
    what the step that ran a failed task ends with: ``:timeout`` for a
    task's timeout clause or missed deadline, else ``:fail``.
    """

    what: str
    reason: str
    cause: Failure | None = None
    fatal: bool = False
    outcome: str = Outcome.FAIL

    def chain(self) -> list[Failure]:
        """This failure and every cause under it, outermost first."""
        out: list[Failure] = []
        failure: Failure | None = self
        while failure is not None:
            out.append(failure)
            failure = failure.cause
        return out

    def explain(self) -> str:
        """The chain as one line per level, indented, for people."""
        return "\n".join("  " * depth + f"{f.what}: {f.reason}" for depth, f in enumerate(self.chain()))

    def root(self) -> Failure:
        """The innermost failure: the skill, event or test that started it."""
        return self.chain()[-1]


class AtOnce:
    """How many times something happened at one instant of simulated time: the guard against a
    runaway loop (``interpreter.MAX_REPEATS_AT_ONCE``)."""

    __slots__ = ("time", "count")

    def __init__(self) -> None:
        self.time = -1.0
        self.count = 0

    def add(self, now: float) -> int:
        """Count one more at ``now``; how many there have been at ``now``."""
        self.count = self.count + 1 if self.time == now else 1
        self.time = now
        return self.count


class Attempts:
    """A task's method attempts since it was posted or last repeated: how many, of which
    methods, and how the last one ended (the interpreter's bookkeeping for retries)."""

    __slots__ = ("count", "by_method", "last_method", "last_failure", "ended_ok", "at_once")

    def __init__(self) -> None:
        self.count = 0
        self.by_method: dict[int, int] = {}  # method number (from 1) -> attempts of it
        self.last_method = ""  # the label of the method tried last
        self.last_failure: Failure | None = None
        self.ended_ok = False  # the last method ended well, and the task's succeed test is still to be checked
        self.at_once = AtOnce()  # attempts at the current instant (not reset by a repeat)

    def begin(self, number: int, label: str) -> None:
        """Charge an attempt of method ``number`` (named ``label``)."""
        self.by_method[number] = self.by_method.get(number, 0) + 1
        self.count += 1
        self.last_method = label

    def refund(self, number: int) -> None:
        """Take back the charge of an attempt of method ``number`` (it was halted, not failed)."""
        self.count -= 1
        self.by_method[number] -= 1
        if not self.by_method[number]:
            del self.by_method[number]

    def restart(self) -> None:
        """The task repeats: it starts again with no attempt spent."""
        self.count = 0
        self.by_method.clear()
        self.last_failure = None
        self.ended_ok = False


class Task:
    """One call of a RAP on the agenda (see the module docstring for its life).

    Its parts: what it is (``id``, stable for the run, in creation order from 1;
    ``call`` and its ``text``; ``parent`` and the ``step`` of the parent's net or
    plan that spawned it; ``depth``, 0 for a posted task; ``priority`` and
    ``deadline``), where it is in its life (``status``, ``started``, ``ended``,
    ``failure``; ``queued`` on the agenda; the ``run`` of its current method,
    its ``children``, its ``timers`` and retry ``backoff``; the ``bindings`` of
    its head), its method :class:`Attempts` (``methods``), and its repeats.
    """

    __slots__ = (
        "id", "call", "text", "parent", "step", "depth", "priority", "deadline",
        "status", "started", "ended", "failure", "queued", "run", "children", "timers", "backoff", "bindings",
        "methods", "repeats", "repeats_at_once",
    )

    def __init__(self, id: int, call: Compound, parent: Task | None, step: Spawner | None,
                 priority: float, deadline: float | None) -> None:
        self.id = id
        self.call = call
        self.text = term_to_str(call)
        self.parent = parent
        self.step = step
        self.depth = parent.depth + 1 if parent is not None else 0
        self.priority = priority
        self.deadline = deadline
        self.status: Status = PENDING
        self.started: float | None = None
        self.ended: float | None = None
        self.failure: Failure | None = None
        self.queued = False
        self.run: RunningMethod | None = None
        self.children: list[Task] = []
        self.timers: list[Timer] = []
        self.backoff: RetryWait | None = None  # the wait before its next attempt, after a failed one
        self.bindings: dict = {}
        self.methods = Attempts()
        self.repeats = 0
        self.repeats_at_once: AtOnce | None = None  # made at its first repeat (most tasks never repeat)

    @property
    def name(self) -> str:
        """The RAP name, e.g. ``attach-at-site``."""
        return self.call.functor

    @property
    def finished(self) -> bool:
        return self.status in FINISHED

    @property
    def attempts(self) -> int:
        """Method attempts since it was posted or last repeated (``methods.count``)."""
        return self.methods.count

    @property
    def last_method(self) -> str:
        """The label of the method tried last, or ``""`` (``methods.last_method``)."""
        return self.methods.last_method

    def __repr__(self) -> str:
        return f"<Task {self.id} {self.text} {self.status}>"

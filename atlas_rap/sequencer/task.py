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


class Attempt(Protocol):
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


class Task:
    """One call of a RAP on the agenda (see the module docstring for its life).

    ``id`` is stable for the run (creation order, from 1); ``depth`` is 0 for
    a posted task; ``step`` is the step of the parent's net that spawned it.
    """

    __slots__ = (
        "id", "call", "text", "parent", "step", "depth", "priority", "deadline", "status",
        "attempts", "tries", "run", "children", "failure", "last_failure", "timers",
        "queued", "method_ended_ok", "repeats", "repeat_time", "repeats_now", "attempt_time", "attempts_now",
        "started", "ended", "bindings", "last_method", "backoff",
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
        self.attempts = 0
        self.tries: dict[int, int] = {}
        self.run: Attempt | None = None
        self.children: list[Task] = []
        self.failure: Failure | None = None
        self.last_failure: Failure | None = None
        self.timers: list[Timer] = []
        self.queued = False
        self.method_ended_ok = False
        self.repeats = 0
        self.repeat_time = -1.0
        self.repeats_now = 0
        self.attempt_time = -1.0  # the instant of the last method attempt, and how many were made in it
        self.attempts_now = 0
        self.started: float | None = None
        self.ended: float | None = None
        self.bindings: dict = {}
        self.last_method = ""
        self.backoff: RetryWait | None = None  # the wait before its next attempt, after a failed one

    @property
    def name(self) -> str:
        """The RAP name, e.g. ``attach-at-site``."""
        return self.call.functor

    @property
    def finished(self) -> bool:
        return self.status in FINISHED

    def __repr__(self) -> str:
        return f"<Task {self.id} {self.text} {self.status}>"

"""The names of trace records (the language reference, docs/language/trace.md), in one place for every producer and consumer.

A leaf module: the sequencer, the skill bus, the layers, the pictures and the
CLI all name events through :class:`Event`, so nobody matches a bare string.
A member *is* its string (a :class:`TextEnum`), so records, and the JSON lines
written from them, are what they were when the names were bare strings.
"""

from __future__ import annotations

from enum import Enum

__all__ = ["Event", "TextEnum"]


class TextEnum(str, Enum):
    """A ``str`` enum whose members print as their value on every Python (``enum.StrEnum`` is 3.11+)."""

    __str__ = str.__str__
    __format__ = str.__format__


class Event(TextEnum):
    """The name of a trace record (its ``event``): one place for producers and consumers to name them.

    A member is its string (``Event.TASK_POSTED == "task-posted"``), so records and the JSON lines
    written from them are what they were when the names were bare strings.
    """

    # the records every trace has (docs/language/trace.md)
    TASK_POSTED = "task-posted"  #: a task was posted, or spawned by a step (``parent``)
    TASK_SELECTED = "task-selected"  #: the agenda selected a task (``repeat``: its repeat count)
    METHOD_SELECTED = "method-selected"  #: a method of the task was chosen (``method``, ``attempt``)
    TASK_SUCCEEDED = "task-succeeded"  #: a task ended well
    TASK_FAILED = "task-failed"  #: a task failed (``reason``; ``because``: the root of the chain)
    TASK_HALTED = "task-halted"  #: a task was halted from above (``reason``)
    STEP_OUTCOME = "step-outcome"  #: a step of a method ended (``outcome``; ``reason`` for a failure)
    SKILL_ENABLED = "skill-enabled"  #: a task's step enabled a skill
    SKILL_DISABLED = "skill-disabled"  #: a skill a task enabled was disabled
    FACT_ASSERTED = "fact-asserted"  #: a fact entered memory (``by``: who asserted it)
    FACT_RETRACTED = "fact-retracted"  #: a fact left memory (``by``: who retracted it)
    PLAN_READY = "plan-ready"  #: the planner delivered a plan (``version``, ``actions``, ``latency``)
    LAYER_SWITCHED = "layer-switched"  #: the primary ATLAS layer changed (emitted by ``layers``)
    # the plan executive (sequencer.deliberation), beyond the first list
    PLAN_REQUESTED = "plan-requested"  #: a ``(plan GOAL ...)`` step asked for a plan
    PLAN_STEP_STARTED = "plan-step-started"  #: a plan step's RAP task was spawned
    PLAN_STEP_DONE = "plan-step-done"  #: a plan step's RAP task succeeded
    PLAN_STEP_FAILED = "plan-step-failed"  #: a plan step's RAP task failed (``reason``)
    REPLANNED = "replanned"  #: a repaired plan was adopted (steps done, kept, new, halted, re-assigned)
    PLAN_ABANDONED = "plan-abandoned"  #: goals (``scope`` ``goal``) or the whole plan (``plan``) given up
    PLAN_DONE = "plan-done"  #: every step done and the goals hold
    # skills shared by tasks (sequencer.interpreter, sequencer.retrying)
    SKILL_PREEMPTED = "skill-preempted"  #: a task that outranks the holder took its skill
    TASK_WAITING = "task-waiting"  #: a task waits for a skill instance, or for a change before a retry
    TASK_RESUMED = "task-resumed"  #: a waiting task goes on (``waited``; ``by`` for a retry's wait)
    # beyond the list above
    MEMORY_ERROR = "memory-error"  #: a change memory could not take (``error``; a broken rule stops the run)
    SKILL_WAITING = "skill-waiting"  #: a skill on a robot's host waits for that robot (``skillbus.remote``)
    SKILL_RESUMED = "skill-resumed"  #: that skill goes on (``skillbus.remote``)

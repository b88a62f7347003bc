"""The words of a task's and a step's life: statuses, step states and step outcomes.

Each is a ``str`` enum (:class:`TextEnum`): a member *is* its string, so it
compares, hashes, prints and goes into JSON exactly as the bare string did
(``Status.FAILED == "failed"``, ``f"{Outcome.FAIL}"`` is ``:fail``), and the
trace is the same byte for byte. Step outcomes that skills report
(``(done (SKILL ...) :arrived)``) stay plain strings; :class:`Outcome` names
the ones the sequencer itself gives.

In hot loops, compare against a module-level name bound to a member
(``PENDING = Status.PENDING`` in ``task``): reading ``Status.PENDING`` off the
enum class costs several times a global's lookup.

This module imports nothing, so every part of the sequencer can use it.
"""

from __future__ import annotations

from atlas_rap.trace_events import TextEnum


class Status(TextEnum):
    """Where a task is in its life (``task`` module docstring)."""

    PENDING = "pending"  #: on the agenda, waiting to be selected (or backing off after a failed attempt)
    RUNNING = "running"  #: a method of it is running
    SUCCEEDED = "succeeded"  #: ended well: its succeed test held, or its method ended and it has no test
    FAILED = "failed"  #: ended badly: constraints false, retries spent, timed out, or cancelled
    HALTED = "halted"  #: stopped from above (its parent's step ended, its plan dropped it)


class StepState(TextEnum):
    """Where a step of a task net (``net.StepNode``) is in its life."""

    NEW = "new"  #: not started yet
    BLOCKED = "blocked"  #: started, held back by a ``(for L)`` until the step ``L`` ends well
    WAITING = "waiting"  #: waiting for a skill instance another task holds
    RUNNING = "running"  #: running its subtask, skill or plan, raced by its wait-fors
    DONE = "done"  #: ended (well or not), or halted


class PlanStepState(TextEnum):
    """Where a step of a plan being carried out (``deliberation.StepRun``) is."""

    WAITING = "waiting"  #: for the steps ordered before it
    RUNNING = "running"  #: its RAP task is running
    DONE = "done"  #: its task succeeded
    FAILED = "failed"  #: its task failed (the plan is repaired or abandoned)
    HALTED = "halted"  #: its task was halted (a new plan dropped or moved the step)


class Outcome(TextEnum):
    """The outcomes the sequencer gives a step (skills may report others, as plain strings)."""

    SUCCEED = ":succeed"  #: the step ended well
    FAIL = ":fail"  #: the step failed; its method fails
    TIMEOUT = ":timeout"  #: a ``wait-for``'s timeout, a task's timeout clause or its deadline ran out
    PREEMPTED = ":preempted"  #: a task of higher priority took its skill, under ``(on-preempt fail)``
    HALTED = ":halted"  #: halted by ``until-end``, or by a task that took its skill (it resumes later)
    WAITING = ":waiting"  #: not an end: ``enable_skill``'s answer when the step must wait for its skill
    PARTIAL = ":partial"  #: a plan reached some of its goals after giving others up (a success)


FAILURE_OUTCOMES = frozenset({Outcome.FAIL, Outcome.TIMEOUT, Outcome.PREEMPTED})
"""Step outcomes that fail the method; every other outcome counts as success.

``:preempted``: a task of higher priority took the skill this step ran, and
the method says ``(on-preempt fail)`` (``Sequencer.enable_skill``)."""

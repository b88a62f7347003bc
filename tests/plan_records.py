"""Plan executive trace records written by hand, for unit tests of the pictures that draw them
(``sequencer.deliberation`` emits the real ones)."""

from __future__ import annotations


def started(t, step, action, task, agent="robot", plan=1, version=1) -> dict:
    """A ``plan-step-started`` record: step ``step`` of the plan, run by task ``task``."""
    return {"t": t, "event": "plan-step-started", "plan": plan, "version": version, "step": step,
            "action": action, "agent": agent, "id": 1, "step_task": task, "task": action}


def ended(t, event, step, action, task, agent="robot", plan=1, version=1, **more) -> dict:
    """A ``plan-step-done`` or ``plan-step-failed`` record (``event``), with ``more`` fields."""
    return {"t": t, "event": event, "plan": plan, "version": version, "step": step, "action": action,
            "agent": agent, "id": 1, "step_task": task, "task": action, **more}

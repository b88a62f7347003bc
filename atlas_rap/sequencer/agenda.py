"""The agenda: tasks waiting to be selected, best first.

Selection order (Firby's RAP interpreter; docs/language/rap.md, How a task runs): higher
priority first, then the earlier deadline (a task with no deadline comes
after any task with one), then age (the task created first). A task is on
the agenda at most once; a task that has ended while queued is skipped
when it comes up.
"""

from __future__ import annotations

import heapq
from math import inf

from atlas_rap.sequencer.task import PENDING, Task


def agenda_key(task: Task) -> tuple[float, float, int]:
    """A task's place in the agenda's order: smaller is selected (and served) first."""
    return -task.priority, inf if task.deadline is None else task.deadline, task.id


class Agenda:
    """A priority queue of pending tasks."""

    def __init__(self) -> None:
        self._heap: list[tuple[float, float, int, Task]] = []

    def push(self, task: Task) -> None:
        """Queue a pending task for selection (a second push while queued does nothing)."""
        if task.queued:
            return
        task.queued = True
        heapq.heappush(self._heap, (*agenda_key(task), task))

    def pop(self) -> Task | None:
        """The best pending task, or None when no task is pending."""
        heap = self._heap
        while heap:
            task = heapq.heappop(heap)[3]
            task.queued = False
            if task.status == PENDING:
                return task
        return None

    def __len__(self) -> int:
        return len(self._heap)

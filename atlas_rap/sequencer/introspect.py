"""Looking inside a running sequencer: the agenda as a task tree, what waits for what.

:func:`agenda_tree` takes a snapshot of the tasks as :class:`TaskView`\\ s
(plain data, safe to keep while the sequencer runs on); the CLI and the
REPL draw it with rich, and :func:`tree_text` writes it as plain text (for
logs and for tests that print the tree when they fail).
"""

from __future__ import annotations

from dataclasses import dataclass

from atlas_rap.sequencer.task import FAILED, HALTED, PENDING, RUNNING, SUCCEEDED, Task

STATUS_MARKS = {PENDING: "○", RUNNING: "▶", SUCCEEDED: "✓", FAILED: "✗", HALTED: "⊘"}
"""One character per task status, for trees and live traces."""


@dataclass(frozen=True, slots=True)
class TaskView:
    """A task as it was when the snapshot was taken."""

    id: int
    task: str
    status: str
    priority: float
    method: str | None
    attempt: int
    waiting: tuple[str, ...]
    reason: str | None
    children: tuple[TaskView, ...]

    @property
    def mark(self) -> str:
        return STATUS_MARKS[self.status]


def view(task: Task) -> TaskView:
    """A snapshot of one task and everything under it."""
    run = task.run
    return TaskView(
        id=task.id,
        task=task.text,
        status=task.status,
        priority=task.priority,
        method=run.label if run is not None else (task.methods.last_method or None),
        attempt=task.methods.count,
        waiting=tuple(run.waiting_for()) if run is not None else (
            (task.backoff.describe(),) if task.backoff is not None else ()),
        reason=task.failure.reason if task.failure is not None else None,
        children=tuple(view(child) for child in task.children),
    )


def agenda_tree(sequencer) -> list[TaskView]:
    """Every posted task, in posting order, with its subtasks."""
    return [view(task) for task in sequencer.roots]


def waiting_for(task: Task) -> list[str]:
    """What a task and its live subtasks are waiting for, deepest last."""
    found = list(task.run.waiting_for()) if task.run is not None else []
    for child in task.children:
        if not child.finished:
            found.extend(waiting_for(child))
    return found


def describe(node: TaskView) -> str:
    """One line for a task: mark, id, call, status, method and what it waits for."""
    parts = [f"{node.mark} [{node.id}] {node.task} {node.status}"]
    if node.method is not None and node.attempt:
        parts.append(f"method {node.method} (attempt {node.attempt})")
    if node.waiting:
        parts.append("waiting for " + ", ".join(node.waiting))
    if node.reason:
        parts.append(f"— {node.reason}")
    return " ".join(parts)


def tree_text(nodes: list[TaskView]) -> str:
    """The task tree as indented plain text."""
    lines: list[str] = []

    def add(node: TaskView, depth: int) -> None:
        lines.append("  " * depth + describe(node))
        for child in node.children:
            add(child, depth + 1)

    for node in nodes:
        add(node, 0)
    return "\n".join(lines)

"""A task's parts: its method attempts (charged, refunded, restarted by a repeat) and the runaway guard."""

from __future__ import annotations

from atlas_rap.lang import parse_term
from atlas_rap.sequencer.task import AtOnce, Attempts, Task


def test_at_once_counts_only_what_happens_at_the_same_instant():
    counter = AtOnce()
    assert [counter.add(t) for t in (0.0, 0.0, 0.0, 0.5, 0.5, 1.0)] == [1, 2, 3, 1, 2, 1]


def test_attempts_are_charged_per_method_refunded_when_halted_and_cleared_by_a_repeat():
    attempts = Attempts()
    attempts.begin(1, "first")
    attempts.begin(2, "fallback")
    attempts.begin(2, "fallback")
    assert (attempts.count, attempts.by_method, attempts.last_method) == (3, {1: 1, 2: 2}, "fallback")
    attempts.refund(1)
    assert (attempts.count, attempts.by_method) == (2, {2: 2})
    attempts.ended_ok = True
    attempts.at_once.add(4.0)
    attempts.restart()
    assert (attempts.count, attempts.by_method, attempts.ended_ok, attempts.last_failure) == (0, {}, False, None)
    assert attempts.last_method == "fallback" and attempts.at_once.count == 1  # kept across a repeat, as before


def test_a_task_still_answers_attempts_and_last_method_from_its_attempts():
    task = Task(1, parse_term("(go-to office)"), None, None, 0, None)
    task.methods.begin(1, "by-corridor")
    assert (task.attempts, task.last_method, task.status) == (1, "by-corridor", "pending")

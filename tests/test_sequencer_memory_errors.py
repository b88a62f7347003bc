"""Memory that cannot take a change fails the task that made it, says which rules and where,
and ends the run cleanly; arithmetic in facts is evaluated; a runaway chain is told briefly."""

from __future__ import annotations

import json

from cli_process import assert_no_traceback, atlas
from scenario import run

CYCLE = """(define-virtual-skill (w) (after 1 (assert (ping 0)) (finish :succeed)))
(define-memory-rule up (on (ping ?n)) (assert (pong ?n)))
(define-memory-rule down (on (pong ?n)) (when (= ?m (+ ?n 1))) (assert (ping ?m)))
(define-rap (go) (method (task-net (t1 (w)))))
(define-virtual-skill (hum) (after 100 (finish :succeed)))
(define-rap (sing) (method (task-net (t1 (hum)))))
(post (go))
(post (sing))
"""


def test_a_memory_rule_cycle_fails_the_task_names_the_rules_and_ends_the_trace_properly(tmp_path):
    (tmp_path / "cyc.rap").write_text(CYCLE, encoding="utf-8")
    done = atlas("run", "cyc.rap", "--trace", "t.jsonl", cwd=tmp_path)
    assert_no_traceback(done)
    assert done.returncode == 1
    assert "cyc.rap:2:1: warning: memory rules can trigger each other in a cycle" in done.stderr
    summary = done.stdout[done.stdout.index("cyc.rap: 0 of 2 posted tasks succeeded"):]
    assert "(stopped by a memory error)" in summary.splitlines()[0]
    assert "up (cyc.rap:2:1) fired 5001 times, down (cyc.rap:3:1) fired 5000 times" in summary
    assert "✗ (go) failed at 1 s" in summary and "✗ (sing) failed at 1 s" in summary
    assert "the run stopped: memory rules did not reach a fixed point" in summary
    records = [json.loads(line) for line in (tmp_path / "t.jsonl").read_text(encoding="utf-8").splitlines()]
    error = next(r for r in records if r["event"] == "memory-error")
    assert error["task"] == "(go)" and error["fact"] == "(ping 0)"
    after = [(r["event"], r.get("skill") or r.get("task")) for r in records[records.index(error) + 1:]]
    assert ("skill-disabled", "(w)") in after and ("skill-disabled", "(hum)") in after
    assert ("task-failed", "(go)") in after and ("task-failed", "(sing)") in after
    assert max(len(line) for line in done.stdout.splitlines()) < 400


def test_arithmetic_in_asserted_facts_is_evaluated_everywhere_a_fact_is_made(tmp_path):
    mission = """
(define-memory-rule doubled (on (counter ?n)) (assert (twice (* ?n 2))))
(define-virtual-skill (tick ?n) (after 1 (assert (ticked (+ ?n 1))) (finish :succeed)))
(define-rap (count-up)
  (method (task-net (sequence
    (wait-for (counter ?n))
    (assert (counter (+ ?n 1)))
    (retract (counter ?n))
    (t1 (tick ?n))
    (wait-for (late ?l))))))
(initial-memory (counter (+ 1 2)))
(at-time 5 (assert (late (- 10 (/ 6 3)))))
(post (count-up))
"""
    with run(tmp_path, mission) as s:
        assert s.result.ok
        assert s.facts("counter") == ["(counter 4)"]
        assert s.facts("twice") == ["(twice 6)", "(twice 8)"]
        assert s.facts("ticked") == ["(ticked 4)"]
        assert s.facts("late") == ["(late 8)"]
        assert s.holds("(counter 4)")


def test_a_step_whose_fact_has_no_arithmetic_value_fails_with_the_fact_named(tmp_path):
    mission = """
(define-rap (bad) (retries 1) (method (task-net (sequence (wait-for (n ?x)) (assert (m (/ ?x 0)))))))
(initial-memory (n 3))
(post (bad))
"""
    with run(tmp_path, mission) as s:
        (bad,) = s.result.tasks
        assert bad.status == "failed"
        assert "division by zero" in bad.failure.root().reason
        assert "(assert (m (/ 3 0)))" in bad.failure.root().what


def test_a_runaway_recursion_is_told_with_its_cause_first_and_the_chain_folded(tmp_path):
    (tmp_path / "loop.rap").write_text("(define-rap (loop) (method (task-net (t1 (loop)))))\n(post (loop))\n",
                                       encoding="utf-8")
    done = atlas("run", "loop.rap", "--quiet", cwd=tmp_path)
    assert done.returncode == 1
    lines = done.stdout.splitlines()
    assert len(lines) < 25, done.stdout
    assert lines[2].strip().startswith("cause: (loop): tasks nested deeper than 64")
    assert any("… 61 more levels of (loop) …" in line for line in lines)
    assert max(len(line) for line in lines) < 200

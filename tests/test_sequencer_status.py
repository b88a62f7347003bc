"""Statuses, step states, outcomes and trace event names are str enums that read, print and serialise as the
bare strings did."""

from __future__ import annotations

import json

import pytest

from atlas_rap.lang import parse_term, parse_text
from atlas_rap.sequencer import Sequencer, Trace
from atlas_rap.sequencer.status import FAILURE_OUTCOMES, Outcome, Status, StepState
from atlas_rap.sequencer.trace import EVENTS, Event


@pytest.mark.parametrize("member", [*Status, *StepState, *Outcome, *Event])
def test_a_member_is_its_string_in_comparisons_sets_printing_and_json(member):
    text = member.value
    assert member == text and hash(member) == hash(text) and {text: 1}[member] == 1
    assert str(member) == f"{member}" == "%s" % member == text
    assert json.dumps({member: [member]}) == json.dumps({text: [text]})


def test_the_failure_outcomes_are_found_by_the_plain_strings_skills_report():
    assert {":fail", ":timeout", ":preempted"} == FAILURE_OUTCOMES
    assert ":fail" in FAILURE_OUTCOMES and ":succeed" not in FAILURE_OUTCOMES and ":halted" not in FAILURE_OUTCOMES


def test_the_values_are_the_words_of_the_trace():
    assert [s.value for s in Status] == ["pending", "running", "succeeded", "failed", "halted"]
    assert [o.value for o in Outcome] == [":succeed", ":fail", ":timeout", ":preempted", ":halted", ":waiting",
                                          ":partial"]


def test_every_record_a_run_traces_is_named_by_an_event_member_and_written_as_before():
    program = parse_text("""
        (define-rap (outer) (method (task-net (sequence (t1 (inner)) (assert (done-outer))))))
        (define-rap (inner) (succeed (ready)) (method (primitive (wait-for (go) :timeout 1))))
    """).forms
    trace = Trace(keep=True)
    seq = Sequencer(program, trace=trace)
    seq.post(parse_term("(outer)"))
    seq.settle()
    seq.assert_fact(parse_term("(ready)"))
    seq.advance_to(2.0)
    records = trace.records
    assert records and all(isinstance(r["event"], Event) for r in records), records
    assert {r["event"] for r in records} <= set(EVENTS)
    assert json.dumps(records[0]) == json.dumps({**records[0], "event": records[0]["event"].value})


def test_the_event_names_keep_their_order_with_the_new_ones_after():
    assert EVENTS[:4] == ("task-posted", "task-selected", "method-selected", "task-succeeded")
    assert EVENTS[-3:] == ("memory-error", "skill-waiting", "skill-resumed")

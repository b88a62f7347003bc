"""Statuses, step states and outcomes are str enums that read, print and serialise as the bare strings did."""

from __future__ import annotations

import json

import pytest

from atlas_rap.sequencer.status import FAILURE_OUTCOMES, Outcome, Status, StepState


@pytest.mark.parametrize("member", [*Status, *StepState, *Outcome])
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

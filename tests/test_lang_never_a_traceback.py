"""Whatever text a user gives, reading it ends in an AST or a SourceError:
never a Python or Lark exception."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from atlas_rap.errors import SourceError
from atlas_rap.lang import parse_text

# Fragments of the language, so random text is often almost valid, which is
# where validators are most likely to trip.
FRAGMENTS = ["(", ")", "(", ")", " ", "\n", "define-rap", "method", "task-net", "sequence", "parallel",
             "primitive", "enable", "disable", ":above", "wait-for", ":timeout", ":succeed", "context",
             "succeed", "operator", ":purpose", ":plot", ":effects", "not", "and", "for", "until-end",
             "t1", "?x", "?", "1", "-2.5", '"s"', '"', "#|", "|#", ";", "post", "include", "world",
             "initial", "goals", "agents", "controlled", "define-relation", "define-memory-rule", "on",
             "when", "after", "finish", "at-time", "define-virtual-skill", "simultaneous", "t", "nil",
             ":priority", "(sequence)", "()", "assert", "retract", "plan", "initial-memory", "index"]


@settings(max_examples=400, deadline=None)
@given(st.lists(st.sampled_from(FRAGMENTS), max_size=60))
def test_any_text_of_language_fragments_reads_or_fails_with_a_source_error(fragments):
    text = " ".join(fragments)
    try:
        parse_text(text, "fuzz.rap")
    except SourceError as error:
        assert str(error).startswith("fuzz.rap:")


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=200))
def test_any_unicode_text_reads_or_fails_with_a_source_error(text):
    try:
        parse_text(text, "fuzz.rap")
    except SourceError as error:
        assert str(error).startswith("fuzz.rap:")

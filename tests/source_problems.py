"""Helpers for tests of error reports: parse text and get its located problems."""

from __future__ import annotations

import pytest

from atlas_rap.errors import Problem, SourceError
from atlas_rap.lang import parse_text


def problems_of(text: str, filename: str = "bad.rap") -> list[Problem]:
    """Every problem reported for ``text`` (which must have at least one)."""
    with pytest.raises(SourceError) as caught:
        parse_text(text, filename)
    return caught.value.problems


def only_problem(text: str) -> Problem:
    """The one problem of ``text``; fails showing them all if there are more."""
    problems = problems_of(text)
    assert len(problems) == 1, "\n".join(p.render() for p in problems)
    return problems[0]


def at(problem: Problem) -> tuple[int, int]:
    """(line, column) of a problem."""
    return problem.location.line, problem.location.column

"""Arithmetic in facts: evaluated when a fact is asserted or retracted, as queries evaluate it."""

from __future__ import annotations

import pytest

from atlas_rap.logic import (
    Compound,
    FactError,
    Memory,
    MemoryRule,
    QueryError,
    RuleEngine,
    RuleError,
    Var,
    evaluated_fact,
    substitute,
    term_to_str,
)
from atlas_rap.lang import parse_term

C = Compound.of
N, V = Var("n"), Var("v")


def fact(text: str) -> Compound:
    term = parse_term(text)
    assert type(term) is Compound
    return term


@pytest.mark.parametrize("written, stored", [
    ("(counter (+ 3 1))", "(counter 4)"),
    ("(pos (+ 1 (* 2 3)))", "(pos 7)"),
    ("(pos ((+ 1 1) (* 2 3)))", "(pos (2 6))"),  # a list argument
    ("(holding (box (- 5 2)) robot)", "(holding (box 3) robot)"),  # any position, any depth
    ("(deep (a (b (c (/ 9 3)))))", "(deep (a (b (c 3))))"),
    ("(x (- 4))", "(x -4)"),  # (- a) negates
    ("(x (/ 6 3) (/ 7 2) (/ 1.0 4))", "(x 2 3.5 0.25)"),  # / of integers is an integer when exact
    ("(x (+) (*) (- 10 1 2))", "(x 0 1 7)"),
    ("(x (+ 1 2.5))", "(x 3.5)"),
])
def test_arithmetic_in_a_fact_is_replaced_by_its_value(written: str, stored: str) -> None:
    assert term_to_str(evaluated_fact(fact(written))) == stored


def test_the_predicate_itself_is_never_evaluated() -> None:
    assert evaluated_fact(C("+", 1, 2)) == C("+", 1, 2)
    assert evaluated_fact(C("-", C("+", 1, 2))) == C("-", 3)


def test_a_fact_without_arithmetic_is_returned_as_it_is() -> None:
    flat = C("ev", 3, 1)
    nested = C("done", C("beep", 1), ":succeed")
    assert evaluated_fact(flat) is flat
    assert evaluated_fact(nested) is nested
    not_ground = C("counter", C("+", N, 1))
    assert evaluated_fact(not_ground) is not_ground  # memory refuses it, with its own message


@pytest.mark.parametrize("written, reason", [
    ("(counter (+ a 1))", "a is not a number, in (+ a 1)"),
    ("(level (/ 1 0))", "division by zero in (/ 1 0)"),
    ("(x (-))", "(-) needs at least one number"),
    ("(x (p (* 2 (- \"two\"))))", '"two" is not a number, in (- "two")'),
])
def test_arithmetic_without_a_value_is_a_fact_error_naming_the_fact(written: str, reason: str) -> None:
    with pytest.raises(FactError) as caught:
        evaluated_fact(fact(written))
    assert str(caught.value) == f"cannot evaluate the arithmetic in the fact {written}: {reason}"


@pytest.mark.parametrize("expression", [
    "(+ 1 2)", "(- 7)", "(- 10 1 2)", "(* 2 3 4)", "(/ 6 3)", "(/ 7 2)", "(/ 4)", "(+ 1 (* 2 (- 3)))", "(+)",
])
def test_facts_and_queries_share_one_arithmetic(expression: str) -> None:
    in_a_fact = evaluated_fact(fact(f"(value {expression})")).args[0]
    answer = Memory().ask(C("=", V, parse_term(expression)))
    assert answer is not None
    assert in_a_fact == answer[V] and type(in_a_fact) is type(answer[V])


def test_a_query_still_reports_bad_arithmetic_as_before() -> None:
    with pytest.raises(QueryError, match=r"\(< \(/ 1 0\) 3\): division by zero in \(/ 1 0\)"):
        Memory().holds(C("<", C("/", 1, 0), 3))
    with pytest.raises(QueryError, match=r"\(< \(-\) 3\): \(-\) needs at least one number"):
        Memory().holds(C("<", C("-"), 3))


# -- through the rule engine: every change passes RuleEngine.apply ---------------


def test_an_asserted_fact_is_stored_evaluated_so_a_later_query_matches() -> None:
    memory = Memory()
    engine = RuleEngine()
    written = substitute(C("counter", C("+", N, 1)), {N: 3})  # (assert (counter (+ ?n 1))) with ?n = 3
    changes = engine.assert_fact(memory, written)
    assert changes == [("assert", C("counter", 4))]
    assert memory.holds(C("counter", 4))
    assert not memory.holds(C("counter", C("+", 3, 1)))


def test_a_retracted_fact_is_evaluated_too() -> None:
    memory = Memory([C("counter", 4)])
    assert RuleEngine().retract_fact(memory, C("counter", C("*", 2, 2))) == [("retract", C("counter", 4))]
    assert len(memory) == 0


def test_an_outside_change_with_bad_arithmetic_is_a_fact_error_and_changes_nothing() -> None:
    memory = Memory()
    with pytest.raises(FactError, match=r"the fact \(counter \(\+ a 1\)\): a is not a number"):
        RuleEngine().apply(memory, [("assert", C("counter", C("+", "a", 1)))])
    assert len(memory) == 0


def test_rule_effects_are_evaluated_and_trigger_on_the_value() -> None:
    bump = MemoryRule("bump", C("tick", N), C("count", V), (("retract", C("count", V)),
                                                          ("assert", C("count", C("+", V, N)))))
    ten = MemoryRule("ten", C("count", 10), None, (("assert", C("reached", 10)),))
    memory = Memory([C("count", 7)])
    engine = RuleEngine([bump, ten])
    assert engine.assert_fact(memory, C("tick", 3)) == [
        ("assert", C("tick", 3)), ("retract", C("count", 7)), ("assert", C("count", 10)),
        ("assert", C("reached", 10)),
    ]


def test_a_rule_effect_with_bad_arithmetic_is_a_rule_error_naming_the_rule() -> None:
    halve = MemoryRule("halve", C("size", N), None, (("assert", C("half", C("/", N, 0))),))
    memory = Memory()
    with pytest.raises(RuleError) as caught:
        RuleEngine([halve]).assert_fact(memory, C("size", 8))
    assert str(caught.value) == (
        "memory rule halve: cannot evaluate the effect (assert (half (/ 8 0))): division by zero in (/ 8 0)")
    assert caught.value.rules == ("halve",)
    assert caught.value.changes == [("assert", C("size", 8))]

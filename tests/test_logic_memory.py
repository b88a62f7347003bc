"""Memory: ground facts with times, indexes, deterministic order, listeners."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from atlas_rap.errors import AtlasError
from atlas_rap.logic import Compound, FactError, Memory, String, Var, match, term_to_str

C = Compound.of
X, Y = Var("x"), Var("y")


def texts(facts: object) -> list[str]:
    """Facts as s-expression text: what a failing assertion prints."""
    return [term_to_str(fact) for fact in facts]  # type: ignore[attr-defined]


# -- asserting and retracting ---------------------------------------------------


def test_asserting_a_new_fact_returns_true_and_a_known_one_false() -> None:
    memory = Memory()
    assert memory.assert_fact(C("at", "robot", "lab"), 1.0) is True
    assert memory.assert_fact(C("at", "robot", "lab"), 2.0) is False
    assert len(memory) == 1
    assert memory.time_of(C("at", "robot", "lab")) == 1.0


def test_a_fact_with_a_variable_is_refused_with_a_clear_error() -> None:
    memory = Memory()
    with pytest.raises(FactError, match=r"ground.*\(at \?x lab\)"):
        memory.assert_fact(C("at", X, "lab"))
    with pytest.raises(FactError, match="not robot"):
        memory.assert_fact("robot")  # type: ignore[arg-type]
    with pytest.raises(FactError, match="predicate name"):
        memory.assert_fact(Compound("", (1, 2)))
    assert issubclass(FactError, AtlasError)
    assert len(memory) == 0


def test_retracting_removes_a_fact_and_says_whether_it_was_there() -> None:
    memory = Memory([C("at", "robot", "lab"), C("at", "box", "hall")])
    assert memory.retract(C("at", "robot", "lab")) is True
    assert memory.retract(C("at", "robot", "lab")) is False
    assert memory.retract("robot") is False  # type: ignore[arg-type]
    assert C("at", "robot", "lab") not in memory
    assert memory.time_of(C("at", "robot", "lab")) is None
    assert texts(memory) == ["(at box hall)"]
    assert list(memory.query(C("at", "robot", X))) == []


def test_retract_matching_removes_every_matching_fact_in_memory_order() -> None:
    memory = Memory([C("at", "a", "lab"), C("on", "a", "b"), C("at", "b", "lab"), C("at", "c", "hall")])
    removed = memory.retract_matching(C("at", X, "lab"))
    assert texts(removed) == ["(at a lab)", "(at b lab)"]
    assert texts(memory) == ["(on a b)", "(at c hall)"]


def test_facts_are_kept_and_listed_in_assertion_order() -> None:
    facts = [C("p", n) for n in (5, 3, 9, 1)] + [C("q", "z"), C("p", 0)]
    memory = Memory(facts)
    assert list(memory) == facts
    memory.retract(C("p", 3))
    memory.assert_fact(C("p", 3))
    assert texts(memory) == ["(p 5)", "(p 9)", "(p 1)", "(q z)", "(p 0)", "(p 3)"]
    assert [time for _, time in memory.items()] == [0.0] * 6


def test_facts_with_equal_numbers_are_one_fact() -> None:
    memory = Memory([C("count", "a", 1)])
    assert memory.assert_fact(C("count", "a", 1.0)) is False
    assert C("count", "a", 1.0) in memory
    assert memory.holds(C("count", "a", 1.0))


def test_strings_and_symbols_are_different_facts() -> None:
    memory = Memory([C("name", "robot", String("Robbie"))])
    assert not memory.holds(C("name", "robot", "robbie"))
    assert memory.ask(C("name", "robot", X)) == {X: String("Robbie")}


def test_a_copy_is_independent_of_the_original() -> None:
    memory = Memory([C("at", "robot", "lab")], time=3.0)
    other = memory.copy()
    other.assert_fact(C("at", "box", "hall"))
    other.retract(C("at", "robot", "lab"))
    assert texts(memory) == ["(at robot lab)"]
    assert texts(other) == ["(at box hall)"]
    assert other.time_of(C("at", "box", "hall")) == 0.0
    assert memory.time_of(C("at", "robot", "lab")) == 3.0


def test_changing_memory_while_iterating_over_it_is_safe() -> None:
    memory = Memory([C("p", n) for n in range(5)])
    for fact in memory:
        memory.retract(fact)
        memory.assert_fact(C("q", fact.args[0]))
    assert texts(memory) == ["(q 0)", "(q 1)", "(q 2)", "(q 3)", "(q 4)"]


def test_changing_memory_while_consuming_answers_does_not_change_the_answers() -> None:
    for size in (3, 50):  # a small bucket and a big one
        memory = Memory([C("at", "robot", n) for n in range(size)])
        seen = []
        for answer in memory.query(C("at", "robot", X)):
            seen.append(answer[X])
            memory.retract(C("at", "robot", answer[X]))
            memory.assert_fact(C("at", "robot", answer[X] + 1000))
        assert seen == list(range(size))


# -- indexes ----------------------------------------------------------------------


def test_a_pattern_with_a_bound_first_argument_finds_only_its_facts() -> None:
    memory = Memory([C("at", f"thing-{n}", f"place-{n % 7}") for n in range(1000)])
    assert memory.ask(C("at", "thing-123", X)) == {X: "place-4"}
    assert list(memory.query(C("at", "thing-123", "place-5"))) == []
    assert list(memory.query(C("at", "nothing", X))) == []
    assert list(memory.query(C("at", "thing-1", X, Y))) == []


def test_a_first_argument_bound_in_the_substitution_uses_the_index() -> None:
    memory = Memory([C("at", "a", "lab"), C("at", "b", "hall")])
    assert list(memory.query(C("at", X, Y), {X: "b"})) == [{X: "b", Y: "hall"}]
    assert list(memory.query(C("at", C("box", X), Y), {X: 1})) == []


def test_compound_first_arguments_are_indexed_too() -> None:
    memory = Memory([C("at", C("box", 1), "lab"), C("at", C("box", 2), "hall")])
    assert memory.ask(C("at", C("box", 2), X)) == {X: "hall"}
    assert list(memory.query(C("at", C("box", X), Y))) == [{X: 1, Y: "lab"}, {X: 2, Y: "hall"}]
    assert list(memory.query(C("at", C("box", X), Y), {X: 2})) == [{X: 2, Y: "hall"}]


def test_predicates_of_different_arities_are_different_predicates() -> None:
    memory = Memory([C("at", "robot"), C("at", "robot", "lab"), C("ok")])
    assert list(memory.query(C("at", X))) == [{X: "robot"}]
    assert list(memory.query(C("ok"))) == [{}]
    assert list(memory.query(C("at"))) == []


def test_a_big_bucket_keeps_assertion_order_through_retractions() -> None:
    memory = Memory([C("in", "room", n) for n in range(100)])
    for n in range(0, 100, 3):
        memory.retract(C("in", "room", n))
    memory.assert_fact(C("in", "room", 0))
    expected = [n for n in range(100) if n % 3] + [0]
    assert [answer[X] for answer in memory.query(C("in", "room", X))] == expected
    assert memory.ask(C("in", "room", X)) == {X: 1}
    for n in expected:
        memory.retract(C("in", "room", n))
    assert len(memory) == 0 and list(memory.query(C("in", X, Y))) == []


def test_a_repeated_variable_must_match_equal_arguments() -> None:
    memory = Memory([C("edge", "a", "a"), C("edge", "a", "b"), C("edge", "b", "b")])
    assert [a[X] for a in memory.query(C("edge", X, X))] == ["a", "b"]
    assert list(memory.query(C("edge", "a", X), {X: "b"})) == [{X: "b"}]


# -- listeners ----------------------------------------------------------------------


def test_listeners_hear_every_change_with_its_time() -> None:
    memory = Memory()
    heard: list[tuple[str, str, float]] = []
    unsubscribe = memory.subscribe(lambda kind, fact, time: heard.append((kind, term_to_str(fact), time)))
    memory.assert_fact(C("at", "robot", "lab"), 1.5)
    memory.assert_fact(C("at", "robot", "lab"), 2.0)
    memory.retract(C("at", "robot", "lab"), 3.0)
    memory.retract(C("at", "robot", "lab"), 4.0)
    unsubscribe()
    memory.assert_fact(C("at", "robot", "hall"), 5.0)
    assert heard == [("assert", "(at robot lab)", 1.5), ("retract", "(at robot lab)", 3.0)]


def test_a_listener_on_predicates_hears_only_about_those() -> None:
    memory = Memory()
    heard: list[str] = []
    unsubscribe = memory.subscribe(lambda kind, fact, time: heard.append(term_to_str(fact)), predicates=["done", "at"])
    memory.assert_fact(C("at", "robot", "lab"))
    memory.assert_fact(C("color", "box", "red"))
    memory.assert_fact(C("done", C("move", "lab"), ":succeed"))
    unsubscribe()
    memory.assert_fact(C("done", C("move", "hall"), ":succeed"))
    assert heard == ["(at robot lab)", "(done (move lab) :succeed)"]


def test_listeners_are_called_in_subscription_order_and_may_unsubscribe_while_called() -> None:
    memory = Memory()
    calls: list[str] = []
    unsubscribe_first = memory.subscribe(lambda *_: (calls.append("first"), unsubscribe_first()))
    memory.subscribe(lambda *_: calls.append("second"))
    memory.assert_fact(C("p", 1))
    memory.assert_fact(C("p", 2))
    assert calls == ["first", "second", "second"]


# -- properties: memory agrees with a plain list ------------------------------------

facts = st.builds(
    lambda pred, first, second: C(pred, first, second),
    st.sampled_from(["at", "on"]),
    st.sampled_from(["a", "b", "c", 1, 1.0, 2]),
    st.sampled_from(["a", "b", 1]),
)
operations = st.lists(st.tuples(st.sampled_from(["assert", "retract"]), facts), max_size=60)
patterns = st.builds(
    lambda pred, first, second: C(pred, first, second),
    st.sampled_from(["at", "on"]),
    st.sampled_from(["a", "b", 1, X, Y]),
    st.sampled_from(["a", 1, X, Y]),
)


@given(operations, patterns)
def test_memory_agrees_with_a_plain_list_of_facts(ops: list, pattern: Compound) -> None:
    memory = Memory()
    reference: list[Compound] = []
    for kind, fact in ops:
        if kind == "assert":
            assert memory.assert_fact(fact) == (fact not in reference)
            if fact not in reference:
                reference.append(fact)
        else:
            assert memory.retract(fact) == (fact in reference)
            if fact in reference:
                reference.remove(fact)
    assert texts(memory) == texts(reference)
    assert len(memory) == len(reference)
    expected = [fact for fact in reference if match(pattern, fact) is not None]
    assert texts(memory.facts(pattern)) == texts(expected)
    answers = [match(pattern, fact) for fact in expected]
    assert list(memory.query(pattern)) == answers

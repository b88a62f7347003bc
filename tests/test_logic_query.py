"""Queries over memory: patterns, and/or/not, comparisons, arithmetic, get-value, relations."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from atlas_rap.logic import (
    Compound,
    Memory,
    QueryError,
    Relation,
    RelationDepthError,
    String,
    Subst,
    Term,
    Var,
    evaluate,
    substitute,
    term_to_str,
    unify,
    variables,
)

C = Compound.of
X, Y, Z, W = Var("x"), Var("y"), Var("z"), Var("w")


def answers(memory: Memory, query: Term, subst: Subst | None = None, relations: dict | None = None) -> list[str]:
    """Each answer as text, the query's variables only: ``?x=a ?y=1``."""
    result = []
    for answer in memory.query(query, subst, relations):
        result.append(" ".join(f"?{v.name}={term_to_str(substitute(v, answer))}" for v in variables(query)))
    return result


@pytest.fixture
def office() -> Memory:
    return Memory(
        [
            C("at", "robot", "lab"),
            C("at", "box-1", "hall"),
            C("at", "box-2", "lab"),
            C("size", "box-1", 40),
            C("size", "box-2", 7),
            C("max-lift", "left-arm", 25),
            C("max-lift", "right-arm", 15),
            C("door", "lab", "hall"),
        ]
    )


# -- logic -----------------------------------------------------------------------


def test_a_pattern_answers_in_memory_order(office: Memory) -> None:
    assert answers(office, C("at", X, "lab")) == ["?x=robot", "?x=box-2"]
    assert answers(office, C("at", X, Y)) == ["?x=robot ?y=lab", "?x=box-1 ?y=hall", "?x=box-2 ?y=lab"]


def test_and_joins_left_to_right(office: Memory) -> None:
    query = C("and", C("at", X, Y), C("size", X, Z))
    assert answers(office, query) == ["?x=box-1 ?y=hall ?z=40", "?x=box-2 ?y=lab ?z=7"]


def test_or_gives_the_answers_of_each_branch_in_turn(office: Memory) -> None:
    query = C("or", C("at", X, "hall"), C("max-lift", X, Y))
    assert answers(office, query) == ["?x=box-1 ?y=?y", "?x=left-arm ?y=25", "?x=right-arm ?y=15"]


def test_not_is_negation_as_failure_under_the_bindings_so_far(office: Memory) -> None:
    unsized = C("and", C("at", X, Y), C("not", C("size", X, Z)))
    assert answers(office, unsized) == ["?x=robot ?y=lab ?z=?z"]
    assert answers(office, C("not", C("at", X, "kitchen"))) == ["?x=?x"]
    assert answers(office, C("not", C("at", X, "lab"))) == []


def test_t_is_true_and_nil_is_false(office: Memory) -> None:
    assert list(office.query("t")) == [{}]
    assert list(office.query("nil")) == []
    assert list(office.query(C("and"))) == [{}]
    assert list(office.query(C("or"))) == []
    assert office.holds(C("and", "t", C("not", "nil")))


def test_a_variable_bound_to_a_query_is_that_query(office: Memory) -> None:
    assert answers(office, Var("q"), {Var("q"): C("at", "robot", X)}) == ["?q=(at robot lab)"]


def test_a_variable_predicate_bound_to_a_symbol_is_that_predicate(office: Memory) -> None:
    query = Compound("", (Var("p"), "robot", X))
    assert answers(office, query, {Var("p"): "at"}) == ["?p=at ?x=lab"]
    with pytest.raises(QueryError, match=r"predicate name.*\(\?p robot \?x\)"):
        list(office.query(query))


def test_the_given_substitution_is_extended_not_changed(office: Memory) -> None:
    given_subst = {X: "box-1"}
    for query in (C("at", X, Y), C("and", C("at", X, Y), "t")):
        result = list(office.query(query, given_subst))
        assert result == [{X: "box-1", Y: "hall"}]
        result[0][Z] = "scribble"
    assert given_subst == {X: "box-1"}


def test_answers_are_separate_dicts_even_when_a_query_succeeds_twice(office: Memory) -> None:
    first, second = office.query(C("or", "t", "t"))
    assert first == second == {} and first is not second


# -- comparisons and arithmetic ----------------------------------------------------


def test_comparisons_compare_numbers(office: Memory) -> None:
    assert answers(office, C("and", C("size", X, Y), C(">", Y, 10))) == ["?x=box-1 ?y=40"]
    assert answers(office, C("and", C("size", X, Y), C("<=", Y, 7))) == ["?x=box-2 ?y=7"]
    assert office.holds(C("<", 1, 2.5)) and office.holds(C(">=", 2, 2.0)) and not office.holds(C("<", 3, 3))


def test_arithmetic_is_evaluated_inside_comparisons_and_nests(office: Memory) -> None:
    assert office.holds(C("=", C("+", 1, C("*", 2, 3), 4), 11))
    assert office.holds(C("=", C("-", 10, 1, 2), 7))
    assert office.holds(C("=", C("-", 5), -5))
    assert office.holds(C("=", C("/", 7, 2), 3.5))
    assert office.ask(C("=", X, C("/", 6, 2))) == {X: 3}
    assert type(office.ask(C("=", X, C("/", 6, 2)))[X]) is int  # type: ignore[index]
    assert office.holds(C("=", C("+"), 0)) and office.holds(C("=", C("*"), 1))


def test_equals_binds_an_unbound_variable_to_the_value_of_an_expression(office: Memory) -> None:
    query = C("and", C("size", "box-1", Y), C("=", X, C("+", Y, 1)))
    assert answers(office, query) == ["?y=40 ?x=41"]


def test_equals_unifies_terms_and_numbers_compare_numerically(office: Memory) -> None:
    assert answers(office, C("=", C("f", X, 2), C("f", "a", Y))) == ["?x=a ?y=2"]
    assert office.holds(C("=", 1, 1.0))
    assert not office.holds(C("=", "a", String("a")))
    assert answers(office, C("=", X, Y)) == ["?x=?y ?y=?y"]


def test_not_equals_compares_bound_terms(office: Memory) -> None:
    query = C("and", C("at", X, "lab"), C("at", Y, "lab"), C("/=", X, Y))
    assert answers(office, query) == ["?x=robot ?y=box-2", "?x=box-2 ?y=robot"]
    assert not office.holds(C("/=", 2, 2.0))
    assert office.holds(C("/=", C("+", 1, 1), 3))


def test_get_value_reads_the_value_of_an_attribute_fact(office: Memory) -> None:
    assert office.ask(C("=", X, C("get-value", "box-1", "size"))) == {X: 40}
    assert office.holds(C(">", C("get-value", "box-1", "size"), C("*", 2, C("get-value", "box-2", "size"))))
    assert answers(office, C("and", C("at", X, "lab"), C(">", C("get-value", X, "size"), 5))) == ["?x=box-2"]


def test_get_value_without_a_fact_fails_the_query(office: Memory) -> None:
    assert not office.holds(C("=", X, C("get-value", "robot", "size")))
    assert office.holds(C("not", C(">", C("get-value", "robot", "size"), 0)))


@pytest.mark.parametrize(
    ("query", "message"),
    [
        (C("<", X, 3), r"\(< \?x 3\): \?x is unbound"),
        (C("and", C("at", X, "lab"), C(">", X, 3)), r"\(> \?x 3\): \?x is robot, not a number"),
        (C("<", C("+", "box", 1), 3), r"\(< \(\+ box 1\) 3\): box is not a number"),
        (C("=", X, C("+", Y, 1)), r"\?y is unbound"),
        (C("<", C("/", 1, 0), 3), r"division by zero"),
        (C("/=", X, 3), r"\(/= \?x 3\): \?x is unbound"),
        (C("=", X, C("get-value", Y, "size")), r"get-value \?y size\) needs a bound object"),
        (C("<", 1, 2, 3), r"compares two terms"),
        (C("not", "t", "t"), r"takes one query"),
        ("robot", r"not a query: robot"),
        (Var("q"), r"unbound variable"),
        (7, r"not a query: 7"),
    ],
)
def test_a_query_that_cannot_be_evaluated_raises_a_query_error_naming_it(office: Memory, query: Term, message: str) -> None:
    with pytest.raises(QueryError, match=message):
        list(office.query(query))


# -- defined relations -------------------------------------------------------------

CAN_LIFT = {
    "can-lift": [
        Relation(C("can-lift", Var("agent"), Var("weight")), C(">=", C("get-value", Var("agent"), "max-lift"), Var("weight")))
    ]
}


def test_a_relation_is_proved_from_its_body_with_arithmetic_arguments(office: Memory) -> None:
    # docs/language/ap.md, operator and define-relation: (can-lift ?arm (/ ?size-of-thing 2)) over (define-relation (can-lift ?agent ?weight) ...)
    query = C(
        "and",
        C("=", Var("size-of-thing"), C("get-value", "box-1", "size")),
        C("max-lift", X, Var("_")),
        C("can-lift", X, C("/", Var("size-of-thing"), 2)),
    )
    assert [a.split()[1] for a in answers(office, query, relations=CAN_LIFT)] == ["?x=left-arm"]
    assert not office.holds(C("can-lift", "right-arm", 20), relations=CAN_LIFT)


def test_a_relation_with_several_clauses_answers_in_clause_order(office: Memory) -> None:
    family = Memory([C("parent", "ann", "bob"), C("parent", "bob", "cid"), C("parent", "cid", "dan")])
    ancestor = {
        "ancestor": [
            Relation(C("ancestor", X, Y), C("parent", X, Y)),
            Relation(C("ancestor", X, Y), C("and", C("parent", X, Z), C("ancestor", Z, Y))),
        ]
    }
    assert answers(family, C("ancestor", "ann", W), relations=ancestor) == ["?w=bob", "?w=cid", "?w=dan"]
    assert answers(family, C("ancestor", W, "dan"), relations=ancestor) == ["?w=cid", "?w=ann", "?w=bob"]


def test_the_variables_of_a_relation_are_renamed_apart_on_each_call(office: Memory) -> None:
    same = {"same-place": [Relation(C("same-place", X, Y), C("and", C("at", X, Z), C("at", Y, Z), C("/=", X, Y)))]}
    query = C("and", C("same-place", X, Y), C("same-place", Y, Z))
    assert answers(office, query, relations=same) == ["?x=robot ?y=box-2 ?z=robot", "?x=box-2 ?y=robot ?z=box-2"]
    assert list(office.query(C("same-place", "robot", Z), {Z: "hall"}, relations=same)) == []


def test_a_relation_shadows_facts_of_the_same_predicate(office: Memory) -> None:
    nowhere = {"at": [Relation(C("at", X, "nowhere"), "t")]}
    assert answers(office, C("at", "robot", Y), relations=nowhere) == ["?y=nowhere"]


def test_endless_recursion_through_relations_stops_with_a_clear_error(office: Memory) -> None:
    loop = {"loop": [Relation(C("loop", X), C("loop", C("s", X)))]}
    with pytest.raises(RelationDepthError, match=r"more than 64 deep.*\(loop \(s \(s"):
        office.holds(C("loop", 0), relations=loop)
    with pytest.raises(RelationDepthError, match="more than 5 deep"):
        list(evaluate(C("loop", 0), office, relations=loop, max_depth=5))
    assert issubclass(RelationDepthError, QueryError)


# -- property: memory queries agree with brute force over a list -------------------

VARS = [X, Y, Z]
facts = st.lists(
    st.builds(C, st.sampled_from(["p", "q"]), st.sampled_from(["a", "b", 1]), st.sampled_from(["a", "b", 2])),
    max_size=14,
)
patterns = st.builds(
    C,
    st.sampled_from(["p", "q"]),
    st.sampled_from(["a", 1, *VARS]),
    st.sampled_from(["b", 2, *VARS]),
)
queries = st.recursive(
    patterns,
    lambda inner: st.one_of(
        st.builds(lambda qs: Compound("and", tuple(qs)), st.lists(inner, max_size=3)),
        st.builds(lambda qs: Compound("or", tuple(qs)), st.lists(inner, max_size=3)),
        st.builds(lambda q: C("not", q), inner),
    ),
    max_leaves=6,
)


def brute_force(query: Compound, facts: list[Compound], subst: Subst) -> list[Subst]:
    """The query language's and/or/not, the obvious way, over a plain list."""
    if query.functor == "and":
        results = [subst]
        for conjunct in query.args:
            results = [s2 for s1 in results for s2 in brute_force(conjunct, facts, s1)]  # type: ignore[arg-type]
        return results
    if query.functor == "or":
        return [s for disjunct in query.args for s in brute_force(disjunct, facts, subst)]  # type: ignore[arg-type]
    if query.functor == "not":
        return [] if brute_force(query.args[0], facts, subst) else [subst]  # type: ignore[arg-type]
    unified = (unify(query, fact, subst) for fact in facts)
    return [s for s in unified if s is not None]


def restricted(answers: list[Subst], query: Compound) -> list[str]:
    return [" ".join(term_to_str(substitute(v, a)) for v in variables(query)) for a in answers]


@settings(max_examples=300)
@given(facts, queries)
def test_queries_over_memory_agree_with_brute_force_over_a_list(fact_list: list[Compound], query: Compound) -> None:
    memory = Memory(fact_list)
    distinct = list(dict.fromkeys(fact_list))
    expected = restricted(brute_force(query, distinct, {}), query)
    assert restricted(list(memory.query(query)), query) == expected, term_to_str(query)
    assert restricted(list(evaluate(query, memory)), query) == expected, term_to_str(query)
    assert memory.holds(query) == bool(expected)

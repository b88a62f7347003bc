"""Unification (two-sided, occurs check) and matching (one-sided, against ground terms)."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from atlas_rap.logic import Compound, String, Var, is_ground, match, substitute, term_to_str, unify, variables

C = Compound.of
X, Y, Z = Var("x"), Var("y"), Var("z")

# Small domains, so that random terms unify often enough to test something.
symbols = st.sampled_from(["a", "b", "t"])
numbers = st.sampled_from([1, 2, 1.0, 2.5])
atoms = st.one_of(symbols, numbers, st.just(String("a")), st.sampled_from([X, Y, Z]))
terms = st.recursive(
    atoms,
    lambda inner: st.builds(Compound, st.sampled_from(["f", "g", ""]), st.lists(inner, min_size=1, max_size=3).map(tuple)),
    max_leaves=10,
)
ground_terms = terms.filter(is_ground)


def show(subst: dict | None) -> str:
    """A substitution as readable text, for failure messages."""
    if subst is None:
        return "no unifier"
    return "{" + ", ".join(f"{term_to_str(k)}: {term_to_str(v)}" for k, v in subst.items()) + "}"


# -- examples ---------------------------------------------------------------


def test_a_variable_unifies_with_anything_and_is_bound_to_it() -> None:
    assert unify(X, C("at", "robot", "lab")) == {X: C("at", "robot", "lab")}
    assert unify(C("at", "robot", "lab"), X) == {X: C("at", "robot", "lab")}


def test_compounds_unify_argument_by_argument() -> None:
    s = unify(C("at", X, "lab"), C("at", "robot", Y))
    assert s is not None, show(s)
    assert substitute(C("at", X, Y), s) == C("at", "robot", "lab")


def test_compounds_with_different_functors_or_arities_do_not_unify() -> None:
    assert unify(C("at", X, Y), C("on", X, Y)) is None
    assert unify(C("at", X), C("at", X, Y)) is None
    assert unify(C("f"), "f") is None


def test_numbers_unify_numerically() -> None:
    assert unify(1, 1.0) == {}
    assert unify(C("p", 2), C("p", 2.0)) == {}
    assert unify(1, 2) is None


def test_a_symbol_does_not_unify_with_a_string_or_a_number_of_the_same_text() -> None:
    assert unify("a", String("a")) is None
    assert unify("1", 1) is None


def test_a_shared_variable_must_take_one_value() -> None:
    assert unify(C("p", X, X), C("p", "a", "b")) is None
    assert unify(C("p", X, X), C("p", "a", Y)) is not None


def test_the_occurs_check_refuses_infinite_terms() -> None:
    assert unify(X, C("f", X)) is None
    assert unify(C("p", X, Y), C("p", Y, C("f", X))) is None


def test_unify_extends_the_given_substitution_without_changing_it() -> None:
    given_subst = {X: "a"}
    assert unify(C("p", X, Y), C("p", "a", "b"), given_subst) == {X: "a", Y: "b"}
    assert unify(C("p", X), C("p", "b"), given_subst) is None
    assert given_subst == {X: "a"}


def test_a_variable_unified_with_itself_binds_nothing() -> None:
    assert unify(X, Var("x")) == {}
    assert unify(C("p", X), C("p", Var("x"))) == {}


def test_match_binds_pattern_variables_to_parts_of_a_fact() -> None:
    assert match(C("at", X, C("room", Y)), C("at", "robot", C("room", 3))) == {X: "robot", Y: 3}
    assert match(C("at", X, X), C("at", "a", "b")) is None
    assert match(C("at", X, "lab"), C("at", "robot", "lab"), {X: "box"}) is None


# -- properties ---------------------------------------------------------------


@given(terms, terms)
def test_a_unifier_makes_both_terms_equal(a: object, b: object) -> None:
    s = unify(a, b)  # type: ignore[arg-type]
    if s is not None:
        left, right = substitute(a, s), substitute(b, s)  # type: ignore[arg-type]
        assert left == right, f"{term_to_str(left)} != {term_to_str(right)} under {show(s)}"


@given(terms, terms)
def test_unification_succeeds_in_both_directions_or_in_neither(a: object, b: object) -> None:
    assert (unify(a, b) is None) == (unify(b, a) is None)  # type: ignore[arg-type]


@given(terms)
def test_a_term_unifies_with_itself_without_new_bindings(a: object) -> None:
    assert unify(a, a) == {}  # type: ignore[arg-type]


@given(st.sampled_from([X, Y, Z]), terms)
def test_a_variable_does_not_unify_with_a_compound_containing_it(var: Var, term: object) -> None:
    container = C("f", term, var)
    assert unify(var, container) is None
    assert unify(container, var) is None


@given(terms, terms)
def test_unification_never_binds_a_variable_to_a_term_containing_it(a: object, b: object) -> None:
    s = unify(a, b)  # type: ignore[arg-type]
    if s is not None:
        for var in s:
            assert var not in variables(substitute(var, s)), show(s)


@given(terms, ground_terms)
def test_match_agrees_with_unify_when_the_second_term_is_ground(pattern: object, fact: object) -> None:
    matched = match(pattern, fact)  # type: ignore[arg-type]
    unified = unify(pattern, fact)  # type: ignore[arg-type]
    assert (matched is None) == (unified is None), f"match {show(matched)} vs unify {show(unified)}"
    if matched is not None:
        assert substitute(pattern, matched) == fact  # type: ignore[arg-type]


@given(terms, terms, st.dictionaries(st.sampled_from([X, Y, Z]), symbols, max_size=2))
def test_unify_under_bindings_is_unify_of_the_substituted_terms(a: object, b: object, bindings: dict) -> None:
    with_bindings = unify(a, b, bindings)  # type: ignore[arg-type]
    substituted = unify(substitute(a, bindings), substitute(b, bindings))  # type: ignore[arg-type]
    assert (with_bindings is None) == (substituted is None)

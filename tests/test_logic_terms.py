"""Terms: values, variables, substitutions and printing."""

from __future__ import annotations

import copy
import pickle
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from atlas_rap.logic import (
    Compound,
    String,
    Var,
    fresh_var,
    is_anonymous,
    is_ground,
    is_keyword,
    is_number,
    is_symbol,
    substitute,
    term_to_str,
    variables,
    walk,
)

C = Compound.of
X, Y, Z = Var("x"), Var("y"), Var("z")


# -- a strategy for terms, and a tiny reader for the printed text -------------

symbols = st.sampled_from(["a", "b", "robot", "office-3", ":succeed", "t", "nil", "<=", "+"])
numbers = st.one_of(st.integers(-1000, 1000), st.floats(allow_nan=False, allow_infinity=False))
strings = st.builds(String, st.text(alphabet='ab "\\\n', max_size=6))
named_vars = st.sampled_from([X, Y, Z])
atoms = st.one_of(symbols, numbers, strings, named_vars)
terms = st.recursive(
    atoms,
    lambda inner: st.one_of(
        st.builds(Compound, st.sampled_from(["f", "g", "at"]), st.lists(inner, max_size=3).map(tuple)),
        st.builds(lambda first, rest: Compound("", (first, *rest)), st.one_of(numbers, strings, named_vars), st.lists(inner, max_size=2)),
    ),
    max_leaves=12,
)

_TOKEN = re.compile(r'\s*(?:(\()|(\))|"((?:[^"\\]|\\.)*)"|([^\s()"]+))', re.S)


def read(text: str) -> object:
    """Just enough of the reader's lexical rules (docs/language/index.md) to check printing."""
    stack: list[list[object]] = [[]]
    for match in _TOKEN.finditer(text):
        opening, closing, string, atom = match.groups()
        if opening:
            stack.append([])
        elif closing:
            items = stack.pop()
            if not items:
                stack[-1].append("nil")
            elif type(items[0]) is str:
                stack[-1].append(Compound(items[0], tuple(items[1:])))  # type: ignore[arg-type]
            else:
                stack[-1].append(Compound("", tuple(items)))  # type: ignore[arg-type]
        elif string is not None:
            stack[-1].append(String(re.sub(r"\\(.)", r"\1", string, flags=re.S)))
        elif atom.startswith("?"):
            stack[-1].append(Var(atom[1:]))
        else:
            try:
                stack[-1].append(int(atom))
            except ValueError:
                try:
                    stack[-1].append(float(atom))
                except ValueError:
                    stack[-1].append(atom)
    (term,) = stack[0]
    return term


# -- values -----------------------------------------------------------------


def test_a_string_is_never_equal_to_the_symbol_with_the_same_text() -> None:
    assert String("a") != "a"
    assert "a" != String("a")
    assert C("p", String("a")) != C("p", "a")
    assert len({String("a"), "a"}) == 2


def test_a_variable_is_never_equal_to_the_symbol_with_its_name() -> None:
    assert Var("x") != "x"
    assert Var("x") == Var("x")
    assert len({Var("x"), "x", Var("x")}) == 2


def test_compounds_are_equal_when_functor_and_arguments_are_equal() -> None:
    assert C("at", "robot", "lab") == Compound("at", ["robot", "lab"])
    assert hash(C("at", "robot", "lab")) == hash(Compound("at", ("robot", "lab")))
    assert C("at", "robot", "lab") != C("at", "lab", "robot")
    assert C("at", "robot") != C("on", "robot")
    assert C("f") != C("f", "nil")
    assert C("f", 1) != (("f", (1,)))


def test_compounds_holding_equal_numbers_are_the_same_fact() -> None:
    assert C("p", 1) == C("p", 1.0)
    assert len({C("p", 1), C("p", 1.0)}) == 1


def test_a_compound_cannot_be_changed() -> None:
    fact = C("at", "robot", "lab")
    with pytest.raises(AttributeError):
        fact.functor = "on"  # type: ignore[misc]
    with pytest.raises(AttributeError):
        del fact.args
    with pytest.raises(AttributeError):
        X.name = "y"  # type: ignore[misc]


def test_compounds_and_variables_survive_pickling_and_copying_with_their_hash() -> None:
    fact = C("at", "robot", C("room", 3, String("Lab")), X)
    for clone in (pickle.loads(pickle.dumps(fact)), copy.deepcopy(fact), copy.copy(fact)):
        assert clone == fact and hash(clone) == hash(fact)
    assert pickle.loads(pickle.dumps(X)) == X and hash(pickle.loads(pickle.dumps(X))) == hash(X)


def test_kind_predicates_tell_symbols_keywords_and_numbers_apart() -> None:
    assert is_symbol("robot") and is_symbol(":succeed") and not is_symbol(String("robot"))
    assert is_keyword(":succeed") and not is_keyword("succeed") and not is_keyword(X)
    assert is_number(3) and is_number(2.5) and not is_number(True) and not is_number("3")
    assert C("at", "robot", "lab").arity == 2


# -- variables ----------------------------------------------------------------


def test_groundness_sees_variables_at_any_depth() -> None:
    assert is_ground(C("at", "robot", C("room", 3)))
    assert not is_ground(C("at", "robot", C("room", C("floor", X))))
    assert not is_ground(X)
    assert is_ground("robot") and is_ground(3) and is_ground(String("x"))


def test_variables_come_in_order_of_first_appearance_each_once() -> None:
    term = C("f", Y, C("g", X, Y), Z, X)
    assert variables(term) == [Y, X, Z]
    assert variables(C("f", 1, "a")) == []


def test_fresh_variables_are_all_different_and_the_bare_ones_are_anonymous() -> None:
    first, second = fresh_var(), fresh_var()
    assert first != second
    assert is_anonymous(first) and is_anonymous(second)
    renamed = fresh_var("agent")
    assert not is_anonymous(renamed) and renamed.name.startswith("agent")


@given(st.from_regex(r"[a-z0-9][a-z0-9_\-*+<>=/!]{0,11}", fullmatch=True))
def test_no_name_a_user_can_write_is_anonymous_or_generated(name: str) -> None:
    # User names start with a letter or digit and are folded to lower case.
    assert not is_anonymous(Var(name))
    assert Var(name) != fresh_var() and Var(name) != fresh_var(name)


# -- substitutions ------------------------------------------------------------


def test_walk_follows_a_chain_of_bindings_at_the_top_only() -> None:
    subst = {X: Y, Y: C("f", Z), Z: 3}
    assert walk(X, subst) == C("f", Z)
    assert walk(Z, {}) == Z
    assert walk("a", subst) == "a"


def test_substitute_resolves_chains_fully_and_leaves_unbound_variables() -> None:
    subst = {X: Y, Y: C("f", Z), Z: 3}
    assert substitute(C("p", X, Var("w")), subst) == C("p", C("f", 3), Var("w"))


def test_substitute_shares_ground_terms_instead_of_copying_them() -> None:
    fact = C("at", "robot", C("room", 3))
    assert substitute(fact, {X: 1}) is fact
    pattern = C("at", "robot", X)
    assert substitute(pattern, {Y: 1}) is pattern


@given(terms)
def test_substituting_nothing_changes_nothing(term: object) -> None:
    assert substitute(term, {}) == term  # type: ignore[arg-type]


@given(terms, st.dictionaries(named_vars, st.one_of(symbols, numbers, strings), max_size=3))
def test_substituting_ground_values_for_every_variable_gives_a_ground_term(term: object, values: dict) -> None:
    result = substitute(term, values)  # type: ignore[arg-type]
    assert set(variables(result)) == set(variables(term)) - set(values)  # type: ignore[arg-type]


# -- printing ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("term", "text"),
    [
        ("robot", "robot"),
        (":succeed", ":succeed"),
        (3, "3"),
        (-2.5, "-2.5"),
        (0.1, "0.1"),
        (1e100, "1e+100"),
        (String('say "hi" \\ bye'), '"say \\"hi\\" \\\\ bye"'),
        (X, "?x"),
        (C("at", "robot", X), "(at robot ?x)"),
        (Compound("", (1, 2, 3)), "(1 2 3)"),
        (Compound("", (Var("p"), "a")), "(?p a)"),
        (C("f"), "(f)"),
        (C("and", C("at", X, "lab"), C("not", C("<", C("+", X, 1), 3))), "(and (at ?x lab) (not (< (+ ?x 1) 3)))"),
    ],
)
def test_terms_print_as_s_expressions(term: object, text: str) -> None:
    assert term_to_str(term) == text  # type: ignore[arg-type]


def test_an_anonymous_variable_prints_as_a_bare_question_mark() -> None:
    assert term_to_str(C("at", fresh_var(), "lab")) == "(at ? lab)"
    assert term_to_str(C("at", Var("_1"), "lab")) == "(at ? lab)"  # the reader's '?'
    assert is_anonymous(Var("_1")) and not is_anonymous(Var("x_1"))


def test_str_of_a_term_is_its_s_expression() -> None:
    assert str(C("at", "robot", String("Lab"))) == '(at robot "Lab")'
    assert str(X) == "?x" and str(String("a")) == '"a"'


@given(terms)
def test_printed_terms_read_back_to_the_same_term(term: object) -> None:
    assert read(term_to_str(term)) == term  # type: ignore[arg-type]

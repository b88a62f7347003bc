"""Memory rules: triggered by assertions, run to a fixed point, cycles reported."""

from __future__ import annotations

import pytest

from atlas_rap.logic import (
    Change,
    Compound,
    Memory,
    MemoryRule,
    QueryError,
    Relation,
    RuleCycleError,
    RuleEngine,
    RuleError,
    Var,
    rule_cycles,
    term_to_str,
)

C = Compound.of
THING, NEW, OLD, X, Y = Var("thing"), Var("new"), Var("old"), Var("x"), Var("y")

# docs/language/rap.md, define-memory-rule, as the validator builds it.
AT_IS_UNIQUE = MemoryRule(
    "at-is-unique",
    trigger=C("at", THING, NEW),
    condition=C("and", C("at", THING, OLD), C("/=", OLD, NEW)),
    effects=(("retract", C("at", THING, OLD)),),
)


def texts(changes: list[Change]) -> list[str]:
    """Changes as ``+(fact)`` / ``-(fact)``: what a failing assertion prints."""
    return [("+" if kind == "assert" else "-") + term_to_str(fact) for kind, fact in changes]


def facts(memory: Memory) -> list[str]:
    return [term_to_str(fact) for fact in memory]


# What is in a container is where the container is.
CONTENTS_MOVE_ALONG = MemoryRule(
    "contents-move-along",
    trigger=C("at", X, Y),
    condition=C("in", THING, X),
    effects=(("assert", C("at", THING, Y)),),
)

def test_at_is_unique_keeps_one_place_per_thing() -> None:
    memory = Memory([C("at", "robot", "lab"), C("at", "box", "lab")])
    engine = RuleEngine([AT_IS_UNIQUE])
    changes = engine.assert_fact(memory, C("at", "robot", "hall"), 2.0)
    assert texts(changes) == ["+(at robot hall)", "-(at robot lab)"]
    assert facts(memory) == ["(at box lab)", "(at robot hall)"]
    assert memory.time_of(C("at", "robot", "hall")) == 2.0


def test_asserting_a_fact_already_in_memory_changes_nothing_and_fires_nothing() -> None:
    memory = Memory([C("at", "robot", "lab")])
    fired = MemoryRule("noisy", C("at", X, Y), None, (("assert", C("moved", X)),))
    assert RuleEngine([fired]).assert_fact(memory, C("at", "robot", "lab")) == []
    assert facts(memory) == ["(at robot lab)"]


def test_a_rule_whose_condition_fails_does_nothing() -> None:
    memory = Memory()
    changes = RuleEngine([AT_IS_UNIQUE]).assert_fact(memory, C("at", "robot", "lab"))
    assert texts(changes) == ["+(at robot lab)"]
    assert facts(memory) == ["(at robot lab)"]


def test_a_rule_fires_once_for_each_answer_of_its_condition() -> None:
    memory = Memory([C("in", "box-1", "cart"), C("in", "box-2", "cart"), C("in", "pen", "drawer")])
    changes = RuleEngine([CONTENTS_MOVE_ALONG, AT_IS_UNIQUE]).assert_fact(memory, C("at", "cart", "hall"))
    assert texts(changes) == ["+(at cart hall)", "+(at box-1 hall)", "+(at box-2 hall)"]


def test_a_chain_of_rules_reaches_a_fixed_point_in_a_deterministic_order() -> None:
    memory = Memory([C("at", "robot", "lab"), C("in", "box", "robot"), C("in", "pen", "box")])
    engine = RuleEngine([AT_IS_UNIQUE, CONTENTS_MOVE_ALONG])
    changes = engine.assert_fact(memory, C("at", "robot", "hall"), 1.0)
    assert texts(changes) == [
        "+(at robot hall)",
        "-(at robot lab)",
        "+(at box hall)",
        "+(at pen hall)",
    ]
    assert engine.assert_fact(memory, C("at", "robot", "hall"), 2.0) == []
    changes = engine.assert_fact(memory, C("at", "robot", "dock"), 3.0)
    assert texts(changes) == [
        "+(at robot dock)",
        "-(at robot hall)",
        "+(at box dock)",
        "-(at box hall)",
        "+(at pen dock)",
        "-(at pen hall)",
    ]
    assert facts(memory) == ["(in box robot)", "(in pen box)", "(at robot dock)", "(at box dock)", "(at pen dock)"]


def test_a_fact_retracted_by_one_rule_triggers_no_later_rule() -> None:
    memory = Memory()
    veto = MemoryRule("veto", C("at", X, "forbidden"), None, (("retract", C("at", X, "forbidden")),))
    log = MemoryRule("log", C("at", X, Y), None, (("assert", C("was-at", X, Y)),))
    changes = RuleEngine([veto, log]).assert_fact(memory, C("at", "robot", "forbidden"))
    assert texts(changes) == ["+(at robot forbidden)", "-(at robot forbidden)"]
    assert len(memory) == 0


def test_two_rules_that_trigger_each_other_forever_raise_a_cycle_error_naming_them() -> None:
    count_up = MemoryRule("count-up", C("n", X), C("=", Y, C("+", X, 1)), (("assert", C("m", Y)),))
    count_back = MemoryRule("count-back", C("m", X), C("=", Y, C("+", X, 1)), (("assert", C("n", Y)),))
    memory = Memory()
    engine = RuleEngine([count_up, count_back], max_firings=500)
    with pytest.raises(RuleCycleError) as caught:
        engine.assert_fact(memory, C("n", 0))
    error = caught.value
    assert set(error.rules) == {"count-up", "count-back"}
    assert "count-up" in str(error) and "count-back" in str(error)
    assert "fixed point after 500 firings" in str(error) and "(n 0)" in str(error)
    assert len(error.changes) == 501 and len(memory) == 501


def test_the_cycle_error_names_the_rules_in_the_cycle_first() -> None:
    once = MemoryRule("once", C("start"), None, (("assert", C("n", 0)),))
    forever = MemoryRule("forever", C("n", X), C("=", Y, C("+", X, 1)), (("assert", C("n", Y)),))
    engine = RuleEngine([once, forever])
    with pytest.raises(RuleCycleError) as caught:
        engine.assert_fact(Memory(), C("start"))
    assert caught.value.rules[0] == "forever"
    assert "10000 firings" in str(caught.value)


def test_an_effect_that_is_not_ground_is_an_error_naming_the_rule() -> None:
    sloppy = MemoryRule("sloppy", C("at", X, Y), None, (("assert", C("near", X, Var("z"))),))
    with pytest.raises(RuleError, match=r"memory rule sloppy: .*\(near robot \?z\)"):
        RuleEngine([sloppy]).assert_fact(Memory(), C("at", "robot", "lab"))


def test_retract_fact_reports_the_retraction_and_triggers_nothing() -> None:
    memory = Memory([C("at", "robot", "lab")])
    engine = RuleEngine([AT_IS_UNIQUE])
    assert texts(engine.retract_fact(memory, C("at", "robot", "lab"))) == ["-(at robot lab)"]
    assert engine.retract_fact(memory, C("at", "robot", "lab")) == []


def test_apply_makes_several_outside_changes_in_order() -> None:
    memory = Memory([C("at", "robot", "lab")])
    engine = RuleEngine([AT_IS_UNIQUE])
    changes = engine.apply(memory, [("assert", C("at", "box", "hall")), ("assert", C("at", "robot", "hall")), ("retract", C("at", "box", "hall"))])
    assert texts(changes) == ["+(at box hall)", "+(at robot hall)", "-(at robot lab)", "-(at box hall)"]


def test_rule_conditions_may_use_relations() -> None:
    heavy = {"heavy": [Relation(C("heavy", X), C(">", C("get-value", X, "weight"), 10))]}
    warn = MemoryRule("warn", C("holding", X), C("heavy", X), (("assert", C("slow", "robot")),))
    memory = Memory([C("weight", "anvil", 50), C("weight", "pen", 1)])
    engine = RuleEngine([warn], relations=heavy)
    assert texts(engine.assert_fact(memory, C("holding", "pen"))) == ["+(holding pen)"]
    assert texts(engine.assert_fact(memory, C("holding", "anvil"))) == ["+(holding anvil)", "+(slow robot)"]


def test_listeners_hear_the_changes_that_rules_make() -> None:
    memory = Memory([C("at", "robot", "lab")])
    heard: list[str] = []
    memory.subscribe(lambda kind, fact, time: heard.append(f"{kind} {term_to_str(fact)} {time}"))
    RuleEngine([AT_IS_UNIQUE]).assert_fact(memory, C("at", "robot", "hall"), 4.0)
    assert heard == ["assert (at robot hall) 4.0", "retract (at robot lab) 4.0"]


def test_badly_formed_rules_are_refused() -> None:
    with pytest.raises(RuleError, match="trigger must be a pattern"):
        MemoryRule("bad", X, None, ())  # type: ignore[arg-type]
    with pytest.raises(RuleError, match=r"\(assert FACT\) or \(retract FACT\)"):
        MemoryRule("bad", C("p", X), None, (("delete", C("p", X)),))
    engine = RuleEngine([AT_IS_UNIQUE])
    with pytest.raises(RuleError, match="defined twice"):
        engine.add(AT_IS_UNIQUE)


def test_a_rule_prints_as_the_form_that_defines_it() -> None:
    assert str(AT_IS_UNIQUE) == (
        "(define-memory-rule at-is-unique (on (at ?thing ?new)) "
        "(when (and (at ?thing ?old) (/= ?old ?new))) (retract (at ?thing ?old)))"
    )


# -- where rules were written, in every error while they fire ---------------------

CYCLE_FILE = (
    "; ping-pong for ever\n"
    "(define-memory-rule up (on (ping ?n)) (assert (pong ?n)))\n"
    "(define-memory-rule down (on (pong ?n)) (assert (ping (+ ?n 1))))\n"
)


def rules_of(text: str, filename: str = "cyc.rap") -> list[MemoryRule]:
    from atlas_rap.lang import ast, parse_text

    return [form.rule for form in parse_text(text, filename).forms if isinstance(form, ast.MemoryRuleDef)]


def test_a_rule_read_from_a_file_knows_where_it_was_written() -> None:
    up, down = rules_of(CYCLE_FILE)
    assert (str(up.loc), str(down.loc)) == ("cyc.rap:2:1", "cyc.rap:3:1")
    assert up.label == "up (cyc.rap:2:1)"
    assert AT_IS_UNIQUE.loc is None and AT_IS_UNIQUE.label == "at-is-unique"


def test_the_location_is_not_part_of_a_rules_equality() -> None:
    (written,) = rules_of("(define-memory-rule r (on (p ?x)) (assert (q ?x)))")
    in_code = MemoryRule("r", C("p", X), None, (("assert", C("q", X)),))
    assert written.loc is not None
    assert written == in_code and hash(written) == hash(in_code)


def test_a_cycle_error_names_the_rules_with_file_line_and_column_most_useful_first() -> None:
    memory = Memory()
    with pytest.raises(RuleCycleError) as caught:
        RuleEngine(rules_of(CYCLE_FILE)).assert_fact(memory, C("ping", 0))
    error = caught.value
    message = str(error)
    assert message.startswith(
        "memory rules did not reach a fixed point after 10000 firings caused by asserting (ping 0): "
        "up (cyc.rap:2:1) fired 5001 times, down (cyc.rap:3:1) fired 5000 times; last firings: ")
    assert message.endswith("up on (ping 4999), down on (pong 4999), up on (ping 5000)")
    assert len(message) < 250
    assert error.rules == ("up", "down")
    assert [str(loc) for loc in error.locations] == ["cyc.rap:2:1", "cyc.rap:3:1"]
    assert len(error.changes) == 10001


def test_a_cycle_error_cuts_long_facts_and_rules_made_in_code_have_no_location() -> None:
    grow = MemoryRule("grow", C("big", X), None, (("assert", C("big", C("wrap", X))),))
    with pytest.raises(RuleCycleError) as caught:
        RuleEngine([grow], max_firings=30).assert_fact(Memory(), C("big", "x" * 80))
    assert caught.value.locations == (None,)
    assert "grow fired 31 times" in str(caught.value)
    assert len(str(caught.value)) < 400
    assert "caused by asserting (big xxxxxxxxxxxxxxxxx ... xxxxxxxxxxxx): " in str(caught.value)
    assert "x" * 41 not in str(caught.value)


def test_an_effect_that_is_not_ground_names_the_rule_and_where_it_is() -> None:
    # A file cannot say this (the validator refuses ?z with a caret); a rule made in code can.
    from atlas_rap.errors import SourceLocation

    sloppy = MemoryRule("sloppy", C("at", X, Y), None, (("assert", C("near", X, Var("z"))),),
                        loc=SourceLocation("s.rap", 1, 1))
    with pytest.raises(RuleError) as caught:
        RuleEngine([sloppy]).assert_fact(Memory(), C("at", "robot", "lab"))
    assert str(caught.value).startswith("memory rule sloppy (s.rap:1:1): the effect (assert (near robot ?z)) "
                                        "is not ground")
    assert [str(loc) for loc in caught.value.locations] == ["s.rap:1:1"]
    assert caught.value.changes == [("assert", C("at", "robot", "lab"))]


def test_arithmetic_that_fails_in_an_effect_names_the_rule_and_where_it_is() -> None:
    (bad,) = rules_of("\n(define-memory-rule bad (on (oops ?n)) (assert (level (/ ?n 0))))", "b.rap")
    with pytest.raises(RuleError, match=r"^memory rule bad \(b.rap:2:1\): cannot evaluate the effect "
                                        r"\(assert \(level \(/ 3 0\)\)\): division by zero in \(/ 3 0\)$"):
        RuleEngine([bad]).assert_fact(Memory(), C("oops", 3))


def test_a_condition_that_raises_a_query_error_becomes_a_rule_error_naming_the_rule() -> None:
    (odd,) = rules_of("(define-memory-rule odd (on (n ?n)) (when (< ?n foo)) (assert (small ?n)))", "q.rap")
    with pytest.raises(RuleError) as caught:
        RuleEngine([odd]).assert_fact(Memory(), C("n", 3))
    assert not isinstance(caught.value, QueryError)
    assert str(caught.value) == ("memory rule odd (q.rap:1:1): its condition (when (< ?n foo)) cannot be "
                                 "evaluated: (< ?n foo): foo is not a number; arithmetic and < need numbers")
    assert isinstance(caught.value.__cause__, QueryError)


def test_a_runaway_relation_in_a_condition_is_wrapped_too() -> None:
    loop = {"loop": [Relation(C("loop", X), C("loop", X))]}
    rule = MemoryRule("spin", C("go", X), C("loop", X), (("assert", C("went", X)),))
    with pytest.raises(RuleError, match=r"memory rule spin: its condition \(when \(loop \?x\)\) cannot be "
                                        r"evaluated: defined relations called each other more than"):
        RuleEngine([rule], relations=loop).assert_fact(Memory(), C("go", 1))


# -- cycles seen before anything runs ---------------------------------------------


def names(cycles: list[tuple[MemoryRule, ...]]) -> list[list[str]]:
    return [[rule.name for rule in cycle] for cycle in cycles]


def test_two_rules_that_assert_each_others_trigger_are_a_cycle() -> None:
    assert names(rule_cycles(rules_of(CYCLE_FILE))) == [["up", "down"]]


def test_a_rule_that_asserts_its_own_trigger_pattern_is_a_cycle_of_one() -> None:
    count = MemoryRule("count", C("count", X), C("<", X, 10), (("assert", C("count", C("+", X, 1))),))
    assert names(rule_cycles([AT_IS_UNIQUE, count])) == [["count"]]
    assert names(rule_cycles([CONTENTS_MOVE_ALONG])) == [["contents-move-along"]]


def test_asserting_exactly_the_trigger_fact_again_is_not_a_cycle() -> None:
    echo = MemoryRule("echo", C("seen", X, Y), None, (("assert", C("seen", X, Y)), ("assert", C("heard", X))))
    assert rule_cycles([echo]) == []


def test_retractions_and_non_unifying_effects_make_no_edges() -> None:
    veto = MemoryRule("veto", C("at", X, "forbidden"), None, (("retract", C("at", X, "forbidden")),))
    log = MemoryRule("log", C("at", X, Y), None, (("assert", C("was-at", X, Y)),))
    two = MemoryRule("two", C("count", 2), None, (("assert", C("count", C("+", 1, 2))),))
    assert rule_cycles([veto, log, AT_IS_UNIQUE, two]) == []


def test_arithmetic_in_an_effect_is_its_value_or_any_number() -> None:
    two = MemoryRule("two", C("count", 2), None, (("assert", C("count", C("+", 1, 1))), ("assert", C("x")),))
    assert rule_cycles([two]) == []  # (count 2) again: already in memory
    step = MemoryRule("step", C("count", 3), None, (("assert", C("count", C("+", X, 1))),))
    assert names(rule_cycles([step])) == [["step"]]  # ?x bound somehow: some number, maybe 3


def test_variables_are_renamed_apart_before_unifying() -> None:
    # (p a ?x) and the trigger (p ?x b) unify only once ?x is renamed in one of them: (p a b) triggers it.
    shift = MemoryRule("shift", C("p", X, "b"), None, (("assert", C("p", "a", X)),))
    assert names(rule_cycles([shift])) == [["shift"]]


def test_cycles_are_found_once_per_group_shortest_first_in_definition_order() -> None:
    a = MemoryRule("a", C("a", X), None, (("assert", C("b", X)),))
    b = MemoryRule("b", C("b", X), None, (("assert", C("c", X)), ("assert", C("a", X))))
    c = MemoryRule("c", C("c", X), None, (("assert", C("a", X)),))
    solo = MemoryRule("solo", C("s", X), None, (("assert", C("s", C("f", X))),))
    lone = MemoryRule("lone", C("l", X), None, (("assert", C("a", X)),))
    assert names(rule_cycles([lone, solo, c, b, a])) == [["solo"], ["c", "a", "b"]]
    assert names(rule_cycles([a, b, c])) == [["a", "b"]]
    assert names(rule_cycles([a, b, c])) == names(rule_cycles([a, b, c]))

"""Memory rules: triggered by assertions, run to a fixed point, cycles reported."""

from __future__ import annotations

import pytest

from atlas_rap.logic import (
    Change,
    Compound,
    Memory,
    MemoryRule,
    Relation,
    RuleCycleError,
    RuleEngine,
    RuleError,
    Var,
    term_to_str,
)

C = Compound.of
THING, NEW, OLD, X, Y = Var("thing"), Var("new"), Var("old"), Var("x"), Var("y")

# LANGUAGE.md §2.5, as the validator builds it.
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

"""The shipped layer-switching rules (rap_library/layers.rap) on their own: facts in, primary layer out.

The runs in test_layers.py show the rules at work in a world; here each case is
the few facts the layers would say, in order, so a rule's guard is checked
where a run would rarely reach it.
"""

from __future__ import annotations

from atlas_rap.lang import ast
from atlas_rap.lang.loader import load, parse_term
from atlas_rap.logic import Compound
from atlas_rap.sequencer.interpreter import Sequencer
from atlas_rap.shipped import shipped_root

RULES = shipped_root("rap_library") / "layers.rap"


def rules_in_memory() -> Sequencer:
    program = load(RULES)
    seq = Sequencer(rules=[form.rule for form in program.of_type(ast.MemoryRuleDef)])
    for form in program.of_type(ast.InitialMemory):
        seq.change([("assert", fact) for fact in form.facts], "initial-memory")
    return seq


def say(seq: Sequencer, *facts: str) -> None:
    for text in facts:
        seq.assert_fact(parse_term(text), "layer")
    seq.settle()


def primary(seq: Sequencer) -> str:
    (layer,) = [fact.args[0] for fact in seq.memory if isinstance(fact, Compound) and fact.functor == "primary-layer"]
    return str(layer).upper()  # symbols are read in lower case


def holds(seq: Sequencer, text: str) -> bool:
    return parse_term(text) in seq.memory


def test_a_good_map_stops_mapping_and_hands_the_drive_to_layer_ii():
    seq = rules_in_memory()
    say(seq, "(obstacle none)", "(map-quality 0.5)")
    assert primary(seq) == "IV" and holds(seq, "(mapping on)")
    say(seq, "(map-quality 0.93)")
    assert primary(seq) == "II" and holds(seq, "(mapping off)") and holds(seq, "(map mature)")


def test_a_way_remapped_round_a_block_on_a_mature_map_goes_back_to_layer_ii():
    seq = rules_in_memory()
    say(seq, "(obstacle none)", "(map-quality 0.93)", "(route-blocked corridor office)", "(no-route)")
    assert primary(seq) == "IV" and holds(seq, "(mapping on)")
    say(seq, "(remapped corridor office)")
    assert primary(seq) == "II" and holds(seq, "(mapping off)")


def test_a_way_remapped_while_the_map_is_still_being_learnt_keeps_layer_iv_mapping():
    # A person lingering in the robot's way on its first run: Layer III found no way round on the
    # young map, Layer IV remapped and found one. The map is still poor: Layer IV keeps mapping.
    seq = rules_in_memory()
    say(seq, "(obstacle none)", "(map-quality 0.6)", "(route-blocked lab corridor)", "(no-route)")
    say(seq, "(remapped lab corridor)")
    assert primary(seq) == "IV" and holds(seq, "(mapping on)")
    assert not holds(seq, "(map mature)")

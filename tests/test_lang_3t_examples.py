"""The RAP and the operator of the 3T paper (docs/language/rap.md, define-rap; ap.md, operator) parse
unchanged, field by field."""

from __future__ import annotations

from atlas_rap.lang import ast, parse_text
from atlas_rap.logic import Compound, Var
from paper_examples import ATTACH_AT_SITE

GRASP_BULKY_OBJECT = """\
(operator grasp-bulky-object
  :purpose (holding planner ?large-thing)
  :arguments ((?size-of-thing (get-value ?large-thing size)))
  :preconditions ((top ?large-thing clear) (on ?large-thing ?something))
  :constraints ((can-lift ?arm-or-robot1 (/ ?size-of-thing 2))
                (can-lift ?arm-or-robot2 (/ ?size-of-thing 2)))
  :plot (simultaneous (grip ?arm-or-robot1 ?large-thing)
                      (grip ?arm-or-robot2 ?large-thing))
  :effects ((holding planner ?large-thing)
            (top ?something clear)
            (on ?large-thing nothing)))
"""

C = Compound.of
site = Var("thesite")


def test_attach_at_site_reads_as_one_rap_with_a_succeed_test_and_two_methods():
    (rap,) = parse_text(ATTACH_AT_SITE, "attach.rap").forms
    assert isinstance(rap, ast.RapDef)
    assert rap.name == "attach-at-site"
    assert rap.params == (site,)
    assert rap.succeed == C("docked", site)
    assert (rap.constraints, rap.timeout, rap.priority, rap.retries) == (None, None, None, None)
    assert len(rap.methods) == 2
    assert (rap.loc.file, rap.loc.line, rap.loc.column) == ("attach.rap", 1, 1)


def test_the_first_method_attaches_magnetically_on_a_ferrous_hull():
    rap = parse_text(ATTACH_AT_SITE).forms[0]
    method = rap.methods[0]
    assert method.name is None
    assert method.context == C("ferrous-hull", site)
    assert isinstance(method.body, ast.TaskNet)
    (sequence,) = method.body.nets
    assert isinstance(sequence, ast.Sequence)
    t1, t2, wait = sequence.parts
    assert (t1.label, t1.task) == ("t1", C("approach-site", site))
    assert (t2.label, t2.task) == ("t2", C("magnetically-attach", site))
    assert (t1.before, t1.until_end, t1.waits) == ((), None, ())
    assert wait == ast.WaitFor(query=C("docked", site), outcome=":succeed", timeout=None)
    assert (method.loc.line, method.loc.column) == (3, 3)
    assert (t2.loc.line, t2.loc.column) == (8, 9)


def test_the_second_method_grips_when_the_hull_is_not_ferrous():
    method = parse_text(ATTACH_AT_SITE).forms[0].methods[1]
    assert method.context == C("not", C("ferrous-hull", site))
    steps = method.body.nets[0].parts
    assert [s.task for s in steps[:2]] == [C("approach-site", site), C("grip-attach", site)]
    assert steps[2].query == C("docked", site)


def test_the_older_index_head_reads_the_same():
    older = ATTACH_AT_SITE.replace("(define-rap (attach-at-site ?thesite)",
                                   "(define-rap (index (attach-at-site ?thesite))")
    assert parse_text(older).forms == parse_text(ATTACH_AT_SITE).forms


def test_grasp_bulky_object_reads_with_every_part():
    (op,) = parse_text(GRASP_BULKY_OBJECT, "station.ap").forms
    thing, size, something = Var("large-thing"), Var("size-of-thing"), Var("something")
    arm1, arm2 = Var("arm-or-robot1"), Var("arm-or-robot2")
    assert isinstance(op, ast.Operator)
    assert op.name == "grasp-bulky-object"
    assert op.purpose == C("holding", "planner", thing)
    assert op.arguments == (ast.Argument(var=size, expr=C("get-value", thing, "size")),)
    assert op.preconditions == (C("top", thing, "clear"), C("on", thing, something))
    assert op.constraints == (C("can-lift", arm1, C("/", size, 2)), C("can-lift", arm2, C("/", size, 2)))
    assert op.plot == ast.PlotGroup(kind="simultaneous", parts=(
        ast.PlotStep(C("grip", arm1, thing)), ast.PlotStep(C("grip", arm2, thing))))
    assert op.effects == (ast.Effect(C("holding", "planner", thing)),
                          ast.Effect(C("top", something, "clear")),
                          ast.Effect(C("on", thing, "nothing")))
    assert (op.agent, op.duration, op.uncontrolled, op.probability) == (None, 1, False, None)
    assert (op.loc.line, op.loc.column) == (1, 1)


def test_an_operator_reads_the_same_in_the_clause_style():
    clause_style = """\
(Operator grasp-bulky-object
  (purpose (holding planner ?large-thing))
  (arguments (?size-of-thing (get-value ?large-thing size)))
  (preconditions (top ?large-thing clear) (on ?large-thing ?something))
  (constraints (can-lift ?arm-or-robot1 (/ ?size-of-thing 2))
               (can-lift ?arm-or-robot2 (/ ?size-of-thing 2)))
  (plot (simultaneous (grip ?arm-or-robot1 ?large-thing)
                      (grip ?arm-or-robot2 ?large-thing)))
  (effects (holding planner ?large-thing) (top ?something clear) (on ?large-thing nothing)))
"""
    assert parse_text(clause_style).forms == parse_text(GRASP_BULKY_OBJECT).forms

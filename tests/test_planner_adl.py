"""PDDL ADL (or, imply, exists, forall, when) read by atlas_rap.planner.pddl and
compiled away by atlas_rap.planner.ground: plans are found, print as the PDDL
actions and pass the validator, which reads the lifted operators, not the
compilation."""

from __future__ import annotations

import dataclasses
import random
from pathlib import Path

import pytest
from pddl_problems import SHARED_PDDL, write_problem

from atlas_rap.errors import SourceError
from atlas_rap.lang import ast
from atlas_rap.logic import Compound, term_to_str
from atlas_rap.planner.ground import GOAL_FACT, MAX_VARIANTS, ground
from atlas_rap.planner.pddl import load_pddl, parse_pddl
from atlas_rap.planner.plan_file import read_plan_file, validate_plan, validate_plan_file, write_plan_file
from atlas_rap.planner.solve import solve

BRIEFCASE = """\
(define (domain briefcase)
  (:requirements :strips :typing :conditional-effects)
  (:types location portable)
  (:predicates (at ?o - portable ?l - location) (in ?o - portable) (is-at ?l - location))
  (:action move
    :parameters (?from ?to - location)
    :precondition (and (is-at ?from) (not (= ?from ?to)))
    :effect (and (is-at ?to) (not (is-at ?from))
                 (forall (?o - portable)
                   (when (in ?o) (and (at ?o ?to) (not (at ?o ?from)))))))
  (:action put-in
    :parameters (?o - portable ?l - location)
    :precondition (and (at ?o ?l) (is-at ?l) (not (in ?o)))
    :effect (in ?o))
  (:action take-out
    :parameters (?o - portable)
    :precondition (in ?o)
    :effect (not (in ?o))))
"""
BRIEFCASE_PROBLEM = """\
(define (problem carry) (:domain briefcase)
  (:objects home office - location dict paper pen - portable)
  (:init (is-at home) (at dict home) (at paper home) (at pen office))
  (:goal (and (at dict office) (at paper office) (not (in dict)) (not (in paper))
              (at pen home) (is-at office))))
"""

LIGHTS = """\
(define (domain lights)
  (:requirements :adl :typing)
  (:types switch room)
  (:predicates (on ?s - switch) (in ?s - switch ?r - room) (lit ?r - room)
               (broken ?s - switch) (wired ?s - switch) (master))
  (:action toggle
    :parameters (?s - switch)
    :precondition (and (not (broken ?s)) (or (master) (wired ?s)))
    :effect (and (when (on ?s) (not (on ?s)))
                 (when (not (on ?s)) (on ?s))
                 (forall (?r - room) (when (and (in ?s ?r) (not (on ?s))) (lit ?r)))
                 (forall (?r - room)
                   (when (and (in ?s ?r) (on ?s)
                              (not (exists (?t - switch) (and (on ?t) (in ?t ?r) (not (= ?t ?s))))))
                         (not (lit ?r))))))
  (:action flip-master
    :parameters ()
    :precondition (imply (master) (exists (?s - switch) (on ?s)))
    :effect (and (when (master) (not (master))) (when (not (master)) (master))))
  (:action reset
    :parameters ()
    :precondition (not (and (master) (forall (?s - switch) (not (on ?s)))))
    :effect (and (forall (?s - switch) (not (on ?s))) (forall (?r - room) (not (lit ?r))))))
"""
LIGHTS_PROBLEM = """\
(define (problem evening) (:domain lights)
  (:objects s1 s2 s3 s4 - switch r1 r2 r3 - room)
  (:init (in s1 r1) (in s2 r1) (in s3 r2) (in s4 r3) (wired s1) (wired s3) (broken s2) (on s4) (lit r3))
  (:goal {goal}))
"""


def actions(*lines: str) -> list[Compound]:
    return [Compound(line.strip("()").split()[0], tuple(line.strip("()").split()[1:])) for line in lines]


def texts(sequence) -> list[str]:
    return [term_to_str(a) for a in sequence]


def lights(goal: str = "(and (lit r1) (lit r2) (not (lit r3)))", fond: bool = False):
    domain = LIGHTS
    if fond:  # flipping the master may black out every room
        flip = "(and (when (master) (not (master))) (when (not (master)) (master)))"
        domain = domain.replace(f":effect {flip}", f":effect (oneof {flip} (and {flip} "
                                                   "(forall (?r - room) (not (lit ?r)))))")
        assert "oneof" in domain
    return parse_pddl(domain, LIGHTS_PROBLEM.format(goal=goal), "lights.pddl", "evening.pddl")


# --------------------------------------------------------------------------- reading


def test_when_and_forall_effects_are_read_as_conditional_effects() -> None:
    problem = parse_pddl(BRIEFCASE, BRIEFCASE_PROBLEM)
    move = problem.operator("move")
    plain = [e for e in move.effects if type(e) is ast.Effect]
    conditional = [e for e in move.effects if type(e) is ast.ConditionalEffect]
    assert [term_to_str(e.fact) for e in plain] == ["(is-at ?to)", "(is-at ?from)"]
    assert [(term_to_str(e.fact), e.positive) for e in conditional] == [("(at ?o ?to)", True),
                                                                       ("(at ?o ?from)", False)]
    assert all(term_to_str(e.condition) == "(adl:and (type:portable ?o) (in ?o))" for e in conditional)
    assert all(e.variables == (conditional[0].variables[0],) for e in conditional)


def test_formulas_are_kept_in_negation_normal_form() -> None:
    problem = lights()
    toggle, flip, reset = (problem.operator(n) for n in ("toggle", "flip-master", "reset"))
    assert [term_to_str(p) for p in toggle.preconditions] == [
        "(type:switch ?s)", "(not (broken ?s))", "(adl:or (master) (wired ?s))"]
    assert [term_to_str(p) for p in flip.preconditions] == [
        "(adl:or (not (master)) (adl:exists (?s) (adl:and (type:switch ?s) (on ?s))))"]
    # (not (and A (forall ...))) pushed down to (or (not A) (exists ... (not ...)))
    assert [term_to_str(p) for p in reset.preconditions] == [
        "(adl:or (not (master)) (adl:exists (?s) (adl:and (type:switch ?s) (on ?s))))"]


def test_a_negated_disjunction_becomes_plain_literals() -> None:
    domain = """(define (domain d) (:requirements :adl) (:predicates (p ?x) (q ?x))
      (:action a :parameters (?x) :precondition (not (or (p ?x) (q ?x))) :effect (p ?x)))"""
    problem = parse_pddl(domain, "(define (problem r) (:domain d) (:objects o) (:init) (:goal (p o)))")
    assert [term_to_str(p) for p in problem.operator("a").preconditions] == ["(not (p ?x))", "(not (q ?x))"]


def test_a_quantified_variable_that_shadows_a_parameter_is_renamed() -> None:
    domain = """(define (domain d) (:requirements :adl) (:predicates (p ?x) (q ?x) (r ?x))
      (:action mark :parameters (?x) :precondition (and (p ?x) (exists (?x) (q ?x))) :effect (r ?x)))"""
    problem = parse_pddl(domain, """(define (problem s) (:domain d) (:objects a b)
      (:init (p a) (q b)) (:goal (r a)))""")
    assert term_to_str(problem.operator("mark").preconditions[1]) == "(adl:exists (?x~1) (q ?x~1))"
    result = solve(problem)
    assert texts(result.sequence) == ["(mark a)"]


def position(text: str, marker: str) -> tuple[int, int]:
    """(line, column) of the first occurrence of ``marker``."""
    before = text[: text.index(marker)]
    return before.count("\n") + 1, len(before) - (before.rfind("\n") + 1) + 1


def located(tmp_path: Path, domain: str, marker: str) -> str:
    """The report of loading ``domain``, checked to point at ``marker`` with a caret and a hint."""
    paths = write_problem(tmp_path, domain, "(define (problem r) (:domain d) (:objects o) (:init (p o)) (:goal (q o)))")
    with pytest.raises(SourceError) as caught:
        load_pddl(*paths)
    report = str(caught.value)
    line, column = position(domain, marker)
    assert report.startswith(f"{paths[0]}:{line}:{column}: error: "), report
    assert report.splitlines()[2].strip() == "^" and caught.value.problem.hint
    return report


ADL_TEMPLATE = """\
(define (domain d) (:requirements :adl) (:predicates (p ?x) (q ?x) (at ?x ?y))
  (:action a :parameters (?x)
    :precondition {pre}
    :effect {eff}))
"""


def test_numeric_fluents_stay_located_errors(tmp_path: Path) -> None:
    report = located(tmp_path, ADL_TEMPLATE.format(pre="(p ?x)", eff="(when (p ?x) (increase (fuel) 1))"),
                     "(increase")
    assert "numeric fluents ('increase') are not supported" in report
    report = located(tmp_path, ADL_TEMPLATE.format(pre="(or (> (fuel ?x) 1) (p ?x))", eff="(q ?x)"), "(>")
    assert "numeric fluents ('>') are not supported" in report


def test_a_function_term_is_a_located_error_naming_object_fluents(tmp_path: Path) -> None:
    report = located(tmp_path, ADL_TEMPLATE.format(pre="(forall (?y) (at ?x (loc ?y)))", eff="(q ?x)"), "(loc")
    assert "numeric fluents and object fluents" in report


def test_oneof_inside_when_is_a_located_error() -> None:
    domain = """(define (domain d) (:requirements :adl :non-deterministic) (:predicates (p ?x) (q ?x))
  (:action a :parameters (?x) :effect (when (p ?x) (oneof (q ?x) (p ?x)))))"""
    with pytest.raises(SourceError, match=r"domain.pddl:2:52: error: \(oneof \.\.\.\) inside when or forall"):
        parse_pddl(domain, "(define (problem r) (:domain d) (:objects o) (:init) (:goal (q o)))")


# ---------------------------------------------------------------------- planning


def test_the_briefcase_carries_what_is_in_it_and_the_plan_validates(tmp_path: Path) -> None:
    domain, prob = write_problem(tmp_path, BRIEFCASE, BRIEFCASE_PROBLEM)
    problem = load_pddl(domain, prob)
    result = solve(problem)
    assert result.status == "solved"
    steps = texts(result.sequence)
    assert steps[-1] == "(move home office)" or "(take-out" in steps[-1]
    assert "(put-in pen office)" in steps and "(put-in dict home)" in steps and "(put-in paper home)" in steps
    check = validate_plan(problem, result.sequence)
    assert check.ok, check.message

    path = tmp_path / "plan.txt"
    write_plan_file(path, result.sequence)
    lines = path.read_text().splitlines()
    assert all(line.split()[0] in ("(move", "(put-in", "(take-out") for line in lines[:-1]), lines
    assert read_plan_file(path) == result.sequence
    assert validate_plan_file(domain, prob, path).ok


def test_the_validator_applies_conditional_effects_from_the_state_before_the_step() -> None:
    problem = parse_pddl(BRIEFCASE, BRIEFCASE_PROBLEM)
    empty = validate_plan(problem, actions("(move home office)", "(put-in pen office)", "(move office home)"))
    assert not empty.ok and "goal (at dict office) is not met" in empty.message
    carried = validate_plan(problem, actions(
        "(put-in dict home)", "(put-in paper home)", "(move home office)", "(take-out dict)",
        "(take-out paper)", "(put-in pen office)", "(move office home)", "(take-out pen)", "(move home office)"))
    assert carried.ok, carried.message


def test_a_variant_per_combination_of_open_conditions() -> None:
    task = ground(parse_pddl(BRIEFCASE, BRIEFCASE_PROBLEM))
    moves = [a for a in task.actions if term_to_str(a.term) == "(move home office)"]
    assert len(moves) == 8  # three portables, each in the briefcase or not
    assert {a.operator.name for a in moves} == {"move"}
    everything = next(a for a in moves if len(a.pre) == 4)
    assert sorted(term_to_str(task.facts[f]) for f in everything.add) == [
        "(at dict office)", "(at paper office)", "(at pen office)", "(is-at office)"]


def test_static_conditions_are_decided_when_grounding() -> None:
    domain = """(define (domain d) (:requirements :adl :typing) (:types box)
  (:predicates (heavy ?b - box) (loaded ?b - box) (tired) (done))
  (:action lift :parameters ()
    :effect (and (done) (forall (?b - box) (when (heavy ?b) (and (tired) (loaded ?b)))))))"""
    problem = parse_pddl(domain, """(define (problem p) (:domain d) (:objects a b c - box)
      (:init (heavy b)) (:goal (and (done) (loaded b))))""")
    task = ground(problem)
    assert len(task.actions) == 1
    assert sorted(term_to_str(task.facts[f]) for f in task.actions[0].add) == ["(done)", "(loaded b)", "(tired)"]
    assert texts(solve(problem).sequence) == ["(lift)"]


def test_or_imply_and_exists_preconditions() -> None:
    problem = lights()
    result = solve(problem)
    assert result.status == "solved"
    assert validate_plan(problem, result.sequence).ok
    steps = texts(result.sequence)
    assert "(toggle s2)" not in steps  # broken
    assert "(toggle s1)" in steps and "(toggle s3)" in steps
    # s4 is not wired: turning it off (r3 dark) needs the master, or a reset
    assert "(toggle s4)" not in steps or "(flip-master)" in steps


def test_a_universal_precondition() -> None:
    domain = """(define (domain d) (:requirements :adl :typing) (:types box)
  (:predicates (packed ?b - box) (shipped))
  (:action pack :parameters (?b - box) :precondition (not (packed ?b)) :effect (packed ?b))
  (:action ship :parameters ()
    :precondition (forall (?b - box) (packed ?b)) :effect (shipped)))"""
    problem = parse_pddl(domain, """(define (problem p) (:domain d) (:objects a b c - box)
      (:init (packed b)) (:goal (shipped)))""")
    result = solve(problem)
    assert sorted(texts(result.sequence)[:-1]) == ["(pack a)", "(pack c)"]
    assert texts(result.sequence)[-1] == "(ship)"
    assert validate_plan(problem, result.sequence).ok
    early = validate_plan(problem, actions("(pack a)", "(ship)"))
    assert not early.ok and early.failed_step == 2
    assert "precondition (forall (?b) (or (not (type:box ?b)) (packed ?b))) does not hold" in early.message


def test_a_universal_goal_is_a_plain_conjunction() -> None:
    problem = lights("(forall (?r - room) (imply (not (= ?r r3)) (lit ?r)))")
    task = ground(problem)
    assert GOAL_FACT not in task.fact_ids
    assert sorted(term_to_str(task.facts[g]) for g in task.goal) == ["(lit r1)", "(lit r2)"]
    result = solve(problem)
    assert result.status == "solved" and validate_plan(problem, result.sequence).ok


def test_a_disjunctive_goal_needs_no_extra_step() -> None:
    problem = lights("(or (and (lit r1) (not (lit r3))) (lit r2))")
    task = ground(problem)
    assert [task.facts[g] for g in task.goal] == [GOAL_FACT]
    result = solve(problem)
    assert result.status == "solved"
    assert texts(result.sequence) in (["(toggle s1)"], ["(toggle s3)"])
    assert validate_plan(problem, result.sequence).ok
    assert not validate_plan(problem, []).ok


def test_an_existential_goal_already_true_is_solved_by_the_empty_plan() -> None:
    result = solve(lights("(exists (?r - room) (lit ?r))"))
    assert result.status == "solved" and result.sequence == []


def test_an_impossible_formula_goal_is_unsolvable() -> None:
    result = solve(lights("(forall (?s - switch) (on ?s))"))  # s2 is broken and off
    assert result.status == "unsolvable"


def test_a_goal_formula_false_whatever_the_plan_does_is_reported_at_the_goal() -> None:
    result = solve(lights("(exists (?r - room) (and (lit ?r) (broken s1)))"))  # broken never changes
    assert result.status == "unsolvable"
    (problem,) = result.problems
    assert (problem.location.file, problem.location.line, problem.location.column) == ("evening.pddl", 4, 10)
    assert "no sequence of actions can make it true" in problem.message


def test_too_many_variants_is_a_located_error_naming_the_action() -> None:
    domain = """(define (domain d) (:requirements :adl)
  (:predicates (a ?x) (b ?x))
  (:action set :parameters (?x) :effect (a ?x))
  (:action poke :parameters () :effect (forall (?x) (when (a ?x) (b ?x)))))"""

    def problem(n: int):
        objects = " ".join(f"o{i}" for i in range(n))
        return parse_pddl(domain, f"(define (problem p) (:domain d) (:objects {objects}) (:init) (:goal (b o0)))")

    assert len([a for a in ground(problem(8)).actions if a.name == "poke"]) == MAX_VARIANTS
    with pytest.raises(SourceError) as caught:
        ground(problem(9))
    report = str(caught.value)
    assert "domain.pddl:4:3: error: action (poke): its conditional effects" in report
    assert f"more than {MAX_VARIANTS} variants" in report and "^" in report


def test_a_blackout_outcome_of_the_master_switch_is_planned_around() -> None:
    problem = lights("(or (lit r1) (lit r2))", fond=True)
    assert [op.name for op in problem.operators] == ["toggle", "flip-master", "flip-master~2", "reset"]
    task = ground(problem)
    assert {a.name for a in task.nature} == {"flip-master~2"}
    result = solve(problem)
    assert result.status == "solved" and "(flip-master)" not in texts(result.sequence)
    assert validate_plan(problem, result.sequence, adversarial=True).ok


def test_a_conditional_effect_in_a_fond_outcome() -> None:
    domain = """(define (domain d) (:requirements :adl :non-deterministic)
  (:predicates (p ?x) (q ?x) (spare ?x))
  (:action go :parameters (?x) :precondition (p ?x)
    :effect (oneof (q ?x) (and (q ?x) (when (spare ?x) (not (p ?x)))))))"""
    problem = parse_pddl(domain, "(define (problem r) (:domain d) (:objects o) (:init (p o)) (:goal (q o)))")
    assert [op.name for op in problem.operators] == ["go", "go~2"]
    assert texts(solve(problem).sequence) == ["(go o)"]


# ------------------------------------------------- the compilation against the lifted semantics

def random_walks(problem, seeds: range, length: int) -> int:
    """Random sequences of ground actions: each state the ground task reaches is the
    one the validator (lifted operators, PDDL semantics) reaches; wherever a lifted
    action applies, one of its variants does, and all that do have the same result
    (but for GOAL_FACT); the task's goal holds only where the problem's does."""
    task = ground(problem)
    reached = task.fact_ids.get(GOAL_FACT)
    by_term: dict[Compound, list] = {}
    for action in task.actions:
        by_term.setdefault(action.term, []).append(action)
    nature: dict[Compound, list] = {}
    for action in task.nature:
        nature.setdefault(action.term, []).append(action)
    checked = 0
    for seed in seeds:
        rng = random.Random(seed)
        state, steps = task.init, []
        for _ in range(length):
            applicable = [a for a in task.actions if task.applicable(a, state)]
            if not applicable:
                break
            action = rng.choice(applicable)
            assert sum(1 for a in by_term[action.term] if task.applicable(a, state)) >= 1
            successors = {task.apply(a, state) - {reached} for a in by_term[action.term] if task.applicable(a, state)}
            assert len(successors) == 1  # every applicable variant does the same
            state = task.apply(action, state)
            steps.append(action.term)
            if task.is_goal(state):
                assert validate_plan(problem, steps).ok, texts(steps)
            facts = [task.facts[f] for f in sorted(state) if task.facts[f] != GOAL_FACT]
            absent = [Compound("not", (f,)) for i, f in enumerate(task.facts)
                      if i not in state and f != GOAL_FACT]
            same = dataclasses.replace(problem, goals=tuple(facts + absent))
            check = validate_plan(same, steps)
            assert check.ok, (seed, texts(steps), check.message)
            here = dataclasses.replace(problem, initial=tuple(facts), goals=())
            for term, variants in by_term.items():
                lifted = validate_plan(here, [term]).failed_step is None
                assert lifted == any(task.applicable(a, state) for a in variants), (texts(steps), term)
            for term, variants in nature.items():  # an uncontrolled action happens one way, exactly
                assert len({task.apply(a, state) for a in variants if task.applicable(a, state)}) <= 1
            checked += 1
    return checked


@pytest.mark.parametrize("which", ["briefcase", "lights", "lights-or-goal", "lights-fond-or-goal"])
def test_the_compiled_actions_do_what_the_lifted_ones_do(which: str) -> None:
    either = "(or (lit r1) (and (lit r2) (not (lit r3))))"
    problem = {"briefcase": lambda: parse_pddl(BRIEFCASE, BRIEFCASE_PROBLEM),
               "lights": lights,
               "lights-or-goal": lambda: lights(either),
               "lights-fond-or-goal": lambda: lights(either, fond=True)}[which]()
    assert random_walks(problem, range(6), 10) > 30

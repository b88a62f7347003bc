"""Every form of docs/language/rap.md and ap.md reads into the AST a user expects,
field by field, and the lexical rules of §1 hold (case folding, comments,
numbers). The 3T examples (define-rap, operator) are in test_lang_3t_examples.py;
the errors below are those that test_lang_errors.py does not already cover."""

from __future__ import annotations


from atlas_rap.lang import ast, parse_text
from atlas_rap.logic import Compound, MemoryRule, String, Var

from source_problems import at, only_problem

C = Compound.of


def only_form(text: str):
    (form,) = parse_text(text, "forms.rap").forms
    return form


def method_body(text: str):
    """The body of the first method of the one define-rap in ``text``."""
    return only_form(text).methods[0].body


def where(node) -> tuple[int, int]:
    return node.loc.line, node.loc.column


# ----------------------------------------------------------------- §2.5 memory rules

AT_IS_UNIQUE = """\
(define-memory-rule at-is-unique
  (on (at ?thing ?new))
  (when (and (at ?thing ?old) (/= ?old ?new)))
  (retract (at ?thing ?old)))
"""


def test_the_at_is_unique_memory_rule_reads_field_by_field():
    rule_def = only_form(AT_IS_UNIQUE)
    thing, old, new = Var("thing"), Var("old"), Var("new")
    assert isinstance(rule_def, ast.MemoryRuleDef)
    assert rule_def.name == "at-is-unique"
    assert rule_def.rule.trigger == C("at", thing, new)
    assert rule_def.rule.condition == C("and", C("at", thing, old), C("/=", old, new))
    assert rule_def.rule.effects == (("retract", C("at", thing, old)),)
    assert rule_def.rule == MemoryRule("at-is-unique", C("at", thing, new),
                                       C("and", C("at", thing, old), C("/=", old, new)),
                                       (("retract", C("at", thing, old)),))
    assert where(rule_def) == (1, 1)


def test_a_memory_rule_without_when_has_no_condition_and_keeps_its_effects_in_order():
    rule = only_form("(define-memory-rule door-shut\n  (on (closed ?d))\n"
                     "  (retract (open ?d))\n  (assert (sealed ?d)))\n").rule
    assert rule.condition is None
    assert rule.effects == (("retract", C("open", Var("d"))), ("assert", C("sealed", Var("d"))))


# ----------------------------------------------------------------- §2.6 virtual skills, at-time

VIRTUAL_SKILLS = """\
(define-virtual-skill (approach-site ?site)
  (after 2.0 (assert (near robot ?site)))
  (after 2.5 (finish :succeed)))

(define-virtual-skill (grip-attach ?site)
  (when (not (gripper-ok)) (after 0.5 (finish :fail)))
  (after 1.0 (assert (docked ?site)) (finish :succeed)))
"""


def test_a_virtual_skill_reads_as_timed_script_lines():
    approach, _ = parse_text(VIRTUAL_SKILLS).forms
    site = Var("site")
    assert isinstance(approach, ast.VirtualSkillDef)
    assert approach.name == "approach-site"
    assert approach.head == C("approach-site", site)
    assert approach.lines == (
        ast.After(delay=2.0, actions=(ast.MemoryOp("assert", C("near", "robot", site)),)),
        ast.After(delay=2.5, actions=(ast.Finish(":succeed"),)),
    )
    assert where(approach.lines[1]) == (3, 3)


def test_a_when_guard_in_a_virtual_skill_holds_its_query_and_its_after_lines():
    _, grip = parse_text(VIRTUAL_SKILLS).forms
    guard, after = grip.lines
    assert isinstance(guard, ast.When)
    assert guard.condition == C("not", C("gripper-ok"))
    assert guard.lines == (ast.After(delay=0.5, actions=(ast.Finish(":fail"),)),)
    assert after == ast.After(delay=1.0, actions=(ast.MemoryOp("assert", C("docked", Var("site"))),
                                                  ast.Finish(":succeed")))
    assert (where(grip), where(guard)) == ((5, 1), (6, 3))


def test_at_time_changes_memory_at_a_simulated_time():
    event = only_form("(at-time 30 (retract (open airlock)) (assert (closed airlock)))\n")
    assert isinstance(event, ast.AtTime)
    assert event.time == 30
    assert event.actions == (ast.MemoryOp("retract", C("open", "airlock")),
                             ast.MemoryOp("assert", C("closed", "airlock")))


# ----------------------------------------------------------------- §2.4 primitives

PRIMITIVE = """\
(define-rap (go-to ?x ?y)
  (method
    (primitive
      (enable (move-to ?x ?y) (avoid-obstacles))
      (wait-for (at robot ?place) :succeed)
      (wait-for (blocked robot) :fail)
      (disable :above))))
"""


def test_the_primitive_example_enables_two_skills_waits_for_two_outcomes_and_disables_above():
    primitive = method_body(PRIMITIVE)
    assert isinstance(primitive, ast.Primitive)
    enable, succeeded, blocked, disable = primitive.actions
    assert enable == ast.Enable(skills=(C("move-to", Var("x"), Var("y")), C("avoid-obstacles")))
    assert succeeded == ast.WaitFor(query=C("at", "robot", Var("place")), outcome=":succeed", timeout=None)
    assert blocked == ast.WaitFor(query=C("blocked", "robot"), outcome=":fail", timeout=None)
    assert disable == ast.Disable(skills=(), above=True)
    assert [where(a) for a in primitive.actions] == [(4, 7), (5, 7), (6, 7), (7, 7)]


def test_disable_may_name_the_skills_to_turn_off():
    primitive = method_body("(define-rap (look)\n  (method (primitive (enable (pan) (tilt)) (disable (tilt)))))\n")
    assert primitive.actions[1] == ast.Disable(skills=(C("tilt"),), above=False)


# ----------------------------------------------------------------- §2.2, §2.3 steps and annotations

def test_a_step_with_several_wait_fors_is_a_multi_outcome_step():
    net = method_body("""\
(define-rap (pick-up ?o)
  (method
    (task-net
      (t1 (grasp ?o)
          (wait-for (holding ?o) :succeed)
          (wait-for (dropped ?o) :fail)
          (wait-for (slipping ?o) :regrip :timeout 5)))))
""")
    (step,) = net.nets
    o = Var("o")
    assert (step.label, step.task) == ("t1", C("grasp", o))
    assert step.waits == (
        ast.WaitFor(C("holding", o), ":succeed"),
        ast.WaitFor(C("dropped", o), ":fail"),
        ast.WaitFor(C("slipping", o), ":regrip", 5),
    )


def test_for_and_until_end_annotations_name_other_steps_of_the_method():
    net = method_body("""\
(define-rap (inspect ?o)
  (method
    (task-net
      (t1 (approach ?o) (for t3))
      (t2 (track-object ?o) (until-end t3))
      (t3 (photograph ?o)))))
""")
    t1, t2, t3 = net.nets
    assert (t1.label, t1.before, t1.until_end) == ("t1", ("t3",), None)
    assert (t2.label, t2.before, t2.until_end) == ("t2", (), "t3")
    assert (t3.label, t3.before, t3.until_end, t3.waits) == ("t3", (), None, ())


def test_for_may_name_several_later_steps():
    net = method_body("(define-rap (go)\n  (method (task-net (t1 (a) (for t2 t3)) (t2 (b)) (t3 (c)))))\n")
    assert net.nets[0].before == ("t2", "t3")


def test_a_bare_wait_for_in_a_sequence_may_carry_an_outcome_and_a_timeout():
    (sequence,) = method_body("""\
(define-rap (open-door ?d)
  (method
    (task-net
      (sequence
        (push ?d)
        (wait-for (open ?d) :timeout 10)
        (wait-for (jammed ?d) :stuck)))))
""").nets
    push, wait_open, wait_jammed = sequence.parts
    assert push == ast.Step(task=C("push", Var("d")), label=None)
    assert wait_open == ast.WaitFor(C("open", Var("d")), ":succeed", 10)
    assert wait_jammed == ast.WaitFor(C("jammed", Var("d")), ":stuck", None)
    assert where(wait_open) == (6, 9)


def test_assert_and_retract_are_net_steps_that_change_memory():
    (sequence,) = method_body("""\
(define-rap (stow ?tool)
  (method
    (task-net
      (sequence
        (t1 (put-away ?tool))
        (assert (stowed ?tool))
        (retract (in-hand ?tool))))))
""").nets
    _, added, removed = sequence.parts
    assert added == ast.MemoryOp("assert", C("stowed", Var("tool")))
    assert removed == ast.MemoryOp("retract", C("in-hand", Var("tool")))
    assert where(added) == (6, 9)


def test_a_parallel_net_holds_its_parts_in_the_order_written():
    (parallel,) = method_body("(define-rap (go)\n  (method (task-net (parallel (a) (b) (sequence (c) (d))))))\n").nets
    assert isinstance(parallel, ast.Parallel)
    a, b, sequence = parallel.parts
    assert (a.task, b.task) == (C("a"), C("b"))
    assert sequence == ast.Sequence(parts=(ast.Step(C("c")), ast.Step(C("d"))))


# ----------------------------------------------------------------- §2.7 mission forms

MISSION = """\
(include "lib/navigation.rap")
(world "worlds/Station-B.yaml")
(initial-memory (at robot dock) (door-open airlock))
(post (deliver box-1 "Lab B") :priority 5 :deadline 120.5)
(plan (holding planner box-1) (inspected camera-site))
"""


def test_a_mission_file_reads_each_form_in_order():
    include, world, memory, post, plan = parse_text(MISSION, "mission.rap").forms
    assert include == ast.Include("lib/navigation.rap")
    assert world == ast.WorldDecl("worlds/Station-B.yaml")
    assert memory == ast.InitialMemory((C("at", "robot", "dock"), C("door-open", "airlock")))
    assert post == ast.Post(C("deliver", "box-1", String("Lab B")), priority=5, deadline=120.5)
    assert plan == ast.PlanRequest((C("holding", "planner", "box-1"), C("inspected", "camera-site")))
    assert [where(form) for form in (include, world, memory, post, plan)] == [(i, 1) for i in range(1, 6)]
    assert include.loc.file == "mission.rap"


def test_world_none_means_virtual_skills_only():
    assert only_form("(world none)") == ast.WorldDecl("none")


def test_post_without_options_has_no_priority_and_no_deadline():
    post = only_form("(post (patrol corridor-2))")
    assert (post.task, post.priority, post.deadline) == (C("patrol", "corridor-2"), None, None)


def test_post_options_may_come_in_either_order():
    assert only_form("(post (go) :deadline 9 :priority -1)") == ast.Post(C("go"), priority=-1, deadline=9)


# ----------------------------------------------------------------- §3.2 problems, agents, relations

PROBLEM = """\
(include "../operators/space-station.ap")
(agents
  (controlled left-arm right-arm camera-1)
  (uncontrolled astronaut))
(define-relation (can-lift ?agent ?weight)
  (>= (get-value ?agent max-lift) ?weight))
(initial (at robot dock) (max-lift left-arm 25) (size box-1 40))
(goals (holding planner box-1) (inspected camera-site))
"""


def test_a_planning_problem_reads_agents_a_relation_the_initial_state_and_goals():
    include, agents, relation, initial, goals = parse_text(PROBLEM, "problem.ap").forms
    assert include == ast.Include("../operators/space-station.ap")
    assert agents == ast.Agents(controlled=("left-arm", "right-arm", "camera-1"), uncontrolled=("astronaut",))
    assert initial == ast.Initial((C("at", "robot", "dock"), C("max-lift", "left-arm", 25),
                                   C("size", "box-1", 40)))
    assert goals == ast.Goals((C("holding", "planner", "box-1"), C("inspected", "camera-site")))
    assert where(relation) == (5, 1)


def test_the_can_lift_relation_has_a_head_and_a_comparison_body():
    relation = parse_text(PROBLEM).forms[2]
    agent, weight = Var("agent"), Var("weight")
    assert isinstance(relation, ast.RelationDef)
    assert relation.name == "can-lift"
    assert relation.head == C("can-lift", agent, weight)
    assert relation.body == C(">=", C("get-value", agent, "max-lift"), weight)


def test_a_relation_with_several_queries_is_their_conjunction():
    relation = only_form("(define-relation (free ?arm) (arm ?arm) (not (holding ?arm ?x)))")
    assert relation.body == C("and", C("arm", Var("arm")), C("not", C("holding", Var("arm"), Var("x"))))


def test_agents_may_list_only_uncontrolled_agents():
    assert only_form("(agents (uncontrolled astronaut wind))") == ast.Agents((), ("astronaut", "wind"))


# ----------------------------------------------------------------- §3.1 operator parts beyond the 3T example

def test_an_operator_names_its_agent_duration_and_negative_effects():
    operator = only_form("""\
(operator put-down
  :agent ?arm
  :purpose (on ?thing floor)
  :preconditions ((holding ?arm ?thing))
  :plot (sequence (lower ?arm) (open-gripper ?arm))
  :effects ((on ?thing floor) (not (holding ?arm ?thing)))
  :duration 2.5)
""")
    arm, thing = Var("arm"), Var("thing")
    assert operator.agent == arm
    assert operator.duration == 2.5
    assert operator.effects == (ast.Effect(C("on", thing, "floor"), positive=True),
                                ast.Effect(C("holding", arm, thing), positive=False))
    assert operator.plot == ast.PlotGroup("sequence", (ast.PlotStep(C("lower", arm)),
                                                       ast.PlotStep(C("open-gripper", arm))))
    assert (operator.uncontrolled, operator.probability) == (False, None)


def test_an_uncontrolled_operator_carries_its_probability():
    operator = only_form("""\
(operator astronaut-bumps-arm
  :uncontrolled t
  :probability 0.1
  :preconditions ((near astronaut ?arm))
  :effects ((not (holding ?arm ?thing))))
""")
    assert (operator.uncontrolled, operator.probability) == (True, 0.1)
    assert operator.purpose is None
    assert operator.duration == 1
    assert operator.effects == (ast.Effect(C("holding", Var("arm"), Var("thing")), positive=False),)


def test_uncontrolled_nil_is_a_controlled_operator():
    assert only_form("(operator wait :uncontrolled nil :effects ((rested)))").uncontrolled is False


def test_a_single_bare_precondition_is_a_list_of_one():
    operator = only_form("(operator go :preconditions (at robot dock) :effects ((moved)))")
    assert operator.preconditions == (C("at", "robot", "dock"),)


# ----------------------------------------------------------------- §1 lexical rules

def test_symbols_fold_to_lower_case_so_Operator_is_operator():
    upper = only_form("(Operator Grasp-Box :Purpose (Holding ?Arm Box-1) :EFFECTS ((Holding ?Arm Box-1)))")
    lower = only_form("(operator grasp-box :purpose (holding ?arm box-1) :effects ((holding ?arm box-1)))")
    assert upper == lower
    assert upper.name == "grasp-box"
    assert upper.purpose == C("holding", Var("arm"), "box-1")


def test_strings_keep_their_case_and_their_content():
    post = only_form('(POST (Greet "Dr. Jones" "say \\"Hi\\"\\nthen wait"))')
    assert post.task == C("greet", String("Dr. Jones"), String('say "Hi"\nthen wait'))
    assert String("Dr. Jones") != "dr. jones"
    assert only_form('(World "Station-B.yaml")').world == "Station-B.yaml"


def test_line_and_block_comments_are_skipped_and_positions_still_count_them():
    source = parse_text("""\
; a mission with comments
#| a block comment
   (post (never-posted)) |#
(post (go)) ; trailing comment
(initial-memory #| inline |# (sign "a ; is not a comment here"))
""")
    post, memory = source.forms
    assert post.task == C("go")
    assert where(post) == (4, 1)
    assert memory.facts == (C("sign", String("a ; is not a comment here")),)
    assert where(memory) == (5, 1)


def test_a_string_spanning_lines_keeps_the_positions_of_later_forms():
    say, go = parse_text('(post (say "two\nlines"))\n  (post (go))\n').forms
    assert say.task.args == (String("two\nlines"),)
    assert where(go) == (3, 3)


def test_numbers_read_as_ints_and_floats():
    (memory,) = parse_text("(initial-memory (reading a -3) (reading b 2.5) (reading c 1e3) (reading d 0))").forms
    values = [fact.args[1] for fact in memory.facts]
    assert values == [-3, 2.5, 1000.0, 0]
    assert [type(v) for v in values] == [int, float, float, int]


def test_t_and_nil_are_symbols_and_a_dash_alone_is_a_symbol():
    (memory,) = parse_text("(initial-memory (flag t) (flag nil) (op -))").forms
    assert [fact.args[0] for fact in memory.facts] == ["t", "nil", "-"]


# ----------------------------------------------------------------- errors not in test_lang_errors.py


def test_a_method_with_two_bodies_is_an_error_at_the_second_body():
    problem = only_problem("(define-rap (go)\n  (method\n    (task-net (walk))\n    (primitive (enable (walk)))))\n")
    assert problem.message == "method has two bodies"
    assert at(problem) == (4, 6)
    assert "split it into two methods" in problem.hint


def test_not_with_two_queries_is_an_error_that_suggests_and():
    problem = only_problem("(define-rap (go)\n  (succeed (not (a) (b)))\n  (method (task-net (walk))))\n")
    assert problem.message == "'not' takes 1 argument, found 2"
    assert at(problem) == (2, 12)
    assert problem.hint == "wrap several queries in (and ...)"


def test_a_probability_above_one_is_an_error_at_the_value():
    problem = only_problem("(operator slip :uncontrolled t\n  :probability 1.5\n  :effects ((not (holding ?x))))\n")
    assert problem.message == "probability must be at most 1, found 1.5"
    assert at(problem) == (2, 16)


def test_a_probability_on_a_controlled_operator_is_an_error_at_the_keyword():
    problem = only_problem("(operator slip\n  :effects ((not (holding ?x)))\n  :probability 0.2)\n")
    assert problem.message == "probability is for uncontrolled operators"
    assert at(problem) == (3, 3)
    assert problem.hint == "add :uncontrolled t, or remove :probability"


def test_an_unknown_primitive_action_suggests_the_nearest_action():
    problem = only_problem("(define-rap (go ?x)\n  (method\n    (primitive\n      (enabel (move-to ?x)))))\n")
    assert problem.message == "unknown primitive action 'enabel'"
    assert problem.hint == "did you mean 'enable'?"
    assert at(problem) == (4, 8)


def test_an_unknown_clause_style_operator_part_suggests_the_nearest_part_at_its_name():
    problem = only_problem("(operator move\n  (purpose (at ?x))\n  (effect (at ?x)))\n")
    assert problem.message == "unknown operator part 'effect'"
    assert problem.hint == "did you mean 'effects'?"
    # The caret goes under the misspelt name, as for an unknown define-rap clause.
    assert at(problem) == (3, 4)


def test_until_end_naming_a_missing_step_is_an_error_at_the_annotated_step():
    problem = only_problem("(define-rap (go)\n  (method (task-net\n    (t1 (walk))\n"
                           "    (t2 (track ?o) (until-end t3)))))\n")
    assert problem.message == "no step labelled 't3' in this method"
    assert problem.hint == "the labels in this method are t1, t2"
    assert at(problem) == (4, 5)


def test_a_step_label_used_twice_in_one_method_names_the_first_use():
    problem = only_problem("(define-rap (go)\n  (method (task-net\n    (t1 (walk))\n    (t1 (run)))))\n")
    assert problem.message == "step label 't1' used twice in one method (first at line 3)"
    assert at(problem) == (4, 5)


def test_an_annotation_on_a_step_without_a_label_is_an_error():
    problem = only_problem("(define-rap (go)\n  (method (task-net\n    (walk ?x (for t1)))))\n")
    assert problem.message == "annotation on a step without a label"
    assert at(problem) == (3, 14)
    # Also when the task has no other argument: this must not read as a step
    # labelled 'walk' whose task is named 'for'.
    problem = only_problem("(define-rap (go)\n  (method (task-net\n    (walk (for t1)))))\n")
    assert problem.message == "annotation on a step without a label"
    assert at(problem) == (3, 11)


def test_a_wait_for_with_two_outcomes_is_an_error_at_the_second():
    problem = only_problem("(define-rap (go)\n  (method (task-net (wait-for (a) :succeed :fail))))\n")
    assert problem.message == "wait-for has two outcomes, :succeed and :fail"
    assert at(problem) == (2, 44)


def test_a_memory_rule_with_two_on_clauses_is_an_error_at_the_second():
    problem = only_problem("(define-memory-rule r\n  (on (a ?x))\n  (on (b ?x))\n  (assert (c ?x)))\n")
    assert problem.message == "rule has two 'on' clauses"
    assert at(problem) == (3, 4)


def test_a_memory_rule_with_no_on_clause_is_an_error_at_the_rule():
    problem = only_problem("(define-memory-rule r\n  (when (a ?x))\n  (assert (c ?x)))\n")
    assert problem.message == "memory rule has no (on FACT) clause"
    assert at(problem) == (1, 1)
    assert problem.hint == "say which assertion triggers it, e.g. (on (at ?thing ?place))"


def test_post_with_a_misspelt_option_suggests_the_nearest_option():
    problem = only_problem("(post (deliver box-1) :prority 2)\n")
    assert problem.message == "unknown option :prority"
    assert problem.hint == "did you mean ':priority'?"
    assert at(problem) == (1, 23)


def test_post_with_an_unknown_option_lists_the_options():
    problem = only_problem("(post (deliver box-1) :colour 2)\n")
    assert problem.message == "unknown option :colour"
    assert problem.hint == "expected one of: :priority, :deadline"


def test_a_negative_deadline_is_an_error():
    problem = only_problem("(post (go) :deadline -1)\n")
    assert problem.message == ":deadline must be at least 0, found -1"
    assert at(problem) == (1, 22)


def test_finish_without_an_outcome_keyword_is_an_error():
    problem = only_problem("(define-virtual-skill (beep)\n  (after 1 (finish done)))\n")
    assert problem.message == "finish takes an outcome keyword such as :succeed, found 'done'"
    assert at(problem) == (2, 20)


def test_a_when_inside_a_when_is_an_error():
    problem = only_problem("(define-virtual-skill (beep)\n  (when (a) (when (b) (after 1 (finish :fail)))))\n")
    assert problem.message == "when inside when: combine the queries with (and ...)"
    assert at(problem) == (2, 3)


def test_uncontrolled_takes_t_or_nil():
    problem = only_problem("(operator slip :uncontrolled yes)\n")
    assert problem.message == "uncontrolled takes t or nil, found 'yes'"
    assert at(problem) == (1, 30)


def test_a_misspelt_agent_group_suggests_the_nearest_group():
    problem = only_problem("(agents\n  (controled left-arm))\n")
    assert problem.message == "unknown agent group 'controled'"
    assert problem.hint == "did you mean 'controlled'?"
    assert at(problem) == (2, 4)


def test_the_reported_source_line_is_the_line_of_the_error_even_after_a_form_feed():
    # A form feed (^L, a page break in Lisp sources) or U+2028 is not a line break
    # for the reader's line numbers, so it must not be one for the line shown either.
    problem = only_problem("; page one\n\f\n(post (go) :prority 1)\n")
    assert at(problem) == (3, 12)
    assert problem.source_line == "(post (go) :prority 1)"
    problem = only_problem('(post (say "a\u2028b"))\n(post (go) :prority 1)\n')
    assert at(problem) == (2, 12)
    assert problem.source_line == "(post (go) :prority 1)"

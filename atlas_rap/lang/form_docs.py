"""A line or two on each form of the RAP and AP languages, for an editor's hover and completion.

Each entry is the form as it is written, and what it does, in a sentence or two.
The whole story of each form, with examples, is in the language reference
(``docs/``). The keys are every head the validator knows, so a form a user
can write is a form the editor can explain.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["FORMS", "FormDoc"]


@dataclass(frozen=True, slots=True)
class FormDoc:
    """How a form is written (``usage``), and what it does (``summary``)."""

    usage: str
    summary: str

    def markdown(self) -> str:
        return f"```rap\n{self.usage}\n```\n\n{self.summary}"


def _doc(usage: str, summary: str) -> FormDoc:
    return FormDoc(usage, " ".join(summary.split()))


FORMS: dict[str, FormDoc] = {
    # -- RAPs (a task and its methods)
    "define-rap": _doc("(define-rap (NAME ?ARG ...) CLAUSE ...)",
                       "A Reactive Action Package: a task, its success test and the methods that do it, chosen "
                       "by context and tried again on failure."),
    "succeed": _doc("(succeed QUERY)",
                    "The task's success test: true when the task is selected, and it succeeds at once; checked "
                    "again after each method ends."),
    "constraints": _doc("(constraints QUERY)",
                        "Validity: checked each time the task is selected; false, and the task fails without "
                        "trying a method."),
    "repeat-while": _doc("(repeat-while QUERY)", "After a success, run the task again while QUERY holds."),
    "repeat-until": _doc("(repeat-until QUERY)", "After a success, run the task again until QUERY holds."),
    "timeout": _doc("(timeout SECONDS)", "The task fails with outcome :timeout if it is not done in time."),
    "priority": _doc("(priority N)", "The task's default priority on the agenda: higher runs first."),
    "retries": _doc("(retries N)",
                    "How many method attempts in all before the task fails (default 3); a method not yet tried "
                    "comes before one repeated."),
    "retry-backoff": _doc("(retry-backoff SECONDS)",
                          "How long a failed attempt waits for a change in what the RAP reads before it tries "
                          "again anyway (default 1 s; 0: at once)."),
    "method": _doc("(method [NAME] [(context QUERY)] [(on-preempt resume|fail)] BODY)",
                   "One way to do the task, applicable when its context matches memory; the bindings flow into "
                   "BODY, a task-net or a primitive."),
    "context": _doc("(context QUERY)", "When the method applies: a memory query whose bindings the body uses."),
    "on-preempt": _doc("(on-preempt resume|fail)",
                       "When a task of higher priority takes a skill this method holds: resume the step "
                       "afterwards (the default), or fail it with :preempted."),
    "task-net": _doc("(task-net NET ...)",
                     "A method body made of subtasks: several nets run at once, ordered only by their `for` "
                     "annotations."),
    "sequence": _doc("(sequence NET ...)", "Its parts one after another."),
    "parallel": _doc("(parallel NET ...)", "Its parts at once; it ends when all have ended."),
    "for": _doc("(for LABEL)", "On a step: it must end successfully before step LABEL may start."),
    "until-end": _doc("(until-end LABEL)", "On a step: it runs beside step LABEL and is halted when LABEL ends."),
    "wait-for": _doc("(wait-for QUERY [OUTCOME] [:timeout SECONDS])",
                     "Wait until QUERY holds in memory, binding its variables; the first of a step's wait-fors "
                     "to match decides its outcome (:succeed by default)."),
    "assert": _doc("(assert FACT)", "Add FACT to memory (a net step, a rule's action, an at-time action)."),
    "retract": _doc("(retract FACT)", "Remove FACT from memory."),
    "primitive": _doc("(primitive ACTION ...)",
                      "A method body that drives skills directly: enable, wait-for, disable."),
    "enable": _doc("(enable (SKILL ARG ...) ...)", "Turn skills on with these arguments."),
    "disable": _doc("(disable :above | (SKILL ARG ...) ...)",
                    "Turn skills off; :above, every skill this primitive enabled (done anyway when the task "
                    "ends, however it ends)."),
    # -- memory
    "define-memory-rule": _doc("(define-memory-rule NAME (on FACT) [(when QUERY)] (assert F) | (retract F) ...)",
                               "Keeps memory consistent: when FACT is asserted and QUERY holds, make the changes; "
                               "rules run to a fixed point."),
    "on": _doc("(on FACT)", "The assertion that triggers a memory rule."),
    "when": _doc("(when QUERY ...)",
                 "A memory rule's extra condition; in a virtual skill, guards script lines by a query made when "
                 "the skill is enabled."),
    "initial-memory": _doc("(initial-memory FACT ...)", "Facts in memory before anything runs."),
    "and": _doc("(and QUERY ...)", "All hold, bindings shared from left to right."),
    "or": _doc("(or QUERY ...)", "One of them holds."),
    "not": _doc("(not QUERY)", "Negation as failure: QUERY has no match in memory. In effects: FACT becomes false."),
    # -- virtual skills and scripted events
    "define-virtual-skill": _doc("(define-virtual-skill (NAME ?ARG ...) LINE ...)",
                                 "A skill whose behaviour is a script, for running RAPs without a robot."),
    "after": _doc("(after SECONDS ACTION ...)", "In a virtual skill: do these actions SECONDS after it is enabled."),
    "finish": _doc("(finish OUTCOME)", "In a virtual skill: assert (done (SKILL ARG ...) OUTCOME) and stop."),
    "at-time": _doc("(at-time SECONDS (assert F) | (retract F) ...)",
                    "Change memory at that simulated time, whatever runs: the world acting on its own."),
    # -- missions
    "include": _doc('(include "path.rap")', "Load another file, relative to this one; each file once."),
    "world": _doc('(world NAME | "path.yaml" | none)',
                  "The world `atlas run` runs the mission in, unless --world says otherwise; none: virtual "
                  "skills and scripted events only."),
    "post": _doc("(post (TASK ARG ...) [:priority N] [:deadline SECONDS])", "Put a top-level task on the agenda."),
    "plan": _doc("(plan GOAL ... [:deadline SECONDS] [:max-failures N])",
                 "Ask the planner for a plan for these goals and carry it out, each step by a RAP; its steps "
                 "are repaired and re-planned as they fail."),
    # -- AP: operators and problems
    "operator": _doc("(operator NAME :purpose GOAL :agent ?A :preconditions (...) :constraints (...) "
                     ":plot (...) :effects (...) ...)",
                     "A planning operator: chosen for the goal it serves, by an agent that meets its constraints."),
    "purpose": _doc(":purpose GOAL", "The goal the operator is chosen for; without it, every positive effect."),
    "agent": _doc(":agent ?A", "The agent that does the operator: a controlled agent that meets the constraints."),
    "arguments": _doc(":arguments ((?V EXPR) ...)", "Derived values; (get-value OBJ ATTR) reads (ATTR OBJ ?value)."),
    "preconditions": _doc(":preconditions (FACT ...)", "What must hold before the operator: the planner's subgoals."),
    "effects": _doc(":effects (FACT | (not FACT) ...)", "What the operator makes true, and false."),
    "plot": _doc(":plot (sequence | parallel | simultaneous STEP ...)",
                 "The operator's own steps: goals or actions; simultaneous steps overlap, by distinct agents."),
    "simultaneous": _doc("(simultaneous STEP ...)", "Steps that overlap in time, each by a different agent."),
    "duration": _doc(":duration SECONDS", "How long the operator takes (default 1)."),
    "uncontrolled": _doc(":uncontrolled t  |  (uncontrolled AGENT ...)",
                         "An agent the planner does not command (a person, nature): its operators are never "
                         "planned, only reasoned about in counterplanning."),
    "controlled": _doc("(controlled AGENT ...)", "The agents the planner may give steps to."),
    "probability": _doc(":probability P", "How likely an uncontrolled operator happens when it can: the risk."),
    "agents": _doc("(agents (controlled AGENT ...) (uncontrolled AGENT ...))", "The problem's agents."),
    "define-relation": _doc("(define-relation (NAME ?ARG ...) QUERY)",
                            "A relation that constraints may use, true when QUERY holds; several of one name "
                            "are alternatives."),
    "initial": _doc("(initial FACT ...)", "The planning problem's initial state; the robot believes it too."),
    "goals": _doc("(goals GOAL ...)", "What the plan must achieve."),
    "deadline": _doc("(deadline GOAL SECONDS)", "GOAL must be achieved within SECONDS of the plan's start."),
}

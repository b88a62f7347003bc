"""Executing plans through RAPs: ``(plan GOAL ...)`` in a mission file.

:func:`expand_plan_requests` is the planner's side of LANGUAGE.md §2.7. For
each ``(plan GOAL ...)`` of a loaded program it plans with the program's
operators, agents and relations, from its ``initial`` and
``initial-memory`` facts, matches every step to a RAP
(:mod:`~atlas_rap.planner.dispatch`) and replaces the form by a generated
RAP and a post of it:

    (define-rap (carry-out-plan-1)
      (method
        (task-net
          (s1 (attach-at-site hull-1) (for s3))
          (s2 (point-camera camera-1 hull-1))
          (s3 (unload-at-site hull-1 tool-kit)))))
    (post (carry-out-plan-1))

The task net keeps the plan's partial order: an ordering ``a`` before ``b``
is ``(for sb)`` on step ``a``; unordered steps (and simultaneous ones) run at
once. The planner's ``initial`` facts are what the robot believes too: they
go into RAP memory beside ``initial-memory``. Planning happens when the mission is loaded, before anything runs, so
a goal with no plan or a step no RAP can execute is an error naming the goal
or the step. The sequencer does not import the planner: the mission loader
takes this function as its ``planner`` hook.
"""

from __future__ import annotations

import dataclasses

from atlas_rap.errors import Problem, SourceError
from atlas_rap.lang import ast, parse_text
from atlas_rap.logic import Compound, is_ground, term_to_str
from atlas_rap.planner.checks import check_problem
from atlas_rap.planner.dispatch import match_steps
from atlas_rap.planner.plan import Plan
from atlas_rap.planner.problem import problem_from_program
from atlas_rap.planner.solve import solve

PLAN_TASK = "carry-out-plan-{n}"


def expand_plan_requests(program, timeout: float = 60.0):
    """``program`` with each ``(plan ...)`` replaced by a generated RAP and its post."""
    requests = program.of_type(ast.PlanRequest)
    if not requests:
        return program
    base = problem_from_program(program)
    memory_facts = tuple(f for form in program.of_type(ast.InitialMemory) for f in form.facts)
    raps = program.of_type(ast.RapDef)
    replaced: dict[int, list] = {}
    problems: list[Problem] = []
    for n, request in enumerate(requests, 1):
        problem = base.asked(request.goals, base.initial + memory_facts, request.loc)
        found = check_problem(problem)
        if found:
            problems += found
            continue
        plan = solve(problem, timeout=timeout)
        line = program.source_line(request.loc)
        if plan.status != "solved":
            goals = " ".join(term_to_str(g) for g in request.goals)
            problems.append(Problem(f"no plan for {goals}: {plan.status}" + (f" ({plan.reason})" if plan.reason else ""),
                                    request.loc, line, "check the initial facts and the operators that achieve "
                                                       "these goals with `atlas plan`"))
            continue
        text, missing = plan_rap_text(plan, raps, PLAN_TASK.format(n=n))
        for step in missing:
            problems.append(Problem(f"plan step {step}: no RAP can execute it", request.loc, line,
                                    "write a RAP whose succeed clause unifies with the step's purpose, "
                                    "or a RAP of the step's name"))
        if missing:
            continue
        rap = parse_text(text, f"<plan {n}>").forms[0]
        post = ast.Post(task=Compound(PLAN_TASK.format(n=n), ()), loc=request.loc)
        replaced[id(request)] = [rap, post]
    if problems:
        raise SourceError(problems)
    believed = [f for f in base.initial if f not in set(memory_facts)]
    forms = tuple(new for form in program.forms for new in replaced.get(id(form), [form]))
    if believed:
        forms = (ast.InitialMemory(facts=tuple(believed), loc=requests[0].loc),) + forms
    return dataclasses.replace(program, forms=forms)


def plan_rap_text(plan: Plan, raps: list[ast.RapDef], name: str) -> tuple[str, list[str]]:
    """The source of a RAP ``(NAME)`` whose task net carries out ``plan``, and the
    steps (as text) that no RAP in ``raps`` can execute."""
    dispatches = match_steps(plan, raps)
    missing = [f"{d.step.id} {term_to_str(d.step.action)}" for d in dispatches
               if d.task is None or not is_ground(d.task)]
    after: dict[int, list[int]] = {s.id: [] for s in plan.steps}
    for a, b in plan.orderings:
        after[a].append(b)
    lines = [f"(define-rap ({name})", "  (method", "    (task-net"]
    for d in dispatches:
        if d.task is None:
            continue
        fors = "".join(f" (for s{b})" for b in sorted(after[d.step.id]))
        lines.append(f"      (s{d.step.id} {term_to_str(d.task)}{fors})")
    if len(lines) == 3:  # nothing to do: the goals already hold
        lines.append(f"      (assert (carried-out {name}))")
    lines[-1] += ")))"
    return "\n".join(lines) + "\n", missing

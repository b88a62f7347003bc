"""Executing plans through RAPs: the RAP that carries out a plan, for ``(plan GOAL ...)``.

:func:`plan_rap_text` is the planner's side of LANGUAGE.md §2.7. Given a
plan and the RAPs there are, it matches every step to a RAP
(:mod:`~atlas_rap.planner.dispatch`) and writes a RAP whose task net
carries the plan out:

    (define-rap (carry-out-plan-1)
      (method
        (task-net
          (s1 (attach-at-site hull-1) (for s3))
          (s2 (point-camera camera-1 hull-1))
          (s3 (unload-at-site hull-1 tool-kit)))))

The task net keeps the plan's partial order: an ordering ``a`` before ``b``
is ``(for sb)`` on step ``a``; unordered steps (and simultaneous ones) run at
once. The mission engine (``atlas_rap.layers.engine``) plans each ``(plan
...)`` of a program when it loads it, before anything of it runs, puts this
RAP and a post of it in the request's place, and the planner's ``initial``
facts into RAP memory; a goal with no plan or a step no RAP can execute is
an error naming the goal or the step.
"""

from __future__ import annotations

from atlas_rap.lang import ast
from atlas_rap.logic import is_ground, term_to_str
from atlas_rap.planner.dispatch import match_steps
from atlas_rap.planner.plan import Plan

PLAN_TASK = "carry-out-plan-{n}"
"""The name of the RAP that carries out the n-th plan of a run."""


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

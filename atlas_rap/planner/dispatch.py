"""Dispatch: which RAP executes each plan step (docs/language/ap.md, What the planner returns).

A step is executed by the RAP whose ``succeed`` clause unifies with the
step's purpose (a RAP parameter that match leaves unbound takes the value
of the operator's variable of the same name); failing that, by a RAP of
the step's name and number of arguments. The purpose of a step that is a whole operator is the
operator's ``:purpose`` with its bindings; a plot step's purpose is the
step itself. Use :func:`load_raps` to gather the RAPs of a folder and
:func:`match_steps` before a plan is executed: a step no RAP can execute is
an error that names the step, reported before anything runs.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from atlas_rap.lang import ast
from atlas_rap.logic import (
    Compound,
    Term,
    is_ground,
    substitute,
    term_to_str,
    unify,
    variables,
)
from atlas_rap.planner.plan import Plan, PlanStep


@dataclass(frozen=True)
class Dispatch:
    """The RAP chosen for one step (``rap`` None when none can execute it), and the
    task to post: the RAP's head with the step's values."""

    step: PlanStep
    rap: ast.RapDef | None
    task: Compound | None
    how: str = ""


def load_raps(folder: str | Path) -> list[ast.RapDef]:
    """The RAPs of every ``.rap`` file under ``folder`` (recursively, in name order)."""
    from atlas_rap.lang import load

    raps: dict[str, ast.RapDef] = {}
    for path in sorted(Path(folder).rglob("*.rap")):
        for rap in load(path).of_type(ast.RapDef):
            raps.setdefault(rap.name, rap)
    return list(raps.values())


def match_steps(plan: Plan, raps: list[ast.RapDef]) -> list[Dispatch]:
    """The RAP for each step of ``plan``, in step order."""
    return [_match(step, step.purpose if step.purpose is not None else step.action, raps) for step in plan.steps]


def _match(step: PlanStep, purpose: Term, raps: list[ast.RapDef]) -> Dispatch:
    for rap in raps:
        if rap.succeed is None:
            continue
        s = unify(rap.succeed, purpose)
        if s is not None:
            task = _fill(substitute(rap.head, s), step)
            if is_ground(task):
                return Dispatch(step, rap, task, f"succeed {term_to_str(rap.succeed)} unifies with the purpose")
    action = step.action
    for rap in raps:
        if rap.name == action.functor and len(rap.params) == len(action.args):
            s = unify(rap.head, action)
            if s is not None:
                return Dispatch(step, rap, substitute(rap.head, s), "same name")
    return Dispatch(step, None, None, "no RAP's succeed unifies with the purpose and no RAP has the step's name")


def _fill(task: Compound, step: PlanStep) -> Compound:
    """RAP parameters the succeed match left unbound take the value of the step's
    operator variable of the same name (``?cam`` in both)."""
    return substitute(task, {v: step.binding[v] for v in variables(task) if v in step.binding})  # type: ignore[return-value]

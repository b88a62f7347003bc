"""Load-time check of the places a mission names against its world's places.

A skill parameter named ``place`` (``navigate-to``'s, :mod:`atlas_rap.skills.catalog`) takes the name
of one of the world's places. A RAP parameter is a place too when the RAP passes it on, as it stands,
as a place to a skill it enables or calls or to another RAP (``(go-to ?to)`` in ``deliver``'s task net,
``(navigate-to ?place)`` in ``go-to``'s primitive), followed through the program to a fixed point.

Every literal symbol given for a place, in a ``post`` or in a task-net step, is checked against the
places of the world the run is in. A name the world lacks would fail every time the step is reached
("there is no place named office in world small-office-map", retried by ``go-to`` and its callers),
so it is an error before the run, with the caret under the name and the world's places as the hint
(``atlas run``, and ``atlas check`` for a file that names its world with ``(world ...)``). Variables,
and places reached only through memory (``(at robot ?here)``), are not checked.
"""

from __future__ import annotations

from typing import Collection, Iterator

from atlas_rap.errors import Problem, SourceLocation, did_you_mean
from atlas_rap.lang import ast
from atlas_rap.logic import Compound, Var
from atlas_rap.sequencer.checks import ParamTypes, item_location, net_nodes

__all__ = ["PLACE_PARAMETER", "place_positions", "place_problems"]

PLACE_PARAMETER = "place"
"""The name of a skill parameter that takes one of the world's places."""

Key = tuple[str, int]  # a task or skill by name and number of arguments


def place_positions(program, param_types: ParamTypes) -> dict[Key, set[int]]:
    """Which arguments of each skill and RAP of ``program`` are places (indices from 0)."""
    positions: dict[Key, set[int]] = {
        (name, len(params)): {i for i, (param, _) in enumerate(params) if param == PLACE_PARAMETER}
        for name, params in param_types.items()}
    raps = program.of_type(ast.RapDef)
    changed = True
    while changed:
        changed = False
        for rap in raps:
            mine = positions.setdefault((rap.name, len(rap.params)), set())
            for call, _ in _calls(rap):
                for i in positions.get((call.functor, len(call.args)), ()):
                    arg = call.args[i]
                    if isinstance(arg, Var) and arg in rap.params and rap.params.index(arg) not in mine:
                        mine.add(rap.params.index(arg))
                        changed = True
    return positions


def place_problems(program, world: str, places: Collection[str], param_types: ParamTypes) -> list[Problem]:
    """An error for each literal place in ``program``'s posts and task-net steps that ``world``, whose
    places are ``places``, lacks (module docstring)."""
    positions = place_positions(program, param_types)
    problems: list[Problem] = []

    def check(call: Compound, locate) -> None:
        for i in sorted(positions.get((call.functor, len(call.args)), ())):
            name = call.args[i]
            if isinstance(name, str) and name not in places:
                loc = locate(i)
                known = ", ".join(sorted(places)) or "none"
                hint = did_you_mean(name, sorted(places)) or f"the places of {world}: {known}"
                problems.append(Problem(f"there is no place named {name} in world {world}", loc,
                                        program.source_line(loc), hint))

    for post in program.of_type(ast.Post):
        check(post.task, lambda i, post=post: item_location(program, post.loc, (1, i + 1)))
    for rap in program.of_type(ast.RapDef):
        for call, loc in _calls(rap):
            check(call, lambda i, loc=loc: loc)
    return problems


def _calls(rap: ast.RapDef) -> Iterator[tuple[Compound, SourceLocation]]:
    """The task calls of ``rap``'s task nets and the skills its primitives enable, with where each is."""
    for method in rap.methods:
        if isinstance(method.body, ast.TaskNet):
            for node in net_nodes(method.body):
                if isinstance(node, ast.Step) and node.plan is None:
                    yield node.task, node.loc
        else:
            for action in method.body.actions:
                if isinstance(action, ast.Enable):
                    for skill in action.skills:
                        yield skill, action.loc

"""The AST as a rich tree, for ``atlas check --tree`` (and later the REPL).

Every node is shown with its fields, generically, so new nodes (a ``(plan ...)``
in a task net, a ``deadline``) need nothing here; fields that only say where
something is written (``loc``, ``goal_loc``, ``goal_locs``) are left out."""

from __future__ import annotations

import dataclasses

from rich.markup import escape
from rich.tree import Tree

from atlas_rap.logic import Compound, MemoryRule, String, Var, term_to_str

_TERMS = (str, int, float, String, Var, Compound)


def _label(value: object) -> str:
    if isinstance(value, bool):
        return "t" if value else "nil"
    if isinstance(value, _TERMS):
        return escape(term_to_str(value))
    return escape(repr(value))


def _add(parent: Tree, name: str, value: object) -> None:
    if value is None or value == () or (value is False and name != "positive"):
        return
    if isinstance(value, tuple) and value and all(isinstance(v, _TERMS) for v in value):
        parent.add(f"[cyan]{name}[/]: " + " ".join(_label(v) for v in value))
    elif isinstance(value, tuple):
        branch = parent.add(f"[cyan]{name}[/]")
        for item in value:
            _node(branch, item)
    elif dataclasses.is_dataclass(value) and not isinstance(value, _TERMS):
        _node(parent.add(f"[cyan]{name}[/]"), value)
    else:
        parent.add(f"[cyan]{name}[/]: {_label(value)}")


def _node(parent: Tree, node: object) -> None:
    if isinstance(node, tuple) and len(node) == 2 and isinstance(node[0], str):  # a rule effect
        parent.add(f"{node[0]} {term_to_str(node[1])}")
        return
    if not dataclasses.is_dataclass(node) or isinstance(node, _TERMS):
        parent.add(_label(node))
        return
    loc = getattr(node, "loc", None)
    where = f" [dim]{loc.line}:{loc.column}[/]" if loc is not None and not isinstance(node, MemoryRule) else ""
    branch = parent.add(f"[bold]{type(node).__name__}[/]{where}")
    for field in dataclasses.fields(node):
        if field.name != "loc" and not field.name.endswith(("_loc", "_locs")):  # positions: shown as line:col
            _add(branch, field.name, getattr(node, field.name))


def ast_tree(source) -> Tree:
    """A rich ``Tree`` of one file's AST, each node with its line:column."""
    root = Tree(f"[bold]{source.path}[/]")
    for form in source.forms:
        _node(root, form)
    return root

"""AST nodes back to source text, pretty-printed.

Use :func:`format_file` or :func:`format_node` to show a definition as a
person would write it (``atlas check --format``), or to write generated RAPs
and operators to disk. Reading the printed text gives an equal AST (the
round-trip property the tests check). Operators print in the keyword
style; RAP heads print in the modern ``(define-rap (name ?arg ...) ...)`` form.
"""

from __future__ import annotations

from functools import singledispatch
from typing import Union

from atlas_rap.lang import ast
from atlas_rap.logic import Compound, String, Term, term_to_str

# A layout tree: a leaf is source text, a list is a parenthesised form.
Layout = Union[str, list]

WIDTH = 88


def _t(term: Term) -> str:
    return term_to_str(term)


def _num(value: float) -> str:
    return repr(value)


def _compound(term: Compound) -> Layout:
    """A compound term as a layout, so long facts can break across lines."""
    head = [] if term.functor == "" else [term.functor]
    return head + [_compound(a) if isinstance(a, Compound) else _t(a) for a in term.args]


@singledispatch
def layout(node: object) -> Layout:
    """The layout tree of a node (extend with ``@layout.register``)."""
    if isinstance(node, Compound):
        return _compound(node)
    return _t(node)  # a plain term


@layout.register
def _(node: ast.WaitFor) -> Layout:
    out = ["wait-for", layout(node.query)]
    if node.outcome != ":succeed":
        out.append(node.outcome)
    if node.timeout is not None:
        out += [":timeout", _num(node.timeout)]
    return out


@layout.register
def _(node: ast.MemoryOp) -> Layout:
    return [node.kind, layout(node.fact)]


@layout.register
def _(node: ast.Step) -> Layout:
    if node.label is None:
        return layout(node.task)
    out: list = [node.label, layout(node.task)]
    if node.before:
        out.append(["for", *node.before])
    if node.until_end:
        out.append(["until-end", node.until_end])
    out += [layout(w) for w in node.waits]
    return out


@layout.register
def _(node: ast.Sequence) -> Layout:
    return ["sequence", *(layout(p) for p in node.parts)]


@layout.register
def _(node: ast.Parallel) -> Layout:
    return ["parallel", *(layout(p) for p in node.parts)]


@layout.register
def _(node: ast.TaskNet) -> Layout:
    return ["task-net", *(layout(n) for n in node.nets)]


@layout.register
def _(node: ast.Enable) -> Layout:
    return ["enable", *(layout(s) for s in node.skills)]


@layout.register
def _(node: ast.Disable) -> Layout:
    return ["disable", ":above"] if node.above else ["disable", *(layout(s) for s in node.skills)]


@layout.register
def _(node: ast.Primitive) -> Layout:
    return ["primitive", *(layout(a) for a in node.actions)]


@layout.register
def _(node: ast.Method) -> Layout:
    out: list = ["method"]
    if node.name is not None:
        out.append(node.name)
    if node.context is not None:
        out.append(["context", layout(node.context)])
    if node.on_preempt != "resume":
        out.append(["on-preempt", node.on_preempt])
    out.append(layout(node.body))
    return out


@layout.register
def _(node: ast.RapDef) -> Layout:
    out: list = ["define-rap", layout(node.head)]
    for clause in ("succeed", "constraints", "repeat_while", "repeat_until"):
        value = getattr(node, clause)
        if value is not None:
            out.append([clause.replace("_", "-"), layout(value)])
    for clause in ("timeout", "priority", "retries", "retry_backoff"):
        value = getattr(node, clause)
        if value is not None:
            out.append([clause.replace("_", "-"), _num(value)])
    out += [layout(m) for m in node.methods]
    return out


@layout.register
def _(node: ast.MemoryRuleDef) -> Layout:
    rule = node.rule
    out: list = ["define-memory-rule", rule.name, ["on", layout(rule.trigger)]]
    if rule.condition is not None:
        out.append(["when", layout(rule.condition)])
    out += [[kind, layout(fact)] for kind, fact in rule.effects]
    return out


@layout.register
def _(node: ast.Finish) -> Layout:
    return ["finish", node.outcome]


@layout.register
def _(node: ast.After) -> Layout:
    return ["after", _num(node.delay), *(layout(a) for a in node.actions)]


@layout.register
def _(node: ast.When) -> Layout:
    return ["when", layout(node.condition), *(layout(line) for line in node.lines)]


@layout.register
def _(node: ast.VirtualSkillDef) -> Layout:
    return ["define-virtual-skill", layout(node.head), *(layout(line) for line in node.lines)]


@layout.register
def _(node: ast.AtTime) -> Layout:
    return ["at-time", _num(node.time), *(layout(a) for a in node.actions)]


@layout.register
def _(node: ast.Include) -> Layout:
    return ["include", _t(String(node.path))]


@layout.register
def _(node: ast.WorldDecl) -> Layout:
    return ["world", _t(String(node.world))]


@layout.register
def _(node: ast.InitialMemory) -> Layout:
    return ["initial-memory", *(layout(f) for f in node.facts)]


@layout.register
def _(node: ast.Post) -> Layout:
    out: list = ["post", layout(node.task)]
    if node.priority is not None:
        out += [":priority", _num(node.priority)]
    if node.deadline is not None:
        out += [":deadline", _num(node.deadline)]
    return out


@layout.register
def _(node: ast.PlanRequest) -> Layout:
    out: list = ["plan", *(layout(g) for g in node.goals)]
    if node.deadline is not None:
        out += [":deadline", _num(node.deadline)]
    if node.max_failures is not None:
        out += [":max-failures", _num(node.max_failures)]
    return out


@layout.register
def _(node: ast.PlotStep) -> Layout:
    return layout(node.term)


@layout.register
def _(node: ast.PlotGroup) -> Layout:
    return [node.kind, *(layout(p) for p in node.parts)]


@layout.register
def _(node: ast.Effect) -> Layout:
    return layout(node.fact) if node.positive else ["not", layout(node.fact)]


@layout.register
def _(node: ast.Argument) -> Layout:
    return [_t(node.var), layout(node.expr)]


@layout.register
def _(node: ast.Operator) -> Layout:
    out: list = ["operator", node.name]
    if node.purpose is not None:
        out += [":purpose", layout(node.purpose)]
    if node.agent is not None:
        out += [":agent", _t(node.agent)]
    for key in ("arguments", "preconditions", "constraints"):
        values = getattr(node, key)
        if values:
            out += [f":{key}", [layout(v) for v in values]]
    if node.plot is not None:
        out += [":plot", layout(node.plot)]
    if node.effects:
        out += [":effects", [layout(e) for e in node.effects]]
    if node.duration != 1:
        out += [":duration", _num(node.duration)]
    if node.uncontrolled:
        out += [":uncontrolled", "t"]
    if node.probability is not None:
        out += [":probability", _num(node.probability)]
    return out


@layout.register
def _(node: ast.Agents) -> Layout:
    out: list = ["agents"]
    if node.controlled:
        out.append(["controlled", *node.controlled])
    if node.uncontrolled:
        out.append(["uncontrolled", *node.uncontrolled])
    return out


@layout.register
def _(node: ast.RelationDef) -> Layout:
    return ["define-relation", layout(node.head), layout(node.body)]


@layout.register
def _(node: ast.Initial) -> Layout:
    return ["initial", *(layout(f) for f in node.facts)]


@layout.register
def _(node: ast.Goals) -> Layout:
    return ["goals", *(layout(g) for g in node.goals)]


@layout.register
def _(node: ast.Deadline) -> Layout:
    return ["deadline", layout(node.goal), _num(node.seconds)]


def _flat(tree: Layout) -> str:
    if isinstance(tree, str):
        return tree
    return "(" + " ".join(_flat(x) for x in tree) + ")"


def _render(tree: Layout, indent: int, out: list[str]) -> None:
    flat = _flat(tree)
    if isinstance(tree, str) or indent + len(flat) <= WIDTH or not tree:
        out.append(flat)
        return
    # Keep the head (and a short second item such as a name or label) on the first line.
    keep = 1
    if len(tree) > 2 and isinstance(tree[0], str) and isinstance(tree[1], str) and not tree[1].startswith(":"):
        keep = 2
    first = "(" + " ".join(_flat(x) for x in tree[:keep])
    out.append(first)
    pad = indent + 2
    for item in tree[keep:]:
        out.append("\n" + " " * pad)
        _render(item, pad, out)
    out.append(")")


def format_node(node: object) -> str:
    """One node as pretty-printed source text."""
    out: list[str] = []
    _render(layout(node), 0, out)
    return "".join(out)


def format_file(source: ast.SourceFile) -> str:
    """A whole file's forms as source text, one blank line between forms."""
    return "\n\n".join(format_node(form) for form in source.forms) + "\n"

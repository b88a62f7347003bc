"""The partial order of a plan as Graphviz DOT text (``atlas plan --dot``), coloured as the
pictures of :mod:`~atlas_rap.views.plan_render` are, for people who lay plans out with Graphviz."""

from __future__ import annotations

from atlas_rap.logic import term_to_str
from atlas_rap.planner.plan import Plan
from atlas_rap.views.plan_render import COUNTER_COLOUR, agent_colours, counter_labels


def plan_dot(plan: Plan) -> str:
    """The partial order as a Graphviz digraph: steps filled with their agent's colour
    (the colours of ``--render`` and ``--render-order``; a cluster ``agents`` names them),
    orderings dashed, links labelled with their facts, simultaneous steps side by side,
    counterplan steps outlined orange and labelled with the threat they counter."""
    colours = agent_colours(plan)
    counters = counter_labels(plan)
    out = ["digraph plan {", "  rankdir=LR;", '  node [shape=box, fontname="Helvetica"];',
           '  init [shape=circle, label="init"];', '  goal [shape=doublecircle, label="goal"];']
    for s in plan.steps:
        label = _dot_escape(term_to_str(s.action)) + (f"\\n[{_dot_escape(s.agent)}]" if s.agent else "")
        fill, edge = colours[s.agent]
        pen = ""
        if s.id in counters:
            what = _dot_escape(counters[s.id]).replace("; ", "\\n").replace(" \u2192 ", "\\n\u2192 ")
            label, edge, pen = f"{label}\\n{what}", COUNTER_COLOUR, ", penwidth=2.5"
        out.append(f'  s{s.id} [label="{label}", style="filled,rounded", fillcolor="{fill}", color="{edge}"{pen}];')
    linked = {(a, b) for a, b, _ in plan.links}
    for a, b in plan.orderings:
        if (a, b) not in linked:
            out.append(f"  s{a} -> s{b} [style=dashed];")
    for a, b, fact in plan.links:
        src = "init" if a == "init" else f"s{a}"
        dst = "goal" if b == "goal" else f"s{b}"
        out.append(f'  {src} -> {dst} [label="{_dot_escape(fact)}", fontsize=9];')
    for group in plan.simultaneous:
        out.append("  { rank=same; " + " ".join(f"s{i};" for i in group) + " }")
    agents = [a for a in colours if any(s.agent == a for s in plan.steps)]
    if agents != [None] and agents:
        out.append('  subgraph cluster_agents { label="agents"; style=dashed; color="#adb5bd"; '
                   'fontname="Helvetica";')
        for i, agent in enumerate(agents):
            fill, edge = colours[agent]
            name = _dot_escape(agent) if agent is not None else "(no agent)"
            out.append(f'    agent{i} [label="{name}", style="filled,rounded", fillcolor="{fill}", '
                       f'color="{edge}"];')
        out.extend(f"    agent{i} -> agent{i + 1} [style=invis];" for i in range(len(agents) - 1))
        out.append("  }")
    out.append("}")
    return "\n".join(out)


def _dot_escape(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', '\\"')

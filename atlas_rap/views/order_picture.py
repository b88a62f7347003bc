"""The partial order of a plan as a graph picture (``atlas plan --render-order OUT.png``).

Drawn with matplotlib alone (no Graphviz binary; ``--dot`` prints the same
graph for Graphviz), left to right in columns:

- **Columns** are the longest path from ``init`` (:func:`order_columns`):
  ``init`` is column 0, a step is one column right of the latest thing it
  needs (its causal links and orderings), the steps of one ``simultaneous``
  group share a column, and ``goal`` is the last column.
- **Steps** are boxes with their action (``s3 (go-to office)``), filled
  with their agent's colour (the colours of the Gantt chart and ``--dot``,
  :func:`~atlas_rap.views.plan_render.agent_colours`; a legend names them).
  Counterplan steps are outlined orange and name the threat they counter
  and the fact they keep. Simultaneous steps sit together, tied by a purple
  dotted line.
- **Causal links** (:func:`drawn_edges`) are solid arrows labelled with the
  facts they carry; a link from ``init`` is labelled just before the step
  that needs it, any other just after the step that makes it (one label
  for the same facts going from one step to several). Links an uncontrolled
  agent may still break (the threats left) are red, and a note under the
  picture names each threat.
- **Pure orderings** (an ordering that is not a causal link, kept only
  when no chain of other edges implies it) are dashed.

How it is laid out (a Sugiyama-style layered drawing): the labels have
columns of their own between the columns of boxes, and an edge has an item
in every column it crosses (its label, or a thin slot), so edges never run
under a box or another edge's label and cross only between columns. The
order of the items in a column is chosen to reduce crossings (barycentre
sweeps, the best order kept), their heights to keep edges level with what
they join (weighted least squares under the spacing, by pool adjacent
violators; a long edge's slots then at one height where there is room).
Everything is deterministic: the same plan gives the same PNG bytes
(:func:`~atlas_rap.views.plan_render.save_figure`).

Over 25 KB on purpose: one picture (a plan's partial order), whose named steps share the
layout they compute.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, field
from pathlib import Path

from atlas_rap.views.page import DPI
from atlas_rap.planner.plan import Plan
from atlas_rap.views.plan_render import (
    ARROW_COLOUR,
    COUNTER_COLOUR,
    SIMULTANEOUS_COLOUR,
    THREAT_COLOUR,
    agent_colours,
    counter_labels,
    lanes_by_first_use,
    reduced_orderings,
    save_figure,
    step_label,
)

INIT, GOAL = "init", "goal"
Node = int | str

NODE_FONT = 7.0
COUNTER_FONT = 6.5
LABEL_FONT = 6.0
NODE_WRAP = 24  # characters per line of a box
COUNTER_WRAP = 32  # ... of the threat a counterplan step answers (a smaller font)
LABEL_WRAP = 26  # ... of an edge label
MAX_LABEL_FACTS = 4  # facts listed on one edge; more are "+N more"
BOX_PAD_X, BOX_PAD_Y = 0.07, 0.05  # inches inside a box round its text
NODE_GAP = 0.22  # inches between boxes in a column
SLOT = 0.06  # height of an edge's slot in a column it crosses
SLOT_GAP = 0.06  # inches between a slot or a label and anything next to it
COLUMN_MARGIN = 0.24  # inches between a column of boxes and a column of labels, where edges bend
LINK_COLOUR = "#5c6670"
COUNTER_TEXT = "#c2410c"  # the orange of counterplan steps, darker: legible on every agent's colour
ORDER_COLOUR = ARROW_COLOUR
SWEEPS = 8
WEIGHT = {"n": 4.0, "l": 2.0, "d": 1.0}
"""How hard a box, a label and an edge's slot hold their place when a column is spaced out:
slots give way, so boxes stay level with what they are linked to."""


# ----------------------------------------------------------------------------- what is drawn (pure)

def order_columns(plan: Plan) -> dict[Node, int]:
    """The column of each node (``"init"``, step ids, ``"goal"``): the length of the
    longest path to it from ``init`` over causal links and orderings, with the steps
    of a simultaneous group in one column and ``goal`` one past the last step."""
    preds: dict[int, set[int]] = {s.id: set() for s in plan.steps}
    for a, b in plan.orderings:
        preds[b].add(a)
    for a, b, _ in plan.links:
        if a != INIT and b != GOAL:
            preds[b].add(a)
    order = _topological(preds)
    column: dict[Node, int] = {INIT: 0}
    groups = {i: group for group in plan.simultaneous for i in group}
    for _ in range(len(order) + 1):  # a group pulled right moves what follows it: again until nothing moves
        changed = False
        for step in order:
            new = max([1] + [column[p] + 1 for p in preds[step]])
            new = max([new] + [column.get(m, 1) for m in groups.get(step, ())])
            if column.get(step) != new:
                column[step], changed = new, True
        if not changed:
            break
    column[GOAL] = max((column[s.id] for s in plan.steps), default=0) + 1
    return column


@dataclass(frozen=True)
class Edge:
    """An edge of the picture: a causal link (``kind="link"``, its facts) or a pure ordering."""

    src: Node
    dst: Node
    kind: str
    facts: tuple[str, ...] = ()
    threatened: bool = False


def drawn_edges(plan: Plan) -> list[Edge]:
    """The edges the picture draws: every causal link (the facts of one pair together,
    in the plan's order), then each ordering of the transitive reduction of links and
    orderings that is not a link (a pure ordering)."""
    facts: dict[tuple[Node, Node], list[str]] = {}
    for a, b, fact in plan.links:
        facts.setdefault((a, b), []).append(fact)
    threatened = {(t.producer, t.consumer, t.fact) for t in plan.threats}
    edges = [Edge(a, b, "link", tuple(fs), any((a, b, f) in threatened for f in fs)) for (a, b), fs in facts.items()]
    between_steps = set(plan.orderings) | {(a, b) for a, b in facts if a != INIT and b != GOAL}
    edges += [Edge(a, b, "order") for a, b in reduced_orderings(between_steps) if (a, b) not in facts]
    return edges


# ----------------------------------------------------------------------------- layout

@dataclass
class _Item:
    """What takes room in a column: a box (``("n", node)``), an edge label (``("l", i)``)
    or the slot of an edge crossing the column (``("d", edge, column)``)."""

    key: tuple
    height: float
    width: float = 0.0
    y: float = 0.0
    lines: list[str] = field(default_factory=list)
    counter_lines: list[str] = field(default_factory=list)
    threatened: bool = False


def render_order(plan: Plan, path: str | Path) -> Path:
    """Write the partial order of ``plan`` as a PNG at ``path``; return its path.

    The layout has two kinds of column: even ones hold the boxes (column ``c`` of
    :func:`order_columns` is ``2c``), odd ones between them hold the edge labels. An
    edge has an item in every column it crosses (its label, or a thin slot), so the
    ordering and spacing of items keep edges off boxes and labels, and edges cross
    only between columns."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 6), dpi=DPI)
    FigureCanvasAgg(fig)
    measure = _Measure(fig.canvas.get_renderer())
    column = order_columns(plan)
    edges = drawn_edges(plan)
    colours = agent_colours(plan)
    by_id = {s.id: s for s in plan.steps}
    counters = {step: label.split("; ") for step, label in counter_labels(plan).items()}

    items = _Items(2 * column[GOAL] + 1)
    _add_boxes(items, plan, column, by_id, counters, measure)
    label_at = _add_labels(items, edges, column, measure)
    chains = _add_edge_chains(items, edges, column, label_at)
    preds, succs = _neighbours(items.items, chains)
    layers = [sorted(layer, key=_start_key(plan, by_id)) for layer in items.layers]
    layers = _reduce_crossings(layers, preds, succs, _simultaneous_groups(plan))
    _place_heights(layers, items.items, preds, succs)
    _straighten(layers, items.items, chains)

    columns = _Columns(layers, items.items)
    ax = _chart_axes(fig, items.items, columns.total_w)
    _draw_edges(ax, edges, chains, items.items, columns.where, columns.x_left, columns.widths, columns.centre)
    _draw_labels(ax, items.items, columns.where, columns.centre)
    _draw_nodes(ax, items.items, columns.where, columns.centre, colours, by_id, counters)
    _draw_simultaneous(ax, plan, items.items, columns.where, columns.centre)
    _legend_and_notes(ax, fig, plan, colours, edges)
    return save_figure(fig, path)


class _Measure:
    """The size of text as the figure's renderer draws it."""

    def __init__(self, renderer) -> None:
        self.renderer = renderer

    def __call__(self, lines: list[str], size: float) -> tuple[float, float]:
        """(width, height) in inches of ``lines`` at ``size`` points."""
        from matplotlib.font_manager import FontProperties

        prop = FontProperties(size=size)
        width = max((self.renderer.get_text_width_height_descent(line, prop, ismath=False)[0] for line in lines),
                    default=0)
        return width / DPI, len(lines) * size * 1.25 / 72


def _wrap(text: str, width: int) -> list[str]:
    """``text`` in lines of at most ``width`` characters, words kept whole."""
    return textwrap.wrap(text, width, break_long_words=False, break_on_hyphens=False) or [text]


class _Items:
    """Every item of the picture by key, and the keys in each of the ``n_columns`` columns."""

    def __init__(self, n_columns: int) -> None:
        self.items: dict[tuple, _Item] = {}
        self.layers: list[list[tuple]] = [[] for _ in range(n_columns)]

    def add(self, item: _Item, column: int) -> None:
        """Put ``item`` in ``column``."""
        self.items[item.key] = item
        self.layers[column].append(item.key)


def _add_boxes(items: _Items, plan: Plan, column: dict[Node, int], by_id: dict, counters: dict,
               measure: _Measure) -> None:
    """A box for ``init``, each step (its action, and the threat a counterplan step counters) and ``goal``."""
    for node in [INIT, *(s.id for s in plan.steps), GOAL]:
        if node in (INIT, GOAL):
            lines, extra = [str(node)], []
        else:
            lines = _wrap(step_label(by_id[node]), NODE_WRAP)
            extra = []
            for c in counters.get(node, ()):
                threat, _, kept = c.partition(" \u2192 ")
                extra += _wrap(threat, COUNTER_WRAP) + _wrap("\u2192 " + kept, COUNTER_WRAP)
        w1, h1 = measure(lines, NODE_FONT)
        w2, h2 = measure(extra, COUNTER_FONT)
        key = ("n", node)
        items.add(_Item(key, h1 + h2 + 2 * BOX_PAD_Y, max(w1, w2) + 2 * BOX_PAD_X, lines=lines, counter_lines=extra),
                  2 * column[node])


def _add_labels(items: _Items, edges: list[Edge], column: dict[Node, int],
                measure: _Measure) -> dict[int, tuple[int, tuple]]:
    """The labels of the causal links; for each link, its label's column and key.

    A link from init is labelled just before the step that needs it (init has many);
    any other just after the step that makes it, one label for one fact going to several steps."""
    label_at: dict[int, tuple[int, tuple]] = {}
    shared: dict[tuple, tuple] = {}
    for e, edge in enumerate(edges):
        if edge.kind != "link":
            continue
        shown = list(edge.facts[:MAX_LABEL_FACTS])
        if len(edge.facts) > MAX_LABEL_FACTS:
            shown.append(f"+{len(edge.facts) - MAX_LABEL_FACTS} more")
        lines = [w for f in shown for w in _wrap(f, LABEL_WRAP)]
        at = 2 * column[edge.dst] - 1 if edge.src == INIT else 2 * column[edge.src] + 1
        share = (at, edge.src, edge.dst if edge.src == INIT else None, tuple(lines), edge.threatened)
        if share not in shared:
            key = ("l", len(shared))
            width, height = measure(lines, LABEL_FONT)
            items.add(_Item(key, height + 0.05, width + 0.08, lines=lines, threatened=edge.threatened), at)
            shared[share] = key
        label_at[e] = (at, shared[share])
    return label_at


def _add_edge_chains(items: _Items, edges: list[Edge], column: dict[Node, int],
                     label_at: dict[int, tuple[int, tuple]]) -> list[list[tuple]]:
    """Each edge's chain of items from its source box to its target box: its label in the label's
    column, a slot in every other column it crosses."""
    chains: list[list[tuple]] = []
    for e, edge in enumerate(edges):
        chain = [("n", edge.src)]
        for c in range(2 * column[edge.src] + 1, 2 * column[edge.dst]):
            if e in label_at and label_at[e][0] == c:
                chain.append(label_at[e][1])
                continue
            key = ("d", e, c)
            items.add(_Item(key, SLOT), c)
            chain.append(key)
        chain.append(("n", edge.dst))
        chains.append(chain)
    return chains


def _neighbours(items: dict[tuple, _Item], chains: list[list[tuple]]) -> tuple[dict, dict]:
    """Each item's neighbours along the chains: the items left of it and those right of it."""
    preds: dict[tuple, list[tuple]] = {key: [] for key in items}
    succs: dict[tuple, list[tuple]] = {key: [] for key in items}
    for chain in chains:
        for a, b in zip(chain, chain[1:]):
            if b not in succs[a]:
                succs[a].append(b)
                preds[b].append(a)
    return preds, succs


def _simultaneous_groups(plan: Plan) -> dict[tuple, tuple]:
    """The box of each step in a simultaneous group: the boxes of its group."""
    return {("n", i): tuple(("n", m) for m in group) for group in plan.simultaneous for i in group}


def _start_key(plan: Plan, by_id: dict):
    """The order of items in a column before the crossings are reduced: init, then by the agent's
    lane (in order of first use), then by key."""
    lane_index = {agent: i for i, agent in enumerate(lanes_by_first_use(plan))}

    def start_key(key: tuple) -> tuple:
        node = key[1] if key[0] == "n" else None
        agent = by_id[node].agent if isinstance(node, int) else None
        return (0 if node == INIT else lane_index.get(agent, len(lane_index)) + 1, str(key[1]).zfill(6), str(key))

    return start_key


class _Columns:
    """Where the columns are, left to right: each one's left edge, width and centre, the width of
    them all, and each item's column."""

    def __init__(self, layers: list[list[tuple]], items: dict[tuple, _Item]) -> None:
        n_columns = len(layers)
        self.widths = [max([items[k].width for k in layer] + [0.0 if c % 2 else 0.3])
                       for c, layer in enumerate(layers)]
        self.x_left: list[float] = []
        x = 0.0
        for c in range(n_columns):
            self.x_left.append(x)
            x += self.widths[c] + (COLUMN_MARGIN if c < n_columns - 1 else 0.0)
        self.total_w = x
        self.centre = [self.x_left[c] + self.widths[c] / 2 for c in range(n_columns)]
        self.where = {key: c for c, layer in enumerate(layers) for key in layer}


def _chart_axes(fig, items: dict[tuple, _Item], total_w: float):
    """Size the figure to the items (``total_w`` inches wide, 2 inches around) and add the axes."""
    tops = [item.y - item.height / 2 for item in items.values()]
    bottoms = [item.y + item.height / 2 for item in items.values()]
    y_top, y_bottom = min(tops) - 0.12, max(bottoms) + 0.12
    height = y_bottom - y_top
    fig.set_size_inches(total_w + 4, height + 4)
    ax = fig.add_axes((2 / (total_w + 4), 2 / (height + 4), total_w / (total_w + 4), height / (height + 4)))
    ax.set_xlim(0, total_w)
    ax.set_ylim(y_bottom, y_top)
    ax.set_axis_off()
    return ax


def _draw_labels(ax, items: dict[tuple, _Item], where: dict, centre: list[float]) -> None:
    """The links' labels: their facts on white, red when an uncontrolled agent may break the link."""
    for key, item in items.items():
        if key[0] == "l":
            ax.text(centre[where[key]], item.y, "\n".join(item.lines), fontsize=LABEL_FONT,
                    color=THREAT_COLOUR if item.threatened else "#343a40", ha="center", va="center",
                    linespacing=1.25, zorder=4,
                    bbox={"boxstyle": "round,pad=0.1", "facecolor": "white", "edgecolor": "none"})


def _topological(preds: dict[int, set[int]]) -> list[int]:
    """Step ids in an order where each comes after its predecessors (ties by id)."""
    import heapq

    waiting = {node: len(ps) for node, ps in preds.items()}
    succs: dict[int, list[int]] = {node: [] for node in preds}
    for node, ps in preds.items():
        for p in ps:
            succs[p].append(node)
    ready = [node for node, n in waiting.items() if n == 0]
    heapq.heapify(ready)
    out = []
    while ready:
        node = heapq.heappop(ready)
        out.append(node)
        for s in succs[node]:
            waiting[s] -= 1
            if waiting[s] == 0:
                heapq.heappush(ready, s)
    return out + sorted(n for n in preds if n not in set(out))  # (a circle: never made by the planner)


def _reduce_crossings(layers: list[list[tuple]], preds: dict, succs: dict, groups: dict) -> list[list[tuple]]:
    """Barycentre sweeps, down and up; the order with the fewest crossings wins (the first on ties)."""

    def crossings(order: list[list[tuple]]) -> int:
        total = 0
        for left, right in zip(order, order[1:]):
            pos = {k: i for i, k in enumerate(right)}
            ends = [(i, pos[s]) for i, k in enumerate(left) for s in succs[k] if s in pos]
            total += sum(1 for a in range(len(ends)) for b in range(a + 1, len(ends))
                         if (ends[a][0] - ends[b][0]) * (ends[a][1] - ends[b][1]) < 0)
        return total

    def together(layer: list[tuple]) -> list[tuple]:
        out, seen = [], set()
        for key in layer:
            if key in seen:
                continue
            members = [m for m in groups.get(key, (key,)) if m in layer] or [key]
            out.extend(members)
            seen.update(members)
        return out

    best, best_count = [list(layer) for layer in layers], crossings(layers)
    current = [list(layer) for layer in layers]
    for sweep in range(SWEEPS):
        down = sweep % 2 == 0
        indices = range(1, len(current)) if down else range(len(current) - 2, -1, -1)
        for c in indices:
            fixed = current[c - 1] if down else current[c + 1]
            pos = {k: i for i, k in enumerate(fixed)}
            neighbours = preds if down else succs
            layer = current[c]

            def bary(item: tuple, i: int) -> float:
                near = [pos[n] for n in neighbours[item] if n in pos]
                return sum(near) / len(near) if near else float(i) * len(fixed) / max(len(layer), 1)

            value = {k: bary(k, i) for i, k in enumerate(layer)}
            for key in layer:  # a simultaneous group moves as one
                members = [m for m in groups.get(key, ()) if m in value]
                if members:
                    value[key] = sum(value[m] for m in members) / len(members)
            current[c] = together(sorted(layer, key=lambda k: value[k]))  # stable: ties keep their order
        count = crossings(current)
        if count < best_count:
            best, best_count = [list(layer) for layer in current], count
    return best


def _separation(a: _Item, b: _Item) -> float:
    gap = NODE_GAP if a.key[0] == b.key[0] == "n" else SLOT_GAP
    return (a.height + b.height) / 2 + gap


def _place_heights(layers: list[list[tuple]], items: dict, preds: dict, succs: dict) -> None:
    """The y (downwards, inches) of every item: stacked, then each column in turn pulled
    towards its neighbours' heights under the spacing (least squares, in order)."""
    for layer in layers:
        y = 0.0
        for i, key in enumerate(layer):
            if i:
                y += _separation(items[layer[i - 1]], items[key])
            items[key].y = y
        shift = y / 2
        for key in layer:
            items[key].y -= shift
    passes = [(range(1, len(layers)), (preds,)), (range(len(layers) - 2, -1, -1), (succs,))] * (SWEEPS // 2)
    passes += [(range(len(layers)), (preds, succs))] * SWEEPS
    for columns, sides in passes:
        for c in columns:
            layer = layers[c]
            desired = []
            for key in layer:
                near = [items[n].y for side in sides for n in side[key]]
                desired.append(sum(near) / len(near) if near else items[key].y)
            gaps = [_separation(items[a], items[b]) for a, b in zip(layer, layer[1:])]
            weights = [WEIGHT[key[0]] for key in layer]
            for key, y in zip(layer, _pava(desired, gaps, weights)):
                items[key].y = y


def _straighten(layers: list[list[tuple]], items: dict, chains: list[list[tuple]]) -> None:
    """Put each run of an edge's slots at one height where its columns leave room for it
    (nearest their mean), so a long edge runs straight instead of stepping."""
    index = {key: (c, i) for c, layer in enumerate(layers) for i, key in enumerate(layer)}
    for chain in chains:
        runs: list[list[tuple]] = [[]]
        for key in chain[1:-1]:
            if key[0] == "d":
                runs[-1].append(key)
            elif runs[-1]:
                runs.append([])
        for run in runs:
            if len(run) < 2:
                continue
            lo, hi = float("-inf"), float("inf")
            for key in run:
                c, i = index[key]
                layer = layers[c]
                if i > 0:
                    lo = max(lo, items[layer[i - 1]].y + _separation(items[layer[i - 1]], items[key]))
                if i + 1 < len(layer):
                    hi = min(hi, items[layer[i + 1]].y - _separation(items[key], items[layer[i + 1]]))
            if lo <= hi:
                y = min(max(sum(items[k].y for k in run) / len(run), lo), hi)
                for key in run:
                    items[key].y = y


def _pava(desired: list[float], gaps: list[float], weights: list[float] | None = None) -> list[float]:
    """Positions ``y`` nearest ``desired`` (weighted least squares) with ``y[i+1] - y[i] >= gaps[i]``
    (pool adjacent violators on ``y[i] - sum(gaps[:i])``)."""
    offsets = [0.0]
    for g in gaps:
        offsets.append(offsets[-1] + g)
    weights = weights or [1.0] * len(desired)
    blocks: list[list[float]] = []  # [weighted mean, weight, count]
    for d, o, w in zip(desired, offsets, weights):
        blocks.append([d - o, w, 1])
        while len(blocks) > 1 and blocks[-2][0] > blocks[-1][0]:
            m2, w2, n2 = blocks.pop()
            m1, w1, n1 = blocks.pop()
            blocks.append([(m1 * w1 + m2 * w2) / (w1 + w2), w1 + w2, n1 + n2])
    z = [m for m, _, n in blocks for _ in range(int(n))]
    return [zi + o for zi, o in zip(z, offsets)]


# ----------------------------------------------------------------------------- drawing

def _draw_edges(ax, edges: list[Edge], chains: list[list[tuple]], items: dict, where: dict,
                x_left: list[float], widths: list[float], centre: list[float]) -> None:
    """Each edge as a smooth curve: straight across every column it crosses (through its
    label or its slot), bending between columns with horizontal tangents. Edges leave and
    enter boxes at ports spread along the boxes' sides (edges through one label share one)."""
    from matplotlib.patches import FancyArrowPatch
    from matplotlib.path import Path as MPath

    outs: dict[tuple, list[tuple[float, int]]] = {}
    ins: dict[tuple, list[tuple[float, int]]] = {}
    for e, chain in enumerate(chains):
        outs.setdefault(chain[0], []).append((items[chain[1]].y, e))
        ins.setdefault(chain[-1], []).append((items[chain[-2]].y, e))
    start: dict[int, float] = {}
    end: dict[int, float] = {}
    for ports, into in ((outs, start), (ins, end)):
        for key, found in ports.items():
            ys = sorted(set(y for y, _ in found))
            spread = min(0.3 * items[key].height, 0.045 * (len(ys) - 1))
            offset = {y: -spread + 2 * spread * i / (len(ys) - 1) if len(ys) > 1 else 0.0 for i, y in enumerate(ys)}
            for y, e in found:
                into[e] = items[key].y + offset[y]
    for e, (edge, chain) in enumerate(zip(edges, chains)):
        src, dst = chain[0], chain[-1]
        points = [(centre[where[src]] + items[src].width / 2, start[e])]
        for key in chain[1:-1]:
            c = where[key]
            points += [(x_left[c], items[key].y), (x_left[c] + widths[c], items[key].y)]
        points.append((centre[where[dst]] - items[dst].width / 2, end[e]))
        verts, codes = [points[0]], [MPath.MOVETO]
        for (x0, y0), (x1, y1) in zip(points, points[1:]):
            half = (x1 - x0) / 2
            verts += [(x0 + half, y0), (x1 - half, y1), (x1, y1)]
            codes += [MPath.CURVE4] * 3
        colour = THREAT_COLOUR if edge.threatened else (LINK_COLOUR if edge.kind == "link" else ORDER_COLOUR)
        ax.add_patch(FancyArrowPatch(path=MPath(verts, codes), arrowstyle="-|>", mutation_scale=8, color=colour,
                                     lw=0.8 if edge.kind == "link" else 0.9,
                                     linestyle="-" if edge.kind == "link" else (0, (4, 2.5)),
                                     shrinkA=0, shrinkB=0, zorder=2))


def _draw_nodes(ax, items: dict, where: dict, centre: list[float], colours: dict, by_id: dict,
                counters: dict) -> None:
    from matplotlib.patches import FancyBboxPatch

    for key, item in items.items():
        if key[0] != "n":
            continue
        node = key[1]
        x, y, w, h = centre[where[key]], item.y, item.width, item.height
        if node in (INIT, GOAL):
            fill, edge, lw = "#f1f3f5", "#343a40", 1.0
        else:
            fill, edge = colours[by_id[node].agent]
            lw = 0.8
        counter = node in counters
        ax.add_patch(FancyBboxPatch((x - w / 2, y - h / 2), w, h, boxstyle="round,pad=0,rounding_size=0.05",
                                    facecolor=fill, edgecolor=COUNTER_COLOUR if counter else edge,
                                    lw=2.0 if counter else lw, zorder=5))
        if node == GOAL:  # a double outline, as Graphviz draws a goal
            ax.add_patch(FancyBboxPatch((x - w / 2 - 0.035, y - h / 2 - 0.035), w + 0.07, h + 0.07,
                                        boxstyle="round,pad=0,rounding_size=0.07", fill=False, edgecolor=edge,
                                        lw=0.8, zorder=5))
        top = y - h / 2 + BOX_PAD_Y
        main_h = len(item.lines) * NODE_FONT * 1.25 / 72
        ax.text(x, top + main_h / 2, "\n".join(item.lines), fontsize=NODE_FONT, ha="center", va="center",
                linespacing=1.25, zorder=6, fontweight="bold" if node in (INIT, GOAL) else "normal")
        if item.counter_lines:
            extra_h = len(item.counter_lines) * COUNTER_FONT * 1.25 / 72
            ax.text(x, top + main_h + extra_h / 2, "\n".join(item.counter_lines), fontsize=COUNTER_FONT,
                    color=COUNTER_TEXT, ha="center", va="center", linespacing=1.25, zorder=6)


def _draw_simultaneous(ax, plan: Plan, items: dict, where: dict, centre: list[float]) -> None:
    """The steps of a simultaneous group, adjacent in their column, tied by a dotted line."""
    for group in plan.simultaneous:
        boxes = sorted((items[("n", i)] for i in group), key=lambda item: item.y)
        x = centre[where[("n", group[0])]]
        for a, b in zip(boxes, boxes[1:]):
            ax.plot([x, x], [a.y + a.height / 2, b.y - b.height / 2], color=SIMULTANEOUS_COLOUR, lw=1.6,
                    ls=(0, (1, 1.5)), zorder=4.5)


def _legend_and_notes(ax, fig, plan: Plan, colours: dict, edges: list[Edge]) -> None:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.transforms import offset_copy

    agents = [a for a in colours if a is not None and any(s.agent == a for s in plan.steps)]
    handles: list = [Patch(facecolor=colours[a][0], edgecolor=colours[a][1], label=a) for a in agents]
    if any(s.agent is None for s in plan.steps):
        handles.append(Patch(facecolor=colours[None][0], edgecolor=colours[None][1], label="(no agent)"))
    handles.append(Line2D([], [], color=LINK_COLOUR, lw=0.8, marker=">", ms=4, label="causal link (its facts)"))
    if any(e.kind == "order" for e in edges):
        handles.append(Line2D([], [], color=ORDER_COLOUR, lw=0.9, ls=(0, (4, 2.5)), label="ordering only"))
    if plan.counterplan:
        handles.append(Patch(facecolor="white", edgecolor=COUNTER_COLOUR, lw=2.0, label="counterplan step"))
    if plan.simultaneous:
        handles.append(Line2D([], [], color=SIMULTANEOUS_COLOUR, lw=1.6, ls=(0, (1, 1.5)), label="simultaneous"))
    if any(e.threatened for e in edges):
        handles.append(Line2D([], [], color=THREAT_COLOUR, lw=0.8, label="link an uncontrolled agent may break"))
    width = ax.get_position().width * fig.get_figwidth()
    above = offset_copy(ax.transAxes, fig=fig, x=0, y=0.12, units="inches")
    ax.legend(handles=handles, loc="lower left", bbox_to_anchor=(0, 1), bbox_transform=above,
              ncol=max(1, min(len(handles), int(width / 1.7))), fontsize=7, frameon=False, handlelength=2.0,
              columnspacing=1.2, borderaxespad=0, title="agents and notation", title_fontsize=7,
              alignment="left")
    title = (f"partial order: {len(plan.steps)} steps, {len(plan.orderings)} orderings, {len(plan.links)} causal links,"
             f" risk {plan.risk:g}")
    legend_rows = -(-len(handles) // max(1, min(len(handles), int(width / 1.7))))
    ax.annotate(title, (0, 1), xycoords="axes fraction", xytext=(0, 0.12 * 72 + 14 * legend_rows + 16),
                textcoords="offset points", fontsize=10, ha="left", va="bottom", annotation_clip=False)
    notes = [] if not plan.threats else ["threats left (what the risk is made of):"] + [
        f"    {t.describe()}" for t in plan.threats]
    for i, note in enumerate(notes):
        ax.annotate(note, (0, 0), xycoords="axes fraction", xytext=(0, -8 - 10.5 * i), textcoords="offset points",
                    fontsize=7, color=THREAT_COLOUR, va="top", ha="left", annotation_clip=False)

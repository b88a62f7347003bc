"""The picture of a plan's schedule: a Gantt chart, a lane per agent (``atlas plan --render``).

What it shows, and the choices made:

- **Lanes** are the agents, in order of first use: the agent whose first
  step starts earliest comes first (ties go to the lower step id), steps
  without an agent last (:func:`lanes_by_first_use`). Each lane starts with
  its name (bold, in the agent's colour) and holds a row per step, by start
  time; bars are filled with the agent's colour (:func:`agent_colours`, the
  same colours as ``--render-order`` and ``--dot``).
- **Orderings** are drawn as arrows only for the transitive reduction of the
  plan's orderings (:func:`reduced_orderings`): an ordering implied by two
  others adds nothing to read. An arrow leaves the end of a bar, bends, and
  enters the start of the next bar from the left, muted and under the bars,
  with its head in the free space before the bar; step labels stay at the
  left of the chart, where no arrow goes.
- **Counterplan steps** are outlined orange, and the threat each answers is
  written at the right of its row, outside the chart: "counters (ACTION) →
  keeps (FACT)" (:func:`counter_labels`).
- **Simultaneous** steps (one ``simultaneous`` plot) are tied at their common
  start by a purple line with a dot on each bar.
- A **deadline** of the goals (``(deadline GOAL SECONDS)``), when the plan has one, is
  a red dash-dotted line.
- **Threats left** (what the risk is made of): a red dashed line on the row
  of the step that needs the fact, over the interval the fact must be kept,
  with a cross at the end of the step after which the uncontrolled action
  may happen; a note under the chart names each one (``PlanThreat.describe``).

:func:`save_figure` lays the page out round what it shows and writes it with
:func:`atlas_rap.views.page.write_png`, so the same plan gives the same bytes.
matplotlib and networkx are imported inside the functions that draw.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from atlas_rap.logic import term_to_str
from atlas_rap.views.page import DPI
from atlas_rap.planner.plan import Plan, PlanStep

NO_AGENT = "(no agent)"
AGENT_FILLS = ("#a5d8ff", "#b2f2bb", "#d0bfff", "#99e9f2", "#fcc2d7",
               "#c0eb75", "#eebefa", "#bac8ff", "#96f2d7", "#ffec99")
"""Fills for the agents, in lane order (light open-color shades; no orange or red, which mean
counterplan steps and threats)."""
AGENT_EDGES = ("#1864ab", "#2b8a3e", "#5f3dc4", "#0b7285", "#a61e4d",
               "#5c940d", "#862e9c", "#364fc7", "#087f5b", "#946c00")
NO_AGENT_FILL, NO_AGENT_EDGE = "#e9ecef", "#495057"
COUNTER_COLOUR = "#e8590c"
THREAT_COLOUR = "#c92a2a"
ARROW_COLOUR = "#7d8791"
SIMULTANEOUS_COLOUR = "#7048e8"
LANE_SHADE = "#f5f6f7"
NOTE_LINE = 10.5  # points between lines of the notes under the chart
CHART_WIDTH = 7.0  # inches of the time axis
ROW = 0.25  # inches per row at the normal font size
BAR = 0.56  # bar height in rows
PAD = 0.12  # inches of white round the picture


# ----------------------------------------------------------------------------- what is drawn (pure)

def lanes_by_first_use(plan: Plan) -> list[str | None]:
    """The agents in the order the chart shows their lanes: by the start of each agent's
    first step, ties by the lowest step id; ``None`` (steps without an agent) last."""
    first: dict[str, tuple[float, int]] = {}
    for step in plan.steps:
        if step.agent is not None:
            key = (step.start, step.id)
            first[step.agent] = min(first.get(step.agent, key), key)
    lanes: list[str | None] = sorted(first, key=lambda agent: (*first[agent], agent))
    if any(step.agent is None for step in plan.steps):
        lanes.append(None)
    return lanes


def agent_colours(plan: Plan) -> dict[str | None, tuple[str, str]]:
    """(fill, edge) colour of each agent, in lane order; ``None`` is grey."""
    colours: dict[str | None, tuple[str, str]] = {}
    for i, agent in enumerate(a for a in lanes_by_first_use(plan) if a is not None):
        colours[agent] = (AGENT_FILLS[i % len(AGENT_FILLS)], AGENT_EDGES[i % len(AGENT_EDGES)])
    colours[None] = (NO_AGENT_FILL, NO_AGENT_EDGE)
    return colours


def lane_rows(plan: Plan) -> list[tuple[str | None, list[PlanStep]]]:
    """Each lane (:func:`lanes_by_first_use`) with its steps by start time, ties by id."""
    return [(lane, sorted((s for s in plan.steps if s.agent == lane), key=lambda s: (s.start, s.id)))
            for lane in lanes_by_first_use(plan)]


def reduced_orderings(orderings: Iterable[tuple[int, int]]) -> list[tuple[int, int]]:
    """The transitive reduction of ``orderings`` (pairs of step ids), sorted: the pairs not
    implied by a chain of others. Orderings in a circle (never made by the planner) are kept
    as they are."""
    import networkx as nx

    pairs = sorted(set(orderings))
    graph = nx.DiGraph(pairs)
    if not nx.is_directed_acyclic_graph(graph):
        return pairs
    return sorted(nx.transitive_reduction(graph).edges())


def counter_labels(plan: Plan) -> dict[int, str]:
    """For each counterplan step, what it answers: "counters (THREAT) → keeps (FACT)"
    (several threats of one step are joined by "; ")."""
    labels: dict[int, list[str]] = {}
    for c in plan.counterplan:
        labels.setdefault(int(c["step"]), []).append(f"counters {c['threat']} \u2192 keeps {c['protects']}")
    return {step: "; ".join(parts) for step, parts in labels.items()}


def step_label(step: PlanStep) -> str:
    """A step as the pictures name it: ``s3 (go-to office)``."""
    return f"s{step.id} {term_to_str(step.action)}"


# ----------------------------------------------------------------------------- the Gantt chart

def render_plan(plan: Plan, path: str | Path) -> Path:
    """Write the schedule of ``plan`` as a PNG at ``path``; return its path."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Rectangle
    from matplotlib.transforms import offset_copy

    lanes = lane_rows(plan)
    headers = lanes != [(None, lanes[0][1])] if lanes else False
    colours = agent_colours(plan)
    counters = counter_labels(plan)
    font = 8 if len(plan.steps) <= 40 else 6
    rows: dict[int, int] = {}
    ticks: list[tuple[int, str, dict]] = []
    bands: list[tuple[int, int, str | None]] = []
    y = 0
    for lane, steps in lanes:
        first = y
        if headers:
            ticks.append((y, lane or NO_AGENT, {"fontweight": "bold", "color": colours[lane][1]}))
            y += 1
        for step in steps:
            rows[step.id] = y
            ticks.append((y, step_label(step), {}))
            y += 1
        bands.append((first, y - 1, lane))
    n_rows = max(y, 1)
    makespan = max(plan.makespan, 1e-9)
    span = makespan * 1.06
    bend = 0.16 * span / CHART_WIDTH  # how far (in time) an arrow runs straight out of a bar and into the next
    chart_h = max(ROW * n_rows * font / 8, 0.6)

    fig_w, fig_h = CHART_WIDTH + 4, chart_h + 2  # for now: save_figure fits the page round the chart
    fig = Figure(figsize=(fig_w, fig_h), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((2 / fig_w, 1 / fig_h, CHART_WIDTH / fig_w, chart_h / fig_h))
    deadline = getattr(plan, "deadline", None)
    ax.set_xlim(-0.03 * makespan, max(makespan, deadline or 0.0) * 1.03)
    ax.set_ylim(n_rows - 0.5, -0.5)
    by_id = {s.id: s for s in plan.steps}

    for i, (top, bottom, lane) in enumerate(bands):
        if i % 2 == 0 and headers:
            ax.axhspan(top - 0.5, bottom + 0.5, color=LANE_SHADE, lw=0, zorder=0)
        if i and headers:
            ax.axhline(top - 0.5, color="#ced4da", lw=0.6, zorder=0.5)
    for step in plan.steps:
        fill, edge = colours[step.agent]
        counter = step.id in counters
        ax.add_patch(Rectangle((step.start, rows[step.id] - BAR / 2), step.end - step.start, BAR,
                               facecolor=fill, edgecolor=COUNTER_COLOUR if counter else edge,
                               lw=1.8 if counter else 0.7, zorder=3))
    for a, b in reduced_orderings(plan.orderings):
        _gantt_arrow(ax, by_id[a], by_id[b], rows, bend)
    for group in plan.simultaneous:
        ys = sorted(rows[i] for i in group)
        x = min(by_id[i].start for i in group) + 0.4 * bend  # on the bars, clear of the arrow heads
        ax.plot([x, x], [ys[0], ys[-1]], color=SIMULTANEOUS_COLOUR, lw=1.4, ls=(0, (1, 1.5)), zorder=4)
        ax.plot([x] * len(ys), ys, ls="none", marker="D", ms=3.2, color=SIMULTANEOUS_COLOUR, zorder=4.1)
    _draw_threats(ax, plan, rows, by_id)
    if deadline is not None:
        ax.axvline(deadline, color=THREAT_COLOUR, lw=1.2, ls="-.", zorder=4)

    ax.set_yticks([t[0] for t in ticks], [t[1] for t in ticks], fontsize=font)
    for label, (_, _, style) in zip(ax.get_yticklabels(), ticks):
        label.set(**style)
    ax.tick_params(axis="y", length=0)
    ax.tick_params(axis="x", labelsize=8)
    _counter_texts(ax, fig, counters, by_id, rows, bend, font - 1)
    ax.set_xlabel("time (operator durations)", fontsize=8)
    ax.grid(axis="x", color="#dee2e6", lw=0.6, zorder=0.2)
    ax.set_axisbelow(True)
    for spine in ax.spines.values():
        spine.set_color("#adb5bd")
    title = f"plan: {len(plan.steps)} steps, makespan {plan.makespan:g}, risk {plan.risk:g}"
    if plan.risk_before_counterplanning:
        title += f" (was {plan.risk_before_counterplanning:g} before counterplanning)"
    ax.set_title(title, fontsize=10, loc="left")

    handles: list = [Line2D([], [], color=ARROW_COLOUR, lw=0.9, marker=">", ms=4,
                            label="ordering (not implied by others)")]
    if counters:
        handles.append(Patch(facecolor="white", edgecolor=COUNTER_COLOUR, lw=1.8, label="counterplan step"))
    if plan.simultaneous:
        handles.append(Line2D([], [], color=SIMULTANEOUS_COLOUR, lw=1.4, ls=(0, (1, 1.5)), marker="D", ms=3.2,
                              label="simultaneous (start together)"))
    if plan.threats:
        handles.append(Line2D([], [], color=THREAT_COLOUR, ls="--", marker="x", label="threat left"))
    if deadline is not None:
        handles.append(Line2D([], [], color=THREAT_COLOUR, lw=1.2, ls="-.", label=f"deadline {deadline:g}"))
    below = offset_copy(ax.transAxes, fig=fig, x=0, y=-0.42, units="inches")
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(0, 0), bbox_transform=below, ncol=len(handles),
              fontsize=7, frameon=False, handlelength=2.2, columnspacing=1.4, borderaxespad=0)
    for i, note in enumerate(_threat_notes(plan)):
        ax.annotate(note, (0, 0), xycoords="axes fraction", xytext=(0, -0.62 * 72 - NOTE_LINE * (i + 1)),
                    textcoords="offset points", fontsize=7, color=THREAT_COLOUR, va="top", ha="left",
                    annotation_clip=False)
    return save_figure(fig, path)


def _gantt_arrow(ax, first: PlanStep, second: PlanStep, rows: dict[int, int], bend: float) -> None:
    """An ordering: out of the end of ``first``, a curve, into the start of ``second`` from the left."""
    from matplotlib.patches import FancyArrowPatch
    from matplotlib.path import Path as MPath

    (x0, y0), (x1, y1) = (first.end, rows[first.id]), (second.start, rows[second.id])
    bend *= min(1 + 0.15 * abs(y1 - y0), 3.0)  # longer arrows bulge further: ones from one bar part
    verts = [(x0, y0), (x0 + bend, y0), (x1 - bend, y1), (x1, y1)]
    ax.add_patch(FancyArrowPatch(path=MPath(verts, [MPath.MOVETO, MPath.CURVE4, MPath.CURVE4, MPath.CURVE4]),
                                 arrowstyle="-|>", mutation_scale=9, color=ARROW_COLOUR, lw=0.85,
                                 shrinkA=0, shrinkB=0, zorder=2))


def _counter_texts(ax, fig, counters: dict[int, str], by_id: dict, rows: dict[int, int], bend: float,
                   size: float) -> None:
    """Each counterplan step's threat on its row, just after its bar (clear of the arrow that
    leaves it), or before the bar when it would not fit after it but does before it; on a
    white ground, so an arrow passing under it does not hide a word."""
    renderer = fig.canvas.get_renderer()
    x_lo, x_hi = ax.get_xlim()
    per_pixel = (x_hi - x_lo) / ax.get_window_extent(renderer).width
    for step_id, label in sorted(counters.items()):
        step = by_id[step_id]
        text = ax.text(step.end + 0.8 * bend, rows[step_id], label, fontsize=size, color=COUNTER_COLOUR,
                       va="center", ha="left", clip_on=False, zorder=6,
                       bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none", "alpha": 0.85})
        width = text.get_window_extent(renderer).width * per_pixel
        if step.end + 0.8 * bend + width > x_hi and step.start - 0.8 * bend - width >= x_lo:
            text.set(x=step.start - 0.8 * bend, ha="right")


def _threat_notes(plan: Plan) -> list[str]:
    """The note under the chart: a line per threat left; none when nothing threatens."""
    if not plan.threats:
        return []
    return ["threats left (what the risk is made of):"] + [f"    {t.describe()}" for t in plan.threats]


def _draw_threats(ax, plan: Plan, rows: dict[int, int], by_id: dict) -> None:
    """Each threat as a dashed line over the interval its fact must be kept (on the
    consumer's row, or the producer's for a goal) and a cross where it may happen."""
    for t in plan.threats:
        start = 0.0 if t.producer == "init" else by_id[t.producer].end
        end = plan.makespan if t.consumer == "goal" else by_id[t.consumer].start
        row_of = t.consumer if t.consumer != "goal" else t.producer
        if row_of == "init":  # an initial fact kept for the goals: no step's row to draw on
            continue
        y = rows[row_of] + 0.36  # just under the bar, clear of the arrows into it
        ax.plot([start, end], [y, y], color=THREAT_COLOUR, ls="--", lw=1.1, zorder=4)
        ax.plot([by_id[t.after].end], [y], color=THREAT_COLOUR, marker="x", ms=5, mew=1.4, zorder=4)


# ----------------------------------------------------------------------------- writing

def save_figure(fig, path: str | Path, pad: float = PAD) -> Path:
    """Lay ``fig`` out round what it shows (every axes keeps its size in inches, the page
    grows or shrinks to ``pad`` inches round all its text) and write it as a PNG with
    :func:`atlas_rap.views.page.write_png`: the same figure gives the same bytes. Closes nothing:
    the figure must have an Agg canvas (``FigureCanvasAgg(fig)``)."""
    import numpy as np

    from atlas_rap.views.page import write_png

    canvas = fig.canvas
    renderer = canvas.get_renderer()
    box = fig.get_tightbbox(renderer)  # inches
    width, height = fig.get_size_inches()
    new_w, new_h = round((box.width + 2 * pad) * DPI) / DPI, round((box.height + 2 * pad) * DPI) / DPI
    dx, dy = pad - box.x0, pad - box.y0
    for ax in fig.axes:
        pos = ax.get_position()
        x0 = round((pos.x0 * width + dx) * DPI) / DPI  # inches, on whole pixels
        y0 = round((pos.y0 * height + dy) * DPI) / DPI
        ax.set_position((x0 / new_w, y0 / new_h, pos.width * width / new_w, pos.height * height / new_h))
    fig.set_size_inches(new_w, new_h)
    fig.set_facecolor("white")
    canvas.draw()
    out = write_png(np.asarray(canvas.buffer_rgba()), path)
    fig.clear()
    return out

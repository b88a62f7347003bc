"""The picture of a plan: its schedule as a Gantt chart, steps grouped by agent.

Each step is a row, labelled with its action, with a bar from its start to
its end; rows are grouped by agent (named at the right); orderings are
arrows from the end of one step to the start of the next; steps of one
``simultaneous`` group are joined by a bracket; counterplan steps are
orange and say which threat they answer. Each threat left (what the risk is
made of) is a red dashed line on the row of the step that needs the fact,
over the interval the fact must be kept, with a cross at the end of the step
after which the uncontrolled action may happen; a note under the chart names
each one (``PlanThreat.describe``). Use :func:`render_plan` (``atlas plan
--render OUT.png``) when a partial order is easier to see than read.
"""

from __future__ import annotations

from pathlib import Path

from atlas_rap.logic import term_to_str
from atlas_rap.pictures import DPI
from atlas_rap.planner.plan import Plan

NO_AGENT = "(no agent)"
STEP_COLOUR = "#a5d8ff"
COUNTER_COLOUR = "#ffc078"
THREAT_COLOUR = "#c92a2a"
NOTE_LINE = 0.17  # inches per line of the threat note under the chart


def render_plan(plan: Plan, path: str | Path) -> None:
    """Write the schedule of ``plan`` as a PNG at ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyArrowPatch, Patch

    ordered = sorted(plan.steps, key=lambda s: (s.agent or NO_AGENT, s.start, s.id))
    rows = {step.id: i for i, step in enumerate(ordered)}
    makespan = max(plan.makespan, 1e-9)
    font = 8 if len(ordered) <= 40 else 6
    notes = _threat_notes(plan)
    chart_height = 1.4 + 0.22 * len(ordered) * font / 8
    note_height = NOTE_LINE * (len(notes) + 1) if notes else 0.0
    fig, ax = plt.subplots(figsize=(10, chart_height + note_height), dpi=DPI)
    counters = {c["step"]: c for c in plan.counterplan}
    by_id = {s.id: s for s in plan.steps}
    for step in plan.steps:
        colour = COUNTER_COLOUR if step.id in counters else STEP_COLOUR
        ax.barh(rows[step.id], step.end - step.start, left=step.start, height=0.6, color=colour,
                edgecolor="#1c7ed6", lw=0.6)
    lanes = list(dict.fromkeys(s.agent for s in ordered))
    if lanes != [None]:
        for lane in lanes:
            first = next(rows[s.id] for s in ordered if s.agent == lane)
            ax.axhline(first - 0.5, color="#adb5bd", lw=0.6)
            ax.text(makespan * 1.01, first - 0.35, lane or NO_AGENT, fontsize=font, va="top", ha="right",
                    color="#495057", style="italic")
    for a, b in plan.orderings:
        first, second = by_id[a], by_id[b]
        ax.add_patch(FancyArrowPatch((first.end, rows[a]), (second.start, rows[b]), arrowstyle="-|>",
                                     mutation_scale=7, color="#868e96", lw=0.7))
    for group in plan.simultaneous:
        ys = [rows[i] for i in group]
        x = by_id[group[0]].start - 0.01 * makespan
        ax.plot([x, x], [min(ys) - 0.3, max(ys) + 0.3], color="#e8590c", lw=2)
    _draw_threats(ax, plan, rows, by_id)
    ax.set_yticks([rows[s.id] for s in ordered], [f"{s.id} {term_to_str(s.action)}" for s in ordered],
                  fontsize=font)
    ax.set_ylim(max(len(ordered), 1) - 0.5, -0.5)
    ax.set_xlim(-0.03 * makespan, makespan * 1.02)
    ax.set_xlabel("time (operator durations)")
    title = f"plan: {len(plan.steps)} steps, makespan {plan.makespan:g}, risk {plan.risk:g}"
    if plan.risk_before_counterplanning:
        title += f" (was {plan.risk_before_counterplanning:g} before counterplanning)"
    ax.set_title(title, fontsize=10)
    handles = [Patch(color=STEP_COLOUR, label="step")]
    if counters:
        handles.append(Patch(color=COUNTER_COLOUR, label="counterplan step"))
    if plan.simultaneous:
        handles.append(Patch(color="#e8590c", label="simultaneous"))
    if notes:
        handles.append(Line2D([], [], color=THREAT_COLOUR, ls="--", marker="x", label="threat left"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=7, frameon=False)
    ax.grid(axis="x", alpha=0.3)
    height = chart_height + note_height
    for i, note in enumerate(notes):
        fig.text(0.01, (note_height - NOTE_LINE * (i + 1)) / height, note, fontsize=7, color=THREAT_COLOUR,
                 va="bottom", ha="left")
    fig.tight_layout(rect=(0, note_height / height, 1, 1))
    try:
        fig.savefig(path)
    finally:
        plt.close(fig)


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
        y = rows[row_of]
        ax.plot([start, end], [y, y], color=THREAT_COLOUR, ls="--", lw=1.2)
        ax.plot([by_id[t.after].end], [y], color=THREAT_COLOUR, marker="x", ms=6, mew=1.5)

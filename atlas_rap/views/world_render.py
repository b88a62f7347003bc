"""Pictures of runs: a PNG of a world with the robot's path, doors, places and task marks.

:func:`render_run` draws, in metres with equal aspect:

* walls as dark lines;
* door leaves green and dashed when open, red and solid when closed;
  openings without a leaf as a small diamond;
* places as light translucent regions (point places as circles of their
  radius), each named at its point;
* obstacles (boxes and people seen during the run) as brown squares and
  orange discs;
* the robot's path as a line coloured by time (with a colorbar) from a
  start marker, and its final pose as a disc of the robot's radius with
  a heading tick (never smaller than 0.8 % of the map's width, so it
  stays visible in big worlds);
* when the robot's pose was estimated (odometry with noise: the
  localiser's :data:`~atlas_rap.skills.beliefs.POSE_TRACK`), the path it
  *believed* it drove beside the true one, a dashed magenta line, and the
  last estimate's covariance as its 2-sigma ellipse in x and y
  (``believed_path``, ``estimate``); the legend then says "true path" and
  "believed path". Without them the picture is exactly the one drawn
  before beliefs existed;
* task marks (:class:`TaskMark`) as small markers, numbered in time order;
  the legend beside the map lists them ("1 (go-to office) started at
  3.0 s"), so the map itself carries only numbers, and marks that fall
  in the same spot share one label ("3–5");
* plan steps (``plan_events``: the plan executive's trace records,
  :data:`PLAN_EVENTS`) as small squares where the robot was when each
  step started, green when it was done, red when it failed, grey when it
  was halted (a re-plan dropped it, or the plan was abandoned), blue while
  it still runs; numbered ``s3`` on the map (``v2 s3`` when a plan was
  re-planned, ``p2 s3`` when a run has several plans); a re-plan as a
  purple star and an abandoned plan as a dark red cross where they
  happened. The legend lists them in time order
  (:func:`plan_legend_rows`: "s3 (go-to office) [robot] ✓ 3.0–12.5 s").

matplotlib is imported inside :func:`render_run` (object-oriented
``Figure`` + Agg canvas, no pyplot and no global state), so importing this
module stays cheap. The same inputs give the same PNG bytes: no software
version or date is written into the file.

Over 25 KB on purpose: the picture of a run: the world, path, places, task marks, plan
events and their legend share one layout.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from atlas_rap.model import World
from atlas_rap.trace_events import Event
from atlas_rap.views.page import DPI as _DPI
from atlas_rap.views.page import cut_text, map_layout, plain_text, save_figure_png

__all__ = ["PLAN_EVENTS", "TASK_MARK_KINDS", "PlanNote", "PlanStepMark", "TaskMark", "plan_legend_rows",
           "plan_marks", "render_run"]

TASK_MARK_KINDS = ("started", "succeeded", "failed")


@dataclass(frozen=True, slots=True)
class TaskMark:
    """Something that happened to a task at a time and place: ``kind`` is started, succeeded or failed."""

    time: float
    x: float
    y: float
    label: str
    kind: str


PLAN_EVENTS = frozenset({Event.PLAN_READY, Event.PLAN_STEP_STARTED, Event.PLAN_STEP_DONE, Event.PLAN_STEP_FAILED,
                         Event.REPLANNED, Event.PLAN_ABANDONED, Event.PLAN_DONE})
"""The trace events of the plan executive that the picture shows."""


@dataclass(frozen=True, slots=True)
class PlanStepMark:
    """A plan step: where the robot was when it started (``time``), and how it ended.

    ``outcome`` is done, failed, halted (a re-plan dropped it, or the plan
    was abandoned) or running (not ended when the picture was drawn);
    ``end`` is when it ended, ``reason`` why it failed or was halted.
    ``version`` is the plan's version when the step started.
    """

    time: float
    x: float
    y: float
    plan: int
    version: int
    step: int
    action: str
    agent: str | None
    outcome: str
    end: float | None = None
    reason: str = ""


@dataclass(frozen=True, slots=True)
class PlanNote:
    """A moment of a plan, where the robot was: ``kind`` is ready, replanned, abandoned or finished;
    ``text`` is its legend row. Re-plans and abandoned plans are also marked on the map."""

    time: float
    x: float
    y: float
    plan: int
    version: int
    kind: str
    text: str


# Look of the picture -------------------------------------------------------

_MAX_LISTED_MARKS = 40  # beyond this the legend says "... and N more"
_MAX_LABEL_CHARS = 36

_WALL = "#2b2b2b"
_DOOR_OPEN = "#2e9e44"
_DOOR_CLOSED = "#d62728"
_ROBOT_FACE = "#fdd835"
_ROBOT_EDGE = "#333333"
_BOX = "#8d6e63"
_BELIEF = "#d6127a"  # the believed path and the estimate's ellipse: no viridis colour comes near it
_BELIEF_DASH = (0, (3.0, 1.6))
_PERSON = "#fb8c00"
_PLACE_COLOURS = (
    "#4e79a7", "#f28e2b", "#59a14f", "#b07aa1", "#76b7b2",
    "#edc948", "#e15759", "#9c755f", "#ff9da7", "#bab0ac",
)
_MARK_STYLE: dict[str, tuple[str, str, float]] = {
    # kind: (marker, colour, size in points)
    "started": (">", "#1f63c6", 7.0),
    "succeeded": (r"$\checkmark$", "#1a9641", 9.0),
    "failed": ("X", "#d62728", 8.0),
}
_OTHER_MARK = ("o", "#666666", 6.0)
_MAX_LISTED_PLAN_ROWS = 36
_MAX_ROW_CHARS = 84
_STEP_COLOURS = {"done": "#1a9641", "failed": "#d62728", "halted": "#8c8c8c", "running": "#1f63c6"}
_STEP_SIGNS = {"done": "\u2713", "failed": "\u2717", "halted": "halted", "running": "running"}
_NOTE_STYLE: dict[str, tuple[str, str, float]] = {
    "replanned": ("*", "#9c36b5", 11.0),
    "abandoned": ("X", "#862e2e", 9.0),
}


def render_run(
    world: World,
    out_png: str | Path,
    *,
    path: Sequence[tuple[float, float, float, float]] = (),
    doors_open: Mapping[str, bool] | None = None,
    task_marks: Sequence[TaskMark] = (),
    title: str | None = None,
    obstacles: Sequence[tuple[str, tuple[float, float], float]] = (),
    plan_events: Sequence[Mapping[str, Any]] = (),
    objects: Sequence[tuple[str, str, str, tuple[float, float]]] = (),
    believed_path: Sequence[tuple[float, float, float, float]] = (),
    kidnaps: Sequence[tuple[float, tuple[float, float, float], tuple[float, float, float]]] = (),
    estimate: Any = None,
) -> Path:
    """Draw ``world`` and a run in it to the PNG ``out_png``; return its path.

    ``path`` is the robot's trajectory as ``(t, x, y, heading)`` items in
    time order; its last item is the final pose (with no path, the robot
    is drawn at its start pose). ``doors_open`` maps door names to whether
    they are open at the end of the run (doors not in it keep their
    ``open`` from the world). ``task_marks`` are numbered in time order.
    ``title`` follows the world's name in the title (e.g. ``"deliver.rap,
    seed 0"``). ``obstacles`` are ``(kind, (x, y), size)``: ``box`` is a
    square of side ``size``, anything else (``person``) a disc of diameter
    ``size``. ``plan_events`` are trace records of the plan executive
    (:data:`PLAN_EVENTS`, others are ignored), in time order: each plan
    step is drawn where the robot was when it started (:func:`plan_marks`).
    ``objects`` are the world's objects where they are at the end,
    ``(name, colour, kind, (x, y))``: a disc of their colour, named (a bin
    is a square). ``believed_path`` is where the robot believed it was
    (the localiser's track, ``(t, x, y, heading)`` items), drawn beside
    ``path``; ``kidnaps`` the times the robot was carried (``(t, pose
    before, pose after)``, the simulator's ``kidnaps``), drawn as dotted
    arrows and not as driving; ``estimate`` the last
    :class:`~atlas_rap.skills.beliefs.PoseEstimate` (anything with
    ``time``, ``pose`` and a 3 x 3 ``covariance``), drawn as its 2-sigma
    ellipse. The parent directory of ``out_png`` is created if needed.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    out = Path(out_png)
    out.parent.mkdir(parents=True, exist_ok=True)

    marks = sorted(task_marks, key=lambda m: m.time)  # stable: ties keep their given order
    steps, notes = plan_marks(plan_events, path, start=world.robot.start[:2])
    placed = [TaskMark(m.time, m.x, m.y, "", "") for m in [*steps, *notes]]  # (only to size the map)
    drawn = [*path, *believed_path] if believed_path else path  # (a belief gone astray stays in the picture)
    (xmin, xmax, ymin, ymax), map_w, map_h = map_layout(*_extent(world, drawn, [*marks, *placed], obstacles))

    left, bottom, top, right = 0.75, 1.05 if path else 0.6, 0.55, 0.25
    fig_w, fig_h = left + map_w + right, bottom + map_h + top
    fig = Figure(figsize=(fig_w, fig_h), dpi=_DPI)
    FigureCanvasAgg(fig)
    try:
        ax = fig.add_axes((left / fig_w, bottom / fig_h, map_w / fig_w, map_h / fig_h))
        ax.set_xlim(xmin, xmax)
        ax.set_ylim(ymin, ymax)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.grid(True, color="#e6e6e6", linewidth=0.6, zorder=0)
        ax.set_axisbelow(True)
        ax.tick_params(labelsize=8)
        for spine in ax.spines.values():
            spine.set_color("#999999")
        heading = world.name if not title else f"{world.name} \u2014 {title}"
        ax.set_title(plain_text(heading), fontsize=11, loc="left")

        handles: list[Any] = []
        _draw_places(ax, world)
        _draw_walls(ax, world, handles)
        _draw_doors(ax, world, doors_open or {}, handles)
        _draw_obstacles(ax, obstacles, handles)
        _draw_objects(ax, objects, handles)
        _draw_path(fig, ax, path, handles, left / fig_w, (bottom - 0.78) / fig_h, map_w / fig_w,
                   "true path" if believed_path else "path", kidnaps)
        _draw_belief(ax, believed_path, estimate, handles)
        _draw_robot(ax, world, path, handles)
        taken: list[tuple[float, float, float, float]] = []
        _draw_marks(fig, ax, marks, handles, taken)
        _draw_plan(fig, ax, steps, notes, handles, taken)

        if handles:
            ax.legend(
                handles=handles,
                loc="upper left",
                bbox_to_anchor=(1.02, 1.0),
                borderaxespad=0.0,
                fontsize=8,
                frameon=False,
                handlelength=1.8,
                labelspacing=0.45,
            )
        save_figure_png(fig, out, dpi=_DPI, bbox_inches="tight", pad_inches=0.15)
    finally:
        fig.clear()
    return out


# Pieces -------------------------------------------------------------------


def _extent(world, path, marks, obstacles) -> tuple[float, float, float, float]:
    """The world's bounds grown to hold everything drawn, plus a small margin."""
    xmin, ymin, xmax, ymax = (float(v) for v in world.bounds)
    xs = [p[1] for p in path] + [m.x for m in marks] + [o[1][0] for o in obstacles]
    ys = [p[2] for p in path] + [m.y for m in marks] + [o[1][1] for o in obstacles]
    for seg in world.walls:
        xs += [seg.a[0], seg.b[0]]
        ys += [seg.a[1], seg.b[1]]
    finite = [(x, y) for x, y in zip(xs, ys) if math.isfinite(x) and math.isfinite(y)]
    if finite:
        xmin = min(xmin, min(x for x, _ in finite))
        xmax = max(xmax, max(x for x, _ in finite))
        ymin = min(ymin, min(y for _, y in finite))
        ymax = max(ymax, max(y for _, y in finite))
    if not (xmax > xmin):
        xmin, xmax = xmin - 1.0, xmin + 1.0
    if not (ymax > ymin):
        ymin, ymax = ymin - 1.0, ymin + 1.0
    margin = 0.04 * max(xmax - xmin, ymax - ymin) + world.robot.radius
    return xmin - margin, ymin - margin, xmax + margin, ymax + margin


def _halo(width: float = 2.5):
    from matplotlib import patheffects

    return [patheffects.withStroke(linewidth=width, foreground="white")]


def _draw_places(ax, world: World) -> None:
    from matplotlib.patches import Circle, Polygon

    for i, place in enumerate(world.places.values()):
        colour = _PLACE_COLOURS[i % len(_PLACE_COLOURS)]
        if place.region is not None and len(place.region) >= 3:
            patch = Polygon(place.region, closed=True)
        else:
            patch = Circle(place.point, place.radius)
        patch.set(facecolor=colour, alpha=0.16, edgecolor="none", zorder=1)
        ax.add_patch(patch)
        if place.region is not None and len(place.region) >= 3:
            edge = Polygon(place.region, closed=True, fill=False)
        else:
            edge = Circle(place.point, place.radius, fill=False)
        edge.set(edgecolor=colour, alpha=0.55, linewidth=0.8, linestyle=(0, (3, 2)), zorder=1.1)
        ax.add_patch(edge)
        ax.plot(*place.point, marker="o", markersize=2.5, color=colour, zorder=6)
        # The name goes just below the point, clear of a robot standing there
        # (task-mark numbers go up and to the right).
        ax.annotate(
            plain_text(place.name),
            (place.point[0], place.point[1] - world.robot.radius),
            xytext=(0, -2),
            textcoords="offset points",
            ha="center",
            va="top",
            fontsize=8.5,
            color=_darker(colour),
            fontweight="bold",
            path_effects=_halo(),
            zorder=6,
        )


def _draw_walls(ax, world: World, handles: list) -> None:
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    if not world.walls:
        return
    segs = [(seg.a, seg.b) for seg in world.walls]
    ax.add_collection(LineCollection(segs, colors=_WALL, linewidths=2.4, capstyle="round", zorder=3))
    handles.append(Line2D([], [], color=_WALL, linewidth=2.4, label="wall"))


def _draw_doors(ax, world: World, doors_open: Mapping[str, bool], handles: list) -> None:
    from matplotlib.lines import Line2D

    seen: set[str] = set()
    for door in world.doors.values():
        is_open = bool(doors_open.get(door.name, door.open))
        if door.segment is None:
            ax.plot(
                *door.center, marker="D", markersize=4.5, markerfacecolor="white",
                markeredgecolor=_DOOR_OPEN, markeredgewidth=1.2, zorder=4,
            )
            colour, kind = _DOOR_OPEN, "opening"
        else:
            (ax_, ay), (bx, by) = door.segment.a, door.segment.b
            if is_open:
                ax.plot([ax_, bx], [ay, by], color=_DOOR_OPEN, linewidth=1.3,
                        linestyle=(0, (3, 2)), solid_capstyle="butt", zorder=4)
                colour, kind = _DOOR_OPEN, "door open"
            else:
                ax.plot([ax_, bx], [ay, by], color=_DOOR_CLOSED, linewidth=3.2,
                        solid_capstyle="butt", zorder=4)
                colour, kind = _DOOR_CLOSED, "door closed"
        ax.annotate(
            plain_text(door.name), door.center, xytext=(4, -4), textcoords="offset points",
            ha="left", va="top", fontsize=6.5, color=colour, fontstyle="italic",
            path_effects=_halo(2.0), zorder=6,
        )
        seen.add(kind)
    if "door open" in seen:
        handles.append(Line2D([], [], color=_DOOR_OPEN, linewidth=1.3, linestyle=(0, (3, 2)), label="door open"))
    if "door closed" in seen:
        handles.append(Line2D([], [], color=_DOOR_CLOSED, linewidth=3.2, label="door closed"))
    if "opening" in seen:
        handles.append(Line2D([], [], linestyle="none", marker="D", markersize=4.5, markerfacecolor="white",
                              markeredgecolor=_DOOR_OPEN, markeredgewidth=1.2, label="opening"))


def _draw_obstacles(ax, obstacles, handles: list) -> None:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, Rectangle

    kinds: set[str] = set()
    for kind, (x, y), size in obstacles:
        size = float(size)
        if kind == "box":
            patch = Rectangle((x - size / 2, y - size / 2), size, size)
            patch.set(facecolor=_BOX, edgecolor="#4e342e", alpha=0.85, linewidth=0.8, zorder=3.5)
            kinds.add("box")
        else:
            patch = Circle((x, y), size / 2)
            patch.set(facecolor=_PERSON, edgecolor="#a35400", alpha=0.8, linewidth=0.8, zorder=3.5)
            kinds.add("person" if kind == "person" else "obstacle")
        ax.add_patch(patch)
    if "box" in kinds:
        handles.append(Line2D([], [], linestyle="none", marker="s", markersize=7, markerfacecolor=_BOX,
                              markeredgecolor="#4e342e", label="box"))
    for kind in ("person", "obstacle"):
        if kind in kinds:
            handles.append(Line2D([], [], linestyle="none", marker="o", markersize=7,
                                  markerfacecolor=_PERSON, markeredgecolor="#a35400", label=kind))


def _draw_objects(ax, objects, handles: list) -> None:
    """The world's coloured objects where they ended: discs (bins: squares), each named."""
    from matplotlib.colors import is_color_like
    from matplotlib.lines import Line2D

    if not objects:
        return
    for name, colour, kind, (x, y) in objects:
        face = colour if is_color_like(colour) else "#868e96"
        ax.plot([x], [y], linestyle="none", marker="s" if kind == "bin" else "o", markersize=7 if kind == "bin" else 6,
                markerfacecolor=face, markeredgecolor="#212529", markeredgewidth=0.7, zorder=4.5)
        ax.annotate(plain_text(name), (x, y), xytext=(4, -9), textcoords="offset points", fontsize=6.5,
                    color="#343a40", zorder=4.5)
    handles.append(Line2D([], [], linestyle="none", marker="o", markersize=6, markerfacecolor="#ffffff",
                          markeredgecolor="#212529", label="object at the end (its colour; bins square)"))


def _draw_path(fig, ax, path, handles: list, cb_left: float, cb_bottom: float, cb_width: float,
               name: str = "path", kidnaps=()) -> None:
    from matplotlib.collections import LineCollection
    from matplotlib.colors import Normalize
    from matplotlib.lines import Line2D

    if not path:
        return
    ts = [float(p[0]) for p in path]
    pts = [(float(p[1]), float(p[2])) for p in path]
    t0, t1 = ts[0], ts[-1]
    if not (t1 > t0):
        t1 = t0 + 1.0
    norm = Normalize(vmin=t0, vmax=t1)
    jumps = [t for t, _, _ in kidnaps]  # the robot did not drive across these: it was carried
    steps = [i for i in range(len(pts) - 1) if not any(ts[i] < t <= ts[i + 1] + 1e-9 for t in jumps)]
    lc = LineCollection(
        [(pts[i], pts[i + 1]) for i in steps],
        cmap="viridis", norm=norm, linewidths=2.0, capstyle="round", joinstyle="round", zorder=5,
    )
    lc.set_array([(ts[i] + ts[i + 1]) / 2 for i in steps])
    ax.add_collection(lc)
    ax.plot(*pts[0], marker="o", markersize=6, markerfacecolor="white",
            markeredgecolor="#440154", markeredgewidth=1.5, zorder=5.5)
    for t, before, after in kidnaps:
        ax.annotate("", xy=after[:2], xytext=before[:2], zorder=5.2,
                    arrowprops={"arrowstyle": "->", "linestyle": ":", "color": "#555555", "linewidth": 1.2})
    if kidnaps:
        handles.append(Line2D([], [], color="#555555", linestyle=":", linewidth=1.2,
                              label="kidnapped at " + ", ".join(f"{t:g} s" for t, _, _ in kidnaps)))
    handles.append(Line2D([], [], color="#21918c", linewidth=2.0, label=f"{name} (colour = time)"))
    handles.append(Line2D([], [], linestyle="none", marker="o", markersize=6, markerfacecolor="white",
                          markeredgecolor="#440154", markeredgewidth=1.5, label=f"start, t = {ts[0]:g} s"))

    from matplotlib.cm import ScalarMappable

    cax = fig.add_axes((cb_left, cb_bottom, min(cb_width * 0.55, 3.2 / fig.get_figwidth()), 0.1 / fig.get_figheight()))
    cb = fig.colorbar(ScalarMappable(norm=norm, cmap="viridis"), cax=cax, orientation="horizontal")
    cb.set_label("time (s)", fontsize=8, labelpad=2)
    cb.ax.tick_params(labelsize=7, length=2)
    cb.outline.set_linewidth(0.5)


def _draw_belief(ax, believed_path, estimate, handles: list) -> None:
    """The path the robot believed it drove (dashed, over the true one) and the last estimate's
    2-sigma ellipse in x and y, with a cross at its pose; nothing when there is neither."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Ellipse

    from atlas_rap.views.pose_error import covariance_ellipse

    if believed_path:
        xs = [float(p[1]) for p in believed_path]
        ys = [float(p[2]) for p in believed_path]
        ax.plot(xs, ys, color=_BELIEF, linewidth=1.3, linestyle=_BELIEF_DASH, dash_capstyle="butt",
                solid_joinstyle="round", zorder=5.2)
        handles.append(Line2D([], [], color=_BELIEF, linewidth=1.3, linestyle=_BELIEF_DASH,
                              label="believed path (the localiser's)"))
    if estimate is None:
        return
    from matplotlib.colors import to_rgba

    x, y = float(estimate.pose[0]), float(estimate.pose[1])
    width, height, angle = covariance_ellipse(estimate.covariance, sigmas=2.0)
    fill = to_rgba(_BELIEF, 0.18)
    ax.add_patch(Ellipse((x, y), width, height, angle=angle, facecolor=fill, edgecolor=_BELIEF, linewidth=1.1,
                         zorder=7.15))  # over the robot's disc, which may be bigger
    ax.plot([x], [y], linestyle="none", marker="+", markersize=7, markeredgewidth=1.2, color=_BELIEF, zorder=7.2)
    handles.append(Line2D([], [], linestyle="none", marker="o", markersize=8, markerfacecolor=fill,
                          markeredgecolor=_BELIEF, label=f"belief at {float(estimate.time):.1f} s, 2\u03c3 ellipse "
                                                         f"({width:.2f} \u00d7 {height:.2f} m)"))


def _draw_robot(ax, world: World, path, handles: list) -> None:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle

    if path:
        _, x, y, heading = (float(v) for v in path[-1])
        label = "robot, final pose"
    else:
        x, y, heading = (float(v) for v in world.robot.start)
        label = "robot, start pose"
    r = world.robot.radius
    xlo, xhi = ax.get_xlim()
    tiny = 0.008 * (xhi - xlo)  # in a big world the true disc is a speck: draw it at least this big
    shown = max(r, tiny)
    ax.add_patch(Circle((x, y), shown, facecolor=_ROBOT_FACE, edgecolor=_ROBOT_EDGE, linewidth=1.2, zorder=7))
    ax.plot([x, x + 1.6 * shown * math.cos(heading)], [y, y + 1.6 * shown * math.sin(heading)],
            color=_ROBOT_EDGE, linewidth=1.6, solid_capstyle="round", zorder=7.1)
    handles.append(Line2D([], [], linestyle="none", marker="o", markersize=8, markerfacecolor=_ROBOT_FACE,
                          markeredgecolor=_ROBOT_EDGE, label=label))


def _draw_marks(fig, ax, marks: list[TaskMark], handles: list, taken: list) -> None:
    from matplotlib.lines import Line2D

    if not marks:
        return
    styles = [_MARK_STYLE.get(m.kind, _OTHER_MARK) for m in marks]
    _place_groups(fig, ax, [(m.x, m.y) for m in marks], styles, lambda members: _ranges([i + 1 for i in members]),
                  taken)

    handles.append(Line2D([], [], linestyle="none", label="task marks:"))
    for i, m in enumerate(marks[:_MAX_LISTED_MARKS]):
        marker, colour, size = styles[i]
        handles.append(Line2D(
            [], [], linestyle="none", marker=marker, markersize=size, color=colour,
            markeredgecolor="white" if marker in (">", "X", "o") else colour, markeredgewidth=0.6,
            label=f"{i + 1} {_short(m.label)} {m.kind} at {m.time:.1f} s",
        ))
    if len(marks) > _MAX_LISTED_MARKS:
        handles.append(Line2D([], [], linestyle="none",
                              label=f"\u2026 and {len(marks) - _MAX_LISTED_MARKS} more"))


def _draw_plan(fig, ax, steps: list[PlanStepMark], notes: list[PlanNote], handles: list, taken: list) -> None:
    """The plan steps as squares coloured by outcome, numbered; re-plans and abandoned plans
    as their own markers with a word; then the legend rows."""
    from matplotlib.lines import Line2D

    if not steps and not notes:
        return
    if steps:
        tags = _step_prefixes(steps, notes)
        styles = [("s", _STEP_COLOURS.get(m.outcome, "#666666"), 6.5) for m in steps]

        def text_of(members: list[int]) -> str:
            by_prefix: dict[str, list[int]] = {}
            for i in members:
                by_prefix.setdefault(tags[i], []).append(steps[i].step)
            return "; ".join(f"{prefix}s{_ranges(sorted(set(numbers)))}" for prefix, numbers in by_prefix.items())

        _place_groups(fig, ax, [(m.x, m.y) for m in steps], styles, text_of, taken, colour="#1b3a5c")
    shown = [n for n in notes if n.kind in _NOTE_STYLE]
    if shown:
        styles = [_NOTE_STYLE[n.kind] for n in shown]
        words = {"replanned": "re-plan", "abandoned": "abandoned"}

        def note_text(members: list[int]) -> str:
            return ", ".join(dict.fromkeys(
                f"{words[shown[i].kind]} v{shown[i].version}" if shown[i].kind == "replanned" else words[shown[i].kind]
                for i in members))

        _place_groups(fig, ax, [(n.x, n.y) for n in shown], styles, note_text, taken, colour="#5f1e6e")

    handles.append(Line2D([], [], linestyle="none", label="plan steps (where each started):"))
    rows = plan_legend_rows(steps, notes)
    for kind, text in rows[:_MAX_LISTED_PLAN_ROWS]:
        if kind in _STEP_COLOURS:
            handles.append(Line2D([], [], linestyle="none", marker="s", markersize=6.5, color=_STEP_COLOURS[kind],
                                  markeredgecolor="white", markeredgewidth=0.6, label=plain_text(text)))
        elif kind in _NOTE_STYLE:
            marker, colour, size = _NOTE_STYLE[kind]
            handles.append(Line2D([], [], linestyle="none", marker=marker, markersize=size, color=colour,
                                  markeredgecolor="white", markeredgewidth=0.6, label=plain_text(text)))
        else:
            handles.append(Line2D([], [], linestyle="none", label=plain_text(text)))
    if len(rows) > _MAX_LISTED_PLAN_ROWS:
        handles.append(Line2D([], [], linestyle="none", label=f"\u2026 and {len(rows) - _MAX_LISTED_PLAN_ROWS} more"))


def _place_groups(fig, ax, points: list[tuple[float, float]], styles: list[tuple[str, str, float]],
                  text_of, taken: list, colour: str = "#222222") -> None:
    """Markers at ``points``; those in (nearly) the same spot share one label (``text_of``
    their indices) and sit side by side. Each label goes where it hits least of ``taken``
    (the markers and labels placed so far, in points), which it then joins."""
    from matplotlib.transforms import offset_copy

    xlo, xhi = ax.get_xlim()
    ylo, yhi = ax.get_ylim()
    near = 0.025 * max(xhi - xlo, yhi - ylo)
    groups: list[tuple[float, float, list[int]]] = []
    for i, (x, y) in enumerate(points):
        for gx, gy, members in groups:
            if math.hypot(x - gx, y - gy) <= near:
                members.append(i)
                break
        else:
            groups.append((x, y, [i]))

    step = 8.0  # points between markers of one group
    fontsize = 7.5
    pos = ax.get_position()
    ppm = pos.width * fig.get_figwidth() * 72 / (xhi - xlo)  # points per metre (equal aspect)
    anchors = [((gx - xlo) * ppm, (gy - ylo) * ppm) for gx, gy, _ in groups]
    # A row of markers that would cover markers or labels of an earlier call moves down a row or more.
    earlier = list(taken)
    rows: list[tuple[float, float, float, float]] = []
    for i, ((ax0, ay0), g) in enumerate(zip(anchors, groups)):
        box = (ax0 - 5, ay0 - 5, ax0 + (min(len(g[2]), 8) - 1) * step + 5, ay0 + 5)
        for _ in range(4):
            if _overlap(box, earlier) == 0:
                break
            box = (box[0], box[1] - 10, box[2], box[3] - 10)
        anchors[i] = (ax0, box[1] + 5)
        rows.append(box)
    # Every marker row is taken; each label then goes where it hits nothing placed so far.
    taken += rows
    for (gx, gy, members), (px, py), (_, y0) in zip(groups, anchors, [((gx - xlo) * ppm, (gy - ylo) * ppm)
                                                                     for gx, gy, _ in groups]):
        shown = members[:8]
        lower = py - y0  # points the row moved down (0: on the spot)
        for k, i in enumerate(shown):
            marker, mark_colour, size = styles[i]
            tr = offset_copy(ax.transData, fig=fig, x=k * step, y=lower, units="points")
            ax.plot(gx, gy, transform=tr, linestyle="none", marker=marker, markersize=size,
                    color=mark_colour, markeredgecolor="white" if marker in (">", "X", "o", "s", "*") else mark_colour,
                    markeredgewidth=0.6, zorder=8)
        text = text_of(members)
        w, h = 0.62 * fontsize * len(text) + 2, 1.2 * fontsize
        right = (len(shown) - 1) * step + 6
        mid = (len(shown) - 1) * step / 2
        candidates = [  # (x offset, y offset) of the label's lower-left corner, in points
            (right, 3), (right, -3 - h), (-6 - w, 3), (-6 - w, -3 - h),
            (mid - w / 2, 7), (mid - w / 2, -7 - h), (right, -h / 2), (-6 - w, -h / 2),
        ]
        if lower:  # a row moved off the spot: its label level with it, clear of the row above
            candidates.insert(0, (right, -h / 2))
        # the first of the least crowded places
        best = min(candidates, key=lambda c: _overlap((px + c[0], py + c[1], px + c[0] + w, py + c[1] + h), taken))
        taken.append((px + best[0], py + best[1], px + best[0] + w, py + best[1] + h))
        ax.annotate(
            plain_text(text), (gx, gy), xytext=(best[0], best[1] + lower), textcoords="offset points",
            ha="left", va="bottom", fontsize=fontsize, color=colour, fontweight="bold",
            path_effects=_halo(2.2), zorder=9,
        )


# The plan executive's trace, read ------------------------------------------


def plan_marks(
    records: Sequence[Mapping[str, Any]],
    path: Sequence[tuple[float, float, float, float]] = (),
    start: Sequence[float] = (0.0, 0.0),
) -> tuple[list[PlanStepMark], list[PlanNote]]:
    """The plan steps and the plan's moments in ``records`` (trace records in time order;
    those not in :data:`PLAN_EVENTS` are ignored), placed where the robot was then on
    ``path`` (``(t, x, y, heading)`` items; with no path, at ``start``).

    A step is matched to its end by its RAP task (``step_task``), else by plan, version
    and step. A step still running when its plan is re-planned without it (``halted``
    of ``replanned``) or abandoned is halted then; one with no end is still running.
    """
    times = [float(p[0]) for p in path]

    def where(t: float) -> tuple[float, float]:
        if not path:
            return float(start[0]), float(start[1])
        _, x, y, _ = path[min(bisect_left(times, t), len(path) - 1)]
        return float(x), float(y)

    started: dict[object, dict[str, Any]] = {}  # key -> the step as it goes
    notes: list[PlanNote] = []
    version: dict[int, int] = {}
    for record in records:
        event = record.get("event")
        if event not in PLAN_EVENTS:
            continue
        t = float(record.get("t", 0.0))
        plan = int(record.get("plan", 0))
        ver = int(record.get("version", version.get(plan, 1)))
        version[plan] = ver
        if event == Event.PLAN_STEP_STARTED:
            key = _step_key(record)
            if key in started:  # started again (the same task): the first start counts
                continue
            x, y = where(t)
            started[key] = {"time": t, "x": x, "y": y, "plan": plan, "version": ver,
                            "step": int(record.get("step", 0)), "action": str(record.get("action", "")),
                            "agent": record.get("agent"), "outcome": "running", "end": None, "reason": ""}
        elif event in (Event.PLAN_STEP_DONE, Event.PLAN_STEP_FAILED):
            step = started.get(_step_key(record))
            if step is not None and step["outcome"] == "running":
                step.update(outcome="done" if event == Event.PLAN_STEP_DONE else "failed", end=t,
                            reason=str(record.get("reason", "")))
        else:
            x, y = where(t)
            if event == Event.REPLANNED:
                halted = set(map(str, record.get("halted", ())))
                for step in started.values():
                    if step["plan"] == plan and step["outcome"] == "running" and step["action"] in halted:
                        step.update(outcome="halted", end=t, reason=f"re-plan v{ver} dropped it")
            elif event == Event.PLAN_ABANDONED and record.get("scope", "plan") == "plan":
                for step in started.values():
                    if step["plan"] == plan and step["outcome"] == "running":
                        step.update(outcome="halted", end=t, reason="the plan was abandoned")
            kind = {Event.PLAN_READY: "ready", Event.REPLANNED: Event.REPLANNED, Event.PLAN_ABANDONED: "abandoned",
                    Event.PLAN_DONE: "finished"}[event]
            notes.append(PlanNote(t, x, y, plan, ver, kind, _note_text(kind, t, plan, ver, record)))
    steps = sorted((PlanStepMark(**s) for s in started.values()), key=lambda m: m.time)
    return steps, notes


def plan_legend_rows(steps: Sequence[PlanStepMark], notes: Sequence[PlanNote] = ()) -> list[tuple[str, str]]:
    """The legend's rows for the plan, in time order (a moment before the steps that start
    with it): ``(kind, text)``, where ``kind`` is a step's outcome (done, failed, halted,
    running) or a note's kind (ready, replanned, abandoned, finished), and ``text`` e.g.
    ``"s3 (go-to office) [robot] ✓ 3.0–12.5 s"``. A plan's ``ready`` is listed for its
    first version only (a re-plan's row says what changed)."""
    prefixes = _step_prefixes(steps, notes)
    rows: list[tuple[float, int, int, tuple[str, str]]] = []
    for i, n in enumerate(notes):
        if n.kind == "ready" and n.version > 1:
            continue
        rows.append((n.time, 0, i, (n.kind, n.text)))
    for i, m in enumerate(steps):
        agent = f" [{m.agent}]" if m.agent else ""
        head = f"{prefixes[i]}s{m.step} {_one_line(m.action)}{agent} {_STEP_SIGNS.get(m.outcome, m.outcome)}"
        if m.outcome == "done":
            text = f"{head} {m.time:.1f}\u2013{m.end:.1f} s"
        elif m.outcome == "running":
            text = f"{head} from {m.time:.1f} s"
        else:
            text = f"{head} {m.time:.1f}\u2013{m.end:.1f} s" + (f": {_one_line(m.reason)}" if m.reason else "")
        rows.append((m.time, 1, i, (m.outcome, cut_text(text, _MAX_ROW_CHARS))))
    return [row for *_, row in sorted(rows, key=lambda r: r[:3])]


def _step_key(record: Mapping[str, Any]) -> object:
    task = record.get("step_task")
    if task is not None:
        return ("task", task)
    return ("step", record.get("plan"), record.get("version"), record.get("step"))


def _step_prefixes(steps: Sequence[PlanStepMark], notes: Sequence[PlanNote] = ()) -> list[str]:
    """What goes before each step's ``s3``: ``p2 `` when the run has several plans,
    ``v2 `` when its plan has several versions."""
    plans = {m.plan for m in steps} | {n.plan for n in notes}
    versions: dict[int, set[int]] = {}
    for item in [*steps, *notes]:
        versions.setdefault(item.plan, set()).add(item.version)
    return [(f"p{m.plan} " if len(plans) > 1 else "") + (f"v{m.version} " if len(versions[m.plan]) > 1 else "")
            for m in steps]


def _note_text(kind: str, t: float, plan: int, version: int, record: Mapping[str, Any]) -> str:
    """A moment's legend row."""
    if kind == "ready":
        goals = " ".join(map(str, record.get("goals", ())))
        text = f"plan {plan} at {t:.1f} s: {record.get('steps', '?')} steps, makespan {record.get('makespan', '?')}"
        return cut_text(text + (f", for {goals}" if goals else ""), _MAX_ROW_CHARS)
    if kind == "replanned":
        counts = ", ".join(f"{len(record.get(k) or ())} {k}" for k in ("kept", "new", "halted", "reassigned")
                           if record.get(k))
        counts = f"; {counts}" if counts else ""
        cause = _one_line(str(record.get("cause", "")))
        return cut_text(f"re-planned at {t:.1f} s (plan {plan} v{version}{counts}): {cause}", _MAX_ROW_CHARS)
    if kind == "abandoned":
        what = "gave up " + " ".join(map(str, record.get("goals", ()))) if record.get("scope") == "goal" \
            else f"plan {plan} abandoned"
        return cut_text(f"{what} at {t:.1f} s: {_one_line(str(record.get('reason', '')))}", _MAX_ROW_CHARS)
    given_up = " ".join(map(str, record.get("abandoned", ())))
    return cut_text(f"plan {plan} done at {t:.1f} s" + (f", gave up {given_up}" if given_up else ""), _MAX_ROW_CHARS)


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


# Helpers --------------------------------------------------------------------


def _overlap(box: tuple[float, float, float, float], others: list[tuple[float, float, float, float]]) -> float:
    """Total area of ``box`` (x0, y0, x1, y1) covered by ``others`` (counting overlaps among them twice)."""
    x0, y0, x1, y1 = box
    return sum(max(0.0, min(x1, b[2]) - max(x0, b[0])) * max(0.0, min(y1, b[3]) - max(y0, b[1])) for b in others)



def _short(text: str) -> str:
    """A task label for the legend: one line, cut short, in parentheses (once)."""
    text = " ".join(str(text).split())
    if text.startswith("(") and text.endswith(")"):
        text = text[1:-1]
    text = cut_text(text, _MAX_LABEL_CHARS)
    return plain_text(f"({text})")


def _ranges(numbers: list[int]) -> str:
    """``[1, 2, 3, 5]`` -> ``"1\u20133, 5"``."""
    parts: list[str] = []
    start = prev = numbers[0]
    for n in numbers[1:] + [None]:  # type: ignore[list-item]
        if n is not None and n == prev + 1:
            prev = n
            continue
        parts.append(str(start) if start == prev else f"{start}\u2013{prev}")
        if n is not None:
            start = prev = n
    return ", ".join(parts)


def _darker(hex_colour: str, factor: float = 0.65) -> tuple[float, float, float]:
    h = hex_colour.lstrip("#")
    return tuple(int(h[i:i + 2], 16) / 255 * factor for i in (0, 2, 4))  # type: ignore[return-value]

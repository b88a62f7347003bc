"""The figures of the seed paper's skill-acquisition experiment (Figs. 12 and 13), drawn from its results.

The experiment writes a ``figures.json``; these functions take it as a
plain dict and draw each figure as a PNG:

* :func:`plot_map_quality` -- Fig. 12(a), map quality per run against the
  threshold;
* :func:`plot_durations` -- Fig. 12(b), run duration per run against the
  optimal time;
* :func:`plot_run_layers` -- Fig. 13(a), the primary layer across the runs,
  each run scaled into its own unit of the x axis;
* :func:`plot_obstacle_layers` -- Fig. 13(b), the primary layer over the
  obstacle scenario's simulated time, with its events: a panel per case
  (person, corridor box, full block), stacked;
* :func:`write_figures` -- all four into one folder.

Over many seeds (``atlas_rap.views.experiment_seeds``: its ``figures.json``
holds each seed's results in ``per_seed`` and the statistics per run in
``summary``), the same figures show the spread: :func:`plot_map_quality_seeds`
and :func:`plot_durations_seeds` the median per run, its inter-quartile range
and its least and greatest; :func:`plot_run_layers_seeds` each layer's share
of a run's time; :func:`plot_obstacle_seeds` one row per seed for each
obstacle case (:func:`obstacle_cases`: a seed's ``obstacles`` is one case or
a list of them); :func:`write_seeds_figures` all of them into one folder.

A ``timeline`` is the list of moments the primary layer switched
(``{"t": seconds from the start, "layer": "I".."IV", ...}``, the first
entry the layer at t = 0); :func:`timeline_spans` turns it into
(layer, start, end) spans and :func:`primary_seconds` into the seconds
each layer was primary.

Layer I is always active, so the layer plots draw it as a thin line
throughout and as a thick bar where it is *primary*, like the other
layers. Each layer has one colour (:data:`LAYER_COLOURS`) in every figure.

Results marked incomplete (``"complete": false``: the experiment was
stopped) say so above every figure's title, in red, with ``incomplete``'s
text ("interrupted after run 3 of 7").

Over 25 KB on purpose: the figures of one experiment, for one seed and
over many seeds, drawn with the same rows of layers, colours, titles and
marks for an incomplete run (the pieces at the end), so that a layer looks
the same in every figure; the figures over many seeds could move to a
module of their own beside those pieces.

Every figure is 800 × 450 px (8 × 4.5 in at 100 dpi), laid out tight;
Fig. 13(b) of several obstacle cases is 260 px taller for each case after
the first.
matplotlib is imported inside the functions (``Figure`` + Agg canvas, no
pyplot and no global state), so importing this module stays cheap. The
same data give the same PNG bytes: no software version or date is
written into the file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from atlas_rap.layers.layer import LAYER_NAMES, primary_seconds, timeline_spans
from atlas_rap.views.page import plain_text
from atlas_rap.views.seed_spec import seeds_text

__all__ = [
    "FIGURE_FILES", "LAYERS", "LAYER_COLOURS", "obstacle_case", "obstacle_case_keys", "obstacle_cases",
    "obstacle_figure_file", "plot_durations", "plot_durations_seeds", "plot_map_quality", "plot_map_quality_seeds",
    "plot_obstacle_layers", "plot_obstacle_seeds", "plot_run_layers", "plot_run_layers_seeds", "primary_seconds",
    "timeline_spans", "write_figures", "write_seeds_figures",
]

LAYERS = LAYER_NAMES
"""The layers, bottom row to top row."""

LAYER_COLOURS: dict[str, str] = {"I": "#4e79a7", "II": "#59a14f", "III": "#f28e2b", "IV": "#e15759"}
"""One colour per layer, the same in every figure."""

FIGURE_FILES = {
    "map_quality": "fig12a-map-quality.png",
    "durations": "fig12b-durations.png",
    "run_layers": "fig13a-layers-per-run.png",
    "obstacle_layers": "fig13b-obstacles.png",
}
"""The file :func:`write_figures` writes for each figure."""

DPI = 100
SIZE_INCHES = (8.0, 4.5)  # 800 x 450 px at DPI

_MEASURED = "#1f4e79"  # measured values (map quality, durations)
_REFERENCE = "#555555"  # threshold and optimal time
_EVENT = "#333333"
_INCOMPLETE = "#c0392b"
_GRID = "#e6e6e6"
_BAR_HEIGHT = 0.5  # of a layer's row (rows are 1 apart)
_THIN_LINE = 1.2  # points, layer I where it is active but not primary


# Figures -------------------------------------------------------------------


def plot_map_quality(data: Mapping[str, Any], path: str | Path) -> Path:
    """Fig. 12(a): the map quality of each run, with the quality threshold dashed; the PNG's path."""
    fig, ax = _figure(_title("Fig. 12(a) map quality per run", data), data)
    runs = _runs(data)
    numbers = [_run_number(run) for run in runs]
    ax.plot(numbers, [float(run["map_quality"]) for run in runs], marker="o", color=_MEASURED,
            linewidth=1.6, markersize=6, label="map quality", clip_on=False, zorder=3)
    threshold = data.get("threshold")
    if threshold is not None:
        ax.axhline(float(threshold), color=_REFERENCE, linestyle="--", linewidth=1.2,
                   label=f"threshold {float(threshold):g}", zorder=2)
    ax.set_ylim(0.0, 1.0)
    _run_axis(ax, numbers)
    ax.set_ylabel("map quality (0\u20131)")
    ax.legend(loc="lower right", fontsize=9, frameon=False)
    return _save(fig, path)


def plot_durations(data: Mapping[str, Any], path: str | Path) -> Path:
    """Fig. 12(b): how long each run took, with each run's optimal time as a dashed step; the PNG's path."""
    fig, ax = _figure(_title("Fig. 12(b) run duration per run", data), data)
    runs = _runs(data)
    numbers = [_run_number(run) for run in runs]
    durations = [float(run["duration_s"]) for run in runs]
    ax.plot(numbers, durations, marker="o", color=_MEASURED, linewidth=1.6, markersize=6,
            label="run duration", zorder=3)
    step_x: list[float] = []
    step_y: list[float] = []
    for number, run in zip(numbers, runs):
        if run.get("optimal_s") is not None:  # each run's optimal time across its own unit of x
            step_x += [number - 0.5, number + 0.5]
            step_y += [float(run["optimal_s"])] * 2
    if step_x:
        ax.plot(step_x, step_y, color=_REFERENCE, linestyle="--", linewidth=1.2, label="optimal time", zorder=2)
    top = max(durations + step_y, default=1.0)
    ax.set_ylim(0.0, top * 1.1 if top > 0 else 1.0)
    _run_axis(ax, numbers)
    ax.set_ylabel("duration (s)")
    ax.legend(loc="upper right", fontsize=9, frameon=False)
    return _save(fig, path)


def plot_run_layers(data: Mapping[str, Any], path: str | Path) -> Path:
    """Fig. 13(a): which layer was primary during each run; the PNG's path.

    Run ``n`` occupies [n - 1, n] on the x axis, its timeline scaled from
    [0, its duration] into that interval; a run without a timeline shows
    no bar.
    """
    fig, ax = _figure(_title("Fig. 13(a) primary layer per run", data), data)
    runs = _runs(data)
    numbers = [_run_number(run) for run in runs]
    bars: list[tuple[str, float, float]] = []
    for number, run in zip(numbers, runs):
        length = _run_length(run)
        if length <= 0:
            continue
        for layer, start, stop in timeline_spans(run.get("timeline") or [], length):
            bars.append((layer, number - 1 + start / length, number - 1 + stop / length))
    x_min, x_max = (min(numbers) - 1, max(numbers)) if numbers else (0, 1)
    _layer_rows(ax, bars, x_min, x_max)
    for boundary in range(x_min + 1, x_max):  # where one run ends and the next starts
        ax.axvline(boundary, color="#bbbbbb", linewidth=0.8, zorder=1)
    ax.set_xlim(x_min, x_max)
    ax.set_xticks([n - 0.5 for n in numbers], [str(n) for n in numbers])  # each run named at its middle
    ax.grid(False, axis="x")
    ax.set_xlabel("run (each run scaled to its own duration)")
    return _save(fig, path)


def plot_obstacle_layers(data: Mapping[str, Any], path: str | Path) -> Path:
    """Fig. 13(b): which layer was primary over each case of the obstacle scenario, its events
    dotted; the PNG's path.

    ``data["obstacles"]`` is one case (a dict) or a list of them (:func:`obstacle_cases`); each
    case is a panel of its own, stacked in the order given, with its own time axis. A case's
    panel is titled with its ``case`` and ``title`` when it has them, and says the layers seen
    in turn (``seen``) and, when they differ, the seed's order (``expected``). One case is drawn
    as every other figure (800 × 450 px); each further case adds :data:`_OBSTACLE_PANEL_INCHES`.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    cases = obstacle_cases(data)
    if len(cases) <= 1:
        fig, ax = _figure(_title("Fig. 13(b) primary layer with obstacles", data), data)
        if cases:
            _obstacle_panel(ax, cases[0])
        return _save(fig, path)
    height = SIZE_INCHES[1] + _OBSTACLE_PANEL_INCHES * (len(cases) - 1)
    fig = Figure(figsize=(SIZE_INCHES[0], height), dpi=DPI, facecolor="white")
    FigureCanvasAgg(fig)
    fig.suptitle(_title("Fig. 13(b) primary layer with obstacles", data), fontsize=11, x=0.01, ha="left")
    if data.get("complete") is False:
        note = plain_text(f"incomplete: {data.get('incomplete') or 'the experiment stopped early'}")
        fig.text(0.99, 1.0 - 0.1 / height, note, fontsize=10, color=_INCOMPLETE, ha="right", va="top")
    for ax, case in zip(fig.subplots(len(cases), 1), cases):
        _style_axes(ax)
        _obstacle_panel(ax, case, _case_heading(case))
    return _save(fig, path)


_OBSTACLE_PANEL_INCHES = 2.6
"""Inches of height each obstacle case after the first adds to Fig. 13(b)."""


def _obstacle_panel(ax: Any, case: Mapping[str, Any], heading: str | None = None) -> None:
    """One case of Fig. 13(b) on ``ax``: the layer rows over its simulated time, its events dotted
    and labelled in a band above the rows; ``heading`` over the panel."""
    duration = _case_length(case) if case.get("end_s") is not None else max(float(case["duration_s"]), 0.0)
    _layer_rows(ax, timeline_spans(case.get("timeline") or [], duration), 0.0, duration)
    events = sorted(case.get("events") or [], key=lambda event: float(event["t"]))
    label_top = len(LAYERS) + 0.5 + (0.75 if events else 0.0)  # a band above the rows for event labels
    for i, event in enumerate(events):
        t = float(event["t"])
        ax.axvline(t, color=_EVENT, linestyle=":", linewidth=1.4, zorder=4)
        right_half = duration > 0 and t > 0.7 * duration
        ax.text(t, label_top - 0.2 - 0.32 * (i % 2), f" {plain_text(event['what'])} ", fontsize=8, color=_EVENT,
                ha="right" if right_half else "left", va="center", zorder=5)
    ax.set_ylim(0.5, label_top)
    ax.set_xlim(0.0, duration if duration > 0 else 1.0)
    ax.set_xlabel("simulated time (s)")
    if heading:
        ax.set_title(heading, fontsize=9, loc="left")


def _case_heading(case: Mapping[str, Any]) -> str:
    """A case's panel heading: its name and title, then the layers seen in turn (and the seed's order
    when they differ)."""
    name = ": ".join(str(case[key]) for key in ("case", "title") if case.get(key))
    seen, expected = case.get("seen"), case.get("expected")
    order = ""
    if seen is not None:
        order = "seen " + (" \u2192 ".join(seen) or "none")
        if expected is not None and list(expected) != list(seen):
            order += "; the seed: " + " \u2192 ".join(expected)
        elif expected is not None:
            order += ", as the seed"
    return plain_text("\n".join(part for part in (name, order) if part))


def _style_axes(ax: Any) -> None:
    """The grid, tick labels and spines every figure's axes have (as :func:`_figure` gives them)."""
    ax.grid(True, color=_GRID, linewidth=0.6, zorder=0)
    ax.set_axisbelow(True)
    ax.tick_params(labelsize=9)
    for spine in ax.spines.values():
        spine.set_color("#999999")


def write_figures(data: Mapping[str, Any], out_dir: str | Path) -> list[Path]:
    """Draw all four figures into ``out_dir`` (created if needed); their paths, Fig. 12(a) to Fig. 13(b)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return [
        plot_map_quality(data, out / FIGURE_FILES["map_quality"]),
        plot_durations(data, out / FIGURE_FILES["durations"]),
        plot_run_layers(data, out / FIGURE_FILES["run_layers"]),
        plot_obstacle_layers(data, out / FIGURE_FILES["obstacle_layers"]),
    ]


# Figures over many seeds -----------------------------------------------------
#
# The multi-seed figures.json (atlas_rap.views.experiment_seeds) holds "seeds", "per_seed" (each seed's
# own figures.json, as above) and "summary": the statistics per run are computed there and drawn here.


def plot_map_quality_seeds(data: Mapping[str, Any], path: str | Path) -> Path:
    """Fig. 12(a) over many seeds: per run the median map quality (line), its inter-quartile range
    (box) and its least and greatest (whiskers), with the threshold dashed; the PNG's path. The
    axis starts a tenth below the lowest value (on 0-1 the spread would not show)."""
    fig, ax = _figure(_title("Fig. 12(a) map quality per run", data), data)
    numbers = _spread(ax, data, "map_quality")
    threshold = data.get("threshold")
    if threshold is not None:
        ax.axhline(float(threshold), color=_REFERENCE, linestyle="--", linewidth=1.2,
                   label=f"threshold {float(threshold):g}", zorder=2)
    lowest = min([float(entry["map_quality"]["min"]) for entry in _per_run(data)]
                 + ([float(threshold)] if threshold is not None else []), default=0.0)
    ax.set_ylim(max(0.0, math.floor(lowest * 10 - 0.5) / 10), 1.0)  # from a tenth below: 0-1 hides the spread
    _run_axis(ax, numbers)
    ax.set_ylabel("map quality (0\u20131)")
    _spread_legend(ax, "lower right")
    return _save(fig, path)


def plot_durations_seeds(data: Mapping[str, Any], path: str | Path) -> Path:
    """Fig. 12(b) over many seeds: per run the median duration (line), its inter-quartile range (box)
    and its shortest and longest (whiskers), with the optimal time as a dashed step; the PNG's path."""
    fig, ax = _figure(_title("Fig. 12(b) run duration per run", data), data)
    numbers = _spread(ax, data, "duration_s")
    step_x: list[float] = []
    step_y: list[float] = []
    for entry in _per_run(data):
        if entry.get("optimal_s") is not None:
            step_x += [int(entry["run"]) - 0.5, int(entry["run"]) + 0.5]
            step_y += [float(entry["optimal_s"])] * 2
    if step_x:
        ax.plot(step_x, step_y, color=_REFERENCE, linestyle="--", linewidth=1.2, label="optimal time", zorder=2)
    top = max([float(entry["duration_s"]["max"]) for entry in _per_run(data)] + step_y, default=1.0)
    ax.set_ylim(0.0, top * 1.1 if top > 0 else 1.0)
    _run_axis(ax, numbers)
    ax.set_ylabel("duration (s)")
    _spread_legend(ax, "upper right")
    return _save(fig, path)


def plot_run_layers_seeds(data: Mapping[str, Any], path: str | Path) -> Path:
    """Fig. 13(a) over many seeds: for each run, the share of its time each layer was primary,
    averaged over the seeds (each seed counts alike), as a stacked bar, layer I at the bottom; the PNG's path.

    The share of the time rather than the layer primary at each run's end: once the map is good
    nearly every run ends with Layer II, before that with Layer IV, so the end alone shows only
    where the switch happened; the shares show that too, and also how much of the switching run
    Layer IV still drove, and Layer I's short stops.
    """
    fig, ax = _figure(_title("Fig. 13(a) primary layer per run", data), data)
    per_run = _per_run(data)
    numbers = [int(entry["run"]) for entry in per_run]
    bottom = [0.0] * len(per_run)
    for layer in LAYERS:
        shares = [float((entry.get("primary_share") or {}).get(layer, 0.0)) for entry in per_run]
        ax.bar(numbers, shares, bottom=bottom, width=0.6, color=LAYER_COLOURS[layer], label=f"layer {layer}",
               zorder=3)
        bottom = [b + s for b, s in zip(bottom, shares)]
    ax.set_ylim(0.0, 1.0)
    _run_axis(ax, numbers)
    ax.set_ylabel("share of the run's time primary")
    handles, labels = ax.get_legend_handles_labels()  # layer IV on top, as in the bars
    ax.legend(handles[::-1], labels[::-1], loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=9, frameon=False,
              title=f"mean of {_seed_count(data)}", title_fontsize=9)
    return _save(fig, path)


def plot_obstacle_seeds(data: Mapping[str, Any], path: str | Path, case: str | None = None) -> Path:
    """Fig. 13(b) over many seeds: the primary layer over the obstacle scenario, one row (a strip
    coloured by the primary layer) per seed, the events dotted; ``case`` is which scenario
    (:func:`obstacle_case_keys`; None: the one scenario of each seed). The PNG's path."""
    from matplotlib.patches import Patch

    rows = [(seed, obstacle_case(one, case)) for seed, one in _seeds_data(data)]
    title = next((str(found["title"]) for _, found in rows if found is not None and found.get("title")), case)
    heading = _title("Fig. 13(b) primary layer with obstacles", data)
    fig, ax = _figure(heading + (f"\n{plain_text(title)}" if title else ""), data)  # the case on a line of its own
    ends = [_case_length(found) for _, found in rows if found is not None]
    duration = max(ends + [0.0])
    for i, (seed, found) in enumerate(rows):  # the first seed at the top
        y = len(rows) - i
        if found is None:
            ax.text(0.0, y, " no obstacle run", fontsize=8, color=_REFERENCE, va="center")
            continue
        for layer, start, stop in timeline_spans(found.get("timeline") or [], _case_length(found)):
            ax.broken_barh([(start, stop - start)], (y - 0.35, 0.7), facecolors=LAYER_COLOURS[layer],
                           edgecolor="none", zorder=3)
    events = sorted({(float(event["t"]), plain_text(event["what"]))
                     for _, found in rows if found is not None for event in found.get("events") or []})
    label_top = len(rows) + 0.5 + (0.4 * min(len(events), 2) + 0.2 if events else 0.0)
    for i, (t, what) in enumerate(events):
        ax.axvline(t, color=_EVENT, linestyle=":", linewidth=1.2, zorder=4)
        right_half = duration > 0 and t > 0.7 * duration
        ax.text(t, label_top - 0.3 - 0.4 * (i % 2), f" {what} ", fontsize=8, color=_EVENT,
                ha="right" if right_half else "left", va="center", zorder=5)
    every = max(1, -(-len(rows) // 20))  # at most about 20 seed labels
    ax.set_yticks([len(rows) - i for i in range(0, len(rows), every)],
                  [f"seed {rows[i][0]}" for i in range(0, len(rows), every)])
    ax.set_ylim(0.5, label_top)
    ax.set_xlim(0.0, duration if duration > 0 else 1.0)
    ax.grid(False, axis="y")
    ax.set_xlabel("simulated time (s)")
    ax.legend(handles=[Patch(color=LAYER_COLOURS[layer], label=f"layer {layer}") for layer in reversed(LAYERS)],
              loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=9, frameon=False, title="primary",
              title_fontsize=9)
    return _save(fig, path)


def obstacle_cases(data: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """One seed's obstacle scenario as a list of cases: ``data["obstacles"]`` is one case (a dict) or
    a list of them, each with at least ``timeline``, ``end_s`` and ``events`` (``case``, a name, and
    ``title`` if it has them); no scenario, no cases."""
    scenario = data.get("obstacles")
    if scenario is None:
        return []
    return [scenario] if isinstance(scenario, Mapping) else list(scenario)


def obstacle_case(one: Mapping[str, Any], key: str | None) -> Mapping[str, Any] | None:
    """The obstacle case ``key`` (:func:`obstacle_case_keys`) of one seed's results; None if it has none."""
    cases = obstacle_cases(one)
    if key is None:
        return cases[0] if isinstance(one.get("obstacles"), Mapping) else None
    return next((case for i, case in enumerate(cases) if _key(case, i) == key), None)


def obstacle_case_keys(data: Mapping[str, Any]) -> list[str | None]:
    """The obstacle cases over all seeds of multi-seed results, in the order first met: a case's
    ``case`` name, else its place in the list ("1", "2", ...); None for the one scenario of a seed
    whose ``obstacles`` is a single dict."""
    keys: list[str | None] = []
    for _, one in _seeds_data(data):
        single = isinstance(one.get("obstacles"), Mapping)
        for i, case in enumerate(obstacle_cases(one)):
            key = None if single else _key(case, i)
            if key not in keys:
                keys.append(key)
    return keys


def obstacle_figure_file(case: str | None) -> str:
    """The file name of Fig. 13(b) for ``case`` (:func:`obstacle_case_keys`): ``fig13b-obstacles.png``
    for the one scenario, ``fig13b-obstacles-NAME.png`` for a named case."""
    if case is None:
        return FIGURE_FILES["obstacle_layers"]
    slug = "".join(c if c.isalnum() else "-" for c in str(case).lower()).strip("-") or "case"
    return FIGURE_FILES["obstacle_layers"].replace(".png", f"-{slug}.png")


def write_seeds_figures(data: Mapping[str, Any], out_dir: str | Path) -> list[Path]:
    """Draw the figures of multi-seed results into ``out_dir`` (created if needed): Fig. 12(a), 12(b),
    13(a), then one Fig. 13(b) per obstacle case; their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = [
        plot_map_quality_seeds(data, out / FIGURE_FILES["map_quality"]),
        plot_durations_seeds(data, out / FIGURE_FILES["durations"]),
        plot_run_layers_seeds(data, out / FIGURE_FILES["run_layers"]),
    ]
    for case in obstacle_case_keys(data):
        written.append(plot_obstacle_seeds(data, out / obstacle_figure_file(case), case))
    return written


def _spread(ax: Any, data: Mapping[str, Any], what: str) -> list[int]:
    """Per run the median of ``what`` over the seeds as a line, its inter-quartile range as a box,
    its least and greatest as whiskers; the run numbers."""
    per_run = _per_run(data)
    numbers = [int(entry["run"]) for entry in per_run]
    stats = [entry[what] for entry in per_run]
    low, high = [float(s["min"]) for s in stats], [float(s["max"]) for s in stats]
    q1, q3 = [float(s["q1"]) for s in stats], [float(s["q3"]) for s in stats]
    ax.vlines(numbers, low, high, color=_MEASURED, linewidth=1.0, label="least to greatest", zorder=3)
    for cap in (low, high):
        ax.hlines(cap, [n - 0.08 for n in numbers], [n + 0.08 for n in numbers], color=_MEASURED, linewidth=1.0,
                  zorder=3)
    ax.bar(numbers, [b - a for a, b in zip(q1, q3)], bottom=q1, width=0.36, color=_MEASURED, alpha=0.3,
           edgecolor=_MEASURED, linewidth=0.8, label="inter-quartile range", zorder=3)
    ax.plot(numbers, [float(s["median"]) for s in stats], marker="o", color=_MEASURED, linewidth=1.6,
            markersize=5, label=f"median of {_seed_count(data)}", clip_on=False, zorder=4)
    return numbers


def _spread_legend(ax: Any, where: str) -> None:
    """The legend of a spread: the median, the inter-quartile range, least to greatest, then the rest."""
    handles, labels = ax.get_legend_handles_labels()
    first = ("median", "inter-quartile", "least")
    order = sorted(range(len(labels)), key=lambda i: next((k for k, word in enumerate(first)
                                                           if labels[i].startswith(word)), len(first)))
    ax.legend([handles[i] for i in order], [labels[i] for i in order], loc=where, fontsize=9, frameon=False)


def _per_run(data: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """The summary's statistics per run, in order of the run number."""
    return sorted((data.get("summary") or {}).get("per_run") or [], key=lambda entry: int(entry["run"]))


def _seeds_data(data: Mapping[str, Any]) -> list[tuple[Any, Mapping[str, Any]]]:
    """(seed, that seed's figures.json) for each seed of multi-seed results, in their order."""
    return [(one.get("seed"), one) for one in data.get("per_seed") or []]


def _seed_count(data: Mapping[str, Any]) -> str:
    """``"10 seeds"``: how many seeds the results hold."""
    count = len(data.get("per_seed") or [])
    return f"{count} seed{'' if count == 1 else 's'}"


def _key(case: Mapping[str, Any], index: int) -> str:
    return str(case.get("case") or index + 1)


def _case_length(case: Mapping[str, Any]) -> float:
    """Seconds an obstacle case lasted: ``end_s`` from its ``start_s`` (0 if it has none)."""
    return max(float(case["end_s"]) - float(case.get("start_s") or 0.0), 0.0)


# Pieces --------------------------------------------------------------------


def _figure(title: str, data: Mapping[str, Any]) -> tuple[Any, Any]:
    """A blank 800 x 450 px figure on an Agg canvas and its one axes, titled; results marked
    incomplete (``"complete": false``) say so in red, right-aligned above the title."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=SIZE_INCHES, dpi=DPI, facecolor="white")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_title(title, fontsize=11, loc="left")
    if data.get("complete") is False:
        note = plain_text(f"incomplete: {data.get('incomplete') or 'the experiment stopped early'}")
        ax.set_title(note + "\n", fontsize=10, loc="right", color=_INCOMPLETE)  # a line above the title
    ax.grid(True, color=_GRID, linewidth=0.6, zorder=0)
    ax.set_axisbelow(True)
    ax.tick_params(labelsize=9)
    for spine in ax.spines.values():
        spine.set_color("#999999")
    return fig, ax


def _save(fig: Any, path: str | Path) -> Path:
    """Lay ``fig`` out tight and write it as a PNG at ``path`` (parent created), without a software name."""
    from atlas_rap.views.page import save_figure_png

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        fig.tight_layout(pad=0.6)
        save_figure_png(fig, out, dpi=DPI)
    finally:
        fig.clear()
    return out


def _title(figure: str, data: Mapping[str, Any]) -> str:
    """The figure's name, then the world and seed of the experiment when the data say them."""
    about = [str(data["world"])] if data.get("world") else []
    if data.get("seed") is not None:
        about.append(f"seed {data['seed']}")
    elif data.get("seeds"):
        about.append(seeds_text(data["seeds"]))
    return plain_text(f"{figure} \u2014 {', '.join(about)}" if about else figure)


def _runs(data: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """The runs in order of their number (a run without one is numbered by its place in the list)."""
    runs = [dict(run, run=run.get("run", i + 1)) for i, run in enumerate(data.get("runs") or [])]
    return sorted(runs, key=_run_number)


def _run_number(run: Mapping[str, Any]) -> int:
    return int(run["run"])


def _run_length(run: Mapping[str, Any]) -> float:
    """Seconds the run lasted: ``end_s - start_s``, else ``duration_s``, else its last switch."""
    if run.get("end_s") is not None and run.get("start_s") is not None:
        return float(run["end_s"]) - float(run["start_s"])
    if run.get("duration_s") is not None:
        return float(run["duration_s"])
    return max((float(entry["t"]) for entry in run.get("timeline") or []), default=0.0)


def _run_axis(ax: Any, numbers: list[int]) -> None:
    """Runs on x as integers, a little room either side."""
    if numbers:
        ax.set_xlim(min(numbers) - 0.5, max(numbers) + 0.5)
        ax.set_xticks(numbers, [str(n) for n in numbers])
    else:
        ax.set_xlim(0.5, 1.5)
        ax.set_xticks([])
    ax.set_xlabel("run")


def _layer_rows(ax: Any, bars: Sequence[tuple[str, float, float]], x_min: float, x_max: float) -> None:
    """Rows I (bottom) .. IV (top), a solid bar where a layer is primary, layer I thin throughout."""
    rows = {layer: i + 1 for i, layer in enumerate(LAYERS)}
    ax.hlines(rows["I"], x_min, x_max, color=LAYER_COLOURS["I"], linewidth=_THIN_LINE, zorder=2)
    for layer in LAYERS:
        extents = [(start, stop - start) for name, start, stop in bars if name == layer]
        if extents:
            ax.broken_barh(extents, (rows[layer] - _BAR_HEIGHT / 2, _BAR_HEIGHT),
                           facecolors=LAYER_COLOURS[layer], edgecolor="none", zorder=3)
    ax.set_yticks([rows[layer] for layer in LAYERS], [f"layer {layer}" for layer in LAYERS])
    for label, layer in zip(ax.get_yticklabels(), LAYERS):
        label.set_color(LAYER_COLOURS[layer])
    ax.set_ylim(0.5, len(LAYERS) + 0.5)
    ax.set_ylabel("primary layer")
    ax.grid(False, axis="y")


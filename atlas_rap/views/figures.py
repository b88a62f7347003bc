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
  obstacle scenario's simulated time, with its events;
* :func:`write_figures` -- all four into one folder.

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

Every figure is 800 × 450 px (8 × 4.5 in at 100 dpi), laid out tight.
matplotlib is imported inside the functions (``Figure`` + Agg canvas, no
pyplot and no global state), so importing this module stays cheap. The
same data give the same PNG bytes: no software version or date is
written into the file.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from atlas_rap.layers.layer import LAYER_NAMES, primary_seconds, timeline_spans
from atlas_rap.views.page import plain_text

__all__ = [
    "FIGURE_FILES", "LAYERS", "LAYER_COLOURS", "plot_durations", "plot_map_quality", "plot_obstacle_layers",
    "plot_run_layers", "primary_seconds", "timeline_spans", "write_figures",
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
    """Fig. 13(b): which layer was primary over the obstacle scenario, its events dotted; the PNG's path."""
    scenario = data["obstacles"]
    fig, ax = _figure(_title("Fig. 13(b) primary layer with obstacles", data), data)
    duration = max(float(scenario["duration_s"]), 0.0)
    _layer_rows(ax, timeline_spans(scenario.get("timeline") or [], duration), 0.0, duration)
    events = sorted(scenario.get("events") or [], key=lambda event: float(event["t"]))
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
    return _save(fig, path)


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


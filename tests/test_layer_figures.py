"""Figures of the skill-acquisition experiment (views.figures): timelines as spans, and the four PNGs."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from matplotlib.image import imread

from atlas_rap.views.figures import (
    LAYER_COLOURS,
    LAYERS,
    plot_durations,
    plot_map_quality,
    plot_obstacle_layers,
    plot_run_layers,
    primary_seconds,
    timeline_spans,
    write_figures,
)

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
SIZE = (450, 800)  # rows, columns: 8 x 4.5 in at 100 dpi
CASE_ROWS = 260  # Fig. 13(b): the rows each obstacle case after the first adds
FILES = ["fig12a-map-quality.png", "fig12b-durations.png", "fig13a-layers-per-run.png", "fig13b-obstacles.png"]


def switches(*moments: tuple[float, str]) -> list[dict]:
    """A timeline: each (t, layer) a switch, ``previous`` the layer before it."""
    timeline, previous = [], None
    for t, layer in moments:
        timeline.append({"t": t, "layer": layer, "previous": previous, "reason": f"to {layer}"})
        previous = layer
    return timeline


def run(number: int, quality: float, duration: float, optimal: float, timeline: list[dict]) -> dict:
    return {"run": number, "map_quality": quality, "duration_s": duration, "optimal_s": optimal,
            "primary_s": primary_seconds(timeline, duration), "timeline": timeline,
            "start_s": 0.0, "end_s": duration}


def experiment() -> dict:
    """Three runs getting better and an obstacle scenario, as the experiment's figures.json holds them."""
    return {
        "world": "lab-corridor-office", "seed": 0, "threshold": 0.9,
        "runs": [
            run(1, 0.71, 120.3, 55.2, switches((0.0, "IV"), (12.5, "I"), (13.5, "IV"))),
            run(2, 0.88, 80.0, 55.4, switches((0.0, "III"), (30.0, "II"), (70.0, "I"), (71.0, "II"))),
            run(3, 0.94, 57.0, 55.3, switches((0.0, "II"))),
        ],
        "obstacles": [
            case("person", "a person crosses", 62.0, switches((0.0, "II"), (12.8, "I"), (14.6, "II")),
                 ["II", "I", "II"], [{"t": 8.5, "what": "a person starts to cross"}]),
            case("corridor-box", "a box blocks one way", 68.4,
                 switches((0.0, "II"), (19.6, "I"), (23.2, "III"), (23.5, "II")), ["II", "I", "III", "II"],
                 [{"t": 0.0, "what": "a box is put down"}]),
            case("full-block", "a block cuts every known way", 97.5,
                 switches((0.0, "II"), (13.8, "I"), (17.5, "IV"), (69.2, "II")), ["II", "I", "IV", "II"],
                 [{"t": 0.0, "what": "a box is put down"}]),
        ],
    }


def case(key: str, title: str, duration: float, timeline: list[dict], expected: list[str],
         events: list[dict]) -> dict:
    """One case of the obstacle scenario as the experiment writes it (the layers seen from its timeline)."""
    seen = [layer for layer, _, _ in timeline_spans(timeline, duration)]
    return {"case": key, "title": title, "world": f"lab-corridor-office-{key}", "expected": expected, "seen": seen,
            "as_expected": seen == expected, "duration_s": duration, "start_s": 0.0, "end_s": duration,
            "optimal_s": 51.8, "timeline": timeline, "events": events, "ok": True}


def one_scenario() -> dict:
    """The older form of ``obstacles``: one scenario, a dict, with a person and a box in one run."""
    return {"duration_s": 90.0, "optimal_s": 55.2,
            "timeline": switches((0.0, "II"), (14.0, "I"), (16.0, "II"), (40.0, "III"), (46.0, "II")),
            "events": [{"t": 14.0, "what": "person crosses"}, {"t": 40.0, "what": "box blocks the corridor"}]}


def size_of(name: str, cases: int = 3) -> tuple[int, int]:
    """The size of a figure in pixels (rows, columns): Fig. 13(b) grows with its obstacle cases."""
    return (SIZE[0] + CASE_ROWS * max(cases - 1, 0), SIZE[1]) if name.startswith("fig13b") else SIZE


# Timelines -----------------------------------------------------------------


def test_spans_follow_the_switches_and_the_last_ends_at_end() -> None:
    spans = timeline_spans(switches((0.0, "IV"), (12.5, "I"), (13.5, "IV")), 120.3)
    assert spans == [("IV", 0.0, 12.5), ("I", 12.5, 13.5), ("IV", 13.5, 120.3)]


def test_spans_merge_consecutive_entries_of_one_layer() -> None:
    timeline = switches((0.0, "II"), (5.0, "II"), (8.0, "III"), (9.0, "III"), (9.5, "III"), (12.0, "II"))
    assert timeline_spans(timeline, 20.0) == [("II", 0.0, 8.0), ("III", 8.0, 12.0), ("II", 12.0, 20.0)]


def test_spans_drop_switches_of_no_length_and_stop_at_end() -> None:
    timeline = switches((0.0, "I"), (3.0, "IV"), (3.0, "I"), (6.0, "II"), (15.0, "III"))
    assert timeline_spans(timeline, 10.0) == [("I", 0.0, 6.0), ("II", 6.0, 10.0)]


def test_spans_of_an_empty_timeline() -> None:
    assert timeline_spans([], 42.0) == []
    assert primary_seconds([], 42.0) == {"I": 0.0, "II": 0.0, "III": 0.0, "IV": 0.0}


def test_an_unknown_layer_is_an_error() -> None:
    with pytest.raises(ValueError, match="V"):
        timeline_spans(switches((0.0, "I"), (1.0, "V")), 2.0)


@pytest.mark.parametrize("case", experiment()["runs"], ids=lambda r: f"run {r['run']}")
def test_primary_seconds_has_every_layer_and_sums_to_the_duration(case: dict) -> None:
    seconds = primary_seconds(case["timeline"], case["duration_s"])
    assert list(seconds) == list(LAYERS)
    assert sum(seconds.values()) == pytest.approx(case["duration_s"])


def test_primary_seconds_of_a_run() -> None:
    seconds = primary_seconds(switches((0.0, "IV"), (12.5, "I"), (13.5, "IV")), 120.3)
    assert seconds == pytest.approx({"I": 1.0, "II": 0.0, "III": 0.0, "IV": 119.3})


# Figures -------------------------------------------------------------------


def assert_png(path, size=SIZE) -> None:
    assert path.is_file(), path
    assert path.read_bytes()[:8] == PNG_MAGIC, path
    assert imread(path).shape[:2] == size, path


def test_write_figures_writes_the_four_pngs(tmp_path) -> None:
    out = tmp_path / "results" / "figures"  # does not exist yet
    paths = write_figures(experiment(), out)
    assert [p.name for p in paths] == FILES
    assert all(p.parent == out for p in paths)
    for path in paths:
        assert_png(path, size_of(path.name))


def test_each_plot_writes_where_it_is_told(tmp_path) -> None:
    data = experiment()
    for plot, name in zip((plot_map_quality, plot_durations, plot_run_layers, plot_obstacle_layers), FILES):
        path = plot(data, tmp_path / "one" / name)
        assert path == tmp_path / "one" / name
        assert_png(path, size_of(name))


def test_the_obstacle_figure_has_a_panel_per_case_stacked_in_their_order(tmp_path) -> None:
    cases = experiment()["obstacles"]
    for count in (1, 2, 3):
        path = plot_obstacle_layers({"obstacles": cases[:count]}, tmp_path / f"{count}.png")
        assert_png(path, (SIZE[0] + CASE_ROWS * (count - 1), SIZE[1]))
    # each case in its own panel, in order: Layer IV's bar (the full block's) only in the third
    image = imread(tmp_path / "3.png")[..., :3]
    bars = (abs(image - to_rgb(LAYER_COLOURS["IV"])) < 0.02).all(axis=2)[:, 150:]  # right of the row labels
    panels = [band.sum() for band in np.array_split(bars, 3)]
    assert panels[0] == panels[1] == 0 and panels[2] > 2000, panels


def test_an_older_figures_json_with_one_obstacle_scenario_is_drawn_as_one_panel(tmp_path) -> None:
    data = experiment()
    data["obstacles"] = one_scenario()
    assert_png(plot_obstacle_layers(data, tmp_path / "fig13b.png"))
    data["obstacles"] = [one_scenario()]  # a list of one: the same figure
    assert_png(plot_obstacle_layers(data, tmp_path / "fig13b-list.png"))
    assert (tmp_path / "fig13b.png").read_bytes() == (tmp_path / "fig13b-list.png").read_bytes()


def test_a_figure_is_not_blank(tmp_path) -> None:
    image = imread(plot_run_layers(experiment(), tmp_path / "layers.png"))[..., :3]
    assert (image < 0.9).any(axis=2).mean() > 0.05  # bars, labels and axes cover part of it


def test_the_same_data_give_the_same_bytes(tmp_path) -> None:
    first = write_figures(experiment(), tmp_path / "first")
    second = write_figures(experiment(), tmp_path / "second")
    for a, b in zip(first, second):
        assert a.read_bytes() == b.read_bytes(), a.name


def test_a_run_with_an_empty_timeline_is_drawn_without_a_bar(tmp_path) -> None:
    data = experiment()
    data["runs"][1]["timeline"] = []
    data["obstacles"][1]["timeline"] = []
    empty = write_figures(data, tmp_path / "empty")
    for path in empty:
        assert_png(path, size_of(path.name))
    full = write_figures(experiment(), tmp_path / "full")
    # the runs picture differs (run 2 has no bar now); the figures of Fig. 12 do not
    assert empty[2].read_bytes() != full[2].read_bytes()
    assert empty[0].read_bytes() == full[0].read_bytes()


def test_runs_without_any_timeline_or_events(tmp_path) -> None:
    data = experiment()
    for one in data["runs"] + data["obstacles"]:
        one["timeline"] = []
        one["events"] = []
    for path in write_figures(data, tmp_path):
        assert_png(path, size_of(path.name))


def test_layers_keep_their_colour_in_every_figure(tmp_path) -> None:
    """The row of layer II shows the same colour in Fig. 13(a) and Fig. 13(b)."""
    data = experiment()
    data["runs"] = [run(1, 0.9, 10.0, 9.0, switches((0.0, "II")))]
    for one in data["obstacles"]:
        one["timeline"] = switches((0.0, "II"))
    paths = write_figures(data, tmp_path)
    green = to_rgb(LAYER_COLOURS["II"])
    for path in paths[2:]:
        image = imread(path)[..., :3]
        close = (abs(image - green) < 0.02).all(axis=2)
        assert close.mean() > 0.05, path.name

"""The skill-acquisition experiment over many seeds (views.experiment_seeds, `--seeds`): the seed
sets, the statistics over seeds, the same results whatever the number of processes, Ctrl-C, the figures.

The real runs are tiny (one errand a seed, no obstacle scenario): what is tested here is how
seeds are run and gathered, not what the layers do (tests/test_layers.py).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import threading
from pathlib import Path

import pytest
from click.testing import CliRunner
from matplotlib.image import imread

from atlas_rap.cli.experiment import _result_files
from atlas_rap.cli.main import cli
from atlas_rap.outputs import OutputUsageError
from atlas_rap.views.experiment import Settings, skill_acquisition, write_results
from atlas_rap.views.experiment_seeds import (
    combine,
    seed_outcome,
    skill_acquisition_seeds,
    summary,
    write_seeds_results,
)
from atlas_rap.views.figures import (
    LAYERS,
    obstacle_figure_file,
    plot_durations_seeds,
    plot_map_quality_seeds,
    plot_obstacle_seeds,
    plot_run_layers_seeds,
    primary_seconds,
    write_seeds_figures,
)
from atlas_rap.views.seed_spec import parse_seeds, seeds_text
from cli_process import ENV, atlas_command

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
SIZE = (450, 800)  # rows, columns: 8 x 4.5 in at 100 dpi
TINY = Settings(runs=1, obstacles=None)  # one errand a seed: about 2 s of work


# -- seed sets ------------------------------------------------------------------------------------


@pytest.mark.parametrize("spec, seeds", [
    ("0-9", tuple(range(10))),
    ("0,3,5", (0, 3, 5)),
    ("2-4,7", (2, 3, 4, 7)),
    ("7", (7,)),
    (" 7 , 2-3 ", (2, 3, 7)),  # spaces allowed; the seeds come out in increasing order
    ("4-4", (4,)),
])
def test_a_seed_set_names_its_seeds_in_increasing_order(spec, seeds):
    assert parse_seeds(spec) == seeds


@pytest.mark.parametrize("spec, message", [
    ("9-0", "9-0: the range goes down; write it from the smaller seed, 0-9"),
    ("a", "'a' is not a seed or a range of seeds; write them as N or N-M"),
    ("-1", "'-1' is not a seed or a range of seeds"),
    ("3-", "'3-' is not a seed or a range of seeds"),
    ("1,,2", "an empty part is not a seed or a range of seeds"),
    ("", "no seeds given"),
    ("0-3,2", "seed 2 is given twice"),
    ("0-1000", "more than 1000 seeds"),
    ("9223372036854775808", "a seed is at most 2**63 - 1"),
])
def test_a_bad_seed_set_says_what_is_wrong(spec, message):
    with pytest.raises(ValueError) as caught:
        parse_seeds(spec)
    assert message in str(caught.value)


@pytest.mark.parametrize("seeds, text", [
    ((0, 1, 2, 3, 4, 5, 6, 7, 8, 9), "seeds 0\u20139"), ((4,), "seed 4"), ((7, 2, 3, 4), "seeds 2\u20134, 7"),
    ((0, 1, 5), "seeds 0, 1, 5"),
])
def test_seeds_are_written_back_the_short_way(seeds, text):
    assert seeds_text(seeds) == text


@pytest.mark.parametrize("args, message", [
    (["--seeds", "9-0"], "Invalid value for '--seeds': 9-0: the range goes down; write it from the smaller seed, 0-9"),
    (["--seeds", "a"], "Invalid value for '--seeds': 'a' is not a seed or a range of seeds"),
    (["--seeds", "0-2", "--seed", "1"], "--seed and --seeds: give one of them"),
    (["--seed", "1", "--jobs", "2"], "--jobs: with --seed there is one seed to run"),
    (["--seeds", "0-1", "--jobs", "0"], "Invalid value for '--jobs'"),
])
def test_the_command_refuses_bad_seed_options_as_usage_errors(tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    done = CliRunner().invoke(cli, ["experiment", "skill-acquisition", *args, "--out", "out"])
    assert done.exit_code == 2, done.output
    assert message in done.output
    assert not (tmp_path / "out" / "figures.json").exists()


def test_the_multi_seed_form_refuses_an_input_among_the_files_of_its_seed_folders(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out" / "seed-3").mkdir(parents=True)
    (tmp_path / "out" / "seed-3" / "errand.rap").write_text("(initial-memory)\n", encoding="utf-8")
    done = CliRunner().invoke(cli, ["experiment", "skill-acquisition", "--layer-rules", "out/seed-3/errand.rap",
                                    "--out", "out"])
    assert isinstance(done.exception, OutputUsageError) and done.exception.exit_code == 2, done.output
    assert "writes errand.rap, which is the input --layer-rules" in str(done.exception)


# -- the statistics over seeds, on hand-made results -----------------------------------------------


def a_run(number: int, quality: float, duration: float, layers: dict[str, float] | None = None) -> dict:
    layers = layers or {"IV": duration}
    return {"run": number, "ok": True, "ended_by": "done", "map_quality": quality, "map_agreement": 0.95,
            "pose_rmse_m": 0.1, "duration_s": duration, "timeline": [], "start_s": 0.0, "end_s": duration,
            "primary_s": {layer: layers.get(layer, 0.0) for layer in LAYERS}, "path_m": 40.0, "optimal_s": 50.0}


def a_seed(seed: int, runs: list[dict], obstacles=None, complete: bool = True) -> dict:
    data = {"world": "lab-corridor-office", "seed": seed, "localisation": "mcl", "threshold": 0.9, "runs": runs,
            "runs_asked": 4, "complete": complete}
    if not complete:
        data["incomplete"] = f"interrupted after run {len(runs)} of 4"
    if obstacles is not None:
        data["obstacles"] = obstacles
    return data


def switches(*moments: tuple[float, str]) -> list[dict]:
    return [{"t": t, "layer": layer, "reason": f"to {layer}"} for t, layer in moments]


def a_case(name: str | None, end: float, *moments: tuple[float, str]) -> dict:
    case = {"timeline": switches(*moments), "end_s": end, "events": [{"t": 9.0, "what": "a person crosses"}]}
    if name is not None:
        case.update(case=name, title=f"the {name}")
    return case


def four_seeds() -> list[dict]:
    """Seeds 0-3 of four runs; their map quality crosses 0.9 in run 2, 3, 3 and never."""
    return [
        a_seed(0, [a_run(1, 0.80, 100.0), a_run(2, 0.91, 70.0), a_run(3, 0.95, 60.0), a_run(4, 0.95, 58.0)]),
        a_seed(1, [a_run(1, 0.70, 110.0), a_run(2, 0.85, 80.0), a_run(3, 0.90, 62.0), a_run(4, 0.93, 61.0)]),
        a_seed(2, [a_run(1, 0.75, 120.0), a_run(2, 0.88, 90.0), a_run(3, 0.92, 64.0), a_run(4, 0.94, 66.0)]),
        a_seed(3, [a_run(1, 0.60, 160.0, {"IV": 150.0, "I": 10.0}), a_run(2, 0.70, 150.0), a_run(3, 0.80, 140.0),
                   a_run(4, 0.85, 130.0)]),
    ]


def test_per_run_the_median_quartiles_least_and_greatest_over_the_seeds():
    stats = summary(four_seeds(), 4)
    first = stats["per_run"][0]
    assert first["run"] == 1 and first["seeds"] == 4
    # durations 100, 110, 120, 160: linear quartiles at positions 0.75, 1.5 and 2.25 of the sorted values
    assert first["duration_s"] == {"median": 115.0, "q1": 107.5, "q3": 130.0, "min": 100.0, "max": 160.0}
    # quality 0.60, 0.70, 0.75, 0.80
    assert first["map_quality"] == pytest.approx({"median": 0.725, "q1": 0.675, "q3": 0.7625, "min": 0.6,
                                                  "max": 0.8})
    assert first["optimal_s"] == 50.0
    # seed 3 spent a sixteenth of run 1 with layer I primary; the others none
    assert first["primary_share"] == pytest.approx({"I": 0.0156, "II": 0.0, "III": 0.0, "IV": 0.9844}, abs=1e-4)
    assert [entry["run"] for entry in stats["per_run"]] == [1, 2, 3, 4]


def test_crossed_in_says_for_each_seed_the_first_run_at_the_threshold_and_counts_them():
    stats = summary(four_seeds(), 4)
    assert stats["crossed_in"]["by_seed"] == {"0": 2, "1": 3, "2": 3, "3": None}  # seed 1: exactly 0.90 counts
    assert stats["crossed_in"]["histogram"] == {"1": 0, "2": 1, "3": 2, "4": 0, "never": 1}


def test_a_run_in_which_layer_iv_handed_over_to_layer_ii_is_the_crossing_run_though_it_ends_under_it():
    seed = four_seeds()[3]
    seed["runs"][1]["timeline"] = [{"t": 0.0, "layer": "IV", "previous": None, "reason": "map-immature"},
                                   {"t": 40.0, "layer": "II", "previous": "IV", "reason": "map-mature"}]
    seed["runs"][1]["map_quality"] = 0.898  # measured at 0.90 while driving; a little less at the end
    assert seed_outcome(seed)["crossed_in"] == 2
    seed["runs"][1]["timeline"][1]["previous"] = "I"  # back to II after an obstacle: not the map found good
    assert seed_outcome(seed)["crossed_in"] is None


def test_after_crossing_the_median_duration_of_the_runs_after_the_crossing_run_against_optimal():
    stats = summary(four_seeds(), 4)
    # seed 0: runs 3 and 4 (60, 58); seeds 1 and 2: run 4 (61, 66); seed 3 never crossed
    after = stats["after_crossing"]
    assert after["runs"] == 4 and after["median_duration_s"] == 60.5 and after["optimal_s"] == 50.0
    assert after["ratio_to_optimal"] == 1.21
    assert after["by_seed"] == {"0": {"runs": 2, "median_duration_s": 59.0},
                                "1": {"runs": 1, "median_duration_s": 61.0},
                                "2": {"runs": 1, "median_duration_s": 66.0},
                                "3": {"runs": 0, "median_duration_s": None}}


def test_a_seed_outcome_is_what_its_line_says():
    outcome = seed_outcome(four_seeds()[0])
    assert outcome["crossed_in"] == 2 and outcome["runs_after"] == 2 and outcome["median_after_s"] == 59.0
    assert outcome["failed"] == 0 and outcome["obstacles"] == []


def test_no_crossing_anywhere_leaves_the_after_crossing_values_empty():
    seeds = [a_seed(0, [a_run(1, 0.5, 100.0)]), a_seed(1, [a_run(1, 0.6, 90.0)])]
    stats = summary(seeds, 1)
    assert stats["crossed_in"]["histogram"] == {"1": 0, "never": 2}
    assert stats["after_crossing"] == {"runs": 0, "median_duration_s": None, "optimal_s": None,
                                       "ratio_to_optimal": None,
                                       "by_seed": {"0": {"runs": 0, "median_duration_s": None},
                                                   "1": {"runs": 0, "median_duration_s": None}}}


def test_one_obstacle_scenario_per_seed_is_carried_through_with_its_layers():
    seeds = [a_seed(0, [a_run(1, 0.9, 60.0)], a_case(None, 70.0, (0.0, "II"), (13.0, "I"), (15.0, "II"))),
             a_seed(1, [a_run(1, 0.9, 60.0)], a_case(None, 80.0, (0.0, "II"), (30.0, "III"), (36.0, "II"))),
             a_seed(2, [a_run(1, 0.9, 60.0)], complete=False)]  # stopped before its obstacle run
    (case,) = summary(seeds, 1)["obstacles"]
    assert case == {"case": None, "title": None, "by_seed": {"0": {"end_s": 70.0, "layers": ["II", "I", "II"]},
                                                             "1": {"end_s": 80.0, "layers": ["II", "III", "II"]}}}


def test_a_list_of_obstacle_cases_is_summarised_case_by_case():
    cases = [a_case("person", 50.0, (0.0, "II"), (10.0, "I"), (12.0, "II")),
             a_case("box", 90.0, (0.0, "II"), (30.0, "III"), (40.0, "II"))]
    seeds = [a_seed(0, [a_run(1, 0.9, 60.0)], cases), a_seed(1, [a_run(1, 0.9, 60.0)], cases[1:])]
    person, box = summary(seeds, 1)["obstacles"]
    assert person["case"] == "person" and person["title"] == "the person" and list(person["by_seed"]) == ["0"]
    assert box["case"] == "box" and box["by_seed"]["1"] == {"end_s": 90.0, "layers": ["II", "III", "II"]}


def test_combined_results_are_incomplete_when_a_seed_is_missing_or_stopped():
    seeds = four_seeds()
    whole = combine(Settings(runs=4), (0, 1, 2, 3), seeds, interrupted=False)
    assert whole["complete"] is True and "incomplete" not in whole
    assert list(whole) == ["seeds", "threshold", "world", "localisation", "runs_asked", "complete", "per_seed",
                           "summary"]
    stopped = [*seeds[:2], a_seed(2, seeds[2]["runs"][:1], complete=False)]
    part = combine(Settings(runs=4), (0, 1, 2, 3), stopped, interrupted=True)
    assert part["complete"] is False
    assert part["incomplete"] == "interrupted with 2 of 4 seeds complete (seed 2 interrupted after run 1 of 4)"
    assert part["summary"]["per_run"][1]["seeds"] == 2  # run 2: seeds 0 and 1 only


# -- real runs, in one process and in two -----------------------------------------------------------


@pytest.fixture(scope="module")
def two_ways(tmp_path_factory):
    """Seeds 0 and 1, one errand each, run in this process and in two worker processes, written."""
    folders = {}
    for jobs in (1, 2):
        out = tmp_path_factory.mktemp(f"jobs{jobs}")
        ended: list[int] = []
        data = skill_acquisition_seeds(out, TINY, [1, 0], jobs=jobs, finished=lambda one: ended.append(one["seed"]))
        write_seeds_results(data, out)
        folders[jobs] = (out, data, ended)
    return folders


def files_under(folder: Path) -> dict[str, bytes]:
    return {str(path.relative_to(folder)): path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


def test_the_same_seeds_give_the_same_files_byte_for_byte_in_one_process_or_two(two_ways):
    (one, data_one, ended_one), (two, _, ended_two) = two_ways[1], two_ways[2]
    assert sorted(ended_one) == sorted(ended_two) == [0, 1]
    assert data_one["seeds"] == [0, 1] and [s["seed"] for s in data_one["per_seed"]] == [0, 1]
    assert data_one["complete"] is True
    first, second = files_under(one), files_under(two)
    assert list(first) == list(second)
    different = [name for name in first if first[name] != second[name]]
    assert different == []
    assert {"figures.json", "runs.csv", "seed-0/figures.json", "seed-1/map-run1.npz"} <= set(first)


def test_each_seed_folder_holds_what_the_single_seed_form_writes_for_that_seed(two_ways, tmp_path):
    out, _, _ = two_ways[2]
    data = skill_acquisition(tmp_path, Settings(runs=1, obstacles=None, seed=1))
    write_results(data, tmp_path)
    assert files_under(out / "seed-1") == files_under(tmp_path)


def test_the_combined_files_hold_every_seed(two_ways):
    out, data, _ = two_ways[2]
    stored = json.loads((out / "figures.json").read_text(encoding="utf-8"))
    assert stored == data
    assert [one["seed"] for one in stored["per_seed"]] == [0, 1]
    assert stored["per_seed"][1] == json.loads((out / "seed-1" / "figures.json").read_text(encoding="utf-8"))
    assert stored["summary"]["per_run"][0]["seeds"] == 2
    rows = (out / "runs.csv").read_text(encoding="utf-8").splitlines()
    assert rows[0].startswith("seed,run,map_quality,map_agreement,pose_rmse_m,duration_s,optimal_s")
    assert [row.split(",")[:2] for row in rows[1:]] == [["0", "1"], ["1", "1"]]


def test_the_result_file_patterns_cover_every_file_the_multi_seed_form_writes(two_ways):
    out, _, _ = two_ways[2]
    covered = {path for pattern in _result_files() for path in out.glob(pattern)}
    written = {path for path in out.rglob("*") if path.is_file()}
    assert written - covered == set()


# -- Ctrl-C ---------------------------------------------------------------------------------------


@pytest.mark.skipif(threading.current_thread() is not threading.main_thread(), reason="signals need the main thread")
def test_ctrl_c_in_the_parent_alone_stops_the_seeds_running_in_the_workers(tmp_path):
    """SIGINT to the parent only (kill -INT), while run 2 of a seed drives: the parent passes it on."""
    heard: list[str] = []

    def progress(what: str) -> None:  # "seed 0: run 2 of 3"
        heard.append(what)
        if what.endswith("run 2 of 3") and sum(h.endswith("run 2 of 3") for h in heard) == 1:
            os.kill(os.getpid(), signal.SIGINT)

    data = skill_acquisition_seeds(tmp_path, Settings(runs=3, obstacles=None), [0, 1, 2], jobs=2, progress=progress)
    assert data["complete"] is False
    assert data["incomplete"].startswith("interrupted with 0 of 3 seeds complete")
    ran = {one["seed"]: one for one in data["per_seed"]}
    assert 2 not in ran and set(ran) <= {0, 1}, heard  # seed 2 waited for a worker: it never started
    first = int(next(h for h in heard if h.endswith("run 2 of 3")).split(":")[0].split()[1])
    assert len(ran[first]["runs"]) in (1, 2)  # it finished run 1 and was stopped before the end of run 3
    for one in ran.values():
        assert one["complete"] is False and len(one["runs"]) < 3
        assert json.loads((tmp_path / f"seed-{one['seed']}" / "figures.json").read_text())["complete"] is False
    assert not (tmp_path / "seed-2").exists()


def test_ctrl_c_from_a_terminal_exits_130_and_writes_the_results_marked_incomplete(tmp_path):
    """Ctrl-C as a terminal sends it: to every process of the group, once a seed has ended."""
    process = subprocess.Popen(atlas_command("experiment", "skill-acquisition", "--seeds", "0-3", "--jobs", "2",
                                             "--runs", "2", "--obstacles", "none", "--out", "out"),
                               cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env={**ENV, "PYTHONUNBUFFERED": "1"}, start_new_session=True)
    try:
        for line in process.stdout:
            if line.startswith("seed "):
                break
        else:
            raise AssertionError(f"no seed ended: {process.stderr.read()}")
        os.killpg(process.pid, signal.SIGINT)
        out, err = process.communicate(timeout=120)
    finally:
        process.kill()
    assert "Traceback" not in out + err, err
    assert process.returncode == 130, out + err
    ended = int(line.split()[1].rstrip(":"))
    data = json.loads((tmp_path / "out" / "figures.json").read_text(encoding="utf-8"))
    assert data["complete"] is False and data["seeds"] == [0, 1, 2, 3]
    assert "the results are marked incomplete" in err and data["incomplete"] in err
    ran = {one["seed"]: one for one in data["per_seed"]}
    assert ran[ended]["complete"] is True and len(ran[ended]["runs"]) == 2
    assert len(ran) < 4 or not all(one["complete"] for one in ran.values())
    for name in ("fig12a-map-quality", "fig12b-durations", "fig13a-layers-per-run"):
        assert (tmp_path / "out" / f"{name}.png").read_bytes()[:8] == PNG_MAGIC
    assert (tmp_path / "out" / f"seed-{ended}" / "figures.json").is_file()
    assert not [path for path in (tmp_path / "out").rglob("*") if path.name.endswith(".part")]


# -- figures over seeds -------------------------------------------------------------------------


def hand_made(obstacles_as_list: bool = False) -> dict:
    seeds = four_seeds()
    for one in seeds:
        for run in one["runs"]:
            run["timeline"] = switches((0.0, "IV")) if run["map_quality"] < 0.9 else switches((0.0, "II"))
            run["primary_s"] = primary_seconds(run["timeline"], run["duration_s"])
        person = a_case("person", 50.0 + one["seed"], (0.0, "II"), (10.0, "I"), (12.0, "II"))
        box = a_case("box", 90.0, (0.0, "II"), (30.0, "III"), (40.0 + one["seed"], "II"))
        one["obstacles"] = [person, box] if obstacles_as_list else {k: v for k, v in person.items()
                                                                     if k not in ("case", "title")}
    return combine(Settings(runs=4), (0, 1, 2, 3), seeds, interrupted=False)


def assert_png(path: Path) -> None:
    assert path.read_bytes()[:8] == PNG_MAGIC, path
    assert imread(path).shape[:2] == SIZE, path


def test_write_seeds_figures_draws_fig_12_13a_and_one_13b_per_obstacle_case(tmp_path):
    paths = write_seeds_figures(hand_made(obstacles_as_list=True), tmp_path / "new")
    assert [p.name for p in paths] == ["fig12a-map-quality.png", "fig12b-durations.png", "fig13a-layers-per-run.png",
                                       "fig13b-obstacles-person.png", "fig13b-obstacles-box.png"]
    for path in paths:
        assert_png(path)
    (single,) = write_seeds_figures(hand_made(), tmp_path / "one")[3:]
    assert single.name == "fig13b-obstacles.png" == obstacle_figure_file(None)
    assert_png(single)


def test_each_plot_over_seeds_writes_where_it_is_told_and_is_not_blank(tmp_path):
    data = hand_made()
    for plot in (plot_map_quality_seeds, plot_durations_seeds, plot_run_layers_seeds, plot_obstacle_seeds):
        path = plot(data, tmp_path / f"{plot.__name__}.png")
        assert path == tmp_path / f"{plot.__name__}.png"
        assert_png(path)
        image = imread(path)[..., :3]
        assert (image < 0.9).any(axis=2).mean() > 0.02, path.name


def test_the_spread_is_drawn_from_the_summary(tmp_path):
    data = hand_made()
    before = plot_durations_seeds(data, tmp_path / "before.png").read_bytes()
    data["summary"]["per_run"][0]["duration_s"]["max"] = 400.0  # a longer whisker
    assert plot_durations_seeds(data, tmp_path / "after.png").read_bytes() != before


def test_the_same_results_give_the_same_figure_bytes_and_incomplete_ones_say_so(tmp_path):
    first = write_seeds_figures(hand_made(), tmp_path / "first")
    second = write_seeds_figures(hand_made(), tmp_path / "second")
    assert [a.read_bytes() for a in first] == [b.read_bytes() for b in second]
    stopped = hand_made()
    stopped.update(complete=False, incomplete="interrupted with 3 of 4 seeds complete")
    marked = write_seeds_figures(stopped, tmp_path / "stopped")
    red = imread(marked[0])[..., :3]
    reddish = (red[..., 0] > 0.6) & (red[..., 1] < 0.35) & (red[..., 2] < 0.3)  # the note, #c0392b
    assert reddish[:60].sum() > 50 and not reddish[60:].any()
    assert all(a.read_bytes() != b.read_bytes() for a, b in zip(first, marked))

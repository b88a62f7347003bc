"""The skill-acquisition experiment as it ships: the default odometry noise, the pose corrected against
the map being built, the shipped rules, several seeds at once (the Benchmarks page's figures, docs/benchmarks.md, are of seeds 0-9:
``python benchmarks/bench_layers.py --only layers-experiment-seeds``).

What is checked is what the docs claim of every seed, not of a chosen one.
"""

from __future__ import annotations

import statistics

import pytest

from atlas_rap.views.experiment import Settings
from atlas_rap.views.experiment_seeds import crossing_run, skill_acquisition_seeds

SEEDS = (0, 1, 2, 3)
RUNS = 4


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    out = tmp_path_factory.mktemp("seeds")
    return skill_acquisition_seeds(out, Settings(runs=RUNS, obstacles=None), SEEDS, jobs=2)


def test_every_errand_gets_there_and_back_without_a_prior_map_while_layer_iv_maps_and_after(experiment):
    for one in experiment["per_seed"]:
        assert [run["ok"] for run in one["runs"]] == [True] * RUNS, one["seed"]
        first = one["runs"][0]
        assert first["timeline"][0]["layer"] == "IV" and first["primary_s"]["IV"] > 0.5 * first["duration_s"]


def test_the_map_of_the_errands_area_does_not_get_worse_while_layer_iv_maps_and_stays_once_it_stops(experiment):
    for one in experiment["per_seed"]:
        qualities = [run["map_quality"] for run in one["runs"]]
        for before, run in zip(qualities, one["runs"][1:]):
            if run["primary_s"]["IV"] > 0:  # mapping: the same area seen again
                assert run["map_quality"] >= before - 0.005, (one["seed"], qualities)
            elif run["primary_s"]["III"] == 0:  # mapping is over: the map is carried as it is
                assert run["map_quality"] == before, (one["seed"], qualities)
            else:  # ... but for a block Layer III assessed and put on it (the world's visitor, lingering)
                assert run["map_quality"] >= before - 0.01, (one["seed"], qualities)
        if all(run["primary_s"]["IV"] > 0 for run in one["runs"]):  # never good enough: still it rose
            assert qualities[-1] > qualities[0], (one["seed"], qualities)


def test_one_errand_leaves_the_map_short_and_the_runs_after_it_raise_it_by_a_twentieth(experiment):
    """Fig. 12a's shape (issue 28): the survey of the errand's area after one errand there and back is
    short of the threshold, and the runs after it, which see the area again and look where it is
    unsure, raise it by 0.05 or more over runs 1-3 (the benchmark reports seeds 0-39)."""
    for one in experiment["per_seed"]:
        qualities = [run["map_quality"] for run in one["runs"]]
        assert qualities[0] < one["threshold"] - 0.05, (one["seed"], qualities)
        assert qualities[2] - qualities[0] >= 0.05, (one["seed"], qualities)


def test_after_the_switch_layer_ii_drives_each_run_within_a_quarter_of_the_optimal_time(experiment):
    after = []
    for one in experiment["per_seed"]:
        crossed = crossing_run(one)
        for run in one["runs"]:
            if crossed is not None and run["run"] > crossed:
                if run["timeline"][0]["layer"] == "IV":
                    # the run before ended with the map under the threshold (a block Layer III assessed
                    # lowered it): Layer IV maps again until it crosses, then Layer II drives
                    assert run["timeline"][-1]["layer"] == "II", (one["seed"], run["timeline"])
                    assert run["primary_s"]["IV"] < 0.6 * run["duration_s"], (one["seed"], run["primary_s"])
                else:
                    # Layer II drives; Layer I (and III) while something is in the way, and Layer IV for
                    # the seconds it takes to map again where a block Layer III put on the map lowered it
                    assert run["primary_s"]["II"] > 0.9 * run["duration_s"], (one["seed"], run["primary_s"])
                after.append(run["duration_s"] / run["optimal_s"])
    assert after, "no seed switched to Layer II"
    assert statistics.median(after) <= 1.25, after
    assert experiment["summary"]["after_crossing"]["ratio_to_optimal"] <= 1.25


def test_the_runs_mapping_drive_at_top_speed_and_the_figures_say_how_long_their_paths_take_at_it(experiment):
    for one in experiment["per_seed"]:
        for run in one["runs"]:
            # both figures are rounded to 0.01: 0.005 of the time and 0.005 / 0.6 of the path apart at most
            assert run["path_at_top_speed_s"] == pytest.approx(run["path_m"] / 0.6, abs=0.014)
            assert run["duration_s"] >= run["path_at_top_speed_s"] - 0.01, (one["seed"], run)
            if run["primary_s"]["IV"] > 0.9 * run["duration_s"]:
                # the shipped rules set no mapping-speed cap (at 0.6 of top speed such runs took more
                # than 1.4 times their path's time at top speed): mapping costs the run little
                assert run["duration_s"] < 1.3 * run["path_at_top_speed_s"], (one["seed"], run)

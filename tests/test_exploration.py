"""Layer IV explores in the runs after the first (atlas_rap.layers.strategic, "explores"): in the
skill-acquisition experiment, the second errand goes to look at the part of the errand's area the
first left unseen, and the first errand only finds the way. Whole runs at the default noise."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from atlas_rap.maps.errand_area import errand_area
from atlas_rap.layers.exploring import GIVEN_UP, PASSED, ViewpointWatch, explores_this_run
from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.shipped import shipped_root
from atlas_rap.sim.world import load_world
from atlas_rap.views.experiment import Settings, skill_acquisition

RULES = shipped_root("rap_library") / "layers.rap"
SEED = 16  # its first errand leaves the map at 0.762, the corridor's east end unseen


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    """Two errands on seed 16, with the shipped rules (exploring) and with exploring turned off."""
    text = RULES.read_text(encoding="utf-8")
    # shipped: not set (so on), only named in a comment
    assert all(line.startswith(";") for line in text.splitlines() if "explore " in line)
    out: dict[int, tuple[dict, Path]] = {}
    for explore in (1, 0):
        folder = tmp_path_factory.mktemp(f"explore-{explore}")
        rules = None
        if not explore:
            rules = folder / "layers.rap"
            rules.write_text(text + "(initial-memory (layer-setting explore 0))\n", encoding="utf-8")
        data = skill_acquisition(folder / "out", Settings(runs=2, seed=SEED, obstacles=None,
                                                         layer_rules=str(rules) if rules else None))
        out[explore] = data, folder / "out"
    return out


def unseen(folder: Path, run: int) -> int:
    """Cells of the errand's area the grid after ``run`` has never seen."""
    grid = OccupancyGrid.load_npz(folder / f"map-run{run}.npz")
    area = errand_area(load_world("lab-corridor-office"), grid.frame, ["office", "lab"])
    return int((area & ~grid.updated).sum())


def test_the_first_errand_only_finds_the_way(two_runs):
    (explored, folder), (plain, plain_folder) = two_runs[1], two_runs[0]
    assert explored["runs"][0]["duration_s"] == plain["runs"][0]["duration_s"]
    first = [OccupancyGrid.load_npz(f / "map-run1.npz") for f in (folder, plain_folder)]
    assert np.array_equal(first[0].log_odds, first[1].log_odds)


def test_the_second_errand_goes_to_see_what_the_first_left_unseen(two_runs):
    (explored, folder), (plain, plain_folder) = two_runs[1], two_runs[0]
    table = (f"explore 1: quality {[r['map_quality'] for r in explored['runs']]}, unseen {unseen(folder, 1)} "
             f"-> {unseen(folder, 2)}; explore 0: quality {[r['map_quality'] for r in plain['runs']]}, "
             f"unseen {unseen(plain_folder, 1)} -> {unseen(plain_folder, 2)}")
    print(table)
    assert explored["runs"][0]["map_quality"] < 0.9, table  # one errand left the map short: it maps on
    assert all(run["ok"] for run in explored["runs"] + plain["runs"]), table
    assert unseen(folder, 2) < unseen(folder, 1) / 2, table
    assert unseen(plain_folder, 2) > 2 * unseen(plain_folder, 1) / 3, table  # the same way again sees little new
    # looking where the survey is unsure raises the map far more than the same way again
    assert explored["runs"][1]["map_quality"] >= plain["runs"][1]["map_quality"] + 0.05, table



@pytest.mark.parametrize("quality, earlier, stalled, explores", [
    (0.84, [], False, True),  # the default: under 0.9 and never at it
    (0.895, [0.0, 0.84], False, True),  # under it by less than the hysteresis: still never at it
    (0.895, [0.0, 0.84, 0.9], False, False),  # it was at the threshold once: a slip is mapped on the way
    (0.9, [0.0, 0.84], False, False),  # at the threshold: nothing to explore for
    (0.0, [], True, False),  # when stalled: no run before it to judge by
    (0.874, [0.0, 0.841], True, False),  # the run before added 0.033: going the same way still pays
    (0.882, [0.0, 0.841, 0.874], True, True),  # it added 0.008: stalled, so look elsewhere
    (0.895, [0.0, 0.85, 0.89], True, True),  # stalled and under the threshold by any amount
    (0.899, [0.0, 0.85, 0.9], True, False),  # it reached the threshold once: a slip is no reason to explore
    (0.9, [0.0, 0.85, 0.899], True, False),  # at the threshold: nothing to explore for
])
def test_a_run_explores_while_the_map_has_never_reached_the_threshold_or_once_repeating_the_way_stops_paying(
        quality, earlier, stalled, explores):
    assert explores_this_run(quality, earlier, 0.9, 0.02, when_stalled=stalled) is explores


def test_a_viewpoint_is_passed_within_half_a_metre_and_given_up_after_30_s_without_coming_nearer():
    watch, spot = ViewpointWatch(), (5.0, 0.0)
    assert watch.follow(spot, (0.0, 0.0), 0.0) is None
    assert watch.follow(spot, (3.0, 0.0), 10.0) is None  # 2 m nearer: progress
    assert watch.follow(spot, (3.05, 0.0), 39.0) is None  # 29 s without 0.1 m of progress: still patient
    assert watch.follow(spot, (2.9, 0.3), 40.5) == GIVEN_UP  # circling 2 m off for over 30 s
    assert watch.follow(spot, (4.6, 0.0), 41.0) == PASSED  # within 0.5 m
    assert ViewpointWatch().follow(spot, (3.0, 0.0), 100.0) is None  # a new watch starts its clock
    moved_on = ViewpointWatch()
    moved_on.follow(spot, (0.0, 0.0), 0.0)
    assert moved_on.follow((0.0, 5.0), (0.0, 0.0), 31.0) is None  # another spot: its own clock


STALL_SEED = 1  # with the survey taking rings at gmapping's 1.0 m, its third errand adds under 0.02


@pytest.fixture(scope="module")
def stalled_runs(tmp_path_factory):
    """Four errands on seed 1, the survey taking rings at gmapping's linearUpdate 1.0 m and
    angularUpdate 0.5 rad, exploring once repetition stalls, and with exploring off."""
    text = RULES.read_text(encoding="utf-8")
    out: dict[str, tuple[dict, Path]] = {}
    for name, explore in (("stalled", "(layer-setting explore-when-stalled 1)"), ("off", "(layer-setting explore 0)")):
        folder = tmp_path_factory.mktemp(name)
        rules = folder / "layers.rap"
        rules.write_text(text + "(initial-memory (layer-setting map-update-distance 1.0) "
                         f"(layer-setting map-update-turn 0.5) {explore})\n", encoding="utf-8")
        data = skill_acquisition(folder / "out", Settings(runs=4, seed=STALL_SEED, obstacles=None,
                                                         layer_rules=str(rules)))
        out[name] = data, folder / "out"
    return out


def test_exploring_when_stalled_waits_for_a_run_that_adds_little_then_looks_elsewhere(stalled_runs):
    (stalled, folder), (off, off_folder) = stalled_runs["stalled"], stalled_runs["off"]
    qualities = [run["map_quality"] for run in stalled["runs"]]
    table = f"stalled: {qualities}; off: {[run['map_quality'] for run in off['runs']]}"
    print(table)
    assert all(run["ok"] for run in stalled["runs"] + off["runs"]), table
    # every run noted the quality it began with, in the grid it carried on
    assert OccupancyGrid.load_npz(folder / "map-run4.npz").run_qualities == [0.0, *qualities[:3]], table
    # run 2 added 0.02 or more, run 3 less: runs 1-3 are the same errands as with exploring off
    assert qualities[1] - qualities[0] >= 0.02 and qualities[2] - qualities[1] < 0.02, table
    for run in (1, 2, 3):
        grids = [OccupancyGrid.load_npz(f / f"map-run{run}.npz") for f in (folder, off_folder)]
        assert np.array_equal(grids[0].log_odds, grids[1].log_odds), (run, table)
    # run 3 added under 0.02, so run 4 went to look where the map is unsure
    assert unseen(folder, 4) < unseen(off_folder, 4), table
    assert stalled["runs"][3]["map_quality"] > off["runs"][3]["map_quality"], table

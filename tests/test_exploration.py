"""Layer IV explores in the runs after the first (atlas_rap.layers.strategic, "explores"): in the
skill-acquisition experiment, the second errand goes to look at the part of the errand's area the
first left unseen, and the first errand only finds the way. Whole runs at the default noise."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from atlas_rap.maps.errand_area import errand_area
from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.shipped import shipped_root
from atlas_rap.sim.world import load_world
from atlas_rap.views.experiment import Settings, skill_acquisition

RULES = shipped_root("rap_library") / "layers.rap"
SEED = 10  # its errand goes by the storeroom both ways and never sees the corridor's east end


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    """Two errands on seed 10, with the shipped rules (exploring) and with exploring turned off."""
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
    assert explored["runs"][1]["map_quality"] >= 0.9 > plain["runs"][1]["map_quality"], table


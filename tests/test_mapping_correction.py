"""Mapping that corrects its own pose (issue 27, part 3), in whole runs at the default odometry noise:
without a prior map the localiser corrects the odometry against the map being built and carried, and
``localisation="odometry"`` (``--localisation odometry``) is the same run by dead reckoning alone. The
true pose and walls are read here, by the evaluation, only."""

from __future__ import annotations

import pytest

from localisation_runs import deliver

from atlas_rap.maps.agreement import map_agreement
from atlas_rap.views.experiment import Settings, skill_acquisition
from atlas_rap.views.pose_error import pose_errors


@pytest.mark.parametrize(("seed", "errands"), [(0, 7), (1, 1)])
def test_the_experiment_maps_agree_better_with_the_pose_correction_than_without(tmp_path, seed, errands):
    # Seed 1's first errand only: by dead reckoning its second wanders until the run's limit (900 s
    # simulated), a minute of the test suite's time.
    runs = {mode: skill_acquisition(tmp_path / mode, Settings(runs=errands, seed=seed, obstacles=None,
                                                              localisation=mode))["runs"]
            for mode in ("mcl", "odometry")}
    table = "\n".join(f"{mode:9s} agreement {[run['map_agreement'] for run in runs[mode]]} "
                      f"RMSE {[run['pose_rmse_m'] for run in runs[mode]]}" for mode in runs)
    print(table)
    assert all(run["ok"] for run in runs["mcl"]), table
    # the corrected map agrees with the true walls better than dead reckoning's, run after run
    # (docs/how-to/localise.md)
    assert runs["mcl"][0]["map_agreement"] >= 0.9, table
    for corrected, reckoned in zip(runs["mcl"], runs["odometry"]):
        assert corrected["map_agreement"] > reckoned["map_agreement"], table


def test_deliver_without_a_prior_map_is_closer_to_the_truth_with_the_correction_on_every_seed():
    for seed in (0, 3, 4):
        corrected, reckoned = (deliver("lab-corridor-office", seed, prior_map=False, localisation=mode)
                               for mode in ("mcl", "odometry"))
        assert corrected.result.ok and reckoned.result.ok, seed
        with_, without = pose_errors(corrected.engine.system), pose_errors(reckoned.engine.system)
        agree = [map_agreement(run.engine.grid, run.engine.world.walls).share for run in (corrected, reckoned)]
        print(f"seed {seed}: {with_.line()}, map agreement {agree[0]:.3f}; "
              f"dead reckoning {without.line()}, map agreement {agree[1]:.3f}")
        assert with_.rmse < without.rmse, seed
        assert agree[0] > agree[1], seed

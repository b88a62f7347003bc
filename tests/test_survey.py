"""The survey (atlas_rap.maps.survey): Layer IV's second grid of the same rings, fused only when read
far enough apart, which the map quality is measured on."""

from __future__ import annotations

import math

import numpy as np
import pytest

from atlas_rap.layers import MissionEngine, RunOptions
from atlas_rap.maps.grid import OccupancyGrid
from atlas_rap.maps.survey import SURVEY_SPACING, RingSpacing
from atlas_rap.shipped import shipped_root
from atlas_rap.skills.beliefs import GRID

WORLD = "lab-corridor-office"


@pytest.mark.parametrize("poses, counted", [
    ([(0, 0, 0), (0.3, 0, 0), (0.49, 0, 0), (0.5, 0, 0)], [True, False, False, True]),  # by the metres moved
    ([(0, 0, 0), (0, 0, 0.3), (0, 0, -0.5), (0, 0, -0.2)], [True, False, True, False]),  # by the turn, either way
    ([(0, 0, 3.0), (0, 0, -3.0), (0, 0, -2.7)], [True, False, True]),  # across ±π: 0.28 rad, then 0.58
    ([(1, 1, 0), (1.3, 1.3, 0), (1.3, 1.5, 0)], [True, False, True]),  # 0.42 m on the diagonal, then 0.58
])
def test_a_ring_counts_once_the_robot_has_moved_or_turned_enough_since_the_last_that_counted(poses, counted):
    spacing = RingSpacing(0.5, 0.5)
    assert [spacing.counts(tuple(map(float, pose))) for pose in poses] == counted


def test_with_no_spacing_every_ring_counts():
    spacing = RingSpacing(0.0, 0.0)
    assert all(spacing.counts((0.0, 0.0, 0.0)) for _ in range(5))
    assert SURVEY_SPACING == 0.5  # slam_toolbox's minimum_travel_distance and minimum_travel_heading


def stand_then_drive(rules=None):
    """Layer IV's grid and survey after standing 4 s at the start, then driving 2 s."""
    engine = MissionEngine(RunOptions(world=WORLD, seed=0, prior_map=False, layer_rules=rules))
    engine.start()
    grid = engine.manager.context.beliefs[GRID]
    engine.advance(1.0)  # the first rings, standing at the start
    first = grid.log_odds.copy(), grid.survey.log_odds.copy()
    engine.advance(3.0)  # standing still: the same echoes again
    stood = grid.log_odds.copy(), grid.survey.log_odds.copy()
    engine.simulation.command(0.4, 0.0)
    engine.advance(2.0)
    return first, stood, grid


def test_standing_still_the_grid_grows_surer_of_the_same_echoes_and_the_survey_does_not():
    text = (shipped_root("rap_library") / "layers.rap").read_text(encoding="utf-8")
    assert "(layer-setting map-update-distance 0.5)" in text and "(layer-setting map-update-turn 0.5)" in text
    first, stood, grid = stand_then_drive()
    assert (stood[0] < first[0] - 1.0).sum() > 500  # the grid: every ring, surer by repetition alone
    assert np.array_equal(stood[1], first[1])  # the survey: a robot standing still adds nothing
    survey = grid.survey
    assert survey.updated.sum() > 1000  # driving, it surveys ...
    seen = survey.updated & grid.updated
    assert np.abs(survey.log_odds[seen]).mean() < 0.5 * np.abs(grid.log_odds[seen]).mean()  # ... less surely
    assert survey.quality() < grid.quality()


def test_rules_that_set_no_spacing_survey_every_ring(tmp_path):
    text = (shipped_root("rap_library") / "layers.rap").read_text(encoding="utf-8")
    rules = tmp_path / "layers.rap"
    rules.write_text(text.replace("(layer-setting map-update-distance 0.5)", "(layer-setting map-update-distance 0)")
                     .replace("(layer-setting map-update-turn 0.5)", "(layer-setting map-update-turn 0)"),
                     encoding="utf-8")
    _, _, grid = stand_then_drive(str(rules))
    assert np.array_equal(grid.survey.log_odds, grid.log_odds)


def test_a_grid_carried_without_a_survey_is_its_own(tmp_path):
    first, _, grid = stand_then_drive()
    grid.survey = None
    path = grid.save_npz(tmp_path / "no-survey.npz")  # as one written before there was a survey
    engine = MissionEngine(RunOptions(world=WORLD, seed=0, prior_map=False, map_in=str(path)))
    engine.start()
    carried = engine.manager.context.beliefs[GRID]
    assert carried.survey is not None and carried.survey is not carried
    assert np.array_equal(carried.survey.log_odds, carried.log_odds)
    assert np.array_equal(carried.survey.updated, carried.updated)
    assert math.isclose(carried.survey.quality(), OccupancyGrid.load_npz(path).quality())
